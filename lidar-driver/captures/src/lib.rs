//! The real SICK captures carried by the repository (`lidar-driver/captures/data/`, see its
//! README for their origin and content), found by name: the one place that knows where they
//! are, so tests, benches and examples never build a relative path of their own.
//!
//! ```
//! let bytes = sick_captures::read(sick_captures::LMS511_S2H);
//! assert_eq!(&bytes[..4], &[0x02; 4]); // a CoLa-B frame starts the stream
//! ```

use std::path::PathBuf;

/// LMS511 (firmware V1.80): every frame the sensor sent, raw CoLa-B, 174 scans at 25 Hz.
pub const LMS511_S2H: &str = "lms511_20210302_colab.sensor_to_host.colab.bin";
/// LMS511: every request the host sent, raw CoLa-B.
pub const LMS511_H2S: &str = "lms511_20210302_colab.host_to_sensor.colab.bin";
/// LMS511: the whole dialogue as SICK's `.pcapng.json`, with capture times.
pub const LMS511_JSON: &str = "lms511_20210302_colab.pcapng.json";
/// LMS111 (firmware V1.80.2): the sensor's frames, raw CoLa-B, 175 scans at 50 Hz / 0.5°.
pub const LMS111_S2H: &str = "lms111_20210302_colab.sensor_to_host.colab.bin";
/// LMS111: the host's requests, raw CoLa-B.
pub const LMS111_H2S: &str = "lms111_20210302_colab.host_to_sensor.colab.bin";
/// LMS111: the dialogue as SICK's `.pcapng.json`.
pub const LMS111_JSON: &str = "lms111_20210302_colab.pcapng.json";
/// TiM5xx/7xx: 16 scans inside a real Wireshark pcapng (Ethernet/IPv4/TCP).
pub const TIM_PCAPNG: &str = "tim_15hz_0p333deg_colab_16scans.pcapng";

/// Every capture, by file name.
pub const ALL: [&str; 7] = [
    LMS511_S2H,
    LMS511_H2S,
    LMS511_JSON,
    LMS111_S2H,
    LMS111_H2S,
    LMS111_JSON,
    TIM_PCAPNG,
];

/// The folder holding the captures.
pub fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// The path of capture `name` (one of the constants above).
pub fn path(name: &str) -> PathBuf {
    dir().join(name)
}

/// The bytes of capture `name`.
///
/// # Panics
/// When the file is missing: the repository is incomplete (the message says which file).
pub fn read(name: &str) -> Vec<u8> {
    let p = path(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("capture {}: {e}", p.display()))
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_capture_is_in_the_repository() {
        for name in super::ALL {
            assert!(super::read(name).len() > 1000, "{name}");
        }
    }
}
