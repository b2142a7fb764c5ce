//! "Recording" of the replay data on the host at build time: synthetic LMS511 scans (raw
//! u16 millimetre ranges, exactly what the driver hands over) along a tunnel, the true poses
//! and the odometry between scans.
//!
//! Written into OUT_DIR and embedded with `include_bytes!` / `include!` by `src/recorded.rs`.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

/// Beams per LMS511 scan at 0.1667°.
const BEAMS: usize = 1141;
/// Scans recorded.
const SCANS: usize = 20;
/// Vehicle travel between scans, metres (10 m/s at 25 Hz).
const STEP_M: f32 = 0.4;
/// Half width of the straight tunnel, metres.
const HALF_WIDTH_M: f32 = 2.5;

/// Range in metres along a vehicle-frame beam at `angle_rad` from `(0, y0_m)` with heading
/// `heading_rad` to the walls `y = ±HALF_WIDTH_M`; 0 when the beam never meets a wall within
/// 80 m (no echo).
fn straight_tunnel_range_m(y0_m: f32, heading_rad: f32, angle_rad: f32) -> f32 {
    let a = heading_rad + angle_rad;
    let s = a.sin();
    let r = if s > 1e-6 {
        (HALF_WIDTH_M - y0_m) / s
    } else if s < -1e-6 {
        (-HALF_WIDTH_M - y0_m) / s
    } else {
        0.0
    };
    if r > 80.0 {
        0.0
    } else {
        r
    }
}

/// Writes `scans_mm.bin` (SCANS × BEAMS little-endian u16, mm) and `recording.rs` (counts,
/// true poses, odometry) into `out`.
pub fn write_recordings(out: &Path) {
    let mut raw = Vec::with_capacity(SCANS * BEAMS * 2);
    let mut truth = String::new();
    let start_rad = (-5.0f32).to_radians();
    let step_rad = (0.1667f32).to_radians();
    for k in 0..SCANS {
        let x_m = 2.0 + k as f32 * STEP_M;
        let y_m = 0.3 * (k as f32 * 0.3).sin();
        let theta_rad = 0.02 * (k as f32 * 0.2).cos();
        // The LMS511 looks forward: its 90° beam along the vehicle's x axis.
        for i in 0..BEAMS {
            let beam_vehicle_rad = start_rad + i as f32 * step_rad - core::f32::consts::FRAC_PI_2;
            let r_m = straight_tunnel_range_m(y_m, theta_rad, beam_vehicle_rad);
            let mm = (r_m * 1000.0).round().clamp(0.0, 65535.0) as u16;
            raw.extend_from_slice(&mm.to_le_bytes());
        }
        writeln!(truth, "    [{x_m:?}, {y_m:?}, {theta_rad:?}],").expect("write to String");
    }
    fs::write(out.join("scans_mm.bin"), raw).expect("write scans_mm.bin");
    let src = format!(
        "/// Scans in the recording.\npub const SCAN_COUNT: usize = {SCANS};\n\
         /// Beams per scan.\npub const BEAMS_PER_SCAN: usize = {BEAMS};\n\
         /// True vehicle pose `[x_m, y_m, theta_rad]` (world frame) at each scan.\n\
         pub const TRUE_POSES: [[f32; 3]; {SCANS}] = [\n{truth}];\n"
    );
    fs::write(out.join("recording.rs"), src).expect("write recording.rs");
}
