//! The core in thirty lines: a map, a localiser, odometry and scans in, pose and status out.
//!
//! The map and the scans come from loc-core's test kit (a straight 200 m tunnel with the
//! paper's P1 landmarks, LMS511 scans with 10 mm noise); on the vehicle the map is loaded from
//! flash (`TunnelMap::load_from_bytes`) and the scans from the driver's `LMDscandata` DIST1
//! channel (`Scan::load_raw_mm`).
//!
//! `cargo run --release -p loc-core --example quickstart`

use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::landmark::LandmarkModel;
use loc_core::localizer::{Localizer, LocalizerConfig};
use loc_core::map::TunnelMap;
use loc_core::scan::{Scan, LMS511_MAX_BEAMS};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};
use nalgebra::{Matrix3, Vector3};

fn main() {
    let spec = TunnelSpec::straight(200.0)
        .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 3));
    let mut map = Box::new(TunnelMap::new()); // ≈ 137 KiB: never on a small stack
    spec.build_into(&mut map).expect("the tunnel fits the map");

    let config = LocalizerConfig::default();
    // Start 0.3 m / 0.02 rad off, and say so in the covariance.
    let start = Pose2::new(20.3, -0.1, 0.02);
    let cov = Matrix3::from_diagonal(&Vector3::new(0.25, 0.25, 0.003));
    let mut localizer = Box::new(Localizer::new(&*map, config, start, cov).expect("valid prior"));

    let mut sim = ScanSimulator::new(1);
    let mut ranges_m = [0.0f32; LMS511_MAX_BEAMS];
    let mut scan = Box::new(Scan::new());
    let step = OdometryIncrement {
        dx_m: 0.4,
        dy_m: 0.0,
        dtheta_rad: 0.0,
    };
    for k in 0..25 {
        let truth = Pose2::new(20.0 + 0.4 * k as f32, 0.0, 0.0);
        if k > 0 {
            // Wheel odometry, 2 % long, as a loader's drifts.
            let measured = OdometryIncrement {
                dx_m: 1.02 * step.dx_m,
                ..step
            };
            localizer
                .predict_odometry(&measured)
                .expect("plausible increment");
        }
        sim.simulate(&*map, &truth, &config.sensor, &mut ranges_m);
        scan.load_ranges_m(&config.sensor, &ranges_m); // 0 = no echo, skipped
        let status = localizer.update_scan(&mut scan);
        let pose = localizer.pose().expect("initialised");
        println!(
            "scan {k:2}: x {:8.4} m  y {:7.4} m  θ {:8.5} rad  error {:5.1} mm  {status}",
            pose.x_m,
            pose.y_m,
            pose.theta_rad,
            1e3 * pose.translation().dist(truth.translation()),
        );
    }
}
