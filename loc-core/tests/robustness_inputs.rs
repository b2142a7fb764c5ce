//! Robustness of the estimation pipeline: arbitrary ranges, degenerate scans and arbitrary
//! odometry never panic, never leave fixed bounds, and keep the state finite.
#![allow(clippy::disallowed_methods)] // host-only test code: std f32::max/min are fine

use std::sync::OnceLock;

use loc_core::filter::{OdometryIncrement, MAX_VARIANCE};
use loc_core::geometry::{Point2, Pose2};
use loc_core::landmark::LandmarkModel;
use loc_core::localizer::{Localizer, LocalizerConfig, Status};
use loc_core::map::TunnelMap;
use loc_core::matching::{match_scan, MatchConfig, MatchWorkspace, MatcherKind};
use loc_core::scan::{Scan, ScanTiming, SensorSetup, SweepMotion, LMS511_MAX_BEAMS};
use loc_core::strip::{strip_walls, PointLabel, StripConfig};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;

fn map() -> &'static TunnelMap {
    static MAP: OnceLock<Box<TunnelMap>> = OnceLock::new();
    MAP.get_or_init(|| {
        let mut m = Box::new(TunnelMap::new());
        TunnelSpec::straight(200.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 5))
            .build_into(&mut *m)
            .expect("map fits");
        m
    })
}

fn localizer(matcher: MatcherKind) -> Box<Localizer<'static, TunnelMap>> {
    let config = LocalizerConfig::with_matcher(matcher);
    let cov = Matrix3::from_diagonal(&Vector3::new(0.25, 0.01, 0.003));
    Box::new(Localizer::new(map(), config, Pose2::new(50.0, 0.0, 0.0), cov).unwrap())
}

/// The state invariants every call must keep.
fn assert_sane(loc: &Localizer<'static, TunnelMap>) {
    let pose = loc.pose().unwrap();
    assert!(pose.is_finite(), "{pose:?}");
    let c = loc.covariance_matrix().unwrap();
    assert!(c.iter().all(|v| v.is_finite()), "{c}");
    assert!(
        c.diagonal()
            .iter()
            .all(|&v| v > 0.0 && v <= MAX_VARIANCE * 1.001),
        "{c}"
    );
    assert!((c - c.transpose()).abs().max() <= 1e-6 * c.abs().max().max(1.0));
    assert!(c.cholesky().is_some(), "not positive definite: {c}");
    if let Some(m) = loc.last_match() {
        assert!(m.iterations <= MatchConfig::default().max_iterations);
        assert!(m.pose.is_finite());
    }
}

