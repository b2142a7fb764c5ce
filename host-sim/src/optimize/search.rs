//! A search in its directory: the GA loop ([`super::ga::run`]) with the simulated objective
//! evaluated in parallel on this machine, or only as far as the cached evaluations reach
//! (a cluster run's next `pending.csv`), and one shard of pending work.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use super::fitness::SearchObjective;
use super::ga::{self, EvaluationCache, Generation, Halt, Outcome};
use super::genes::{GeneSpace, Genes};
use super::store::{EvaluationLog, GenerationRow, SearchSpec, Shard, Store};

/// How the generations get their fitness.
pub enum Evaluator<'a> {
    /// Simulated here, in parallel; `interrupt` (Ctrl-C) stops starting new evaluations;
    /// `progress(generation, done, total)` after each one.
    Local {
        /// Set by the Ctrl-C handler.
        interrupt: &'a AtomicBool,
        /// Progress within a generation.
        progress: &'a (dyn Fn(usize, usize, usize) + Sync),
    },
    /// Only what is cached: the search stops at the first generation that needs work and
    /// writes it to `pending.csv`.
    CachedOnly,
}

/// Where a search stands after [`run`].
#[derive(Debug, Clone)]
pub struct SearchState {
    /// How the GA loop ended.
    pub outcome: Outcome,
    /// Every scored generation, first first.
    pub generations: Vec<GenerationRow>,
    /// Gene vectors evaluated in all (this session's and earlier ones').
    pub evaluations: usize,
    /// Gene vectors evaluated in this session.
    pub new_evaluations: usize,
    /// Evaluations that could not be run (fitness +∞), with the first reason.
    pub failures: (usize, Option<String>),
    /// Wall time of this session's loop, seconds.
    pub wall_time_s: f64,
}

/// The objective of a search directory.
pub fn objective(
    spec: &SearchSpec,
    scenario: &crate::scenario::Scenario,
) -> Result<SearchObjective, String> {
    let model = loc_core::landmark::LandmarkModel::from_code(&spec.model)
        .ok_or_else(|| format!("search.json names an unknown model `{}`", spec.model))?;
    Ok(SearchObjective::new(
        spec.objective,
        scenario,
        GeneSpace::for_model(model),
    ))
}

/// Evaluates `genes` over `seeds` in parallel, recording each result in `log` as it finishes;
/// `None` where `interrupt` stopped it first.
fn evaluate_all(
    obj: &SearchObjective,
    genes: &[Genes],
    seeds: &[u64],
    log: &EvaluationLog,
    interrupt: &AtomicBool,
    failures: &Mutex<(usize, Option<String>)>,
    on_done: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Option<f64>>, String> {
    let done = AtomicUsize::new(0);
    genes
        .par_iter()
        .map(|g| {
            if interrupt.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let fitness = match obj.fitness(g, seeds) {
                Ok(f) if f.is_finite() => f,
                other => {
                    let reason = match other {
                        Err(e) => e,
                        Ok(f) => format!("the objective is {f}"),
                    };
                    if let Ok(mut f) = failures.lock() {
                        f.0 += 1;
                        f.1.get_or_insert(reason);
                    }
                    f64::INFINITY
                }
            };
            log.record(g, fitness).map_err(|e| e.to_string())?;
            on_done(done.fetch_add(1, Ordering::Relaxed) + 1);
            Ok(Some(fitness))
        })
        .collect()
}

/// Runs (or continues) the search of `store`, writing each generation's files;
/// `on_generation` sees each scored generation's row (progress lines).
pub fn run(
    store: &Store,
    spec: &SearchSpec,
    obj: &SearchObjective,
    evaluator: Evaluator<'_>,
    on_generation: &mut dyn FnMut(&GenerationRow),
) -> Result<SearchState, String> {
    let space = obj.space();
    let mut cache = store.load_cache(space).map_err(|e| e.to_string())?;
    let log = store.evaluation_log(space).map_err(|e| e.to_string())?;
    let failures = Mutex::new((0usize, None));
    let started = Instant::now();
    let mut new_evaluations = 0;
    let mut rows = Vec::new();
    let mut write_error = None;
    let mut evaluate = |generation: usize, missing: &[Genes], cache: &mut EvaluationCache| {
        let (interrupt, progress) = match &evaluator {
            Evaluator::CachedOnly => return Err(Halt::Pending(missing.to_vec())),
            Evaluator::Local {
                interrupt,
                progress,
            } => (*interrupt, *progress),
        };
        let total = missing.len();
        progress(generation, 0, total);
        let results = evaluate_all(
            obj,
            missing,
            &spec.evaluation_seeds(),
            &log,
            interrupt,
            &failures,
            &|done| progress(generation, done, total),
        )
        .map_err(Halt::Failed)?;
        for (g, f) in missing.iter().zip(&results) {
            if let Some(f) = f {
                cache.insert(g, *f);
                new_evaluations += 1;
            }
        }
        if results.iter().any(Option::is_none) {
            return Err(Halt::Interrupted);
        }
        Ok(())
    };
    let mut scored = |g: &Generation| {
        if let Err(e) = store.write_generation(space, g) {
            write_error.get_or_insert(e.to_string());
        }
        let row = GenerationRow::of(g);
        on_generation(&row);
        rows.push(row);
    };
    let outcome = ga::run(space, &spec.ga(), &mut cache, &mut evaluate, &mut scored);
    if let Some(e) = write_error {
        return Err(e);
    }
    store
        .write_generations(space, &rows)
        .map_err(|e| e.to_string())?;
    if let Outcome::Halted(Halt::Pending(p)) = &outcome {
        store.write_pending(space, p).map_err(|e| e.to_string())?;
    }
    let failures = failures.into_inner().unwrap_or_default();
    Ok(SearchState {
        outcome,
        generations: rows,
        evaluations: cache.len(),
        new_evaluations,
        failures,
        wall_time_s: started.elapsed().as_secs_f64(),
    })
}

/// Evaluates this shard's share of `pending.csv` into its shard file. Returns how many.
pub fn run_shard(
    store: &Store,
    spec: &SearchSpec,
    obj: &SearchObjective,
    shard: Shard,
    interrupt: &AtomicBool,
) -> Result<usize, String> {
    let pending = store.read_pending(obj.space()).map_err(|e| e.to_string())?;
    let mine: Vec<Genes> = shard
        .members(pending.len())
        .map(|i| pending[i].clone())
        .collect();
    let log = store
        .shard_log(obj.space(), shard)
        .map_err(|e| e.to_string())?;
    let failures = Mutex::new((0usize, None));
    let results = evaluate_all(
        obj,
        &mine,
        &spec.evaluation_seeds(),
        &log,
        interrupt,
        &failures,
        &|_| {},
    )?;
    if results.iter().any(Option::is_none) {
        return Err("interrupted: run this shard again".into());
    }
    Ok(mine.len())
}
