//! Property tests of the map flash image: an image answers every query exactly as the map
//! it was written from, and no damage makes opening or querying it panic.

use loc_core::crc::crc32;
use loc_core::geometry::Point2;
use loc_core::landmark::LandmarkModel;
use loc_core::map::{MapImage, MapQuery, StoredMap};
use loc_core::testkit::{LandmarkLayout, TunnelSpec};
use proptest::prelude::*;

type Small = StoredMap<600, 48, 600, 2400>;

/// A curved 120 m tunnel with F2 landmarks (piecewise records included), and its image.
fn map_and_image() -> &'static (Small, Vec<u8>) {
    static CELL: std::sync::OnceLock<(Small, Vec<u8>)> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let spec = TunnelSpec::curved(120.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::F2Inverted, 5));
        let mut m = Small::new();
        spec.build_into(&mut m).unwrap();
        let mut buf = vec![0u8; m.image_len()];
        m.write_image(&mut buf).unwrap();
        (m, buf)
    })
}

fn query_everything(image: &MapImage<'_>, p: Point2, a: f32, r: f32) {
    let _ = image.nearest(p, r);
    let _ = image.raycast(p, a, r);
    image.for_each_landmark_segment_near(p, r, &mut |_, _| {});
    let _ = image.wall_frame_at(loc_core::map::WallSide::Left, r);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn an_image_answers_as_its_map(
        x in -20.0f32..140.0, y in -20.0f32..80.0, a in -7.0f32..7.0, r in 0.0f32..90.0,
    ) {
        let (map, bytes) = map_and_image();
        let image = MapImage::from_bytes(bytes).unwrap();
        let p = Point2::new(x, y);
        prop_assert_eq!(image.nearest(p, r), map.nearest(p, r));
        prop_assert_eq!(image.raycast(p, a, r), map.raycast(p, a, r));
        let mut from_image = Vec::new();
        let mut from_map = Vec::new();
        let near = r / 9.0;
        image.for_each_landmark_segment_near(p, near, &mut |id, s| from_image.push((id, s)));
        map.for_each_landmark_segment_near(p, near, &mut |id, s| from_map.push((id, s)));
        prop_assert_eq!(from_image, from_map);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..4096)) {
        if let Ok(image) = MapImage::from_region(&bytes) {
            query_everything(&image, Point2::new(10.0, 1.0), 0.3, 80.0);
        }
    }

    /// Bytes changed and the CRC re-sealed, so the structural checks are what stands between
    /// the damage and the queries; any image they let through must still answer without
    /// panicking, for any query.
    #[test]
    fn resealed_damage_never_panics(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
        x in any::<f32>(), y in any::<f32>(), a in any::<f32>(), r in any::<f32>(),
    ) {
        let mut bytes = map_and_image().1.clone();
        let n = bytes.len();
        for (pos, v) in &edits {
            bytes[pos % n] ^= v;
        }
        let crc = crc32(&bytes[..n - 4]);
        bytes[n - 4..].copy_from_slice(&crc.to_le_bytes());
        if let Ok(image) = MapImage::from_bytes(&bytes) {
            query_everything(&image, Point2::new(x, y), a, r);
        }
    }
}
