//! Helpers shared by the integration tests: the repository's captures (through
//! `sick-captures`) and framing whole files.
#![allow(dead_code)]

use lidar_driver::{Dialect, Framer};

#[allow(unused_imports)] // each test binary uses its own few of them
pub use sick_captures::{
    path as capture, read, LMS111_H2S, LMS111_JSON, LMS111_S2H, LMS511_H2S, LMS511_JSON,
    LMS511_S2H, TIM_PCAPNG,
};

/// Frames a whole byte stream; panics on any dropped frame (the captures are clean).
pub fn frames(bytes: &[u8]) -> Vec<(Dialect, Vec<u8>)> {
    let mut f = Framer::new(vec![0u8; 64 * 1024]);
    let mut out = Vec::new();
    f.feed(bytes, |r| {
        let fr = r.expect("capture frames are all good");
        out.push((fr.dialect(), fr.as_bytes().to_vec()));
    });
    f.finish();
    assert!(f.next_frame().is_none());
    assert_eq!(f.stats().garbage_bytes, 0);
    out
}

/// A source that hands out at most `step` bytes per read (records and frames straddle
/// reads).
pub struct Trickle<'a> {
    pub rest: &'a [u8],
    pub step: usize,
}

impl std::io::Read for Trickle<'_> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let n = self.rest.len().min(out.len()).min(self.step);
        out[..n].copy_from_slice(&self.rest[..n]);
        self.rest = &self.rest[n..];
        Ok(n)
    }
}
