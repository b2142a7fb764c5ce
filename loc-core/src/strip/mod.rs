//! Wall stripping (paper §4.3): fit each tunnel wall with a cubic polynomial by RANSAC, then
//! label every scan point as left wall, right wall, landmark or outlier.
//!
//! Everything here is in the **vehicle frame** (x forward along the tunnel, y left); the map
//! and the pose estimate are not used, so stripping works before localisation.
//!
//! ## Method
//! 1. **Split** the scan (points in beam order, right to left as the LMS511 sweeps) at its
//!    farthest point: the beams before it see one wall, the beams after it the other. Unlike a
//!    split on the sign of `y`, this holds when the vehicle is off-centre, turned a few
//!    degrees, or in a curve (a radius-50 m tunnel puts the far right wall at `y > 0`).
//! 2. **RANSAC** per side: hypotheses interpolate one random point from each quarter of the
//!    side's subsample evenly spread in x, scored (MSAC, truncated quadratic) on it; seeded from
//!    [`StripConfig::seed`] at every call, so a scan always strips the same way; bounded by
//!    [`StripConfig::ransac_iterations`].
//! 3. **Refit** by least squares (4×4 normal equations in a scaled abscissa, see
//!    [`Cubic`]) on the inliers, twice.
//! 4. **Label** each point by its normal distance to the nearer wall: within
//!    [`StripConfig::wall_tolerance_m`] it is wall; off the wall by more, but no farther than
//!    [`StripConfig::landmark_band_inward_m`] into the tunnel or
//!    [`StripConfig::landmark_band_outward_m`] into the rock (inverted landmarks, recesses), it
//!    is a landmark point; anything else (people, vehicles, the tunnel face) is an outlier.
//!    Points beyond [`StripConfig::max_fit_range_m`] (30 m) are not fitted: a cubic cannot
//!    follow a curved wall farther. Out to [`StripConfig::far_wall_range_m`] (65 m) they are
//!    wall points where the extrapolated wall explains them, [`PointLabel::OutOfRange`]
//!    otherwise (and beyond).
//!
//! The walls are named after fitting: the wall with the larger `y` at `x = 0` is the left one,
//! so a sensor mounted backwards (beams sweeping left to right) is handled too.
//!
//! Cost: `O(points)`: 2 × `ransac_iterations` × `score_sample_points` polynomial evaluations,
//! plus four refit passes and one labelling pass over the points.

mod clusters;
mod cubic;
mod ransac;

pub use clusters::{height_weight, landmark_clusters, LandmarkCluster, MAX_CLUSTERS};
pub use cubic::{Cubic, LeastSquares, XScaling};
pub use ransac::WallFit;

use crate::geometry::Point2;
use crate::math;
use crate::rng::Pcg32;

/// Anything that carries a point in the vehicle frame (a bare [`Point2`], a scan point).
pub trait VehiclePoint {
    /// The point in the vehicle frame, metres.
    fn vehicle_point(&self) -> Point2;
}

impl VehiclePoint for Point2 {
    #[inline]
    fn vehicle_point(&self) -> Point2 {
        *self
    }
}

impl VehiclePoint for crate::scan::ScanPoint {
    #[inline]
    fn vehicle_point(&self) -> Point2 {
        self.vehicle
    }
}

/// What a scan point is, after stripping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PointLabel {
    /// On the left wall (larger `y`), within the wall tolerance.
    LeftWall,
    /// On the right wall, within the wall tolerance.
    RightWall,
    /// Off its wall by more than the wall tolerance but inside the landmark band.
    Landmark,
    /// Neither wall nor landmark (or no wall could be fitted).
    #[default]
    Outlier,
    /// Farther from the vehicle than the fit range, or not finite.
    OutOfRange,
}

impl PointLabel {
    /// True for either wall.
    #[inline]
    pub fn is_wall(self) -> bool {
        matches!(self, PointLabel::LeftWall | PointLabel::RightWall)
    }
}

