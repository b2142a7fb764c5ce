//! The Fisher information of one scan at a pose, and its Cramér–Rao bound: how well the
//! scan could fix the pose at best, under the matcher's own measurement model (range noise
//! `σ_r` along each residual's normal, walls rough as [`super::RoughnessModel`] says).
//!
//! It is the yardstick of the localiser's accuracy (the per-scan bound beside the per-scan
//! error; host-sim reports their ratio) and the fast objective of landmark design (a layout
//! whose scans carry more information localises better). It uses the very accumulation
//! the matchers solve with ([`NormalEquations`] and [`RoughWalls`]), on every point given,
//! each paired with its nearest map geometry at the pose.

use nalgebra::Matrix3;

use super::association::{paired, Pairing};
use super::information::NormalEquations;
use super::landmark_offsets::LandmarkAnchors;
use super::roughness::RoughWalls;
use super::MatchConfig;
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::strip::VehiclePoint;

/// The information one scan carries about the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanInformation {
    /// Fisher information of `(x_m, y_m, theta_rad)`, world frame (m⁻², m⁻¹·rad⁻¹,
    /// rad⁻²).
    pub information: Matrix3<f32>,
    /// Points paired with map geometry (the others carry nothing).
    pub points: u16,
}

impl ScanInformation {
    /// The Cramér–Rao bound: the inverse of the information, the least covariance of an
    /// unbiased estimate of the pose from this scan alone; `None` when a direction is not
    /// observed at all (e.g. along a smooth tunnel: the information is singular).
    pub fn bound(&self) -> Option<Matrix3<f32>> {
        let inv = self.information.try_inverse()?;
        let ok =
            inv.iter().all(|v| v.is_finite()) && inv.m11 > 0.0 && inv.m22 > 0.0 && inv.m33 > 0.0;
        ok.then_some(inv)
    }
}

/// The information of `points` (vehicle frame) at `pose` (world frame) against `map`: each
/// point within `gate_m` of map geometry adds its point-to-line Jacobian, wall stretches
/// share their roughness offset (`config.roughness`) and a landmark's points the offset at
/// its anchor (as the matchers take them: `landmark_offsets::LandmarkAnchors`), all in units of `config`'s
/// range noise.
pub fn scan_information<M: MapQuery, P: VehiclePoint>(
    map: &M,
    points: &[P],
    pose: Pose2,
    config: &MatchConfig,
    gate_m: f32,
) -> ScanInformation {
    let (s, c) = crate::math::sin_cos(pose.theta_rad);
    let mut anchors = LandmarkAnchors::new(pose);
    let pairs = points.iter().filter_map(|p| {
        let p = p.vehicle_point();
        let q = Point2::new(
            c * p.x_m - s * p.y_m + pose.x_m,
            s * p.x_m + c * p.y_m + pose.y_m,
        );
        let hit = map.nearest(q, gate_m)?;
        if !hit.projection.distance_m.is_finite() {
            return None;
        }
        // The residual's normal exactly as the matchers pair the point.
        let pairing = Pairing::of(hit.kind);
        let normal = paired(q, hit.segment, hit.projection, pairing).normal;
        let along_wall = anchors.point(map, pairing.landmark_id(), p);
        Some((p, along_wall, normal))
    });
    accumulate(pairs, pose, config)
}

/// The information of points already paired with their map geometry: each item is a point
/// in the vehicle frame and the world-frame unit normal of the line it lies on (at `pose`,
/// world frame), each point where it lies on its wall. The accumulation [`scan_information`]
/// ends with; for callers that know the pairing from the geometry itself (landmark design's
/// Fisher objective), with no map search.
pub fn paired_information(
    pairs: impl Iterator<Item = (Point2, Point2)>,
    pose: Pose2,
    config: &MatchConfig,
) -> ScanInformation {
    accumulate(pairs.map(|(p, n)| (p, p, n)), pose, config)
}

/// The accumulation: each item is a vehicle-frame point, where the walls' offset chain
/// takes it (a landmark's anchor, see [`LandmarkAnchors`]; the point itself on a wall) and
/// its world-frame unit normal.
fn accumulate(
    items: impl Iterator<Item = (Point2, Point2, Point2)>,
    pose: Pose2,
    config: &MatchConfig,
) -> ScanInformation {
    let sigma = config.range_noise_sigma_m;
    let mut eq = NormalEquations::default();
    let mut walls = RoughWalls::new(&config.roughness, sigma, pose.theta_rad);
    let (s, c) = crate::math::sin_cos(pose.theta_rad);
    let t = pose.translation();
    for (p, along_wall, n) in items {
        let q = Point2::new(
            c * p.x_m - s * p.y_m + pose.x_m,
            s * p.x_m + c * p.y_m + pose.y_m,
        );
        match walls.as_mut() {
            Some(rw) => rw.add(&mut eq, along_wall, q, t, n, 0.0, 1.0, 1.0),
            None => {
                eq.add(q, t, n, 0.0, 1.0);
            }
        }
    }
    let inv_var = if sigma.is_finite() && sigma > 0.0 {
        1.0 / (sigma * sigma)
    } else {
        0.0
    };
    ScanInformation {
        information: eq.information_points * inv_var,
        points: crate::math::saturating_u16(eq.count),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::map::TunnelMap;
    use crate::matching::RoughnessModel;
    use crate::testkit::TunnelSpec;

    /// Points on both walls of a straight 4 m tunnel (vehicle frame, vehicle at x = 50).
    fn wall_points(n: usize) -> heapless::Vec<Point2, 512> {
        let mut v = heapless::Vec::new();
        for i in 0..n {
            let x = -10.0 + 20.0 * i as f32 / n as f32;
            let y = if i % 2 == 0 { 2.0 } else { -2.0 };
            let _ = v.push(Point2::new(x, y));
        }
        v
    }

    #[test]
    fn a_smooth_tunnel_fixes_the_lateral_position_and_heading_but_not_the_chainage() {
        let mut map = std::boxed::Box::new(TunnelMap::new());
        TunnelSpec::straight(100.0).build_into(&mut map).unwrap();
        let width = TunnelSpec::straight(100.0).width_m;
        let mut pts = heapless::Vec::<Point2, 512>::new();
        for p in wall_points(200) {
            let _ = pts.push(Point2::new(p.x_m, p.y_m.signum() * width / 2.0));
        }
        let config = MatchConfig {
            range_noise_sigma_m: 0.01,
            roughness: RoughnessModel::SMOOTH,
            ..MatchConfig::default()
        };
        let info = scan_information(&*map, &pts, Pose2::new(50.0, 0.0, 0.0), &config, 0.3);
        assert_eq!(info.points, 200);
        // 200 points of 1 cm: 2e6 m^-2 across, nothing along.
        assert!(
            (info.information.m22 - 2.0e6).abs() < 1.0e3,
            "{}",
            info.information
        );
        assert!(info.information.m11.abs() < 1.0);
        assert!(
            info.bound().is_none(),
            "along a smooth tunnel nothing bounds the chainage"
        );
        // Rough walls: the same points say less (σ_w = σ_r, correlated over 1 m).
        let rough = MatchConfig {
            roughness: RoughnessModel::SHOTCRETE,
            ..config
        };
        let r = scan_information(&*map, &pts, Pose2::new(50.0, 0.0, 0.0), &rough, 0.3);
        assert!(
            r.information.m22 < 0.15 * info.information.m22,
            "{}",
            r.information
        );
        assert!(
            r.information.m22 > 0.05 * info.information.m22,
            "{}",
            r.information
        );
    }
}
