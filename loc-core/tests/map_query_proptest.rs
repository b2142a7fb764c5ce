//! Property tests of the stored map's queries: any input (NaN, infinities, huge values)
//! gives an answer or `None`, never a panic, and answers agree with a brute-force search.
#![allow(clippy::disallowed_methods)] // host-only test code: std f32::max/min are fine

use loc_core::geometry::Point2;
use loc_core::landmark::LandmarkModel;
use loc_core::map::{MapQuery, StoredMap};
use loc_core::testkit::{LandmarkLayout, TunnelSpec};
use proptest::prelude::*;
use std::sync::OnceLock;

type Small = StoredMap<1024, 64, 1024, 4096>;

fn map() -> &'static Small {
    static MAP: OnceLock<Small> = OnceLock::new();
    MAP.get_or_init(|| {
        let spec = TunnelSpec::curved(200.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P3Parabola, 8));
        let mut m = Small::new();
        spec.build_into(&mut m).unwrap();
        m
    })
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -300.0f32..300.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => any::<f32>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn queries_never_panic(x in any_f32(), y in any_f32(), a in any_f32(), r in any_f32()) {
        let m = map();
        let p = Point2::new(x, y);
        if let Some(h) = m.nearest(p, r) {
            prop_assert!(p.is_finite() && h.projection.distance_m <= r * 1.0001 + 1e-6);
        }
        if let Some(h) = m.raycast(p, a, r) {
            prop_assert!(h.range_m >= 0.0 && h.range_m <= r * 1.0001 + 1e-6);
        }
        let mut n = 0usize;
        m.for_each_landmark_segment_near(p, r, &mut |_, _| n += 1);
        prop_assert!(n <= m.landmark_segments().len());
    }

    #[test]
    fn nearest_agrees_with_brute_force(x in -60.0f32..60.0, y in -10.0f32..110.0, r in 0.0f32..20.0) {
        let m = map();
        let p = Point2::new(x, y);
        let brute = m
            .segments()
            .iter()
            .map(|s| s.segment.project(p).distance_m)
            .fold(f32::INFINITY, f32::min);
        match m.nearest(p, r) {
            Some(h) => prop_assert!((h.projection.distance_m - brute).abs() < 1e-4),
            None => prop_assert!(brute > r * 0.9999),
        }
    }
}
