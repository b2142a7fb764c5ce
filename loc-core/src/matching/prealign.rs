//! Coarse along-tunnel alignment before matching: shift the predicted pose along the tunnel
//! so that each observed landmark (a cluster of landmark points) sits on the nearest map
//! landmark.
//!
//! Why: a landmark is about as wide as a typical along-tunnel prediction error (P1 default
//! 0.5 m). With a larger error the landmark points fall beside their landmark, the nearest
//! map geometry is the bare wall, and neither matcher can pull them back.
//!
//! Clusters and map landmarks are compared by **height-weighted centroids** (weight `h⁴`,
//! `h` the height above the wall): the top of a landmark faces the tunnel and is seen from
//! everywhere, while its flanks are seen one at a time, so weighting the top cuts the bias of a
//! plain centroid (up to a quarter of the width) to a few centimetres for a triangle. The
//! matcher removes the residue.
//!
//! The shift is along the tunnel only (the wall tangent from the stripper); it is skipped
//! when clusters disagree, when it exceeds `max_shift_m`, or when no landmark is in view.

use crate::geometry::{Point2, Pose2, Segment};
use crate::map::MapQuery;
use crate::math;
use crate::strip::{
    height_weight, landmark_clusters, PointLabel, StripSummary, VehiclePoint, MAX_CLUSTERS,
};

/// Tuning of the pre-alignment. Distances in metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// Clusters whose along-tunnel offset differs from the weighted median by more than this
    /// are ignored, metres; if they hold most of the points, no shift is made.
    pub max_disagreement_m: f32,
    /// Clusters farther than this from the vehicle are ignored, metres (far landmarks are
    /// sparsely sampled and half hidden, their centroids biased).
    pub max_cluster_range_m: f32,
    /// Shifts shorter than this are not applied, metres: the pre-alignment's own bias is a
    /// centimetre or two, while the matchers converge from about a quarter of a landmark's
    /// width along the tunnel (a P1 0.25 m wide fails from 0.1 m off).
    pub min_shift_m: f32,
    /// The pre-alignment is not run at all for a prediction whose position 1σ is below
    /// this, metres: in steady tracking the prediction is better than the pre-alignment
    /// (see [`super::match_scan_with_prealign`]), and the cost is saved.
    pub min_prior_sd_m: f32,
    /// Shifts longer than this many standard deviations of the predicted position are not
    /// applied by [`super::match_scan_with_prealign`]: the cluster met the wrong map landmark
    /// (with landmarks on one wall only, a few missing, the next one along can look right).
    pub max_shift_sigmas: f32,
}

impl PrealignConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        enabled: true,
        max_shift_m: 2.0,
        search_radius_m: 2.5,
        max_cluster_gap_m: 0.3,
        min_cluster_points: 4,
        max_disagreement_m: 0.25,
        max_cluster_range_m: 20.0,
        min_shift_m: 0.06,
        min_prior_sd_m: 0.04,
        max_shift_sigmas: 4.0,
    };
}

