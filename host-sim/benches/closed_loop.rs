//! Speed of the simulator: one LMS511 scan by ray casting in the rough kilometre tunnel,
//! and a whole closed-loop run of `paper-10m` (vehicle at 1 kHz, 25 Hz scans through
//! loc-core's localiser). The run simulates about 12.8 s of driving: the real-time factor
//! is 12.8 s divided by the time per iteration.
//!
//! `cargo bench -p host-sim -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

use host_sim::closed_loop::RunOptions;
use host_sim::lidar::Lms511;
use host_sim::scenario::named::named;
use host_sim::session::{run_scenario, EstimatorChoice};

fn lms511_scan(c: &mut Criterion) {
    let s = named("tunnel-1km").expect("named scenario");
    let world = s.build_world().expect("world");
    let mut lidar = Lms511::new(s.lidar, 1);
    let (x, y, h) = world.centerline().pose_at(500.0);
    c.bench_function("lms511_scan_1141_beams_rough_1km", |b| {
        b.iter(|| black_box(lidar.scan(world.grid(), (x, y, h), 0.0)))
    });
}

fn closed_loop(c: &mut Criterion) {
    let s = named("paper-10m").expect("named scenario");
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(10);
    g.bench_function("paper_10m_p1_hausdorff_full_run", |b| {
        b.iter(|| {
            let log =
                run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).expect("run");
            black_box(log.samples.len())
        })
    });
    g.finish();
}

criterion_group!(benches, lms511_scan, closed_loop);
criterion_main!(benches);
