//! Matching guided by landmark pre-alignment: the sequence the localizer runs.
//!
//! 1. Pre-align the prediction along the tunnel on the landmark clusters (only if that asks
//!    for more than `min_shift_m`), match from there.
//! 2. Pre-align again from the matched pose: with the heading and the lateral offset now
//!    fixed by the walls, landmark clusters land where they truly are (a 3° heading error
//!    moves a landmark 10 m away by half a metre, enough to make the first pre-alignment
//!    give up). If this asks for a shift above `min_shift_m`, match again from the
//!    shifted pose and keep that result.
//!
//! In steady tracking (a prediction good to a few centimetres) both pre-alignments are
//! skipped; the second match runs only after a large along-tunnel error. A shift beyond
//! `max_shift_sigmas` prediction standard deviations is not applied (a cluster matched to
//! the wrong landmark).
//!
//! When the prediction is poor (the pre-alignment path), the pull-in runs **coarse to
//! fine**: the matches of steps 1 and 2 use every n-th selected point (at most
//! [`COARSE_MATCH_POINTS`], landmarks and walls in their proportions), and one final
//! match on all points starts from the coarse result. Pulling in decimetres takes many
//! iterations with many map searches; on a quarter of the points they cost a quarter, and
//! the final match, starting within millimetres, converges in a few cheap iterations. The
//! acquisition scan's cost so stays within the per-scan budget of a tracking scan.

use super::{match_scan, prealign_along_tunnel, MatchConfig, MatchError, MatchResult};
use super::{MatchWorkspace, PrealignConfig, PrealignShift};
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::strip::{PointLabel, StripSummary, VehiclePoint};

/// Most points of a coarse match (see the module docs).
pub const COARSE_MATCH_POINTS: usize = 64;

/// A guided match and the pre-alignment that started its final run, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidedMatch {
    /// The match.
    pub result: MatchResult,
    /// The pre-alignment shift applied before the final run.
    pub prealign: Option<PrealignShift>,
    /// True when a second match was run after re-pre-aligning.
    pub rematched: bool,
}

/// Matches `selected` (vehicle frame, from [`super::select_match_points`]) against `map`,
/// pre-aligning on the landmark clusters of `points`/`labels` (the whole scan in beam order
/// and its stripping labels) as described in the module docs. `prior_position_sd_m` is the
/// predicted position's standard deviation, metres (`f32::INFINITY` if unknown): when it is
/// below a third of `prealign.min_shift_m` the pre-alignment is skipped.
#[allow(clippy::too_many_arguments)]
pub fn match_scan_with_prealign<M: MapQuery, P: VehiclePoint>(
    map: &M,
    points: &[P],
    labels: &[PointLabel],
    strip: &StripSummary,
    selected: &[Point2],
    predicted: Pose2,
    prior_position_sd_m: f32,
    prealign: &PrealignConfig,
    config: &MatchConfig,
    workspace: &mut MatchWorkspace,
) -> Result<GuidedMatch, MatchError> {
    // A prediction known to within a third of `min_shift_m` cannot profit from a
    // pre-alignment (it would be ignored anyway): skip its cost.
    if prior_position_sd_m.is_finite() && 3.0 * prior_position_sd_m < prealign.min_shift_m {
        return Ok(GuidedMatch {
            result: match_scan(map, selected, predicted, config, workspace)?,
            prealign: None,
            rematched: false,
        });
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
        let limit_m = prealign.max_shift_sigmas * prior_position_sd_m;
        // An unknown (NaN) limit limits nothing.
        n > prealign.min_shift_m && (n <= limit_m || limit_m.is_nan())
    };
    let first_shift =
        prealign_along_tunnel(map, points, labels, strip, predicted, prealign).filter(plausible);
    let start = first_shift.map_or(predicted, |s| s.pose);
    let Ok(first) = match_scan(map, &coarse, start, config, workspace) else {
        // Too few coarse points or no coarse convergence: the full set decides alone.
        return Ok(GuidedMatch {
            result: match_scan(map, selected, start, config, workspace)?,
            prealign: first_shift,
            rematched: false,
        });
    };
    // With few points the coarse set is the whole set and its match is the final one.
    let whole = coarse.len() == selected.len();
    let refine = |coarse_result: MatchResult, workspace: &mut MatchWorkspace| {
        if whole {
            Ok(coarse_result)
        } else {
            match_scan(map, selected, coarse_result.pose, config, workspace)
        }
    };
    let again =
        prealign_along_tunnel(map, points, labels, strip, first.pose, prealign).filter(plausible);
    if let Some(shift) = again {
        if let Ok(second) = match_scan(map, &coarse, shift.pose, config, workspace) {
            return Ok(GuidedMatch {
                result: refine(second, workspace)?,
                prealign: Some(shift),
                rematched: true,
            });
        }
    }
    Ok(GuidedMatch {
        result: refine(first, workspace)?,
        prealign: first_shift,
        rematched: false,
    })
}
