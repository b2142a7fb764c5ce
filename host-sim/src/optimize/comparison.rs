//! `host-sim compare-objectives`: GA + simulated MSE (the paper's), GA + Fisher and
//! CMA-ES + Fisher side by side for one model — the optimum each finds, its evaluations and
//! wall time, each optimum validated by simulation on the same fresh seeds, and the cost of
//! one evaluation of each objective.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use loc_core::landmark::LandmarkModel;
use loc_core::rng::Pcg32;
use serde::Serialize;

use super::fitness::{ObjectiveKind, SearchObjective};
use super::genes::GeneSpace;
use super::store::SearchSpec;
use super::validation::{self, Validation};
use super::{cmaes_search, complete_search, named_genes, NamedGene};
use crate::scenario::Scenario;

/// One optimiser + objective pair's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ComparisonRow {
    /// `GA + simulation`, `GA + Fisher`, `CMA-ES + Fisher`.
    pub method: String,
    /// The optimum.
    pub best_genes: Vec<NamedGene>,
    /// Objective evaluations made.
    pub evaluations: usize,
    /// Wall time of the search (validation excluded), seconds.
    pub wall_time_s: f64,
    /// The optimum validated by simulation.
    pub validation: Validation,
    /// Its validated mean over GA + simulation's.
    pub validated_over_simulation_ga: f64,
}

/// The comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Model code.
    pub model: String,
    /// The rows.
    pub rows: Vec<ComparisonRow>,
    /// CPU time of one simulated evaluation (one thread), seconds.
    pub simulation_eval_s: f64,
    /// CPU time of one Fisher evaluation (one thread), seconds.
    pub fisher_eval_s: f64,
    /// Their ratio.
    pub fisher_speedup: f64,
}

/// Mean time of `f` over the genomes, seconds (on this thread).
fn time_per_call(genomes: &[Vec<f64>], f: &dyn Fn(&[f64])) -> f64 {
    let t0 = cpu_time::ThreadTime::now();
    for g in genomes {
        f(g);
    }
    t0.elapsed().as_secs_f64() / genomes.len().max(1) as f64
}

fn ga_search(
    dir: &Path,
    scenario: &Scenario,
    model: LandmarkModel,
    seed: u64,
    objective: ObjectiveKind,
    interrupt: &AtomicBool,
) -> Result<(super::SearchSummary, f64), String> {
    complete_search(
        dir,
        || {
            let spec = SearchSpec {
                model: model.code().to_string(),
                population: 100,
                elite_fraction: 0.05,
                crossover_fraction: 0.75,
                max_generations: 100,
                stall_generations: 10,
                tolerance: 0.001,
                seed,
                validation_seeds: 15,
                runs_per_evaluation: 1,
                objective,
            };
            (spec, scenario.clone())
        },
        interrupt,
    )
}

/// Runs the comparison for `model` in `scenario` into `out` (the two GA searches are full
/// `optimize` directories, continued if present).
pub fn run(
    scenario: &Scenario,
    model: LandmarkModel,
    seed: u64,
    cmaes_evaluations: usize,
    out: &Path,
    interrupt: &AtomicBool,
    progress: &mut dyn FnMut(String),
) -> Result<Comparison, String> {
    let space = GeneSpace::for_model(model);
    let (sim, sim_wall) = ga_search(
        &out.join("ga-simulation"),
        scenario,
        model,
        seed,
        ObjectiveKind::Simulation,
        interrupt,
    )?;
    progress(format!(
        "GA + simulation: {} evaluations, {sim_wall:.0} s",
        sim.evaluations
    ));
    let (fis, fis_wall) = ga_search(
        &out.join("ga-fisher"),
        scenario,
        model,
        seed,
        ObjectiveKind::Fisher,
        interrupt,
    )?;
    progress(format!(
        "GA + Fisher: {} evaluations, {fis_wall:.1} s",
        fis.evaluations
    ));
    let fisher = SearchObjective::new(ObjectiveKind::Fisher, scenario, space.clone());
    let f = |g: &[f64]| fisher.fitness(g, &[]).unwrap_or(f64::INFINITY);
    let cma = cmaes_search::minimise(&space, &f, cmaes_evaluations, seed)?;
    progress(format!(
        "CMA-ES + Fisher: {} evaluations, {:.1} s",
        cma.evaluations, cma.wall_time_s
    ));
    let seeds = validation::fresh_seeds(seed, 15);
    let cma_validation = validation::validate(&fisher.simulated, &cma.best, &seeds);
    let base = sim.validation_best.mean_position_rms_m;
    let row =
        |method: &str, genes: Vec<NamedGene>, evaluations, wall, v: Validation| ComparisonRow {
            method: method.to_string(),
            best_genes: genes,
            evaluations,
            wall_time_s: wall,
            validated_over_simulation_ga: v.mean_position_rms_m / base,
            validation: v,
        };
    // The cost of one evaluation of each, on one thread, over the same random genomes.
    let mut rng = Pcg32::new(seed, 99);
    let genomes = super::operators::initial_population(&space, 20, &mut rng);
    let simulation_eval_s = time_per_call(&genomes[..10], &|g| {
        let _ = fisher.simulated.evaluate(g, seed);
    });
    let many: Vec<Vec<f64>> = (0..50).flat_map(|_| genomes.clone()).collect();
    let fisher_eval_s = time_per_call(&many, &|g| {
        let _ = f(g);
    });
    Ok(Comparison {
        model: model.code().to_string(),
        rows: vec![
            row(
                "GA + simulation",
                sim.best_genes.clone(),
                sim.evaluations,
                sim_wall,
                sim.validation_best.clone(),
            ),
            row(
                "GA + Fisher",
                fis.best_genes.clone(),
                fis.evaluations,
                fis_wall,
                fis.validation_best.clone(),
            ),
            row(
                "CMA-ES + Fisher",
                named_genes(&space, &cma.best),
                cma.evaluations,
                cma.wall_time_s,
                cma_validation,
            ),
        ],
        simulation_eval_s,
        fisher_eval_s,
        fisher_speedup: simulation_eval_s / fisher_eval_s,
    })
}

/// The comparison as Markdown.
pub fn markdown(c: &Comparison) -> String {
    let mut t = String::from(
        "| method | optimum | evaluations | search time (s) | validated RMS (mm) | vs GA + simulation |\n|---|---|---|---|---|---|\n",
    );
    for r in &c.rows {
        let genes: Vec<String> = r
            .best_genes
            .iter()
            .map(|g| format!("{} {:.3}", g.name, g.value))
            .collect();
        let _ = writeln!(
            t,
            "| {} | {} | {} | {:.1} | {:.2} ± {:.2} | {:.2} |",
            r.method,
            genes.join(", "),
            r.evaluations,
            r.wall_time_s,
            r.validation.mean_position_rms_m * 1e3,
            r.validation.ci95_m * 1e3,
            r.validated_over_simulation_ga
        );
    }
    let _ = writeln!(
        t,
        "\nOne evaluation on one thread: simulation {:.1} ms, Fisher {:.1} µs ({:.0} × cheaper).",
        c.simulation_eval_s * 1e3,
        c.fisher_eval_s * 1e6,
        c.fisher_speedup
    );
    t
}
