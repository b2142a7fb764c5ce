//! Fuzz the whole receive path: arbitrary bytes in arbitrary chunks through the framer, every
//! frame through the telegram, request, answer and `LMDscandata` decoders, and every decoded scan
//! back through the encoder. Nothing may panic; a decoded CoLa-B scan must re-encode to the very
//! same bytes, and any scan must survive a CoLa-A round trip.
//!
//! Run: `cd lidar-driver/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run framer_decoder`
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidar_driver::{Answer, Dialect, Frame, Framer, Request, ScanData, ScanRepr, Telegram};

fn check_frame(f: Frame<'_>) {
    let _ = Request::from_frame(f);
    let Ok(t) = Telegram::parse(f) else { return };
    let _ = Answer::parse(&t);
    if let Ok(s) = ScanData::from_telegram(&t) {
        for c in s.channels() {
            assert_eq!(c.values().count(), c.len());
            let _ = c.distances_mm().flatten().fold(0.0f32, |a, d| a + d);
        }
        let _ = s.encoders().iter().count();
        let repr = ScanRepr::parse(&s);
        if f.dialect() == Dialect::ColaB {
            assert_eq!(repr.to_vec(Dialect::ColaB).unwrap(), f.as_bytes());
        }
        let a = repr.to_vec(Dialect::ColaA).unwrap();
        let back = ScanData::new_checked(Frame::new_checked(&a).unwrap()).unwrap();
        assert_eq!(format!("{:?}", back.header), format!("{:?}", s.header));
        for (x, y) in back.channels().zip(s.channels()) {
            assert!(x.values().eq(y.values()));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the chunk size, so splits at every position are explored.
    let (chunk, bytes) = match data.split_first() {
        Some((&c, rest)) => ((c as usize % 64) + 1, rest),
        None => return,
    };
    let mut framer = Framer::new([0u8; 4096]);
    for piece in bytes.chunks(chunk) {
        framer.feed(piece, |r| {
            if let Ok(f) = r {
                check_frame(f);
            }
        });
    }
    framer.finish();
    while let Some(r) = framer.next_frame() {
        if let Ok(f) = r {
            check_frame(f);
        }
    }
    // The same bytes as one whole frame.
    if let Ok(f) = Frame::new_checked(bytes) {
        check_frame(f);
    }
});
