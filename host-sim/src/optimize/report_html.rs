//! `report.html`: one page with the search's figures (the SVGs beside it) and its tables —
//! settings, best genome, validation, and the generations. No script, no external asset, so
//! it opens from the directory in any browser (and renders headless, which a test checks).

use std::fmt::Write as _;

use super::store::GenerationRow;
use super::SearchSummary;

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn mm(m: f64) -> String {
    if m.is_finite() {
        format!("{:.2}", m * 1000.0)
    } else {
        "failed".into()
    }
}

/// The report page of a finished search.
pub fn render(s: &SearchSummary, rows: &[GenerationRow]) -> String {
    let mut h = String::new();
    let title = format!(
        "Landmark optimisation: {} with {} in {}",
        s.model, s.matcher, s.scenario
    );
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n\
         <style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}\
         th{{background:#eee}}img{{width:100%;border:1px solid #ddd}}</style></head><body>\n<h1>{t}</h1>\n",
        t = esc(&title)
    );
    let st = &s.settings;
    let stop = match s.stop_reason {
        super::stopping::StopReason::MaxGenerations => "the generation limit".to_string(),
        super::stopping::StopReason::Converged {
            average_relative_decrease,
        } => format!(
            "the average relative decrease of the best fitness over {} generations fell to {:.4} % (below {} %)",
            st.stall_generations,
            average_relative_decrease * 100.0,
            st.tolerance * 100.0
        ),
    };
    let _ = writeln!(
        h,
        "<p>{} generations of {} individuals (elite {} %, crossover {} % of the rest), seed {}; \
         {} genomes evaluated ({} simulated run(s) each) in {:.1} s of wall time. Stopped by {}.{}</p>",
        s.generations,
        st.population,
        st.elite_fraction * 100.0,
        st.crossover_fraction * 100.0,
        st.seed,
        s.evaluations,
        st.runs_per_evaluation,
        s.wall_time_s,
        esc(&stop),
        if s.failed_evaluations > 0 {
            format!(
                " {} evaluations could not be run and ranked last.",
                s.failed_evaluations
            )
        } else {
            String::new()
        }
    );
    h += "<h2>Best genome</h2>\n<table><tr><th>gene</th><th>value</th><th>unit</th></tr>\n";
    for g in &s.best_genes {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{:.4}</td><td>{}</td></tr>",
            esc(&g.name),
            g.value,
            g.unit
        );
    }
    let _ = write!(
        h,
        "</table>\n<p>Fitness (eq. 2 MSE at the search's seed): {:.3e} m², RMS {} mm.</p>\n",
        s.best_fitness_mse,
        mm(s.best_rms_eq2)
    );
    h += "<h2>Validation on fresh seeds</h2>\n<table><tr><th>genome</th><th>runs</th>\
          <th>mean position RMS (mm)</th><th>95 % interval (mm)</th></tr>\n";
    for (name, v) in [
        ("best of the search", &s.validation_best),
        (
            "median of generation 1 (random)",
            &s.validation_first_median,
        ),
    ] {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>± {}</td></tr>",
            name,
            v.seeds.len(),
            mm(v.mean_position_rms_m),
            mm(v.ci95_m)
        );
    }
    let _ = write!(
        h,
        "</table>\n<p>The best genome's error is {:.3} of the random median's.</p>\n",
        s.best_over_random_median
    );
    for (file, caption) in [
        ("convergence.svg", "Convergence (the paper's Figure 6)"),
        (
            "shapes.svg",
            "Best shapes of successive generations (Figure 7)",
        ),
        (
            "spacing_histogram.svg",
            "The spacing gene D in the first and last generation (Figure 8)",
        ),
    ] {
        let _ = writeln!(
            h,
            "<h2>{caption}</h2>\n<img src=\"{file}\" alt=\"{caption}\">"
        );
    }
    h += "<h2>Generations</h2>\n<table><tr><th>generation</th><th>new runs</th>\
          <th>best RMS (mm)</th><th>median RMS (mm)</th>";
    for g in &s.best_genes {
        let _ = write!(h, "<th>best {} ({})</th>", esc(&g.name), g.unit);
    }
    h += "</tr>\n";
    for r in rows {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            r.index + 1,
            r.new_evaluations,
            mm(r.best_fitness.sqrt()),
            mm(r.median_fitness.sqrt())
        );
        for v in &r.best {
            let _ = write!(h, "<td>{v:.4}</td>");
        }
        h += "</tr>\n";
    }
    h += "</table>\n</body></html>\n";
    h
}
