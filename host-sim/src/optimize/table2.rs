//! `host-sim table2`: the paper's Table 2 reproduced — a GA search for each of the eight
//! models with each matcher, each optimum validated on fresh seeds (mean and 95 % interval,
//! as the paper's §5.2 reports its repetitions), beside the paper's values.
//!
//! Each search lives in `OUT/<model>-<matcher>/` (a full `optimize` directory with its
//! figures and report), so an interrupted table continues where it stopped.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use loc_core::landmark::LandmarkModel;
use serde::Serialize;

use super::store::SearchSpec;
use super::{complete_search, SearchSummary};
use crate::scenario::{MatcherChoice, Scenario};

/// The paper's Table 2: RMS localisation error (m) of each optimum, (ICP, Hausdorff).
pub fn paper_rms_m(model: LandmarkModel) -> (f64, f64) {
    match model {
        LandmarkModel::P1Triangle => (0.042, 0.022),
        LandmarkModel::P2Rectangle => (0.091, 0.026),
        LandmarkModel::P3Parabola => (0.063, 0.028),
        LandmarkModel::P4Ramp => (0.065, 0.026),
        LandmarkModel::F1Free => (0.073, 0.052),
        LandmarkModel::F2Inverted => (0.043, 0.064),
        LandmarkModel::F3Symmetric => (0.033, 0.068),
        LandmarkModel::F4SymmetricInverted => (0.035, 0.024),
    }
}

/// The budget of each search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Individuals per generation.
    pub population: usize,
    /// Generations at most.
    pub generations: usize,
    /// Validation seeds.
    pub validation_seeds: usize,
    /// Metres of the scenario's drive (`None`: all of it).
    pub length_m: Option<f64>,
    /// Simulated runs averaged per fitness (the paper: 1).
    pub runs_per_evaluation: usize,
}

impl Budget {
    /// The paper's settings: 100 individuals, at most 100 generations, 15 validation runs.
    pub const PAPER: Budget = Budget {
        population: 100,
        generations: 100,
        validation_seeds: 15,
        length_m: None,
        runs_per_evaluation: 1,
    };
    /// `--quick`: a few small generations over 4 m, 3 validation runs (a check that the
    /// table is produced, not a result).
    pub const QUICK: Budget = Budget {
        population: 10,
        generations: 3,
        validation_seeds: 3,
        length_m: Some(4.0),
        runs_per_evaluation: 1,
    };
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table2Row {
    /// The search's summary (best genome, validation, wall time).
    pub summary: SearchSummary,
    /// The paper's RMS for the same model and matcher, metres.
    pub paper_rms_m: f64,
}

/// Runs (or continues) every search of the table. `progress` receives a line per event.
pub fn run(
    base: &Scenario,
    budget: Budget,
    seed: u64,
    out: &Path,
    interrupt: &AtomicBool,
    progress: &mut dyn FnMut(String),
) -> Result<Vec<Table2Row>, String> {
    let mut rows = Vec::new();
    for model in LandmarkModel::ALL {
        for matcher in [MatcherChoice::Icp, MatcherChoice::Hausdorff] {
            let dir = out.join(format!(
                "{}-{}",
                model.code().to_ascii_lowercase(),
                matcher.name()
            ));
            let started = Instant::now();
            let (mut summary, _) = complete_search(
                &dir,
                || {
                    let mut s = base.clone();
                    s.localizer.matcher = matcher;
                    s.seed = seed;
                    if let Some(len) = budget.length_m {
                        s.drive.end_m = s.drive.start_m + len;
                    }
                    let spec = SearchSpec {
                        model: model.code().to_string(),
                        population: budget.population,
                        elite_fraction: 0.05,
                        crossover_fraction: 0.75,
                        max_generations: budget.generations,
                        stall_generations: 10,
                        tolerance: 0.001,
                        seed,
                        validation_seeds: budget.validation_seeds,
                        runs_per_evaluation: budget.runs_per_evaluation,
                        objective: Default::default(),
                    };
                    (spec, s)
                },
                interrupt,
            )?;
            // The table's wall time is the search's and its validation's, this session.
            summary.wall_time_s = started.elapsed().as_secs_f64();
            let (icp, hd) = paper_rms_m(model);
            let paper = if matcher == MatcherChoice::Icp {
                icp
            } else {
                hd
            };
            progress(format!(
                "{} {}: {} generations, {} runs, validated {:.2} ± {:.2} mm (paper {:.0} mm), D = {:.2} m, {:.0} s",
                model.code(),
                matcher.name(),
                summary.generations,
                summary.evaluations,
                summary.validation_best.mean_position_rms_m * 1e3,
                summary.validation_best.ci95_m * 1e3,
                paper * 1e3,
                summary.best_genes[2].value,
                summary.wall_time_s
            ));
            rows.push(Table2Row {
                summary,
                paper_rms_m: paper,
            });
        }
    }
    Ok(rows)
}

/// The table as Markdown: one row per model, ICP and Hausdorff side by side, each with the
/// validated RMS (mean ± 95 %), the paper's value, the optimised D and the wall time.
pub fn markdown(rows: &[Table2Row]) -> String {
    let mut t = String::from(
        "| model | ICP: RMS (mm) | paper | D (m) | time (s) | Hausdorff: RMS (mm) | paper | D (m) | time (s) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for pair in rows.chunks(2) {
        let _ = write!(t, "| {} ", pair[0].summary.model);
        for r in pair {
            let v = &r.summary.validation_best;
            let _ = write!(
                t,
                "| {:.1} ± {:.1} | {:.0} | {:.2} | {:.0} ",
                v.mean_position_rms_m * 1e3,
                v.ci95_m * 1e3,
                r.paper_rms_m * 1e3,
                r.summary.best_genes[2].value,
                r.summary.wall_time_s
            );
        }
        t += "|\n";
    }
    t
}

/// Writes `table2.md` and `table2.json` into `out`.
pub fn write(out: &Path, rows: &[Table2Row]) -> Result<Vec<PathBuf>, String> {
    let md = out.join("table2.md");
    std::fs::write(&md, markdown(rows)).map_err(|e| format!("{}: {e}", md.display()))?;
    let json = out.join("table2.json");
    let text = serde_json::to_string_pretty(rows).map_err(|e| e.to_string())?;
    std::fs::write(&json, text).map_err(|e| format!("{}: {e}", json.display()))?;
    Ok(vec![md, json])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_values_and_the_best_of_the_paper() {
        // P1 with Hausdorff is the paper's best, F4 with Hausdorff second.
        let mut all: Vec<(f64, &str)> = LandmarkModel::ALL
            .iter()
            .flat_map(|&m| {
                let (i, h) = paper_rms_m(m);
                [(i, "icp"), (h, m.code())]
            })
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(all[0], (0.022, "P1"));
        assert_eq!(all[1], (0.024, "F4"));
    }
}
