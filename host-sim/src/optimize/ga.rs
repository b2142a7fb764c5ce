//! The GA's generation loop (§4.2, §4.4), independent of how fitness is computed.
//!
//! Every random draw of generation `g` comes from `Pcg32::new(seed, g)`, and every fitness
//! from an [`EvaluationCache`] filled by the caller's evaluator, so a search is a pure
//! function of its settings and the fitness function: re-running it over a cache that
//! already holds the evaluations (a resumed search, a cluster's merged shards) replays the
//! same generations without a single new evaluation, bit for bit.

use std::collections::{HashMap, HashSet};

use loc_core::rng::Pcg32;

use super::genes::{GeneSpace, Genes};
use super::operators::{self, Composition};
use super::stopping::{StopReason, StoppingRule};

/// The GA's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaSettings {
    /// Individuals per generation (the paper: 100).
    pub population: usize,
    /// Share kept unchanged (the paper: 0.05).
    pub elite_fraction: f64,
    /// Share of the rest made by crossover (the paper: 0.75).
    pub crossover_fraction: f64,
    /// When to stop.
    pub stopping: StoppingRule,
    /// Seed of the GA's draws.
    pub seed: u64,
}

impl GaSettings {
    /// The paper's settings with `seed`.
    pub fn paper(seed: u64) -> Self {
        Self {
            population: 100,
            elite_fraction: 0.05,
            crossover_fraction: 0.75,
            stopping: StoppingRule::PAPER,
            seed,
        }
    }

    /// The generation's composition.
    pub fn composition(&self) -> Composition {
        Composition::new(
            self.population,
            self.elite_fraction,
            self.crossover_fraction,
        )
    }
}

/// Exact key of a gene vector (bit patterns), so that a cached fitness is found only for
/// the very same genes.
pub fn genes_key(genes: &[f64]) -> Vec<u64> {
    genes.iter().map(|g| g.to_bits()).collect()
}

/// Fitness by gene vector, filled by the evaluator.
#[derive(Debug, Clone, Default)]
pub struct EvaluationCache {
    map: HashMap<Vec<u64>, f64>,
}

impl EvaluationCache {
    /// The fitness of `genes`, if evaluated.
    pub fn get(&self, genes: &[f64]) -> Option<f64> {
        self.map.get(&genes_key(genes)).copied()
    }

    /// Records the fitness of `genes`.
    pub fn insert(&mut self, genes: &[f64], fitness: f64) {
        self.map.insert(genes_key(genes), fitness);
    }

    /// Number of gene vectors evaluated.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// True when nothing was evaluated.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }
}

/// One scored generation.
#[derive(Debug, Clone, PartialEq)]
pub struct Generation {
    /// 0 for the initial draw.
    pub index: usize,
    /// The individuals.
    pub population: Vec<Genes>,
    /// Their fitness (MSE of eq. 2; infinite for a failed evaluation).
    pub fitness: Vec<f64>,
    /// Gene vectors first met in this generation (each is evaluated once, whichever
    /// session or shard does it).
    pub new_evaluations: usize,
}

impl Generation {
    /// Index of the best individual (lowest fitness).
    pub fn best_index(&self) -> usize {
        operators::ranking(&self.fitness)
            .first()
            .copied()
            .unwrap_or(0)
    }

    /// The best individual's genes and fitness.
    pub fn best(&self) -> (&Genes, f64) {
        let i = self.best_index();
        (&self.population[i], self.fitness[i])
    }

    /// The median individual (rank ⌊N/2⌋ by fitness).
    pub fn median(&self) -> (&Genes, f64) {
        let ranked = operators::ranking(&self.fitness);
        let i = ranked[ranked.len() / 2];
        (&self.population[i], self.fitness[i])
    }
}

/// Why the evaluator stopped the loop.
#[derive(Debug, Clone, PartialEq)]
pub enum Halt {
    /// The user interrupted (Ctrl-C): what was evaluated is in the cache.
    Interrupted,
    /// Only cached fitness may be used and these gene vectors lack one (a cluster run's
    /// next shard work).
    Pending(Vec<Genes>),
    /// The evaluator failed in a way that must stop the search.
    Failed(String),
}

/// The evaluator of [`run`]: given the generation index and the gene vectors not yet in
/// the cache, it puts each one's fitness in the cache, or halts.
pub type EvaluateFn<'a> = dyn FnMut(usize, &[Genes], &mut EvaluationCache) -> Result<(), Halt> + 'a;

/// How a search ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The stopping rule fired.
    Finished(StopReason),
    /// The evaluator halted the loop.
    Halted(Halt),
}

