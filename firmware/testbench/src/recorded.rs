//! The recorded replay data, embedded in flash: the map flash image exactly as it is
//! flashed (`LCMI`: header, segments, index, landmarks, CRC), the start pose the controller is given, synthetic
//! LMS511 scans as the CoLa-B `LMDscandata` telegrams the scanner sends, the true poses and
//! the odometry between scans.
//!
//! Generated on the host at build time by `build/record.rs` with loc-core's test kit.

mod generated {
    include!(concat!(env!("OUT_DIR"), "/recording.rs"));
}

pub use generated::{
    BEAMS_PER_SCAN, INITIAL_ERROR, MAP_BYTES_LEN, MAP_LANDMARKS, ODOMETRY, SCAN_COUNT, TELEGRAMS,
    TRUE_POSES,
};

/// The map image, as the map flash region holds it.
pub static MAP_BYTES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/map.bin"));

/// The start-pose record (loc-core's `StartPose`), as the flasher writes it.
pub static START_POSE_BYTES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/start_pose.bin"));

/// The scans as the raw CoLa-B `sSN LMDscandata` stream an LMS511 sends (what the emulator
/// replays to the controller).
pub static SCANS_COLAB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/scans_colab.bin"));

/// The CoLa-B frame of scan `index`; `None` past the end.
pub fn telegram(index: usize) -> Option<&'static [u8]> {
    let &(offset, len) = TELEGRAMS.get(index)?;
    SCANS_COLAB.get(offset..offset + len)
}
