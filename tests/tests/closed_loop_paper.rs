//! Closed loop in the paper's simulated tunnel (§5.1): a 10 m drive past P1 landmarks at
//! the optimum spacing. The paper reports 22 mm RMS with Hausdorff matching (Table 2); the
//! product's bound is 10 mm. Short seeded runs (about a second each in release).

use host_sim::closed_loop::RunOptions;
use host_sim::metrics::Metrics;
use host_sim::scenario::named::named;
use host_sim::scenario::MatcherChoice;
use host_sim::session::{run_scenario, EstimatorChoice};

fn paper_run(matcher: MatcherChoice, seed: u64) -> Metrics {
    let mut s = named("paper-10m").expect("named scenario");
    s.localizer.matcher = matcher;
    s.seed = seed;
    let log = run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run");
    assert!(
        log.samples.len() > 250,
        "a 10 m drive at 1 m/s gives ~300 scans"
    );
    log.metrics()
}

#[test]
fn hausdorff_p1_position_rms_within_10_mm() {
    let runs: Vec<Metrics> = (1..=3)
        .map(|seed| paper_run(MatcherChoice::Hausdorff, seed))
        .collect();
    let rms: Vec<f64> = runs.iter().map(|m| m.localizer.position_rms_m).collect();
    let mean = rms.iter().sum::<f64>() / rms.len() as f64;
    // Measured 2.75, 2.63, 3.34 mm for seeds 1–3 (4.7, 4.8, 5.5 before the unbiased wall
    // point choice, the untrimmed consistent points and the odometry scale state).
    assert!(
        mean <= 0.0045,
        "mean position RMS {mean} m over seeds 1-3 ({rms:?})"
    );
    for (m, r) in runs.iter().zip(&rms) {
        assert!(*r <= 0.006, "one seed's RMS {r} m");
        // Far better than odometry alone over the same drive.
        assert!(
            *r < 0.25 * m.odometry.position_rms_m,
            "{r} vs odometry {}",
            m.odometry.position_rms_m
        );
        assert!(m.localizer.heading_rms_rad < 0.005);
    }
}

#[test]
fn icp_p1_beside_hausdorff() {
    for seed in 1..=2 {
        let m = paper_run(MatcherChoice::Icp, seed);
        // Measured 2.64 and 2.64 mm.
        assert!(
            m.localizer.position_rms_m <= 0.0045,
            "ICP seed {seed}: {}",
            m.localizer.position_rms_m
        );
        assert!(m.localizer.max_position_error_m <= 0.05);
    }
}
