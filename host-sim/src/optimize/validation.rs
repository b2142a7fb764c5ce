//! Validation of a genome on fresh seeds (§5.1, Table 3's way): the position RMS of
//! repeated simulated runs, their mean and its 95 % confidence interval.

use rayon::prelude::*;
use serde::Serialize;

use super::fitness::SimulatedObjective;

/// Two-sided 97.5 % quantile of Student's t for `dof` degrees of freedom (exact to three
/// decimals up to 30, the normal's 1.960 beyond).
pub fn t_975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::INFINITY,
        d if d <= 30 => T[d - 1],
        _ => 1.960,
    }
}

/// The position RMS of a genome over repeated runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// Seeds run.
    pub seeds: Vec<u64>,
    /// Each run's position RMS, metres (+∞ for a run that failed).
    pub position_rms_m: Vec<f64>,
    /// Mean of the runs' position RMS, metres.
    pub mean_position_rms_m: f64,
    /// Half-width of its 95 % confidence interval (Student's t), metres.
    pub ci95_m: f64,
}

impl Validation {
    /// Summarises per-seed figures.
    pub fn of(seeds: Vec<u64>, position_rms_m: Vec<f64>) -> Self {
        let n = position_rms_m.len();
        let mean = position_rms_m.iter().sum::<f64>() / n.max(1) as f64;
        let var = if n > 1 {
            position_rms_m
                .iter()
                .map(|r| (r - mean).powi(2))
                .sum::<f64>()
                / (n - 1) as f64
        } else {
            f64::INFINITY
        };
        Self {
            seeds,
            position_rms_m,
            mean_position_rms_m: mean,
            ci95_m: t_975(n.saturating_sub(1)) * (var / n.max(1) as f64).sqrt(),
        }
    }
}

/// Runs `genes` at each of `seeds` (in parallel).
pub fn validate(obj: &SimulatedObjective, genes: &[f64], seeds: &[u64]) -> Validation {
    let rms: Vec<f64> = seeds
        .par_iter()
        .map(|&s| match obj.evaluate(genes, s) {
            Ok(e) if e.position_rms_m.is_finite() => e.position_rms_m,
            _ => f64::INFINITY,
        })
        .collect();
    Validation::of(seeds.to_vec(), rms)
}

/// `count` fresh seeds for a search run with `seed`: `seed + 1 …`, never the search's own.
pub fn fresh_seeds(seed: u64, count: usize) -> Vec<u64> {
    (1..=count as u64).map(|k| seed.wrapping_add(k)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_interval() {
        let v = Validation::of(vec![1, 2, 3, 4], vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(v.mean_position_rms_m, 2.5);
        // s = 1.291, t(3) = 3.182: 3.182 · 1.291 / 2 = 2.054.
        assert!((v.ci95_m - 2.054).abs() < 1e-3, "{}", v.ci95_m);
        assert_eq!(t_975(14), 2.145);
        assert_eq!(t_975(200), 1.960);
        assert!(Validation::of(vec![1], vec![1.0]).ci95_m.is_infinite());
        assert_eq!(fresh_seeds(7, 3), vec![8, 9, 10]);
    }
}