fn any_range() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => 0.0f32..100.0,
        1 => Just(0.0f32),
        1 => Just(80.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(-1.0f32),
        1 => any::<f32>(),
    ]
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -2.0f32..2.0,
        1 => Just(0.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(1e30f32),
        1 => any::<f32>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_ranges_never_panic(
        ranges in prop::collection::vec(any_range(), 0..=LMS511_MAX_BEAMS),
        icp in any::<bool>(),
    ) {
        let mut loc = localizer(if icp { MatcherKind::Icp } else { MatcherKind::Hausdorff });
        let mut scan = Box::new(Scan::from_ranges_m(&SensorSetup::default(), &ranges));
        let status = loc.update_scan(&mut scan);
        assert_ne!(status, Status::NotInitialised);
        assert_sane(&loc);
        prop_assert!(loc.last_labels().len() <= scan.len());
    }

    #[test]
    fn arbitrary_odometry_never_panics(
        steps in prop::collection::vec((any_f32(), any_f32(), any_f32()), 1..16),
        scan_every in 1usize..5,
    ) {
        let mut loc = localizer(MatcherKind::Hausdorff);
        let mut sim = ScanSimulator::new(9);
        let mut scan = Box::new(Scan::new());
        for (k, (dx, dy, dth)) in steps.into_iter().enumerate() {
            let before = loc.pose().unwrap();
            let inc = OdometryIncrement { dx_m: dx, dy_m: dy, dtheta_rad: dth };
            if loc.predict_odometry(&inc).is_err() {
                // A rejected increment leaves the state as it was.
                prop_assert_eq!(loc.pose().unwrap(), before);
            }
            assert_sane(&loc);
            if k % scan_every == 0 {
                let pose = loc.pose().unwrap();
                sim.simulate_scan(map(), &pose, &SensorSetup::default(), LMS511_MAX_BEAMS, &mut scan);
                loc.update_scan(&mut scan);
                assert_sane(&loc);
            }
        }
    }

    /// Whatever speed an integrator hints and whatever timing a telegram claims, the
    /// de-skew never makes a point non-finite nor the state insane: a motion no vehicle
    /// makes is refused and the scan is localised as taken.
    #[test]
    fn arbitrary_sweep_timing_and_speed_never_break_the_state(
        hints in prop::collection::vec((any_f32(), any_f32(), any_f32()), 1..6),
        stamps in prop::collection::vec(any::<u32>(), 1..6),
        beam_period_s in prop_oneof![3 => Just(1.0f32 / 54_000.0), 1 => any_f32()],
    ) {
        let mut loc = localizer(MatcherKind::Hausdorff);
        let mut sim = ScanSimulator::new(3);
        let mut scan = Box::new(Scan::new());
        for ((vx, vy, w), stamp_us) in hints.into_iter().zip(stamps) {
            let pose = loc.pose().unwrap();
            sim.simulate_scan(map(), &pose, &SensorSetup::default(), LMS511_MAX_BEAMS, &mut scan);
            scan.set_timing(Some(ScanTiming { stamp_us, beam_period_s }));
            loc.hint_sweep_speed(SweepMotion { v_x_mps: vx * 10.0, v_y_mps: vy, omega_radps: w * 5.0 });
            loc.update_scan(&mut scan);
            prop_assert!(scan.points().iter().all(|p| p.vehicle.x_m.is_finite() && p.vehicle.y_m.is_finite()));
            if let Some(m) = scan.deskewed() {
                prop_assert!(m.is_plausible(scan.sweep_s()), "{:?}", m);
            }
            assert_sane(&loc);
        }
    }

    #[test]
    fn stages_take_arbitrary_points(
        pts in prop::collection::vec((any_f32(), any_f32()), 0..300),
        pose in (any_f32(), any_f32(), any_f32()),
        icp in any::<bool>(),
    ) {
        let points: Vec<Point2> = pts.iter().map(|&(x, y)| Point2::new(x * 20.0, y * 3.0)).collect();
        let mut labels = vec![PointLabel::Outlier; points.len()];
        let s = strip_walls(&points, &StripConfig::default(), &mut labels);
        let c = s.counts;
        let total = usize::from(c.left_wall) + usize::from(c.right_wall) + usize::from(c.landmark)
            + usize::from(c.outlier) + usize::from(c.out_of_range);
        prop_assert_eq!(total, points.len());
        let cfg = MatchConfig {
            matcher: if icp { MatcherKind::Icp } else { MatcherKind::Hausdorff },
            ..MatchConfig::default()
        };
        let mut ws = Box::new(MatchWorkspace::new());
        let start = Pose2::new(50.0 + pose.0, pose.1, pose.2);
        if let Ok(r) = match_scan(map(), &points, start, &cfg, &mut ws) {
            prop_assert!(r.pose.is_finite());
            prop_assert!(r.iterations <= cfg.max_iterations);
            prop_assert!(r.covariance.iter().all(|v| v.is_finite()));
        }
    }
}

/// Hand-picked degenerate scans: empty, one point, all beams at maximum range, all zeros,
/// and only one wall in view.
#[test]
fn degenerate_scans_are_rejected_cleanly() {
    let setup = SensorSetup::default();
    let mut cases: Vec<Vec<f32>> = vec![
        vec![],
        vec![3.0],
        vec![80.0; LMS511_MAX_BEAMS],
        vec![0.0; LMS511_MAX_BEAMS],
        vec![f32::NAN; LMS511_MAX_BEAMS],
    ];
    // One wall only: a true scan with the right half of the beams blanked.
    let mut one_wall = vec![0.0f32; LMS511_MAX_BEAMS];
    ScanSimulator::new(3).simulate(map(), &Pose2::new(50.0, 0.0, 0.0), &setup, &mut one_wall);
    for r in one_wall.iter_mut().take(LMS511_MAX_BEAMS / 2) {
        *r = 0.0;
    }
    cases.push(one_wall);
    for matcher in [MatcherKind::Hausdorff, MatcherKind::Icp] {
        for (i, ranges) in cases.iter().enumerate() {
            let mut loc = localizer(matcher);
            let before = loc.pose().unwrap();
            let status = loc.update_scan(&mut Scan::from_ranges_m(&setup, ranges));
            assert_sane(&loc);
            if i < 5 {
                assert!(
                    matches!(status, Status::MatchRejected { .. }),
                    "case {i}: {status:?}"
                );
                assert_eq!(loc.pose().unwrap(), before, "case {i}");
            } else {
                // One wall still fixes heading and distance to that wall.
                assert!(
                    matches!(status, Status::Tracking | Status::Degenerate { .. }),
                    "one wall: {status:?}"
                );
                let p = loc.pose().unwrap();
                assert!(p.y_m.abs() < 0.02 && p.theta_rad.abs() < 0.005, "{p:?}");
            }
        }
    }
}

/// Scans before initialisation are ignored.
#[test]
fn uninitialised_localizer_ignores_scans() {
    let mut loc = Box::new(Localizer::uninitialised(map(), LocalizerConfig::default()));
    let mut scan = Scan::from_ranges_m(&SensorSetup::default(), &[5.0; 100]);
    assert_eq!(loc.update_scan(&mut scan), Status::NotInitialised);
    assert!(loc.pose().is_none() && loc.covariance().is_none());
    assert!(loc.predict_odometry(&OdometryIncrement::default()).is_ok());
}
