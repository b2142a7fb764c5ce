//! The recording readers on arbitrary bytes behind each format's magic: they never panic,
//! and the streamed read, however the source splits its reads, gives the frames, damage and
//! errors of the in-memory read.

mod common;

use common::Trickle;
use lidar_driver::recording::{FrameReader, Recording, RecordingReader};
use proptest::prelude::*;

fn magic() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        Just(vec![0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0]),
        Just(vec![
            0x0a, 0x0d, 0x0d, 0x0a, 28, 0, 0, 0, 0x4d, 0x3c, 0x2b, 0x1a
        ]),
        Just(b"[{\"_source\":{\"layers\":{\"tcp\":{\"tcp.payload\":\"02:02\"}}}},".to_vec()),
        Just(vec![0x02, 0x02, 0x02, 0x02, 0, 0, 0, 5]),
        Just(Vec::new()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn streamed_reads_of_any_bytes_match_the_whole_read(
        head in magic(),
        tail in proptest::collection::vec(any::<u8>(), 0..3000),
        step in 1usize..97,
    ) {
        let mut bytes = head;
        bytes.extend(tail);
        let whole = Recording::parse(&bytes);
        let streamed = RecordingReader::new(Trickle { rest: &bytes, step }).and_then(|mut r| {
            let mut frames = Vec::new();
            let mut errors = 0usize;
            let mut f = FrameReader::new(|| r.next_chunk());
            while let Some(item) = f.next_frame()? {
                match item {
                    Ok(frame) => frames.push(frame),
                    Err(_) => errors += 1,
                }
            }
            drop(f);
            Ok((frames, errors, r.damage().to_vec()))
        });
        match (whole, streamed) {
            (Ok(rec), Ok((frames, errors, damage))) => {
                let expected = rec.frames();
                prop_assert_eq!(frames, expected.frames);
                prop_assert_eq!(errors, expected.errors.len());
                prop_assert_eq!(damage, rec.damage);
            }
            (Err(a), Err(b)) => prop_assert_eq!(a.to_string(), b.to_string()),
            (a, b) => prop_assert!(false, "whole {:?} vs streamed {:?}", a.map(|_| ()), b.map(|_| ())),
        }
    }
}
