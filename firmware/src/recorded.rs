//! The recorded replay data, embedded in flash: the stored map exactly as it is flashed
//! (header + postcard payload + CRC), synthetic LMS511 scans as the raw u16 millimetre
//! ranges the driver delivers, the true poses and the odometry between scans.
//!
//! Generated on the host at build time by `build/record.rs` with loc-core's test kit.

mod generated {
    include!(concat!(env!("OUT_DIR"), "/recording.rs"));
}

pub use generated::{
    BEAMS_PER_SCAN, MAP_BYTES_LEN, MAP_LANDMARKS, ODOMETRY, SCAN_COUNT, TRUE_POSES,
};

/// The serialised map, as a flash region holding a map file would contain it.
pub static MAP_BYTES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/map.bin"));

/// The scans, back to back: `SCAN_COUNT × BEAMS_PER_SCAN` little-endian u16, millimetres,
/// 0 = no echo.
static SCANS_MM_LE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/scans_mm.bin"));

/// Copies scan `index`'s raw ranges (mm) into `out`; returns false when `index` is out of
/// range (`out` untouched).
pub fn load_scan_mm(index: usize, out: &mut [u16; BEAMS_PER_SCAN]) -> bool {
    let bytes_per_scan = BEAMS_PER_SCAN * 2;
    let Some(bytes) = SCANS_MM_LE.get(index * bytes_per_scan..(index + 1) * bytes_per_scan) else {
        return false;
    };
    for (slot, pair) in out.iter_mut().zip(bytes.chunks_exact(2)) {
        *slot = u16::from_le_bytes([pair[0], pair[1]]);
    }
    true
}

/// The same scans as the raw CoLa-B `sSN LMDscandata` stream an LMS511 sends (what the
/// emulator replays to the controller).
pub static SCANS_COLAB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/scans_colab.bin"));
