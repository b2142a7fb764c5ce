//! Matching guided by landmark pre-alignment: the sequence the localizer runs.
//!
//! 1. Pre-align the prediction along the tunnel on the landmark clusters (only if that asks
//!    for more than `min_shift_m`), match from there.
//! 2. If the first gave up, pre-align again from the matched pose: with the heading and
//!    the lateral offset now fixed by the walls, landmark clusters land where they truly
//!    are (a 3° heading error moves a landmark 10 m away by half a metre, enough to make
//!    the first pre-alignment give up). If this asks for a shift above `min_shift_m`,
//!    match again from the shifted pose and keep that result.
//!
//! In steady tracking (a prediction good to a few centimetres) both pre-alignments are
//! skipped; the second match runs only after a large along-tunnel error. A shift beyond
//! `max_shift_sigmas` standard deviations of the prediction **in the shift's direction** is
//! not applied (a cluster matched to the wrong landmark): near a tunnel's end, or wherever
//! the walls observe the lateral position weakly, the prediction can be uncertain sideways
//! and still sure along the tunnel, and a look-alike shift of a landmark's tooth along the
//! tunnel must not pass because of the sideways uncertainty.
//!
//! When the prediction is poor (the pre-alignment path), the pull-in runs **coarse to
//! fine**: the matches of steps 1 and 2 use every n-th selected point (at most
//! [`COARSE_MATCH_POINTS`], landmarks and walls in their proportions), and one final
//! match on all points starts from the coarse result (when the first pre-alignment shifted
//! the prediction, the coarse match is point-to-line ICP whatever the configured matcher:
//! see [`match_scan_with_prealign`]). Pulling in decimetres takes many
//! iterations with many map searches; on a quarter of the points they cost a quarter, and
//! the final match, starting within millimetres, converges in a few cheap iterations. The
//! acquisition scan's cost so stays within the per-scan budget of a tracking scan.

use super::{match_scan, prealign_along_tunnel, MatchConfig, MatchError, MatchResult, MatcherKind};
use super::{MatchWorkspace, PrealignConfig, PrealignShift};
use nalgebra::{Matrix2, Matrix3};

use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::strip::{PointLabel, StripSummary, VehiclePoint};

/// Most points of a coarse match (see the module docs).
pub const COARSE_MATCH_POINTS: usize = 48;

/// A coarse match converges at this many times the final match's step tolerances.
pub const COARSE_CONVERGENCE_FACTOR: f32 = 10.0;

/// A guided match and the pre-alignment that started its final run, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidedMatch {
    /// The match.
    pub result: MatchResult,
    /// The pre-alignment shift applied before the final run.
    pub prealign: Option<PrealignShift>,
    /// True when a second match was run after re-pre-aligning.
    pub rematched: bool,
    /// The work of every match of the sequence, failed ones included (units of
    /// [`MatchConfig::max_work`], which bounds it: the matches share one budget).
    pub work: u32,
}

/// The predicted position's uncertainty, as the pre-alignment judges shifts by it: the
/// `(x, y)` covariance of the prediction, world frame, m².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionPrior {
    covariance_m2: Matrix2<f32>,
}

impl PositionPrior {
    /// Nothing known about the prediction: every shift is plausible.
    pub const UNKNOWN: Self = Self {
        covariance_m2: Matrix2::new(f32::INFINITY, 0.0, 0.0, f32::INFINITY),
    };

    /// The position block of a filter covariance `(x_m, y_m, theta_rad)`, world frame.
    pub fn from_covariance(p: &Matrix3<f32>) -> Self {
        Self {
            covariance_m2: p.fixed_view::<2, 2>(0, 0).into_owned(),
        }
    }

    /// The covariance of the predicted position `(x, y)`, world frame, m².
    pub fn covariance_m2(&self) -> &Matrix2<f32> {
        &self.covariance_m2
    }

    /// The same standard deviation `sd_m` (metres) in every direction.
    pub fn isotropic(sd_m: f32) -> Self {
        let v = sd_m * sd_m;
        Self {
            covariance_m2: Matrix2::new(v, 0.0, 0.0, v),
        }
    }

    /// `√(σx² + σy²)`, metres: bounds the standard deviation in any direction.
    pub fn sd_m(&self) -> f32 {
        let c = &self.covariance_m2;
        crate::math::sqrt(crate::math::max(c.m11 + c.m22, 0.0))
    }

    /// The standard deviation along `direction` (world frame, any length but zero), metres;
    /// NaN when unknown (an infinite or degenerate covariance, a zero direction).
    pub fn sd_along_m(&self, direction: Point2) -> f32 {
        let n_sq = direction.norm_sq();
        let c = &self.covariance_m2;
        if !(n_sq > 0.0 && c.iter().all(|v| v.is_finite())) {
            return f32::NAN;
        }
        let (x, y) = (direction.x_m, direction.y_m);
        let v = (c.m11 * x * x + 2.0 * c.m12 * x * y + c.m22 * y * y) / n_sq;
        crate::math::sqrt(crate::math::max(v, 0.0))
    }
}

