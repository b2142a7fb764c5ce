//! Closed loop in the curved, rough kilometre tunnel (`tunnel-1km`), cut to its first
//! 300 m to keep the test short (about 10 s in release): P1 landmarks at D = 9 m keep the
//! error at the lidar's noise level with no growth along the drive; one landmark in five
//! missing costs at most half as much again.

use host_sim::closed_loop::RunOptions;
use host_sim::metrics::Metrics;
use host_sim::scenario::named::named;
use host_sim::scenario::overrides::Overrides;
use host_sim::scenario::Scenario;
use host_sim::session::{run_scenario, EstimatorChoice};

/// `tunnel-1km` with P1 landmarks and `overrides` besides.
fn kilometre(overrides: Overrides) -> Scenario {
    let mut s = named("tunnel-1km").expect("named scenario");
    Overrides {
        landmarks: Some("p1".into()),
        ..overrides
    }
    .apply(&mut s)
    .expect("valid overrides");
    s
}

fn kilometre_run(missing_every: Option<u32>) -> Metrics {
    let s = kilometre(Overrides {
        genes: Some("0.5,0.25,9.0".into()),
        missing_every,
        drive_length_m: Some(300.0),
        ..Overrides::default()
    });
    let log = run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run");
    let m = log.metrics();
    assert!(
        (m.distance_m - 300.0).abs() < 2.0,
        "drove {} m",
        m.distance_m
    );
    m
}

#[test]
fn p1_every_9_m_holds_20_mm_without_drift_and_survives_missing_landmarks() {
    let intact = kilometre_run(None);
    let a = &intact.localizer;
    // Measured: 4.76 mm RMS, first 100 m 4.9 mm, last 100 m 5.1 mm, max 14 mm (before the
    // accuracy work of issue 8: 8.0, 7.3, 8.0, 38 mm).
    assert!(
        a.position_rms_m <= 0.007,
        "position RMS {}",
        a.position_rms_m
    );
    assert!(a.across_rms_m <= 0.006, "across RMS {}", a.across_rms_m);
    assert!(
        a.max_position_error_m <= 0.03,
        "max {}",
        a.max_position_error_m
    );
    // No drift: the last 100 m are as good as the first (margin for noise).
    assert!(
        a.last_100m_position_rms_m <= 1.3 * a.first_100m_position_rms_m + 0.002,
        "first 100 m {} vs last 100 m {}",
        a.first_100m_position_rms_m,
        a.last_100m_position_rms_m
    );
    // Odometry alone is metres off by then.
    assert!(intact.odometry.position_rms_m > 1.0);

    let holes = kilometre_run(Some(5));
    // Measured: 4.94 mm, 1.04 × intact.
    assert!(
        holes.localizer.position_rms_m <= 1.5 * a.position_rms_m,
        "one in five missing: {} vs intact {}",
        holes.localizer.position_rms_m,
        a.position_rms_m
    );
}

/// With smooth walls and a noise-free scanner nothing is left to err but the map: its
/// curves must not be drawn to one side. Chords through points of a curved design wall lie
/// inside the curve (1.3 mm on average at the old 2 mm tolerance), and the localiser then
/// sat 1.07 mm to the inside of the left-hand curve ahead over the first 200 m; the chords
/// now straddle the curve (host-sim `world::simplify`): −0.05 mm.
#[test]
fn a_noise_free_drive_into_a_curve_has_no_lateral_bias() {
    let mut s = kilometre(Overrides {
        drive_length_m: Some(200.0),
        ..Overrides::default()
    });
    s.tunnel.roughness_sigma_m = 0.0;
    s.lidar.range_noise_m = 0.0;
    let log = run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run");
    // Signed error to the left of the true heading, metres.
    let lateral: Vec<f64> = log
        .samples
        .iter()
        .map(|x| {
            let (dx, dy) = (x.estimate.x_m - x.truth.x_m, x.estimate.y_m - x.truth.y_m);
            -dx * x.truth.theta_rad.sin() + dy * x.truth.theta_rad.cos()
        })
        .collect();
    assert!(lateral.len() > 1500, "{} scans", lateral.len());
    let mean = lateral.iter().sum::<f64>() / lateral.len() as f64;
    // The second half of the drive is in and before the curve.
    let late = &lateral[lateral.len() / 2..];
    let late_mean = late.iter().sum::<f64>() / late.len() as f64;
    assert!(
        mean.abs() < 3.0e-4 && late_mean.abs() < 3.0e-4,
        "lateral mean {mean} m, second half {late_mean} m"
    );
}
