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

#[test]
fn narrow_tall_triangles_are_acquired_from_a_poor_start() {
    // P1 0.28 m wide and 0.30 m high (faces longer than the base), the start-up pose up to
    // ~12 cm off: before the pre-alignment measured heights from the base and applied
    // shifts from 6 cm, 29 of 40 seeds locked 0.13 m off (seeds 1 and 3 among them) and
    // stayed there, reporting MapUnconfirmed; measured now 2–3 mm on each.
    for (genes, seed) in [
        ([0.28, 0.3, 9.0], 1),
        ([0.28, 0.3, 9.0], 3),
        ([0.249, 0.3, 2.216], 15),
    ] {
        let mut s = named("paper-10m").expect("named scenario");
        s.landmarks.genes = Some(genes.to_vec());
        s.seed = seed;
        let log =
            run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run");
        let m = log.metrics();
        assert!(
            m.localizer.position_rms_m <= 0.006,
            "{genes:?} seed {seed}: {} m",
            m.localizer.position_rms_m
        );
    }
}
