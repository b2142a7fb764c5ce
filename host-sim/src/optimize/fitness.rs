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

use super::genes::GeneSpace;

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
        // Outside the bounds: not run, ranked last.
        assert_eq!(obj.fitness(&[5.0, 0.25, 3.0], 3), f64::INFINITY);
    }
}
