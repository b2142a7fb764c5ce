//! Data association: each scan point, placed in the world by a candidate pose, paired with
//! the nearest map segment, and the selection of the K best pairs.

use core::cmp::Ordering;

use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::math;

/// One scan point's pairing with the map at the current pose.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Association {
    /// Distance from the world point to the nearest map geometry, metres; the association
    /// gate when nothing lies within it.
    pub distance_m: f32,
    /// The scan point in the world frame at the pose associated with.
    pub world: Point2,
    /// Closest map point, world frame.
    pub closest: Point2,
    /// Unit normal of the residual: the segment's normal, or, when the closest point is an
    /// end of the segment, the direction from that end to the point (so `normal·(world −
    /// closest)` is the true distance either way).
    pub normal: Point2,
    /// False when no map geometry lay within the gate.
    pub associated: bool,
}

impl Association {
    /// The signed point-to-line residual, metres.
    #[inline]
    pub fn residual_m(&self) -> f32 {
        self.normal.dot(self.world.sub(self.closest))
    }
}

/// Places `points` (vehicle frame) in the world at `pose` and associates each with the
/// nearest map geometry within `gate_m`. Writes `min(points, out)` entries; returns how many
/// found a partner.
pub fn associate<M: MapQuery>(
    map: &M,
    points: &[Point2],
    pose: Pose2,
    gate_m: f32,
    out: &mut [Association],
) -> usize {
    let (s, c) = math::sin_cos(pose.theta_rad);
    let mut found = 0;
    for (p, a) in points.iter().zip(out.iter_mut()) {
        let world = Point2::new(
            c * p.x_m - s * p.y_m + pose.x_m,
            s * p.x_m + c * p.y_m + pose.y_m,
        );
        *a = match map.nearest(world, gate_m) {
            Some(hit) if hit.projection.distance_m.is_finite() => {
                let pr = hit.projection;
                let at_end = pr.t <= 0.0 || pr.t >= 1.0;
                let normal = if at_end && pr.distance_m > 1e-6 {
                    world.sub(pr.closest).scale(1.0 / pr.distance_m)
                } else {
                    pr.normal
                };
                found += 1;
                Association {
                    distance_m: pr.distance_m,
                    world,
                    closest: pr.closest,
                    normal,
                    associated: true,
                }
            }
            _ => Association {
                distance_m: gate_m,
                world,
                closest: world,
                normal: Point2::new(1.0, 0.0),
                associated: false,
            },
        };
    }
    found
}

/// Reorders `assoc` so its first `k` entries are the `k` smallest distances (in no
/// particular order) and entry `k − 1` is the k-th ranked one; returns that k-th distance.
/// O(n) expected (introselect), no full sort. `None` for `k = 0` or `k > len`.
pub fn select_k_best(assoc: &mut [Association], k: usize) -> Option<f32> {
    let kth = k.checked_sub(1)?;
    if kth >= assoc.len() {
        return None;
    }
    let (_, nth, _) = assoc.select_nth_unstable_by(kth, |a, b| {
        a.distance_m
            .partial_cmp(&b.distance_m)
            .unwrap_or(Ordering::Equal)
    });
    Some(nth.distance_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(d: f32) -> Association {
        Association {
            distance_m: d,
            ..Association::default()
        }
    }

    #[test]
    fn selects_k_smallest() {
        let mut v = [a(5.0), a(1.0), a(4.0), a(2.0), a(3.0), a(0.5)];
        let kth = select_k_best(&mut v, 3).unwrap();
        assert_eq!(kth, 2.0);
        let mut first: [f32; 3] = core::array::from_fn(|i| v[i].distance_m);
        first.sort_by(|x, y| x.partial_cmp(y).unwrap());
        assert_eq!(first, [0.5, 1.0, 2.0]);
        assert!(select_k_best(&mut v, 0).is_none());
        assert!(select_k_best(&mut v, 7).is_none());
    }
}