impl Default for PrealignConfig {
    fn default() -> Self {
        Self::DEFAULT
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

/// Most distinct landmarks tracked around one cluster.
const MAX_NEARBY: usize = 8;
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
    let clusters = landmark_clusters(
        points,
        labels,
        strip,
        config.max_cluster_gap_m,
        config.min_cluster_points,
    );

    // Per cluster: along-tunnel offset to the nearest map landmark, weighted by points.
    let mut offsets: heapless::Vec<(f32, Point2, f32), MAX_CLUSTERS> = heapless::Vec::new();
    for c in &clusters {
        let centroid_v = c.centroid();
        if centroid_v.norm() > config.max_cluster_range_m {
            continue;
        }
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
    // Weighted median, then the clusters that agree with it.
    let total_w: f32 = offsets.iter().map(|o| o.2).sum();
    let mut sorted = offsets.clone();
    sorted.sort_unstable_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(core::cmp::Ordering::Equal));
    let mut acc = 0.0;
    let mut median = 0.0;
    for o in &sorted {
        acc += o.2;
        median = o.0;
        if acc >= 0.5 * total_w {
            break;
        }
    }
    offsets.retain(|o| math::abs(o.0 - median) <= config.max_disagreement_m);
    let agree_w: f32 = offsets.iter().map(|o| o.2).sum();
    if offsets.is_empty() || agree_w < 0.5 * total_w {
        return None;
    }
    let mean_along = offsets.iter().map(|o| o.0 * o.2).sum::<f32>() / agree_w;
    if !mean_along.is_finite() || math::abs(mean_along) > config.max_shift_m {
        return None;
    }
    let shift = offsets.iter().fold(Point2::ORIGIN, |acc, o| {
        acc.add(o.1.scale(o.0 * o.2 / agree_w))
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

/// Most segments of one landmark considered.
const MAX_LANDMARK_SEGMENTS: usize = 16;

/// The height-weighted centroid (see the module docs) of the map landmark nearest to `p`
/// among those with a segment within `radius_m`.
fn nearest_landmark_centroid<M: MapQuery>(map: &M, p: Point2, radius_m: f32) -> Option<Point2> {
    // Pass 1: pick the landmark whose plain centroid is nearest.
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
    let (id, plain) = nearby
        .iter()
        .map(|e| (e.0, e.1.scale(1.0 / e.2)))
        .min_by(|a, b| {
            a.1.dist_sq(p)
                .partial_cmp(&b.1.dist_sq(p))
                .unwrap_or(core::cmp::Ordering::Equal)
        })?;
    // Pass 2: its segments, base line (the farthest-apart endpoints) and weighted centroid.
    let mut segs: heapless::Vec<Segment, MAX_LANDMARK_SEGMENTS> = heapless::Vec::new();
    map.for_each_landmark_segment_near(p, radius_m, &mut |i, seg| {
        if i == id && !segs.contains(&seg) {
            let _ = segs.push(seg);
        }
    });
    // The base is the polyline's two ends (on the wall): the vertices only one segment
    // has. Not the farthest-apart vertices: a triangle taller than 0.87 of its width has a
    // face longer than its base, and heights measured from a face weigh a base corner,
    // biasing the centroid by half the width. The farthest pair is the fallback for a map
    // whose landmark is not one open polyline within the radius.
    let shared = |q: Point2| segs.iter().filter(|s| s.a == q || s.b == q).count();
    let mut ends: heapless::Vec<Point2, 2> = heapless::Vec::new();
    for q in segs.iter().flat_map(|s| [s.a, s.b]) {
        if shared(q) == 1 && !ends.contains(&q) && ends.push(q).is_err() {
            ends.clear();
            break;
        }
    }
    let mut base = (plain, plain);
    if let [a, b] = ends.as_slice() {
        base = (*a, *b);
    } else {
        let mut best = -1.0f32;
        for s1 in &segs {
            for s2 in &segs {
                for (a, b) in [(s1.a, s2.a), (s1.a, s2.b), (s1.b, s2.a), (s1.b, s2.b)] {
                    let d = a.dist_sq(b);
                    if d > best {
                        best = d;
                        base = (a, b);
                    }
                }
            }
        }
    }
    let axis = base.1.sub(base.0);
    let len = axis.norm();
    if !len.is_finite() || len <= 1e-6 {
        return Some(plain);
    }
    let normal = axis.perp().scale(1.0 / len);
    let (mut sum, mut weight) = (Point2::ORIGIN, 0.0f32);
    const SAMPLES: usize = 8;
    for seg in &segs {
        let step = seg.length() / SAMPLES as f32;
        for k in 0..SAMPLES {
            let q = seg
                .a
                .add(seg.b.sub(seg.a).scale((k as f32 + 0.5) / SAMPLES as f32));
            let w = height_weight(math::abs(q.sub(base.0).dot(normal))) * step;
            sum = sum.add(q.scale(w));
            weight += w;
        }
    }
    Some(if weight > 1e-12 {
        sum.scale(1.0 / weight)
    } else {
        plain
    })
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    #[test]
    fn map_centroids_sit_on_the_landmark_axis_whatever_its_proportions() {
        use crate::landmark::{Genome, LandmarkModel, LandmarkShape};
        use crate::map::TunnelMap;
        use crate::testkit::{LandmarkLayout, TunnelSpec};
        // Flat, square and tall triangles (a tall one's faces are longer than its base).
        for (model, w, h, expect_u) in [
            (LandmarkModel::P1Triangle, 0.5, 0.25, 0.0),
            (LandmarkModel::P1Triangle, 0.28, 0.3, 0.0),
            (LandmarkModel::P1Triangle, 0.1, 0.3, 0.0),
        ] {
            let genome = Genome {
                width_m: w,
                height_m: h,
                spacing_m: 9.0,
                ..Genome::default()
            };
            let layout = LandmarkLayout {
                shape: LandmarkShape::new(model, genome),
                seed: 3,
                first_s_m: 2.0,
            };
            let mut map = std::boxed::Box::new(TunnelMap::new());
            TunnelSpec::straight(60.0)
                .with_landmarks(layout)
                .build_into(&mut map)
                .unwrap();
            assert!(map.landmarks().len() >= 10);
            for l in map.landmarks() {
                let f = l.frame;
                let probe = f.anchor.add(f.inward_normal.scale(0.1));
                let c = nearest_landmark_centroid(&*map, probe, 2.5).unwrap();
                let u = c.sub(f.anchor).dot(f.tangent);
                assert!(
                    (u - expect_u).abs() < 0.005,
                    "{model:?} W {w} H {h}: centroid {u:.3} m along from the centre"
                );
            }
        }
    }
}
