//! Landmark design by the paper's genetic algorithm (§4.2, §4.4): `host-sim optimize`.
//!
//! - [`genes`]: a model's genes, names, units and bounds (Table 1 as loc-core reads it).
//! - [`operators`]: initial draw, ranking, SUS, elitism, crossover, mutation, one GA step.
//! - [`stopping`]: the generation limit and the average-relative-decrease rule.
//! - [`ga`]: the generation loop over an evaluation cache (deterministic from the seed).
//! - [`fitness`]: eq. 2's MSE of one simulated closed-loop run; the search's objective.
//! - [`fisher_objective`]: the deterministic worst-case along-tunnel Cramér–Rao bound.
//! - [`cmaes_search`]: CMA-ES (the `cmaes` crate) over the genes' unit cube.
//! - [`search`]: a search in its directory, evaluated in parallel here or left pending for
//!   a cluster's shards.
//! - [`store`]: the search directory's files.
//! - [`validation`]: repeated runs on fresh seeds, mean and 95 % interval.
//! - [`figures`], [`report_html`]: Figures 6–8 and `report.html`.
//! - [`table2`]: every model with both matchers, beside the paper's Table 2.
//! - [`comparison`]: GA + simulation, GA + Fisher, CMA-ES + Fisher side by side.

pub mod cmaes_search;
pub mod comparison;
pub mod figures;
pub mod fisher_objective;
pub mod fitness;
pub mod ga;
pub mod genes;
pub mod operators;
pub mod report_html;
pub mod search;
pub mod stopping;
pub mod store;
pub mod table2;
pub mod validation;

use std::path::PathBuf;

use serde::Serialize;

use fitness::SearchObjective;
use genes::GeneSpace;
use search::SearchState;
use stopping::StopReason;
use store::{SearchSpec, Store};
use validation::Validation;

/// One gene of the result, named, with its unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedGene {
    /// `W`, `H`, `D`, `h1`…`h6`.
    pub name: String,
    /// `m`, or `H` (multiples of H) for h1…h6.
    pub unit: &'static str,
    /// The value.
    pub value: f64,
}

/// Names each gene of `genes`.
pub fn named_genes(space: &GeneSpace, genes: &[f64]) -> Vec<NamedGene> {
    genes
        .iter()
        .enumerate()
        .map(|(i, &value)| NamedGene {
            name: space.name(i),
            unit: space.unit(i),
            value,
        })
        .collect()
}

/// What a finished search reports (`--json`, `summary.json`, `report.html`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SearchSummary {
    /// Model code.
    pub model: String,
    /// Matcher name.
    pub matcher: String,
    /// Scenario name.
    pub scenario: String,
    /// The search's settings.
    pub settings: SearchSpec,
    /// The best genome found.
    pub best_genes: Vec<NamedGene>,
    /// Its fitness (eq. 2's MSE at the search's seed, m² + rad²).
    pub best_fitness_mse: f64,
    /// √ of it, metres (mostly position).
    pub best_rms_eq2: f64,
    /// Generations run.
    pub generations: usize,
    /// Gene vectors evaluated (simulated runs), all sessions.
    pub evaluations: usize,
    /// Why the search stopped.
    pub stop_reason: StopReason,
    /// Wall time of the last session, seconds (a resumed search counts from its resume).
    pub wall_time_s: f64,
    /// Evaluations that could not be run (ranked last).
    pub failed_evaluations: usize,
    /// The best genome on fresh seeds.
    pub validation_best: Validation,
    /// The median genome of the first generation (a random design) on the same seeds.
    pub validation_first_median: Validation,
    /// `validation_best` mean over `validation_first_median` mean.
    pub best_over_random_median: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Finishes a search whose GA loop stopped with `reason`: validates the best and the first
