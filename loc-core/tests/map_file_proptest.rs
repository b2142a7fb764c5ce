//! Property tests of the map file reader: no input makes it panic or overrun a capacity.

use loc_core::crc::crc32;
use loc_core::landmark::LandmarkModel;
use loc_core::map::{MapError, MapQuery, StoredMap, MAP_HEADER_LEN};
use loc_core::testkit::{LandmarkLayout, TunnelSpec};
use proptest::prelude::*;

type Small = StoredMap<600, 48, 600, 2400>;

/// A valid file: a curved 120 m tunnel with F2 landmarks (piecewise records included).
fn valid_bytes() -> Vec<u8> {
    let spec = TunnelSpec::curved(120.0)
        .with_landmarks(LandmarkLayout::paper(LandmarkModel::F2Inverted, 5));
    let mut m = Small::new();
    spec.build_into(&mut m).unwrap();
    let mut buf = vec![0u8; m.serialized_len()];
    let n = m.to_slice(&mut buf).unwrap();
    buf.truncate(n);
    buf
}

fn check_loaded(m: &Small) {
    assert!(m.segments().len() <= 600);
    assert!(m.landmarks().len() <= 48);
    let s = m.index_stats();
    assert!(s.cells <= 600 && s.cell_refs <= 2400);
    // Queries on whatever was loaded stay well-behaved.
    let _ = m.nearest(loc_core::geometry::Point2::new(10.0, 1.0), 5.0);
    let _ = m.raycast(loc_core::geometry::Point2::new(10.0, 1.0), 0.3, 80.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        if let Ok(m) = Small::from_bytes(&bytes) {
            check_loaded(&m);
        }
    }

    #[test]
    fn arbitrary_bytes_behind_a_valid_header_never_panic(
        payload in proptest::collection::vec(any::<u8>(), 0..2048),
    ) {
        let mut bytes = valid_bytes()[..MAP_HEADER_LEN].to_vec();
        bytes[8..12].copy_from_slice(&(payload.len() as u32).to_le_bytes());
        bytes[12..16].copy_from_slice(&crc32(&payload).to_le_bytes());
        bytes.extend_from_slice(&payload);
        match Small::from_bytes(&bytes) {
            Ok(m) => check_loaded(&m),
            Err(e) => prop_assert!(matches!(
                e,
                MapError::Corrupt { .. } | MapError::CapacityExceeded { .. } | MapError::InvalidGeometry(_)
            ), "{e:?}"),
        }
    }

    #[test]
    fn mutated_maps_never_panic(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        fix_crc in any::<bool>(),
        cut in proptest::option::of(any::<usize>()),
    ) {
        let mut bytes = valid_bytes();
        for (pos, x) in &edits {
            let n = bytes.len();
            bytes[pos % n] ^= x;
        }
        if fix_crc && bytes.len() > MAP_HEADER_LEN {
            let crc = crc32(&bytes[MAP_HEADER_LEN..]);
            bytes[12..16].copy_from_slice(&crc.to_le_bytes());
        }
        if let Some(c) = cut {
            let n = bytes.len();
            bytes.truncate(c % (n + 1));
        }
        if let Ok(m) = Small::from_bytes(&bytes) {
            check_loaded(&m);
        }
    }

    #[test]
    fn any_bytes_after_a_file_are_refused_and_only_padding_after_a_region_map(
        // Padding bytes two times in three, so both outcomes of the region come up.
        tail in proptest::collection::vec(
            prop_oneof![Just(0x00u8), Just(0xFFu8), any::<u8>()],
            1..64,
        ),
    ) {
        let mut bytes = valid_bytes();
        let n = bytes.len();
        bytes.extend_from_slice(&tail);
        let err = Small::from_bytes(&bytes).unwrap_err();
        prop_assert_eq!(err, MapError::TrailingBytes { map_len: n, offset: n, found: tail[0] });
        let first_not_padding = tail.iter().position(|&b| b != 0x00 && b != 0xFF);
        let mut m = Small::new();
        match (m.load_from_region(&bytes), first_not_padding) {
            (Ok(()), None) => check_loaded(&m),
            (Err(MapError::TrailingBytes { offset, found, .. }), Some(i)) => {
                prop_assert_eq!((offset, found), (n + i, tail[i]));
            }
            (r, i) => prop_assert!(false, "{:?} with first non-padding byte {:?}", r, i),
        }
    }

    #[test]
    fn every_truncation_is_reported_as_truncated(cut in 0usize..10_000) {
        let bytes = valid_bytes();
        let cut = cut % bytes.len();
        let err = Small::from_bytes(&bytes[..cut]).unwrap_err();
        prop_assert!(matches!(err, MapError::Truncated { got, .. } if got == cut), "{err:?}");
    }
}
