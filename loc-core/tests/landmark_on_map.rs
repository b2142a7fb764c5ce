//! Landmarks placed through the stored map: every model stands out of its wall by the
//! height its profile says, on the tunnel side, as the lidar's rays see it.

use loc_core::geometry::Point2;
use loc_core::landmark::{Genome, LandmarkModel, LandmarkShape};
use loc_core::map::{FeatureKind, MapQuery, TunnelMap, WallSide};
use loc_core::testkit::TunnelSpec;

#[test]
fn every_model_stands_out_of_the_wall_by_its_profile_height() {
    let spec = TunnelSpec::straight(100.0);
    let mut map = TunnelMap::new();
    let walls = {
        spec.build_into(&mut map).unwrap();
        (
            map.wall_vertices(WallSide::Left).collect::<Vec<_>>(),
            map.wall_vertices(WallSide::Right).collect::<Vec<_>>(),
        )
    };
    let mut b = map.builder(&walls.0, &walls.1).unwrap();
    for (i, model) in LandmarkModel::ALL.into_iter().enumerate() {
        let s = 5.0 + 10.0 * i as f32;
        b.add_landmark(WallSide::Left, s, model, Genome::paper_default(model))
            .unwrap();
        b.add_landmark(
            WallSide::Right,
            s + 5.0,
            model,
            Genome::paper_default(model),
        )
        .unwrap();
    }
    b.finish().unwrap();

    for (i, model) in LandmarkModel::ALL.into_iter().enumerate() {
        let profile = LandmarkShape::paper_default(model).profile();
        let s = 5.0 + 10.0 * i as f32;
        // Probe across the landmark's width, from the centre line towards each wall.
        for k in -4..=4 {
            let du = profile.vertices()[0].x_m.abs() * k as f32 / 5.0;
            let want = profile.height_at(du);
            let left = map
                .raycast(Point2::new(s + du, 0.0), core::f32::consts::FRAC_PI_2, 10.0)
                .unwrap();
            assert!(
                (left.range_m - (2.5 - want)).abs() < 1e-4,
                "{model:?} left u={du}: range {} want {}",
                left.range_m,
                2.5 - want
            );
            if want > 1e-3 {
                assert_eq!(left.kind, FeatureKind::Landmark { id: (2 * i) as u16 });
            }
            // On the right wall u runs along +x too (walls share the chainage direction).
            let right = map
                .raycast(
                    Point2::new(s + 5.0 + du, 0.0),
                    -core::f32::consts::FRAC_PI_2,
                    10.0,
                )
                .unwrap();
            assert!(
                (right.range_m - (2.5 - want)).abs() < 1e-4,
                "{model:?} right u={du}"
            );
        }
    }
}

#[test]
fn landmark_segments_near_a_point_are_reported_once_with_their_id() {
    let spec = TunnelSpec::straight(50.0);
    let mut map = TunnelMap::new();
    spec.build_into(&mut map).unwrap();
    let l: Vec<_> = map.wall_vertices(WallSide::Left).collect();
    let r: Vec<_> = map.wall_vertices(WallSide::Right).collect();
    let mut b = map.builder(&l, &r).unwrap();
    let g = Genome::paper_default(LandmarkModel::P3Parabola);
    b.add_landmark(WallSide::Left, 20.0, LandmarkModel::P3Parabola, g)
        .unwrap();
    b.cell_size_m(0.25); // a landmark spread over many cells
    b.finish().unwrap();
    let mut ids = Vec::new();
    map.for_each_landmark_segment_near(Point2::new(20.0, 2.0), 2.0, &mut |id, seg| {
        ids.push((id, seg))
    });
    assert_eq!(ids.len(), 10, "a parabola has 10 segments");
    assert!(ids.iter().all(|(id, _)| *id == 0));
}
