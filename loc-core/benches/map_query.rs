//! Speed of the stored map's queries on a 1 km tunnel with P1 landmarks on both walls
//! every ~9.5 m (walls sampled every 1 m): `nearest` at scan points, a full 1141-beam
//! ray cast (what the scan simulator does per scan), landmark segments near the vehicle,
//! and loading the map from its file bytes.
//!
//! Run: `cargo bench -p loc-core --bench map_query -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use loc_core::geometry::Point2;
use loc_core::landmark::LandmarkModel;
use loc_core::map::{MapQuery, TunnelMap};
use loc_core::rng::Pcg32;
use loc_core::scan::{SensorSetup, LMS511_MAX_BEAMS};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};
use std::hint::black_box;

fn one_km_map() -> (TunnelSpec, Box<TunnelMap>) {
    let spec = TunnelSpec::straight(1000.0)
        .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 1));
    let mut map = Box::new(TunnelMap::new());
    spec.build_into(&mut *map).expect("1 km map fits TunnelMap");
    (spec, map)
}

fn bench(c: &mut Criterion) {
    let (spec, map) = one_km_map();
    let mut rng = Pcg32::seeded(3);
    // Points near the walls, as scan points transformed by a good pose guess would be.
    let points: Vec<Point2> = (0..1024)
        .map(|_| {
            let side = if rng.uniform01() < 0.5 { 1.0 } else { -1.0 };
            Point2::new(rng.uniform(5.0, 995.0), side * rng.uniform(2.0, 2.7))
        })
        .collect();
    c.bench_function("nearest_1024_points_within_0.5m", |b| {
        b.iter(|| {
            let mut n = 0usize;
            for p in &points {
                n += usize::from(map.nearest(black_box(*p), 0.5).is_some());
            }
            n
        })
    });

    let setup = SensorSetup::lms511_forward(1.0, 0.0);
    let pose = spec.centre_pose(500.0, 0.2);
    let sensor = pose.compose(&setup.mounting);
    c.bench_function("raycast_1141_beams_80m", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for i in 0..LMS511_MAX_BEAMS {
                let a = sensor.theta_rad + setup.geometry.beam_angle_rad(i);
                if let Some(h) = map.raycast(black_box(sensor.translation()), a, 80.0) {
                    sum += h.range_m;
                }
            }
            sum
        })
    });

    let mut sim = ScanSimulator::new(7);
    let mut ranges = vec![0.0f32; LMS511_MAX_BEAMS];
    c.bench_function("simulate_scan_1141_beams_with_noise", |b| {
        b.iter(|| sim.simulate(&*map, black_box(&pose), &setup, &mut ranges))
    });

    c.bench_function("landmark_segments_within_15m", |b| {
        b.iter(|| {
            let mut n = 0usize;
            map.for_each_landmark_segment_near(black_box(pose.translation()), 15.0, &mut |_, _| {
                n += 1
            });
            n
        })
    });

    let mut bytes = vec![0u8; map.serialized_len()];
    let len = map
        .to_slice(&mut bytes)
        .expect("buffer sized by serialized_len");
    let mut target = Box::new(TunnelMap::new());
    c.bench_function("load_1km_map_from_bytes", |b| {
        b.iter(|| target.load_from_bytes(black_box(&bytes[..len])).is_ok())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
