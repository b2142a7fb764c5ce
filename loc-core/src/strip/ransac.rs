//! RANSAC (MSAC scoring) fit of one wall's cubic over a contiguous run of scan points,
//! followed by two least-squares refits on the inliers.
//!
//! Points are weighted by their spacing along x (the gap to the previous beam's point,
//! clamped): beams fall densely on near walls and on landmark flanks facing the sensor but
//! metres apart on far walls, and unweighted fits bend the far wall towards the dense
//! landmark flanks. Spacing weights give every metre of wall a similar say.
//!
//! Budget: hypotheses are scored on a subsample evenly spread in x of at most
//! `score_sample_points` points, so the cost is `iterations × sample` polynomial
//! evaluations plus three passes over the points (extent and subsample, two refits), O(points) with a small constant.

use super::cubic::{Cubic, LeastSquares, XScaling};
use super::{StripConfig, VehiclePoint};
use crate::geometry::Point2;
use crate::math;
use crate::rng::Pcg32;

/// A fitted wall: its polynomial (vehicle frame) and how well the points support it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallFit {
    /// The wall `y = f(x)`, vehicle frame, metres.
    pub cubic: Cubic,
    /// Points within the fit tolerance of the wall used by the final refit (on this wall's
    /// side of the scan; a strided subsample of at most about 256).
    pub inliers: u16,
    /// RMS normal distance of those inliers to the wall, metres.
    pub rms_m: f32,
}

/// Capacity of the scoring subsample.
const MAX_SAMPLE: usize = 128;

/// Points per wall used by each least-squares refit (at most about this many).
const MAX_REFIT: usize = 256;

/// Whether a point takes part in fitting: finite and within the fit range of the vehicle.
#[inline]
pub(super) fn usable(p: Point2, max_fit_range_m: f32) -> bool {
    p.is_finite() && p.norm_sq() <= max_fit_range_m * max_fit_range_m
}

/// Fits one wall to `points` (one side of the scan, in beam order), or `None` when fewer
/// than `min_wall_points` usable points exist or no hypothesis is well posed.
pub(super) fn fit_wall<P: VehiclePoint>(
    points: &[P],
    config: &StripConfig,
    rng: &mut Pcg32,
) -> Option<WallFit> {
    // Hypotheses come from the near wall; the refits extend the wall as far as it keeps
    // explaining the points (out to the far-wall range: where the tunnel bends away from the
    // cubic, the far points stay out of the fit).
    let max_r = config.max_fit_range_m;
    let far_r = math::max(config.far_wall_range_m, max_r);
    let (mut min_x, mut max_x, mut usable_count, mut refit_count) =
        (f32::INFINITY, f32::NEG_INFINITY, 0usize, 0usize);
    for p in points.iter().map(VehiclePoint::vehicle_point) {
        if usable(p, far_r) {
            min_x = math::min(min_x, p.x_m);
            max_x = math::max(max_x, p.x_m);
            refit_count += 1;
            usable_count += usize::from(usable(p, max_r));
        }
    }
    if usable_count < usize::from(config.min_wall_points.max(4)) {
        return None;
    }
    let scaling = XScaling::spanning(min_x, max_x);
    let tol = config.fit_inlier_tolerance_m;
    let tol_sq = tol * tol;

    // Hypotheses are drawn from, and scored on, a subsample evenly spread in x: beams
    // crowd the near wall, and index-based sampling would rarely constrain the far wall.
    let mut sample: heapless::Vec<Point2, MAX_SAMPLE> = heapless::Vec::new();
    let wanted = usize::from(config.score_sample_points).clamp(8, MAX_SAMPLE);
    let step_m = (max_x - min_x) / wanted as f32;
    let mut last_x = f32::NEG_INFINITY;
    for p in points.iter().map(VehiclePoint::vehicle_point) {
        if usable(p, max_r) && math::abs(p.x_m - last_x) >= step_m {
            if sample.push(p).is_err() {
                break;
            }
            last_x = p.x_m;
        }
    }
    let mut best: Option<(f32, Cubic)> = None;
    for _ in 0..config.ransac_iterations {
        let Some(hypothesis) = stratified_hypothesis(&sample, scaling, rng) else {
            continue;
        };
        // MSAC: truncated quadratic loss, better ranked than a bare inlier count. The sum
        // only grows, so a hypothesis is dropped as soon as it reaches the best score so
        // far (checked every 16 points): the same winner, at a fraction of the cost.
        let bound = best.map_or(f32::INFINITY, |(s, _)| s);
        let mut score = 0.0f32;
        for chunk in sample.chunks(16) {
            for p in chunk {
                let r = p.y_m - hypothesis.eval(p.x_m);
                score += math::min(r * r, tol_sq);
            }
            if score >= bound {
                break;
            }
        }
        if score < bound {
            best = Some((score, hypothesis));
        }
    }
    let (_, mut cubic) = best?;

    // Two refits: the first on the hypothesis' inliers, the second on the refined wall's.
    let mut result = None;
    // Refits use at most ~MAX_REFIT points (a strided subsample): a few hundred points pin
    // a cubic far below the tolerances, and this pass dominates the stripper's cost.
    let stride = refit_count.div_ceil(MAX_REFIT).max(1);
    for _ in 0..2 {
        let mut ls = LeastSquares::new(scaling);
        let mut sum_sq = 0.0f32;
        let mut prev = points
            .first()
            .map_or(Point2::ORIGIN, VehiclePoint::vehicle_point);
        for p in points
            .iter()
            .step_by(stride)
            .map(VehiclePoint::vehicle_point)
        {
            if usable(p, far_r) {
                let (r, slope) = cubic.residual_and_slope(p);
                // |normal distance| ≤ tol  ⇔  r² ≤ tol²·(1 + f′²), no square root.
                let stretch = 1.0 + slope * slope;
                if r * r <= tol_sq * stretch {
                    ls.add_weighted(p, spacing_weight(prev, p));
                    sum_sq += r * r / stretch;
                }
            }
            prev = p;
        }
        if ls.count() < u32::from(config.min_wall_points.max(4)) {
            return None;
        }
        let n = ls.count();
        cubic = ls.solve()?;
        result = Some(WallFit {
            cubic,
            inliers: crate::math::saturating_u16(n),
            rms_m: math::sqrt(sum_sq / n as f32),
        });
    }
    result
}

/// The weight of a point: its x distance to the previous (sub)sampled point, clamped to
/// 5 mm … 2 m (the clamp keeps a repeated point and a gap across a landmark in bounds).
#[inline]
fn spacing_weight(prev: Point2, p: Point2) -> f32 {
    let gap = math::abs(p.x_m - prev.x_m);
    if gap.is_finite() {
        gap.clamp(0.005, 2.0)
    } else {
        1.0
    }
}

/// A hypothesis through one random point from each quarter of the x-ordered subsample:
/// spread-out samples give a well-conditioned interpolation (four neighbours would
/// extrapolate wildly).
fn stratified_hypothesis(sample: &[Point2], scaling: XScaling, rng: &mut Pcg32) -> Option<Cubic> {
    let quarter = sample.len() / 4;
    if quarter == 0 {
        return None;
    }
    let mut chosen = [Point2::ORIGIN; 4];
    for (k, slot) in chosen.iter_mut().enumerate() {
        *slot = *sample.get(k * quarter + rng.index(quarter))?;
    }
    Cubic::through(chosen, scaling)
}
