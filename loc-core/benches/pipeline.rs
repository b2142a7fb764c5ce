//! Cost of the estimation pipeline per scan: wall stripping, match-point selection,
//! matching (Hausdorff and PL-ICP, with pre-alignment), the EKF predict + update, and the
//! whole `Localizer::update_scan`, for one 1141-beam LMS511 scan against a 1 km straight
//! tunnel map with P1 landmarks (test kit), σ = 10 mm range noise.
//!
//! The prediction is off by what one scan period of odometry drift gives (2 cm along,
//! 1 cm across, 0.2°): the steady tracking case.
//!
//! Short run: `cargo bench -p loc-core --bench pipeline -- --warm-up-time 1 --measurement-time 3`.
//!
//! Measured 2026-12-01 on the 2-core build machine at load ≈ 1: strip 27.0 µs, select
//! 7.1 µs, match 50.8 µs (Hausdorff, 5 iterations) / 35.7 µs (ICP, 4 iterations), filter
//! 0.58 µs; end to end 75.8 µs (Hausdorff) / 65.9 µs (ICP). (2026-11-22, before the M4F
//! work of the next commits and under load ≈ 5: end to end 174 / 128 µs.)

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use loc_core::filter::{Ekf, OdometryIncrement, OdometryNoise, UpdateConfig};
use loc_core::geometry::Pose2;
use loc_core::landmark::LandmarkModel;
use loc_core::localizer::{Localizer, LocalizerConfig};
use loc_core::map::TunnelMap;
use loc_core::matching::{
    match_scan_with_prealign, select_match_points, MatchConfig, MatchPoints, MatchWorkspace,
    MatcherKind, PrealignConfig,
};
use loc_core::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};
use loc_core::strip::{strip_walls, PointLabel, StripConfig};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};
use nalgebra::{Matrix3, Vector3};
use std::hint::black_box;

struct Fixture {
    map: Box<TunnelMap>,
    scan: Box<Scan>,
    truth: Pose2,
    predicted: Pose2,
}

fn fixture() -> Fixture {
    let mut map = Box::new(TunnelMap::new());
    TunnelSpec::straight(1000.0)
        .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 21))
        .build_into(&mut *map)
        .expect("1 km tunnel fits the map");
    let truth = Pose2::new(503.7, 0.3, 0.02);
    let mut scan = Box::new(Scan::new());
    ScanSimulator::new(77).simulate_scan(
        &*map,
        &truth,
        &SensorSetup::default(),
        LMS511_MAX_BEAMS,
        &mut scan,
    );
    // Beams within ~2° of the tunnel axis see no wall within 80 m (no echo, dropped).
    eprintln!("scan: {} of {} beams echoed", scan.len(), LMS511_MAX_BEAMS);
    let predicted = Pose2::new(truth.x_m + 0.02, truth.y_m - 0.01, truth.theta_rad + 0.0035);
    Fixture {
        map,
        scan,
        truth,
        predicted,
    }
}

/// Position standard deviation of the prediction, metres (as in [`prior`]).
const PRIOR_SD_M: f32 = 0.036;

fn prior() -> Matrix3<f32> {
    Matrix3::from_diagonal(&Vector3::new(
        0.03f32.powi(2),
        0.02f32.powi(2),
        0.005f32.powi(2),
    ))
}

fn stages(c: &mut Criterion) {
    let f = fixture();
    let points = f.scan.points();
    let strip_cfg = StripConfig::default();
    let mut labels = vec![PointLabel::Outlier; points.len()];

    c.bench_function("strip_1141", |b| {
        b.iter(|| strip_walls(black_box(points), &strip_cfg, &mut labels))
    });
    let strip = strip_walls(points, &strip_cfg, &mut labels);

    let mut selected = MatchPoints::new();
    c.bench_function("select_match_points", |b| {
        b.iter(|| {
            select_match_points(
                black_box(points),
                &labels,
                100,
                f32::INFINITY,
                &mut selected,
            )
        })
    });
    let counts = select_match_points(points, &labels, 100, f32::INFINITY, &mut selected);
    eprintln!("strip {:?}; selected {:?}", strip.counts, counts);

    let mut ws = Box::new(MatchWorkspace::new());
    for matcher in [MatcherKind::Hausdorff, MatcherKind::Icp] {
        let cfg = MatchConfig {
            matcher,
            ..MatchConfig::default()
        };
        let r = match_scan_with_prealign(
            &*f.map,
            points,
            &labels,
            &strip,
            &selected,
            f.predicted,
            PRIOR_SD_M,
            &PrealignConfig::default(),
            &cfg,
            &mut ws,
        )
        .expect("match");
        eprintln!(
            "{matcher:?}: {} iterations, error {:.1} mm",
            r.result.iterations,
            1000.0 * r.result.pose.translation().dist(f.truth.translation())
        );
        c.bench_function(&format!("match_{matcher:?}").to_lowercase(), |b| {
            b.iter(|| {
                match_scan_with_prealign(
                    &*f.map,
                    points,
                    &labels,
                    &strip,
                    black_box(&selected),
                    f.predicted,
                    PRIOR_SD_M,
                    &PrealignConfig::default(),
                    &cfg,
                    &mut ws,
                )
            })
        });
    }

    let cfg = MatchConfig::default();
    let result = match_scan_with_prealign(
        &*f.map,
        points,
        &labels,
        &strip,
        &selected,
        f.predicted,
        PRIOR_SD_M,
        &PrealignConfig::default(),
        &cfg,
        &mut ws,
    )
    .expect("match")
    .result;
    let update = UpdateConfig::for_matcher(&cfg);
    let noise = OdometryNoise::default();
    let step = OdometryIncrement {
        dx_m: 0.5,
        dy_m: 0.0,
        dtheta_rad: 0.001,
    };
    let start = Ekf::new(f.predicted, prior()).expect("valid prior");
    c.bench_function("filter_predict_update", |b| {
        b.iter(|| {
            let mut ekf = start;
            let _ = ekf.predict(black_box(&step), &noise);
            ekf.update_with_match(black_box(&result), &update)
        })
    });

    for matcher in [MatcherKind::Hausdorff, MatcherKind::Icp] {
        let config = LocalizerConfig {
            matching: MatchConfig {
                matcher,
                ..MatchConfig::default()
            },
            ..LocalizerConfig::default()
        };
        c.bench_function(&format!("end_to_end_{matcher:?}").to_lowercase(), |b| {
            b.iter_batched_ref(
                || Box::new(Localizer::new(&*f.map, config, f.predicted, prior()).expect("init")),
                |loc| loc.update_scan(black_box(&f.scan)),
                BatchSize::SmallInput,
            )
        });
    }
}

criterion_group!(benches, stages);
criterion_main!(benches);