/// Tuning of the wall stripper. Distances in metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StripConfig {
    /// A point within this normal distance of a wall is a wall point, metres. Must exceed the
    /// range noise (3σ) plus wall roughness and stay below the smallest landmark height.
    pub wall_tolerance_m: f32,
    /// Inlier tolerance for scoring and refitting, metres (tighter than the wall tolerance so
    /// landmark flanks do not bend the fit).
    pub fit_inlier_tolerance_m: f32,
    /// Deepest a landmark reaches into the tunnel from its wall, metres.
    pub landmark_band_inward_m: f32,
    /// Deepest a landmark (a recess) reaches behind its wall, metres.
    pub landmark_band_outward_m: f32,
    /// Points farther than this from the vehicle origin are not fitted, and are never
    /// landmark points, metres: a cubic cannot follow a curved wall farther, and a
    /// landmark's shape is not resolved farther.
    pub max_fit_range_m: f32,
    /// Points between `max_fit_range_m` and this range (metres) are wall points where the
    /// fitted wall, extrapolated, explains them (within `wall_tolerance_m`), and
    /// [`PointLabel::OutOfRange`] otherwise. The far wall points are what fixes the heading
    /// (a lever of tens of metres): on 200 m of `tunnel-1km` the heading RMS was 0.26 mrad
    /// with walls to 30 m, 0.14 mrad with walls to 65 m (the position 5.4 → 4.7 mm); where
    /// the tunnel bends away from the extrapolation, the far points are left out rather
    /// than mistaken for landmarks. (The fit itself stays within `max_fit_range_m` but
    /// for its refits, which take the far points the near fit explains: fitted out to
    /// 65 m, a cubic bends in a 50 m-radius tunnel until near wall points pass for
    /// landmarks.)
    pub far_wall_range_m: f32,
    /// Beyond `max_fit_range_m`, a point within this normal distance of its extrapolated
    /// wall is a wall point, metres (loose: the extrapolation drifts off a curving wall, and
    /// the match pairs each point with the map, not with the cubic; 0.3 m kept fewer far
    /// points: 0.148 against 0.138 mrad heading RMS on the 200 m above).
    pub far_wall_tolerance_m: f32,
    /// RANSAC hypotheses per wall.
    pub ransac_iterations: u16,
    /// Points each hypothesis is drawn from and scored on: a subsample of the wall's side
    /// evenly spread in x (at most 128).
    pub score_sample_points: u16,
    /// Fewest inliers for a wall to count as found.
    pub min_wall_points: u16,
    /// Seed of the RANSAC sampler (re-seeded at every call: deterministic).
    pub seed: u64,
}

impl StripConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    /// Tuned for the LMS511 (≈10 mm range noise) and the paper's landmark sizes
    /// (height 0.01–0.35 m).
    pub const DEFAULT: Self = Self {
        wall_tolerance_m: 0.04,
        fit_inlier_tolerance_m: 0.03,
        landmark_band_inward_m: 0.6,
        landmark_band_outward_m: 0.3,
        max_fit_range_m: 30.0,
        far_wall_range_m: 65.0,
        far_wall_tolerance_m: 0.6,
        ransac_iterations: 16,
        score_sample_points: 64,
        min_wall_points: 12,
        seed: 0x005e_ed0f_ca11,
    };
}

impl Default for StripConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How many points got each label.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LabelCounts {
    /// Left-wall points.
    pub left_wall: u16,
    /// Right-wall points.
    pub right_wall: u16,
    /// Landmark points.
    pub landmark: u16,
    /// Outliers.
    pub outlier: u16,
    /// Out-of-range or non-finite points.
    pub out_of_range: u16,
}

/// The walls found and the label counts of one stripping run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StripSummary {
    /// The left wall (larger `y`), if found.
    pub left: Option<WallFit>,
    /// The right wall, if found.
    pub right: Option<WallFit>,
    /// Points per label.
    pub counts: LabelCounts,
}

impl StripSummary {
    /// The wall a point was assigned to.
    pub fn wall(&self, label: PointLabel) -> Option<&WallFit> {
        match label {
            PointLabel::LeftWall => self.left.as_ref(),
            PointLabel::RightWall => self.right.as_ref(),
            _ => None,
        }
    }

    /// The unit along-tunnel direction (vehicle frame, pointing to increasing x) at
    /// abscissa `x_m` from the wall nearer to `p`, or +x when no wall was found.
    pub fn tunnel_tangent_at(&self, p: Point2) -> Point2 {
        let near = match (&self.left, &self.right) {
            (Some(l), Some(r)) => {
                if math::abs(l.cubic.signed_distance_m(p))
                    <= math::abs(r.cubic.signed_distance_m(p))
                {
                    Some(l)
                } else {
                    Some(r)
                }
            }
            (Some(w), None) | (None, Some(w)) => Some(w),
            (None, None) => None,
        };
        near.map_or(Point2::new(1.0, 0.0), |w| w.cubic.tangent(p.x_m))
    }
}

impl StripSummary {
    /// How far `p` (vehicle frame) stands off the nearer fitted wall into the tunnel, metres
    /// (negative behind the wall); `None` without walls.
    pub fn inward_distance_m(&self, p: Point2) -> Option<f32> {
        let l = self.left.map(|w| -w.cubic.signed_distance_m(p));
        let r = self.right.map(|w| w.cubic.signed_distance_m(p));
        match (l, r) {
            (Some(l), Some(r)) => Some(if math::abs(l) <= math::abs(r) { l } else { r }),
            (Some(d), None) | (None, Some(d)) => Some(d),
            (None, None) => None,
        }
    }
}