/// generation's median genome on the spec's fresh seeds, draws the figures and writes
/// `summary.json` and `report.html`.
pub fn finish(
    store: &Store,
    spec: &SearchSpec,
    obj: &SearchObjective,
    state: &SearchState,
    reason: StopReason,
) -> Result<SearchSummary, String> {
    let space = obj.space();
    let last = state
        .generations
        .last()
        .ok_or("the search has no generation")?;
    let (first_pop, first_fitness) = store.read_generation(space, 0).map_err(|e| e.to_string())?;
    let (last_pop, _) = store
        .read_generation(space, last.index)
        .map_err(|e| e.to_string())?;
    if first_pop.is_empty() {
        return Err("generation 1 is empty".into());
    }
    // The median genome by fitness of generation 1: a random design.
    let first = ga::Generation {
        index: 0,
        population: first_pop,
        fitness: first_fitness,
        new_evaluations: 0,
    };
    let first_median = first.median().0.clone();
    let seeds = validation::fresh_seeds(spec.seed, spec.validation_seeds.max(2));
    let validation_best = validation::validate(&obj.simulated, &last.best, &seeds);
    let validation_first_median = validation::validate(&obj.simulated, &first_median, &seeds);
    let title = format!(
        "{} {} in {}",
        spec.model,
        obj.simulated.scenario.localizer.matcher.name(),
        obj.simulated.scenario.name
    );
    let mut files = figures::write_figures(
        &store.dir,
        &title,
        space,
        &state.generations,
        (0, &first.population),
        (last.index, &last_pop),
    )
    .map_err(|e| e.to_string())?;
    files.push(store.dir.join("generations.csv"));
    let mut summary = SearchSummary {
        model: spec.model.clone(),
        matcher: obj.simulated.scenario.localizer.matcher.name().to_string(),
        scenario: obj.simulated.scenario.name.clone(),
        settings: spec.clone(),
        best_genes: named_genes(space, &last.best),
        best_fitness_mse: last.best_fitness,
        best_rms_eq2: last.best_fitness.sqrt(),
        generations: state.generations.len(),
        evaluations: state.evaluations,
        stop_reason: reason,
        wall_time_s: state.wall_time_s,
        failed_evaluations: state.failures.0,
        best_over_random_median: validation_best.mean_position_rms_m
            / validation_first_median.mean_position_rms_m,
        validation_best,
        validation_first_median,
        files,
    };
    let html = store.dir.join("report.html");
    std::fs::write(&html, report_html::render(&summary, &state.generations))
        .map_err(|e| format!("{}: {e}", html.display()))?;
    summary.files.push(html);
    let json = store.dir.join("summary.json");
    summary.files.push(json.clone());
    let text = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
    std::fs::write(&json, text).map_err(|e| format!("{}: {e}", json.display()))?;
    Ok(summary)
}

/// Opens the search in `dir` (or creates it from `new()` when the directory holds none),
/// runs it to its end on this machine without progress output and finishes it. Returns the
/// summary and the wall time of the GA loop alone (validation excluded), seconds. What
/// `table2` and `compare-objectives` run each search with.
pub fn complete_search(
    dir: &std::path::Path,
    new: impl FnOnce() -> (SearchSpec, crate::scenario::Scenario),
    interrupt: &std::sync::atomic::AtomicBool,
) -> Result<(SearchSummary, f64), String> {
    if !dir.join("search.json").exists() {
        let (spec, scenario) = new();
        Store::create(dir, &spec, &scenario).map_err(|e| e.to_string())?;
    }
    // Every session reads the scenario back from the directory: the same values to the bit.
    let (store, spec, scenario) = Store::open(dir).map_err(|e| e.to_string())?;
    let obj = search::objective(&spec, &scenario)?;
    let state = search::run(
        &store,
        &spec,
        &obj,
        search::Evaluator::Local {
            interrupt,
            progress: &|_, _, _| {},
        },
        &mut |_: &store::GenerationRow| {},
    )?;
    let reason = match state.outcome {
        ga::Outcome::Finished(r) => r,
        ga::Outcome::Halted(ga::Halt::Interrupted) => {
            return Err(format!(
                "interrupted in {}: run the same command again to continue",
                dir.display()
            ))
        }
        ga::Outcome::Halted(h) => return Err(format!("{}: {h:?}", dir.display())),
    };
    let wall = state.wall_time_s;
    Ok((finish(&store, &spec, &obj, &state, reason)?, wall))
}
