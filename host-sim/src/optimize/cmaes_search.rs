//! CMA-ES as a second optimiser (issue 9, item 5), from the `cmaes` crate: the genes are
//! searched in the unit cube of their bounds (each gene scaled to [0, 1]), a candidate
//! outside the cube is evaluated at its clamped image plus a quadratic penalty (so the
//! search is pulled back in without a wall the covariance cannot learn), from the cube's
//! centre with σ₀ = 0.3.

use std::time::Instant;

use cmaes::{CMAESOptions, DVector};

use super::genes::{GeneSpace, Genes};

/// What a CMA-ES run found.
#[derive(Debug, Clone, PartialEq)]
pub struct CmaesResult {
    /// The best genes (within the bounds).
    pub best: Genes,
    /// Their objective value.
    pub best_value: f64,
    /// Objective evaluations made.
    pub evaluations: usize,
    /// Wall time, seconds.
    pub wall_time_s: f64,
}

/// Genes from a point of the unit cube (clamped), and the squared distance it lay outside.
pub fn genes_of(space: &GeneSpace, x: &[f64]) -> (Genes, f64) {
    let mut outside = 0.0;
    let genes = x
        .iter()
        .zip(&space.bounds)
        .map(|(&u, &(lo, hi))| {
            let c = u.clamp(0.0, 1.0);
            outside += (u - c) * (u - c);
            lo + c * (hi - lo)
        })
        .collect();
    (genes, outside)
}

/// Minimises `objective` over `space` with at most `max_evaluations` evaluations; `seed`
/// fixes CMA-ES's draws.
pub fn minimise(
    space: &GeneSpace,
    objective: &dyn Fn(&[f64]) -> f64,
    max_evaluations: usize,
    seed: u64,
) -> Result<CmaesResult, String> {
    let started = Instant::now();
    let mut evaluations = 0usize;
    let mut best: Option<(Genes, f64)> = None;
    let f = |x: &DVector<f64>| {
        let (genes, outside) = genes_of(space, x.as_slice());
        let v = objective(&genes);
        evaluations += 1;
        if v.is_finite() && best.as_ref().is_none_or(|b| v < b.1) {
            best = Some((genes, v));
        }
        // CMA-ES needs finite values: an unobserved layout ranks below any observed one.
        let v = if v.is_finite() { v } else { 1e6 };
        v + 1e3 * outside
    };
    let mut state = CMAESOptions::new(vec![0.5; space.len()], 0.3)
        .seed(seed)
        .max_function_evals(max_evaluations)
        .build(f)
        .map_err(|e| format!("CMA-ES options: {e:?}"))?;
    let _ = state.run();
    drop(state);
    let (best, best_value) = best.ok_or("CMA-ES found no genome with a finite objective")?;
    Ok(CmaesResult {
        best,
        best_value,
        evaluations,
        wall_time_s: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::landmark::LandmarkModel;

    #[test]
    fn finds_the_minimum_of_a_bowl_inside_the_bounds() {
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let bowl = |g: &[f64]| {
            (g[0] - 0.3).powi(2) + (g[1] - 0.15).powi(2) + ((g[2] - 9.0) / 100.0).powi(2)
        };
        let r = minimise(&space, &bowl, 3000, 1).unwrap();
        assert!((r.best[0] - 0.3).abs() < 1e-3, "{r:?}");
        assert!((r.best[2] - 9.0).abs() < 0.2, "{r:?}");
        assert!(r.evaluations <= 3000);
        // Outside the cube: clamped, and the distance reported for the penalty.
        let (g, out) = genes_of(&space, &[1.5, -0.5, 0.5]);
        assert_eq!(g[0], space.bounds[0].1);
        assert_eq!(g[1], space.bounds[1].0);
        assert!((out - 0.5).abs() < 1e-12);
    }
}
