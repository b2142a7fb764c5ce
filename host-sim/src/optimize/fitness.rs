//! The GA's fitness (§4.2, eq. 2): the MSE of one simulated closed-loop run in the scenario's
//! tunnel populated from the genome (§4.4 spacing), with loc-core's localiser.
//!
//! An evaluation is a pure function of (genome, scenario, seed): the scenario's every draw
//! (walls, layout jitter, vehicle, odometry, lidar noise) comes from the seed. All the
//! individuals of a search share one seed (common random numbers), so two genomes are
//! compared on the same noise, and the optimum is then validated on fresh seeds.

use crate::metrics::Accuracy;
use crate::scenario::Scenario;
use crate::session::{run_scenario, EstimatorChoice};

use super::fisher_objective::FisherObjective;
use super::genes::GeneSpace;

/// Which objective a search minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectiveKind {
    /// Eq. 2's MSE of simulated closed-loop runs (the paper's).
    #[default]
    Simulation,
    /// The worst-case along-tunnel Cramér–Rao variance of one scan (deterministic).
    Fisher,
}

impl ObjectiveKind {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            ObjectiveKind::Simulation => "simulation",
            ObjectiveKind::Fisher => "fisher",
        }
    }
}

/// A search's objective: the simulation (always there: it validates every optimum) and,
/// for a Fisher search, the Fisher objective.
#[derive(Debug, Clone)]
pub struct SearchObjective {
    /// The simulated objective.
    pub simulated: SimulatedObjective,
    /// The Fisher objective, when the search minimises it.
    pub fisher: Option<FisherObjective>,
}

impl SearchObjective {
    /// The objective `kind` of `space` in `scenario`.
    pub fn new(kind: ObjectiveKind, scenario: &Scenario, space: GeneSpace) -> Self {
        Self {
            fisher: (kind == ObjectiveKind::Fisher)
                .then(|| FisherObjective::new(scenario, space.clone())),
            simulated: SimulatedObjective {
                scenario: scenario.clone(),
                space,
            },
        }
    }

    /// The genes searched.
    pub fn space(&self) -> &GeneSpace {
        &self.simulated.space
    }

    /// The fitness of `genes`: the simulation's mean MSE over `seeds` (m² + rad²), or the
    /// Fisher objective's worst along-tunnel variance (m²; the seeds play no part).
    pub fn fitness(&self, genes: &[f64], seeds: &[u64]) -> Result<f64, String> {
        match &self.fisher {
            Some(f) => f.evaluate(genes).map(|e| e.worst_along_sd_m.powi(2)),
            None => self
                .simulated
                .evaluate_runs(genes, seeds)
                .map(|e| e.mse_eq2),
        }
    }
}

/// The localiser's figures of one evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation {
    /// Eq. 2's MSE (m² + rad²): the fitness.
    pub mse_eq2: f64,
    /// Position RMS, metres.
    pub position_rms_m: f64,
}

/// The simulated objective: a scenario, the model searched and the seed of every run.
#[derive(Debug, Clone)]
pub struct SimulatedObjective {
    /// The scenario (tunnel, drive, matcher); its landmark model and genes are replaced by
    /// each genome, its seed by the evaluation's.
    pub scenario: Scenario,
    /// The model's genes and bounds.
    pub space: GeneSpace,
}

impl SimulatedObjective {
    /// Runs the scenario with `genes` and `seed`. An error means the genome could not be
    /// run at all (outside the bounds, or a map loc-core cannot hold).
    pub fn evaluate(&self, genes: &[f64], seed: u64) -> Result<Evaluation, String> {
        let mut s = self.scenario.clone();
        s.landmarks.model = self.space.model.code().to_ascii_lowercase();
        s.landmarks.genes = Some(genes.to_vec());
        s.seed = seed;
        let log = run_scenario(&s, EstimatorChoice::Localizer, &Default::default())
            .map_err(|e| e.to_string())?;
        let Accuracy {
            mse_eq2,
            position_rms_m,
            ..
        } = log.metrics().localizer;
        Ok(Evaluation {
            mse_eq2,
            position_rms_m,
        })
    }

    /// The mean of [`Self::evaluate`] over `seeds` (one run per seed; the paper's fitness is
    /// one run). The first run that cannot be made is the error.
    pub fn evaluate_runs(&self, genes: &[f64], seeds: &[u64]) -> Result<Evaluation, String> {
        let mut sum = Evaluation {
            mse_eq2: 0.0,
            position_rms_m: 0.0,
        };
        for &seed in seeds {
            let e = self.evaluate(genes, seed)?;
            sum.mse_eq2 += e.mse_eq2;
            sum.position_rms_m += e.position_rms_m;
        }
        let n = seeds.len().max(1) as f64;
        Ok(Evaluation {
            mse_eq2: sum.mse_eq2 / n,
            position_rms_m: sum.position_rms_m / n,
        })
    }

    /// The fitness of `genes` at `seed`: eq. 2's MSE, or +∞ for a genome that cannot be run
    /// or a run without a finite error (so it ranks last and is never kept).
    pub fn fitness(&self, genes: &[f64], seed: u64) -> f64 {
        match self.evaluate(genes, seed) {
            Ok(e) if e.mse_eq2.is_finite() => e.mse_eq2,
            _ => f64::INFINITY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;
    use loc_core::landmark::LandmarkModel;

    #[test]
    fn fitness_is_a_pure_function_and_tells_genomes_apart() {
        let mut s = named("paper-10m").unwrap();
        s.drive.end_m = 4.0;
        let obj = SimulatedObjective {
            scenario: s,
            space: GeneSpace::for_model(LandmarkModel::P1Triangle),
        };
        let good = [0.5, 0.25, 3.0];
        let a = obj.fitness(&good, 3);
        assert_eq!(a.to_bits(), obj.fitness(&good, 3).to_bits());
        assert!(a.is_finite() && a > 0.0);
        // A tiny landmark barely above the wall roughness localises worse along the tunnel.
        let flat = obj.evaluate(&[0.01, 0.01, 3.0], 3).unwrap();
        assert!(flat.mse_eq2 > a, "{} vs {a}", flat.mse_eq2);
        // Several runs: their mean.
        let two = obj.evaluate_runs(&good, &[3, 4]).unwrap();
        let four = obj.evaluate(&good, 4).unwrap();
        assert!((two.mse_eq2 - (a + four.mse_eq2) / 2.0).abs() < 1e-15);
        // Outside the bounds: not run, ranked last.
        assert_eq!(obj.fitness(&[5.0, 0.25, 3.0], 3), f64::INFINITY);
    }
}