/// Runs the GA. `evaluate` receives the gene vectors of a generation that are not yet in
/// `cache` (no duplicates) and must put each one's fitness in the cache, or halt;
/// `on_generation` sees each scored generation. Returns how it ended.
pub fn run(
    space: &GeneSpace,
    settings: &GaSettings,
    cache: &mut EvaluationCache,
    evaluate: &mut EvaluateFn<'_>,
    on_generation: &mut dyn FnMut(&Generation),
) -> Outcome {
    let mut population = operators::initial_population(
        space,
        settings.population,
        &mut Pcg32::new(settings.seed, 0),
    );
    let mut best = Vec::new();
    let mut seen: HashSet<Vec<u64>> = HashSet::new();
    let mut index = 0;
    loop {
        let first_met = population
            .iter()
            .filter(|g| seen.insert(genes_key(g)))
            .count();
        let mut missing: Vec<Genes> = Vec::new();
        for g in &population {
            if cache.get(g).is_none() && !missing.iter().any(|m| genes_key(m) == genes_key(g)) {
                missing.push(g.clone());
            }
        }
        if !missing.is_empty() {
            if let Err(h) = evaluate(index, &missing, cache) {
                return Outcome::Halted(h);
            }
        }
        let fitness: Option<Vec<f64>> = population.iter().map(|g| cache.get(g)).collect();
        let Some(fitness) = fitness else {
            return Outcome::Halted(Halt::Failed(
                "the evaluator left a genome without fitness".into(),
            ));
        };
        let generation = Generation {
            index,
            population,
            fitness,
            new_evaluations: first_met,
        };
        on_generation(&generation);
        best.push(generation.best().1);
        if let Some(reason) = settings.stopping.check(&best) {
            return Outcome::Finished(reason);
        }
        population = operators::next_generation(
            space,
            &generation.population,
            &generation.fitness,
            settings.composition(),
            &mut Pcg32::new(settings.seed, index as u64 + 1),
        );
        index += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::landmark::LandmarkModel;

    /// A smooth test objective with its minimum at W = 0.3, H = 0.15, D = 9.
    fn bowl(g: &[f64]) -> f64 {
        ((g[0] - 0.3) / 0.6).powi(2)
            + ((g[1] - 0.15) / 0.3).powi(2)
            + ((g[2] - 9.0) / 100.0).powi(2)
    }

    fn local(
        f: fn(&[f64]) -> f64,
    ) -> impl FnMut(usize, &[Genes], &mut EvaluationCache) -> Result<(), Halt> {
        move |_, missing, cache| {
            for g in missing {
                cache.insert(g, f(g));
            }
            Ok(())
        }
    }

    #[test]
    fn converges_on_a_bowl_and_replays_from_its_cache() {
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let settings = GaSettings::paper(11);
        let mut cache = EvaluationCache::default();
        let mut gens = Vec::new();
        let outcome = run(&space, &settings, &mut cache, &mut local(bowl), &mut |g| {
            gens.push(g.clone())
        });
        assert!(matches!(outcome, Outcome::Finished(_)), "{outcome:?}");
        let best: Vec<f64> = gens.iter().map(|g| g.best().1).collect();
        assert!(best.windows(2).all(|w| w[1] <= w[0]), "elitism: {best:?}");
        let (g, f) = gens.last().unwrap().best();
        assert!(f < 1e-3 && (g[2] - 9.0).abs() < 5.0, "{g:?} {f}");
        // The same search over the filled cache: same generations, no evaluation at all.
        let mut replay = Vec::new();
        let mut forbid =
            |_: usize, m: &[Genes], _: &mut EvaluationCache| Err(Halt::Pending(m.to_vec()));
        let again = run(&space, &settings, &mut cache, &mut forbid, &mut |g| {
            replay.push(g.clone())
        });
        assert_eq!(again, outcome);
        assert_eq!(replay.len(), gens.len());
        for (a, b) in replay.iter().zip(&gens) {
            assert_eq!((&a.population, &a.fitness), (&b.population, &b.fitness));
        }
    }

    #[test]
    fn a_halt_keeps_the_cache_and_pending_lists_unique_genomes() {
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let settings = GaSettings {
            population: 10,
            ..GaSettings::paper(2)
        };
        let mut cache = EvaluationCache::default();
        let mut pending =
            |_: usize, m: &[Genes], _: &mut EvaluationCache| Err(Halt::Pending(m.to_vec()));
        let Outcome::Halted(Halt::Pending(first)) =
            run(&space, &settings, &mut cache, &mut pending, &mut |_| {})
        else {
            panic!("expected pending work");
        };
        assert_eq!(first.len(), 10);
        // Evaluate those, ask again: the next generation's new genomes only (elites cached).
        for g in &first {
            cache.insert(g, bowl(g));
        }
        let Outcome::Halted(Halt::Pending(second)) =
            run(&space, &settings, &mut cache, &mut pending, &mut |_| {})
        else {
            panic!("expected pending work");
        };
        assert!(second.len() <= 9, "the elite is cached: {}", second.len());
        assert!(second.iter().all(|g| cache.get(g).is_none()));
    }

    #[test]
    fn stops_at_the_generation_limit() {
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let settings = GaSettings {
            population: 8,
            stopping: StoppingRule {
                max_generations: 3,
                window: 10,
                tolerance: 0.001,
            },
            ..GaSettings::paper(4)
        };
        let mut n = 0;
        let out = run(
            &space,
            &settings,
            &mut EvaluationCache::default(),
            &mut local(bowl),
            &mut |_| n += 1,
        );
        assert_eq!(out, Outcome::Finished(StopReason::MaxGenerations));
        assert_eq!(n, 3);
    }
}
