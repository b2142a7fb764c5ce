//! The curved test tunnel against its analytic geometry: a noiseless simulated scan from
//! the centre line lands on the two wall circles (radius 50 ∓ 2.5 m) within the chord sag
//! of 1 m wall sampling (≤ 2.7 mm), and the map's nearest() agrees.
#![allow(clippy::disallowed_methods)] // host-only test code: std f32::max/min are fine

use loc_core::geometry::Point2;
use loc_core::map::{FeatureKind, MapQuery, TunnelMap};
use loc_core::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};
use loc_core::testkit::{ScanSimulator, TunnelSpec};

#[test]
fn noiseless_scan_lies_on_the_wall_circles() {
    let spec = TunnelSpec::curved(150.0);
    let mut map = Box::new(TunnelMap::new());
    spec.build_into(&mut *map).unwrap();
    let centre = Point2::new(0.0, 50.0);
    let setup = SensorSetup::lms511_forward(1.2, 0.0);
    let mut sim = ScanSimulator::with_noise(0, 0.0);
    let mut scan = Scan::new();
    for s_m in [20.0, 60.0, 100.0] {
        for lateral in [-1.0, 0.0, 0.8] {
            let pose = spec.centre_pose(s_m, lateral);
            sim.simulate_scan(&*map, &pose, &setup, LMS511_MAX_BEAMS, &mut scan);
            assert!(scan.len() > 1000, "{} points", scan.len());
            for p in scan.points() {
                let w = pose.transform_point(p.vehicle);
                let r = w.dist(centre);
                let on_inner = (r - 47.5).abs();
                let on_outer = (r - 52.5).abs();
                assert!(
                    on_inner.min(on_outer) < 2.8e-3,
                    "s={s_m} lat={lateral}: point at radius {r}"
                );
                let hit = map.nearest(w, 0.1).unwrap();
                let want = if on_inner < on_outer {
                    FeatureKind::LeftWall
                } else {
                    FeatureKind::RightWall
                };
                assert_eq!(hit.kind, want);
                assert!(hit.projection.distance_m < 1e-3);
            }
        }
    }
}
