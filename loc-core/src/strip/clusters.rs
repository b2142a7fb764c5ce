//! The landmarks a stripped scan shows: runs of landmark points in beam order
//! ([`LandmarkCluster`]), each with its **height-weighted centroid** (weight `h⁴`, `h` the
//! point's height above the nearer fitted wall).
//!
//! Why the weighting: the top of a landmark faces the tunnel and is seen from everywhere,
//! while its flanks are seen one at a time, so weighting the top cuts the bias of a plain
//! centroid (up to a quarter of the width) to a few centimetres for a triangle. The
//! pre-alignment ([`crate::matching::prealign_along_tunnel`]) and the relocaliser
//! ([`crate::relocalise`]) compare these centroids with the map's landmarks.

use crate::geometry::Point2;
use crate::math;

use super::{PointLabel, StripSummary, VehiclePoint};

/// Most clusters gathered from one scan (an LMS511 sees two or three landmarks per wall).
pub const MAX_CLUSTERS: usize = 16;

/// One observed landmark (or one face of it): a run of landmark points, vehicle frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkCluster {
    /// Σ w·p (vehicle frame) and Σ w with `w = h⁴`.
    weighted_sum: Point2,
    weight: f32,
    /// Plain sum, for landmarks too flat to weight.
    sum: Point2,
    /// Points in the cluster.
    pub count: u16,
    /// The last point added (vehicle frame).
    last: Point2,
}

impl LandmarkCluster {
    fn start(p: Point2, w: f32) -> Self {
        Self {
            weighted_sum: p.scale(w),
            weight: w,
            sum: p,
            count: 1,
            last: p,
        }
    }

    fn add(self, p: Point2, w: f32) -> Self {
        Self {
            weighted_sum: self.weighted_sum.add(p.scale(w)),
            weight: self.weight + w,
            sum: self.sum.add(p),
            count: self.count.saturating_add(1),
            last: p,
        }
    }

    /// The two clusters as one (the faces of one landmark with several peaks).
    pub fn merged(self, other: Self) -> Self {
        Self {
            weighted_sum: self.weighted_sum.add(other.weighted_sum),
            weight: self.weight + other.weight,
            sum: self.sum.add(other.sum),
            count: self.count.saturating_add(other.count),
            last: other.last,
        }
    }

    /// The height-weighted centroid, vehicle frame, metres (the plain centroid for a
    /// cluster without height).
    pub fn centroid(&self) -> Point2 {
        if self.weight > 1e-12 {
            self.weighted_sum.scale(1.0 / self.weight)
        } else {
            self.sum.scale(1.0 / f32::from(self.count.max(1)))
        }
    }
}

/// The landmark clusters of a stripped scan: consecutive landmark points (`labels`, beam
/// order) no farther apart than `max_gap_m` form one cluster; clusters of fewer than
/// `min_points` are dropped; at most [`MAX_CLUSTERS`] (the first ones in beam order).
pub fn landmark_clusters<P: VehiclePoint>(
    points: &[P],
    labels: &[PointLabel],
    strip: &StripSummary,
    max_gap_m: f32,
    min_points: u16,
) -> heapless::Vec<LandmarkCluster, MAX_CLUSTERS> {
    let mut clusters = heapless::Vec::new();
    let mut current: Option<LandmarkCluster> = None;
    let gap_sq = max_gap_m * max_gap_m;
    let close = |c: LandmarkCluster, clusters: &mut heapless::Vec<_, MAX_CLUSTERS>| {
        if c.count >= min_points {
            let _ = clusters.push(c);
        }
    };
    for (p, l) in points
        .iter()
        .map(VehiclePoint::vehicle_point)
        .zip(labels.iter())
    {
        if *l != PointLabel::Landmark || !p.is_finite() {
            continue;
        }
        let w = point_weight(strip, p);
        current = match current {
            Some(c) if max_gap_m >= 0.0 && c.last.dist_sq(p) <= gap_sq => Some(c.add(p, w)),
            other => {
                if let Some(c) = other {
                    close(c, &mut clusters);
                }
                Some(LandmarkCluster::start(p, w))
            }
        };
    }
    if let Some(c) = current {
        close(c, &mut clusters);
    }
    clusters
}

