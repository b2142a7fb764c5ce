//! Closed loop in the bare curved tunnel (`tunnel-1km` without landmarks, the first 300 m
//! and the whole kilometre): the walls fix heading and lateral position but nothing fixes
//! the position along the tunnel. The localiser must then follow odometry along the tunnel, never do worse than
//! odometry alone, and keep the lateral error at the lidar's level. (The paper, whose
//! Hausdorff SLAM diverged without landmarks, reports 194 m RMS on the El Teniente model.)

use host_sim::closed_loop::{RunLog, RunOptions};
use host_sim::scenario::named::named;
use host_sim::scenario::overrides::Overrides;
use host_sim::session::{run_scenario, EstimatorChoice};

fn bare_tunnel_run(length_m: Option<f64>) -> RunLog {
    let mut s = named("tunnel-1km").expect("named scenario");
    Overrides {
        landmarks: Some("none".into()),
        drive_length_m: length_m,
        ..Overrides::default()
    }
    .apply(&mut s)
    .expect("valid overrides");
    run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run")
}

/// What holds over any stretch of the bare tunnel: the along-tunnel error follows
/// odometry's distance error (nothing can fix it, and the scans must not make it worse), the
/// lateral RMS stays at most 30 mm, the estimate is never worse than odometry alone, and
/// almost no scan claims full tracking.
fn assert_bare_tunnel_behaviour(log: &RunLog) {
    let m = log.metrics();
    let a = &m.localizer;
    assert!(
        a.along_rms_m <= 1.1 * m.odometry_distance_error_rms_m + 0.05,
        "along {} vs odometry distance error {}",
        a.along_rms_m,
        m.odometry_distance_error_rms_m
    );
    assert!(
        a.along_rms_m >= 0.5 * m.odometry_distance_error_rms_m,
        "without landmarks nothing can fix the along-tunnel position: {} vs {}",
        a.along_rms_m,
        m.odometry_distance_error_rms_m
    );
    assert!(a.across_rms_m <= 0.030, "lateral RMS {}", a.across_rms_m);
    assert!(
        a.position_rms_m <= m.odometry.position_rms_m,
        "never worse than odometry alone: {} vs {}",
        a.position_rms_m,
        m.odometry.position_rms_m
    );
    let tracking = log.status_count(host_sim::status::EstimatorStatus::is_tracking);
    assert!(
        tracking * 10 < log.samples.len(),
        "{tracking} scans claimed full tracking"
    );
}

/// The whole kilometre: the along-tunnel error reaches 19 m, so the stored walls far
/// ahead of the estimate bend where the scanned ones do not; the lateral error must stay
/// at the lidar's level all the same (the figure: at most 30 mm RMS).
/// Measured: across 22.3 mm; along 11.37 m vs odometry's distance error 11.37 m.
#[test]
fn whole_kilometre_lateral_rms_within_30_mm() {
    assert_bare_tunnel_behaviour(&bare_tunnel_run(None));
}

/// The first 300 m, where the heading is still checked (over the kilometre the world
/// heading error includes the along-tunnel error times the curvature).
/// Measured: along 3.76 m vs odometry's distance error 3.72 m; across 8.4 mm; heading
/// 8.1 mrad.
#[test]
fn along_tunnel_error_follows_odometry_and_lateral_stays_small() {
    let log = bare_tunnel_run(Some(300.0));
    assert_bare_tunnel_behaviour(&log);
    let heading_rms_rad = log.metrics().localizer.heading_rms_rad;
    assert!(heading_rms_rad <= 0.01, "heading RMS {heading_rms_rad}");
}
