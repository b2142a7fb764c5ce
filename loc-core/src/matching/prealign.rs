//! Coarse along-tunnel alignment before matching: shift the predicted pose along the tunnel
//! so that each observed landmark (a cluster of landmark points) sits on the nearest map
//! landmark.
//!
//! Why: a landmark is about as wide as a typical along-tunnel prediction error (P1 default
//! 0.5 m). With a larger error the landmark points fall beside their landmark, the nearest
//! map geometry is the bare wall, and neither matcher can pull them back. Clusters are
//! compared by centroids, so the shift is biased by at most a quarter of a landmark width
//! (only the flank facing the sensor is seen); the matcher removes that residue.
//!
//! The shift is along the tunnel only (the wall tangent from the stripper); it is skipped
//! when clusters disagree, when it exceeds `max_shift_m`, or when no landmark is in view.

use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::math;
use crate::strip::{PointLabel, StripSummary, VehiclePoint};

/// Tuning of the pre-alignment. Distances in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrealignConfig {
    /// Run it at all.
    pub enabled: bool,
    /// Largest shift applied, metres (beyond it the nearest landmark may be the wrong one:
    /// keep it below half the landmark spacing).
    pub max_shift_m: f32,
    /// Map landmarks searched within this distance of a cluster, metres.
    pub search_radius_m: f32,
    /// Consecutive landmark points farther apart than this start a new cluster, metres.
    pub max_cluster_gap_m: f32,
    /// Fewest points in a cluster.
    pub min_cluster_points: u16,
    /// Clusters whose along-tunnel offsets differ by more than this cancel the shift, metres.
    pub max_disagreement_m: f32,
}

impl Default for PrealignConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            max_shift_m: 2.0,
            search_radius_m: 2.5,
            max_cluster_gap_m: 0.3,
            min_cluster_points: 4,
            max_disagreement_m: 0.4,
        }
    }
}

/// A pre-alignment that was applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrealignShift {
    /// The shifted pose (world frame).
    pub pose: Pose2,
    /// The shift, world frame, metres.
    pub shift_world: Point2,
    /// Clusters that agreed on it.
    pub clusters: u8,
}

/// Most clusters considered per scan.
const MAX_CLUSTERS: usize = 16;
/// Most distinct landmarks tracked around one cluster.
const MAX_NEARBY: usize = 8;

#[derive(Clone, Copy)]
struct Cluster {
    sum: Point2,
    count: u16,
    last: Point2,
}

/// Shifts `predicted` along the tunnel so observed landmark clusters (from `labels`, in beam
/// order) meet their nearest map landmarks; `None` when nothing reliable was found.
pub fn prealign_along_tunnel<M: MapQuery, P: VehiclePoint>(
    map: &M,
    points: &[P],
    labels: &[PointLabel],
    strip: &StripSummary,
    predicted: Pose2,
    config: &PrealignConfig,
) -> Option<PrealignShift> {
    if !config.enabled || !predicted.is_finite() {
        return None;
    }
    let mut clusters: heapless::Vec<Cluster, MAX_CLUSTERS> = heapless::Vec::new();
    let mut current: Option<Cluster> = None;
    for (p, l) in points
        .iter()
        .map(VehiclePoint::vehicle_point)
        .zip(labels.iter())
    {
        if *l != PointLabel::Landmark || !p.is_finite() {
            continue;
        }
        current = match current {
            Some(c) if c.last.dist(p) <= config.max_cluster_gap_m => Some(Cluster {
                sum: c.sum.add(p),
                count: c.count.saturating_add(1),
                last: p,
            }),
            other => {
                if let Some(c) = other {
                    if c.count >= config.min_cluster_points {
                        let _ = clusters.push(c);
                    }
                }
                Some(Cluster {
                    sum: p,
                    count: 1,
                    last: p,
                })
            }
        };
    }
    if let Some(c) = current {
        if c.count >= config.min_cluster_points {
            let _ = clusters.push(c);
        }
    }

    // Per cluster: along-tunnel offset to the nearest map landmark, weighted by points.
    let mut offsets: heapless::Vec<(f32, Point2, f32), MAX_CLUSTERS> = heapless::Vec::new();
    for c in &clusters {
        let centroid_v = c.sum.scale(1.0 / f32::from(c.count));
        let centroid_w = predicted.transform_point(centroid_v);
        let tangent_w = predicted.rotate_vector(strip.tunnel_tangent_at(centroid_v));
        let Some(landmark_w) = nearest_landmark_centroid(map, centroid_w, config.search_radius_m)
        else {
            continue;
        };
        let along = landmark_w.sub(centroid_w).dot(tangent_w);
        let _ = offsets.push((along, tangent_w, f32::from(c.count)));
    }
    if offsets.is_empty() {
        return None;
    }
    let total_w: f32 = offsets.iter().map(|o| o.2).sum();
    let mean_along = offsets.iter().map(|o| o.0 * o.2).sum::<f32>() / total_w;
    if offsets
        .iter()
        .any(|o| math::abs(o.0 - mean_along) > config.max_disagreement_m)
        || !mean_along.is_finite()
        || math::abs(mean_along) > config.max_shift_m
    {
        return None;
    }
    let shift = offsets.iter().fold(Point2::ORIGIN, |acc, o| {
        acc.add(o.1.scale(o.0 * o.2 / total_w))
    });
    Some(PrealignShift {
        pose: Pose2::new(
            predicted.x_m + shift.x_m,
            predicted.y_m + shift.y_m,
            predicted.theta_rad,
        ),
        shift_world: shift,
        clusters: u8::try_from(offsets.len()).unwrap_or(u8::MAX),
    })
}

/// The length-weighted centroid of the map landmark nearest to `p` (by centroid) among those
/// with a segment within `radius_m`.
fn nearest_landmark_centroid<M: MapQuery>(map: &M, p: Point2, radius_m: f32) -> Option<Point2> {
    let mut nearby: heapless::Vec<(u16, Point2, f32), MAX_NEARBY> = heapless::Vec::new();
    map.for_each_landmark_segment_near(p, radius_m, &mut |id, seg| {
        let len = seg.length();
        if !len.is_finite() || len <= 0.0 {
            return;
        }
        let mid = seg.a.add(seg.b).scale(0.5);
        if let Some(e) = nearby.iter_mut().find(|e| e.0 == id) {
            e.1 = e.1.add(mid.scale(len));
            e.2 += len;
        } else {
            let _ = nearby.push((id, mid.scale(len), len));
        }
    });
    nearby.iter().map(|e| e.1.scale(1.0 / e.2)).min_by(|a, b| {
        a.dist_sq(p)
            .partial_cmp(&b.dist_sq(p))
            .unwrap_or(core::cmp::Ordering::Equal)
    })
}
