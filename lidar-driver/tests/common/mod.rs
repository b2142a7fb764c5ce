//! Helpers shared by the integration tests: capture paths and framing whole files.
#![allow(dead_code)]

use std::path::PathBuf;

use lidar_driver::{Dialect, Framer};

/// `../shared/captures/<name>` relative to the workspace root.
pub fn capture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/captures")
        .join(name)
}

/// Reads a capture file.
pub fn read(name: &str) -> Vec<u8> {
    std::fs::read(capture(name)).unwrap_or_else(|e| panic!("{}: {e}", capture(name).display()))
}

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

pub const LMS511_S2H: &str = "lms511_20210302_colab.sensor_to_host.colab.bin";
pub const LMS511_H2S: &str = "lms511_20210302_colab.host_to_sensor.colab.bin";
pub const LMS511_JSON: &str = "lms511_20210302_colab.pcapng.json";
pub const LMS111_S2H: &str = "lms111_20210302_colab.sensor_to_host.colab.bin";
pub const LMS111_H2S: &str = "lms111_20210302_colab.host_to_sensor.colab.bin";
pub const LMS111_JSON: &str = "lms111_20210302_colab.pcapng.json";
pub const TIM_PCAPNG: &str = "tim_15hz_0p333deg_colab_16scans.pcapng";