/// The centroid weight `h⁴` of a landmark point `p` (vehicle frame) standing `h` into the
/// tunnel off the nearer fitted wall (0 behind it or without walls). The same as
/// `height_weight(strip.inward_distance_m(p))` without its square roots: with the normal
/// distance `h = v / √(1 + f′²)` (`v` the inward vertical residual), `h⁴ = v⁴ / (1 + f′²)²`
/// and the nearer wall is the one with the smaller `v² / (1 + f′²)`.
#[inline]
fn point_weight(strip: &StripSummary, p: Point2) -> f32 {
    let inward = |w: &super::WallFit, sign: f32| {
        let (r, slope) = w.cubic.residual_and_slope(p);
        let v = sign * r;
        (v, v * v / (1.0 + slope * slope))
    };
    let l = strip.left.as_ref().map(|w| inward(w, -1.0));
    let r = strip.right.as_ref().map(|w| inward(w, 1.0));
    let nearer = match (l, r) {
        (Some(a), Some(b)) => Some(if a.1 <= b.1 { a } else { b }),
        (a, b) => a.or(b),
    };
    match nearer {
        Some((v, h_sq)) if v > 0.0 && h_sq.is_finite() => h_sq * h_sq,
        _ => 0.0,
    }
}

/// The centroid weight of a point `height_m` above its wall: `h⁴`.
#[inline]
pub fn height_weight(height_m: f32) -> f32 {
    let h = if height_m.is_finite() {
        math::max(height_m, 0.0)
    } else {
        0.0
    };
    let h2 = h * h;
    h2 * h2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip::{Cubic, LabelCounts, WallFit, XScaling};

    fn wall(f: impl Fn(f32) -> f32) -> WallFit {
        let s = XScaling::spanning(-5.0, 40.0);
        let pts = [-5.0f32, 10.0, 25.0, 40.0].map(|x| Point2::new(x, f(x)));
        WallFit {
            cubic: Cubic::through(pts, s).unwrap(),
            inliers: 100,
            rms_m: 0.01,
        }
    }

    fn straight_walls() -> StripSummary {
        StripSummary {
            left: Some(wall(|_| 2.5)),
            right: Some(wall(|_| -2.5)),
            counts: LabelCounts::default(),
        }
    }

    #[test]
    fn point_weight_is_the_fourth_power_of_the_inward_distance() {
        let strip = StripSummary {
            left: Some(wall(|x| 2.5 + 0.02 * x)),
            right: Some(wall(|x| -2.5 - 0.001 * x * x)),
            counts: LabelCounts::default(),
        };
        for i in 0..200 {
            let p = Point2::new(-4.0 + 0.22 * i as f32, -3.0 + 0.031 * i as f32);
            let want = height_weight(strip.inward_distance_m(p).unwrap_or(0.0));
            let got = point_weight(&strip, p);
            assert!(
                (got - want).abs() <= 1e-4 * want.max(1e-6),
                "{p:?}: {got} vs {want}"
            );
        }
        let none = StripSummary {
            left: None,
            right: None,
            counts: LabelCounts::default(),
        };
        assert_eq!(point_weight(&none, Point2::new(1.0, 1.0)), 0.0);
    }

    #[test]
    fn clusters_split_at_gaps_and_weigh_the_top() {
        // A triangle 0.5 m wide, 0.25 m high on the left wall at x = 10 (sampled every
        // 5 cm), a two-point glint at x = 14, another triangle at x = 20.
        let mut points = heapless::Vec::<Point2, 64>::new();
        let mut labels = heapless::Vec::<PointLabel, 64>::new();
        let triangle = |x0: f32, points: &mut heapless::Vec<Point2, 64>| {
            for k in 0..=10 {
                let u = -0.25 + 0.05 * k as f32;
                let h = 0.25 * (1.0 - (u / 0.25).abs());
                let _ = points.push(Point2::new(x0 + u, 2.5 - h));
            }
        };
        triangle(10.0, &mut points);
        let _ = points.push(Point2::new(14.0, 2.4));
        let _ = points.push(Point2::new(14.05, 2.4));
        triangle(20.0, &mut points);
        for _ in 0..points.len() {
            let _ = labels.push(PointLabel::Landmark);
        }
        let strip = straight_walls();
        let c = landmark_clusters(&points, &labels, &strip, 0.3, 4);
        assert_eq!(c.len(), 2, "{c:?}");
        for (cluster, x0) in c.iter().zip([10.0, 20.0]) {
            assert_eq!(cluster.count, 11);
            let centroid = cluster.centroid();
            assert!((centroid.x_m - x0).abs() < 1e-3, "{centroid:?}");
            // Weighted towards the top (0.25 m off the wall), not the plain mean height.
            assert!(2.5 - centroid.y_m > 0.15, "{centroid:?}");
        }
        // Wall points between them do not join or split anything.
        let mut relabelled = labels.clone();
        relabelled[11] = PointLabel::LeftWall;
        assert_eq!(
            landmark_clusters(&points, &relabelled, &strip, 0.3, 4).len(),
            2
        );
    }
}