/// Matches `selected` (vehicle frame, from [`super::select_match_points`]) against `map`,
/// pre-aligning on the landmark clusters of `points`/`labels` (the whole scan in beam order
/// and its stripping labels) as described in the module docs. `prior` is the predicted
/// position's uncertainty ([`PositionPrior::UNKNOWN`] if unknown): when its
/// [`PositionPrior::sd_m`] is below `prealign.min_prior_sd_m` the pre-alignment is
/// skipped, and a shift beyond `prealign.max_shift_sigmas` of its
/// [`PositionPrior::sd_along_m`] is not applied.
#[allow(clippy::too_many_arguments)]
pub fn match_scan_with_prealign<M: MapQuery, P: VehiclePoint>(
    map: &M,
    points: &[P],
    labels: &[PointLabel],
    strip: &StripSummary,
    selected: &[Point2],
    predicted: Pose2,
    prior: &PositionPrior,
    prealign: &PrealignConfig,
    config: &MatchConfig,
    workspace: &mut MatchWorkspace,
) -> Result<GuidedMatch, MatchError> {
    workspace.begin_scan();
    // Each match gets what the earlier ones left of the scan's budget.
    let match_scan =
        |points: &[Point2], start: Pose2, config: &MatchConfig, workspace: &mut MatchWorkspace| {
            let left = MatchConfig {
                max_work: config.max_work.saturating_sub(workspace.work()),
                ..*config
            };
            match_scan(map, points, start, &left, workspace)
        };
    let guided = |result, prealign, rematched, workspace: &MatchWorkspace| GuidedMatch {
        result,
        prealign,
        rematched,
        work: workspace.work(),
    };
    // A prediction known to within `min_prior_sd_m` cannot profit from a pre-alignment:
    // skip its cost.
    let prior_sd_m = prior.sd_m();
    // The landmarks are judged against the prediction only here, where it is good enough to
    // start from: a pre-alignment's shift is one the prediction did not foresee.
    let gate = workspace.landmark_gate.take();
    if prior_sd_m.is_finite() && prior_sd_m < prealign.min_prior_sd_m {
        workspace.landmark_gate = gate;
        let result = match_scan(selected, predicted, config, workspace);
        workspace.landmark_gate = None;
        return Ok(guided(result?, None, false, workspace));
    }
    let mut coarse: heapless::Vec<Point2, COARSE_MATCH_POINTS> = heapless::Vec::new();
    let stride = selected.len().div_ceil(COARSE_MATCH_POINTS).max(1);
    for &p in selected.iter().step_by(stride) {
        if coarse.push(p).is_err() {
            break;
        }
    }
    // A shift the prediction's own uncertainty makes implausible is a landmark cluster
    // matched to the wrong map landmark (one wall of look-alike landmarks, some missing):
    // following it would lock the estimate confidently onto a wrong position.
    let plausible = |s: &PrealignShift| {
        let n = s.shift_world.norm();
        let limit_m = prealign.max_shift_sigmas * prior.sd_along_m(s.shift_world);
        // An unknown (NaN) limit limits nothing.
        n > prealign.min_shift_m && (n <= limit_m || limit_m.is_nan())
    };
    // With few points the coarse set is the whole set and its match is the final one.
    let whole = coarse.len() == selected.len();
    // Otherwise the coarse matches only pull in: the final match refines their result, so
    // they stop at a coarser tolerance instead of iterating to full precision on a
    // quarter of the points.
    let coarse_config = if whole {
        *config
    } else {
        MatchConfig {
            convergence_translation_m: COARSE_CONVERGENCE_FACTOR * config.convergence_translation_m,
            convergence_rotation_rad: COARSE_CONVERGENCE_FACTOR * config.convergence_rotation_rad,
            ..*config
        }
    };
    let first_shift =
        prealign_along_tunnel(map, points, labels, strip, predicted, prealign).filter(plausible);
    let start = first_shift.map_or(predicted, |s| s.pose);
    // A pull-in the landmarks started (a pre-alignment shift: walls and landmarks agree
    // where the estimate should go) runs point-to-line ICP, whose Gauss–Newton steps reach
    // it in a few iterations where the Hausdorff loop's take ten or more and the scan's
    // work budget ends the final match before it converges (`paper-10m` seed 2: its first
    // scan 56 mm off, the run 4.19 mm; with ICP pulling in, 2.63 mm). Without a shift —
    // no landmark in view, the walls alone — the configured matcher pulls in as before
    // (ICP there took the bare S-bend's end from 18 to 33 mm sideways).
    let pull_in = MatchConfig {
        matcher: if first_shift.is_some() && !whole {
            MatcherKind::Icp
        } else {
            coarse_config.matcher
        },
        ..coarse_config
    };
    let Ok(first) = match_scan(&coarse, start, &pull_in, workspace) else {
        // Too few coarse points or no coarse convergence: the full set decides alone.
        let result = match_scan(selected, start, config, workspace)?;
        return Ok(guided(result, first_shift, false, workspace));
    };
    let refine = |coarse_result: MatchResult, workspace: &mut MatchWorkspace| {
        if whole {
            Ok(coarse_result)
        } else {
            match_scan(selected, coarse_result.pose, config, workspace)
        }
    };
    // A first pre-alignment that found its shift needs no second one.
    let again = if first_shift.is_some() {
        None
    } else {
        prealign_along_tunnel(map, points, labels, strip, first.pose, prealign).filter(plausible)
    };
    if let Some(shift) = again {
        if let Ok(second) = match_scan(&coarse, shift.pose, &coarse_config, workspace) {
            let result = refine(second, workspace)?;
            return Ok(guided(result, Some(shift), true, workspace));
        }
    }
    let result = refine(first, workspace)?;
    Ok(guided(result, first_shift, false, workspace))
}