/// Strips the walls from a scan: fits both walls and writes one label per point into
/// `labels` (only the first `min(points.len(), labels.len())` points are processed).
///
/// `points` are in the vehicle frame and in beam order. Never panics: empty, tiny or
/// degenerate scans give `None` walls and every point labelled [`PointLabel::Outlier`] (or
/// [`PointLabel::OutOfRange`]).
pub fn strip_walls<P: VehiclePoint>(
    points: &[P],
    config: &StripConfig,
    labels: &mut [PointLabel],
) -> StripSummary {
    let n = points.len().min(labels.len());
    let points = points.get(..n).unwrap_or_default();
    let mut rng = Pcg32::seeded(config.seed);

    // Split at the farthest usable point (see the module docs).
    let mut split = 0usize;
    let mut far_sq = -1.0f32;
    for (i, p) in points.iter().map(VehiclePoint::vehicle_point).enumerate() {
        let d = p.norm_sq();
        if p.is_finite() && d > far_sq {
            far_sq = d;
            split = i;
        }
    }
    let (first, second) = points.split_at(split.min(points.len()));
    let a = ransac::fit_wall(first, config, &mut rng);
    let b = ransac::fit_wall(second, config, &mut rng);
    let (left, right) = name_walls(a, b);

    let mut counts = LabelCounts::default();
    for (p, label) in points
        .iter()
        .map(VehiclePoint::vehicle_point)
        .zip(labels.iter_mut())
    {
        *label = label_point(p, left.as_ref(), right.as_ref(), config);
        let c = match label {
            PointLabel::LeftWall => &mut counts.left_wall,
            PointLabel::RightWall => &mut counts.right_wall,
            PointLabel::Landmark => &mut counts.landmark,
            PointLabel::Outlier => &mut counts.outlier,
            PointLabel::OutOfRange => &mut counts.out_of_range,
        };
        *c = c.saturating_add(1);
    }
    StripSummary {
        left,
        right,
        counts,
    }
}

/// Orders two fitted walls as (left, right) by their `y` at `x = 0`.
fn name_walls(a: Option<WallFit>, b: Option<WallFit>) -> (Option<WallFit>, Option<WallFit>) {
    match (a, b) {
        (Some(a), Some(b)) => {
            if a.cubic.eval(0.0) >= b.cubic.eval(0.0) {
                (Some(a), Some(b))
            } else {
                (Some(b), Some(a))
            }
        }
        (Some(w), None) | (None, Some(w)) => {
            if w.cubic.eval(0.0) >= 0.0 {
                (Some(w), None)
            } else {
                (None, Some(w))
            }
        }
        (None, None) => (None, None),
    }
}

/// The label of one point given the fitted walls.
fn label_point(
    p: Point2,
    left: Option<&WallFit>,
    right: Option<&WallFit>,
    config: &StripConfig,
) -> PointLabel {
    let far_range_m = math::max(config.far_wall_range_m, config.max_fit_range_m);
    if !ransac::usable(p, far_range_m) {
        return PointLabel::OutOfRange;
    }
    let near = ransac::usable(p, config.max_fit_range_m);
    // Nearer wall by vertical residual. Inward: positive into the tunnel (below the left
    // wall, above the right one). The wall on the point's own side (left for y ≥ 0) is
    // evaluated first; a point within the wall tolerance of it belongs to it (the other
    // wall lies a tunnel width away), which spares the second polynomial evaluation for
    // most points.
    let l = || left.map(|w| (PointLabel::LeftWall, w.cubic.residual_and_slope(p), -1.0f32));
    let r = || right.map(|w| (PointLabel::RightWall, w.cubic.residual_and_slope(p), 1.0f32));
    let own = if p.y_m >= 0.0 { l() } else { r() };
    let tol_m = config.wall_tolerance_m;
    let own_is_wall = own.is_some_and(|(_, (res, slope), _)| {
        tol_m >= 0.0 && res * res <= tol_m * tol_m * (1.0 + slope * slope)
    });
    let nearer = if own_is_wall {
        own
    } else {
        let other = if p.y_m >= 0.0 { r() } else { l() };
        match (own, other) {
            (Some(a), Some(b)) => Some(if math::abs(a.1 .0) <= math::abs(b.1 .0) {
                a
            } else {
                b
            }),
            (a, b) => a.or(b),
        }
    };
    let Some((wall, (residual, slope), sign)) = nearer else {
        return PointLabel::Outlier;
    };
    // The normal distance is `residual / √(1 + slope²)`; each test `|distance| ≤ limit` is
    // made as `residual² ≤ limit²·(1 + slope²)`, without the square root (one per point
    // was a tenth of the stripper's cost on the Cortex-M4F).
    let inward = sign * residual;
    let inward_sq = inward * inward;
    let stretch = 1.0 + slope * slope;
    let within = |limit_m: f32| limit_m >= 0.0 && inward_sq <= limit_m * limit_m * stretch;
    if within(config.wall_tolerance_m) {
        wall
    } else if !near {
        // Beyond the fit the extrapolated wall drifts off a curving tunnel's: a looser
        // tolerance keeps its far points, the map decides in the match.
        if within(config.far_wall_tolerance_m) {
            wall
        } else {
            PointLabel::OutOfRange
        }
    } else if inward > 0.0 && within(config.landmark_band_inward_m)
        || inward < 0.0 && within(config.landmark_band_outward_m)
    {
        PointLabel::Landmark
    } else {
        PointLabel::Outlier
    }
}

#[cfg(test)]
mod tests;
