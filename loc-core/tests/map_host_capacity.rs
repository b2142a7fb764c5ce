//! A host-size map: rough walls sampled every 0.1 m over 1.4 km (28 000 wall segments),
//! boxed, built in place, queried, saved and loaded.

use loc_core::geometry::Point2;
use loc_core::landmark::{Genome, LandmarkModel};
use loc_core::map::{Capacity, FeatureKind, HostMap, MapError, MapQuery, TunnelMap, WallSide};
use loc_core::rng::Pcg32;

#[test]
fn rough_walled_host_map_builds_queries_and_round_trips() {
    // A debug build moves `HostMap::new()` (1.3 MiB) through the stack before boxing it;
    // test threads have 2 MiB, so run on a thread with room (as HostMap's docs say).
    std::thread::Builder::new()
        .stack_size(32 << 20)
        .spawn(rough_walled_host_map)
        .unwrap()
        .join()
        .unwrap();
}

fn rough_walled_host_map() {
    let mut map = Box::new(HostMap::new());
    let mut rng = Pcg32::seeded(21);
    let n = 14_000;
    // Roughness of lidar-accuracy magnitude (±15 mm), drawn once per wall vertex.
    let rough: Vec<(f32, f32)> = (0..=n)
        .map(|_| (rng.uniform(-0.015, 0.015), rng.uniform(-0.015, 0.015)))
        .collect();
    let left = (0..=n).map(|i| Point2::new(i as f32 * 0.1, 2.5 + rough[i].0));
    let right = (0..=n).map(|i| Point2::new(i as f32 * 0.1, -2.5 + rough[i].1));
    let mut b = map.builder_from_iters(left, right).unwrap();
    let g = Genome::paper_default(LandmarkModel::P1Triangle);
    let mut s = 5.0;
    while s < 1395.0 {
        b.add_landmark(WallSide::Left, s, LandmarkModel::P1Triangle, g)
            .unwrap();
        b.add_landmark(WallSide::Right, s + 4.0, LandmarkModel::P1Triangle, g)
            .unwrap();
        s += 9.5;
    }
    b.finish().unwrap();
    assert_eq!(map.wall_segments(WallSide::Left).len(), n);
    println!(
        "host map: {} segments, {} landmarks, index {:?}",
        map.segments().len(),
        map.landmarks().len(),
        map.index_stats()
    );

    let hit = map
        .raycast(Point2::new(700.0, 0.0), -core::f32::consts::FRAC_PI_2, 80.0)
        .unwrap();
    assert_eq!(hit.kind, FeatureKind::RightWall);
    assert!((hit.range_m - 2.5).abs() < 0.02);

    let mut bytes = vec![0u8; map.serialized_len()];
    let len = map.to_slice(&mut bytes).unwrap();
    let mut back = Box::new(HostMap::new());
    back.load_from_bytes(&bytes[..len]).unwrap();
    assert_eq!(back.segments(), map.segments());

    // The firmware-size map says which capacity is too small, and by how much.
    let mut small = Box::new(TunnelMap::new());
    assert_eq!(
        small.load_from_bytes(&bytes[..len]).unwrap_err(),
        MapError::CapacityExceeded {
            what: Capacity::Segments,
            needed: n,
            capacity: 4096
        }
    );
}
