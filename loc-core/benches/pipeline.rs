//! Cost of the estimation pipeline per scan: each stage of `Localizer::update_scan` (wall
//! stripping, match-point selection, matching — Hausdorff and PL-ICP, with pre-alignment —
//! and the EKF update), timed through the localizer's own stage hook (`StageObserver`), and
//! the whole `update_scan`, for one 1141-beam LMS511 scan against a 1 km straight tunnel map
//! with P1 landmarks (test kit), σ = 10 mm range noise. Every figure is the code the
//! vehicle runs, with the default configuration.
//!
//! The prediction is off by what one scan period of odometry drift gives (2 cm along,
//! 1 cm across, 0.2°): the steady tracking case.
//!
//! Short run: `cargo bench -p loc-core --bench pipeline -- --warm-up-time 1 --measurement-time 3`.
//!
//! Measured 2026-12-01 on the 2-core build machine at load ≈ 1: strip 27.0 µs, select
//! 7.1 µs, match 50.8 µs (Hausdorff, 5 iterations) / 35.7 µs (ICP, 4 iterations), filter
//! 0.58 µs; end to end 75.8 µs (Hausdorff) / 65.9 µs (ICP). (2026-11-22, before the M4F
//! work of the next commits and under load ≈ 5: end to end 174 / 128 µs.) With the walls'
//! roughness modelled (`end_to_end_hausdorff_rough_walls`, 2026-12-03): 99 µs, against
//! 80 µs for the same scan with smooth walls in that run.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use loc_core::geometry::Pose2;
use loc_core::landmark::LandmarkModel;
use loc_core::localizer::{Localizer, LocalizerConfig, Stage, StageObserver};
use loc_core::map::TunnelMap;
use loc_core::matching::{MatcherKind, RoughnessModel};
use loc_core::scan::{Scan, ScanTiming, SensorSetup, SweepMotion, LMS511_MAX_BEAMS};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};
use nalgebra::{Matrix3, Vector3};

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

fn prior() -> Matrix3<f32> {
    Matrix3::from_diagonal(&Vector3::new(
        0.03f32.powi(2),
        0.02f32.powi(2),
        0.005f32.powi(2),
    ))
}

/// Times one stage of `Localizer::update_scan_observed`: the very chain the vehicle runs.
struct StageClock {
    stage: Stage,
    started: Option<Instant>,
    elapsed: Duration,
}

impl StageObserver for StageClock {
    fn begin(&mut self, stage: Stage) {
        if stage == self.stage {
            self.started = Some(Instant::now());
        }
    }

    fn end(&mut self, stage: Stage) {
        if let (true, Some(t0)) = (stage == self.stage, self.started.take()) {
            self.elapsed += t0.elapsed();
        }
    }
}

fn stages(c: &mut Criterion) {
    let f = fixture();
    for matcher in [MatcherKind::Hausdorff, MatcherKind::Icp] {
        let config = LocalizerConfig::with_matcher(matcher);
        let fresh =
            || Box::new(Localizer::new(&*f.map, config, f.predicted, prior()).expect("init"));
        let mut probe = fresh();
        let status = probe.update_scan(&mut f.scan.clone());
        let m = probe.last_match().expect("the scan matches");
        eprintln!(
            "{matcher:?}: {status}; {} iterations, error {:.1} mm; strip {:?}",
            m.iterations,
            1000.0 * m.pose.translation().dist(f.truth.translation()),
            probe.last_strip().map(|s| s.counts)
        );
        let name = format!("{matcher:?}").to_lowercase();
        for stage in Stage::ALL {
            // Strip and select do not depend on the matcher: timed once.
            if matcher == MatcherKind::Icp && matches!(stage, Stage::Strip | Stage::Select) {
                continue;
            }
            c.bench_function(&format!("{}_{name}", stage.name()), |b| {
                b.iter_custom(|iters| {
                    let mut clock = StageClock {
                        stage,
                        started: None,
                        elapsed: Duration::ZERO,
                    };
                    for _ in 0..iters {
                        let (mut loc, mut scan) = (fresh(), f.scan.clone());
                        black_box(loc.update_scan_observed(black_box(&mut scan), &mut clock));
                    }
                    clock.elapsed
                })
            });
        }
        c.bench_function(&format!("end_to_end_{name}"), |b| {
            b.iter_batched_ref(
                || (fresh(), f.scan.clone()),
                |(loc, scan)| loc.update_scan(black_box(scan)),
                BatchSize::SmallInput,
            )
        });
    }
    rough_walls(c, &f);
    deskew(c, &f);
}

/// Carrying the scan's points over the scanner's sweep (`Scan::deskew`, part of the strip
/// stage when the scan has a timing and the localizer a previous scan): 3 m/s and
/// 0.5 rad/s over a 25 Hz LMS511 sweep.
fn deskew(c: &mut Criterion, f: &Fixture) {
    let mut timed = f.scan.clone();
    timed.set_timing(Some(ScanTiming {
        stamp_us: 40_000,
        beam_period_s: 1.0 / 54_000.0,
    }));
    let motion = SweepMotion {
        v_x_mps: 3.0,
        v_y_mps: 0.0,
        omega_radps: 0.5,
    };
    c.bench_function("deskew", |b| {
        b.iter_batched_ref(
            || timed.clone(),
            |scan| scan.deskew(black_box(&motion)),
            BatchSize::SmallInput,
        )
    });
}

/// The same scan with the walls' roughness modelled (host-sim's tunnels: 5 mm, correlated
/// over 0.5 m): what the rough walls' filter adds (the vehicle runs it when its
/// configuration record sets a roughness).
fn rough_walls(c: &mut Criterion, f: &Fixture) {
    let mut config = LocalizerConfig::with_matcher(MatcherKind::Hausdorff);
    config.matching.roughness = RoughnessModel {
        sigma_m: 0.005,
        correlation_m: 0.5,
    };
    let fresh = || Box::new(Localizer::new(&*f.map, config, f.predicted, prior()).expect("init"));
    c.bench_function("end_to_end_hausdorff_rough_walls", |b| {
        b.iter_batched_ref(
            || (fresh(), f.scan.clone()),
            |(loc, scan)| loc.update_scan(black_box(scan)),
            BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, stages);
criterion_main!(benches);
