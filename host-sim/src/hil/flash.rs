//! What goes into the map flash region of QEMU's `mps2-an386` for a HIL run, as a flasher
//! would write it: the map image from the region's start, the localiser's configuration
//! record in the 4 KiB before the last, the start pose in the last 4 KiB (the firmware's
//! `controller::split_region`).

use std::path::{Path, PathBuf};

use loc_core::localizer::{StartPose, CONFIG_RECORD_MAX_BYTES};
use loc_core::map::TunnelMap;

use crate::estimator::localizer_config;
use crate::record::{files, initial_pose};
use crate::scenario::Scenario;

/// Start of the map flash region (`firmware::board::mps2_an386::MAP_REGION_ADDR`).
pub const MAP_REGION_ADDR: u32 = 0x0030_0000;
/// Its length, bytes.
pub const MAP_REGION_LEN: u32 = 0x0010_0000;
/// The configuration block: the 4 KiB before the start-pose block.
pub const CONFIG_ADDR: u32 = MAP_REGION_ADDR + MAP_REGION_LEN - 2 * 4096;
/// The start-pose block: the region's last 4 KiB.
pub const START_POSE_ADDR: u32 = MAP_REGION_ADDR + MAP_REGION_LEN - 4096;

/// The files written.
#[derive(Debug, Clone)]
pub struct Flashed {
    /// The map image.
    pub image: PathBuf,
    /// The configuration record.
    pub config: PathBuf,
    /// The start-pose record.
    pub start_pose: PathBuf,
}

/// Writes the three files into `out`: `map`'s image, the scenario's localiser configuration,
/// and the recording's initial pose.
pub fn write(
    scenario: &Scenario,
    map: &TunnelMap,
    recording: &Path,
    out: &Path,
) -> Result<Flashed, String> {
    let mut image = vec![0u8; map.image_len()];
    map.write_image(&mut image).map_err(|e| e.to_string())?;
    if image.len() as u32 > CONFIG_ADDR - MAP_REGION_ADDR {
        return Err(format!(
            "the map image ({} bytes) does not fit QEMU's map region ({} bytes before the configuration block)",
            image.len(),
            CONFIG_ADDR - MAP_REGION_ADDR
        ));
    }
    let mut config = vec![0u8; CONFIG_RECORD_MAX_BYTES];
    let n = localizer_config(scenario)
        .to_record(&mut config)
        .map_err(|e| e.to_string())?;
    config.truncate(n);
    let initial = initial_pose::read(&recording.join(files::INITIAL_POSE))
        .map_err(|e| e.to_string())?
        .ok_or("the recording has no initial pose")?;
    let start = StartPose {
        pose: loc_core::geometry::Pose2::new(
            initial.pose.x_m as f32,
            initial.pose.y_m as f32,
            initial.pose.theta_rad as f32,
        ),
        sigma_xy_m: initial.sigma_xy_m as f32,
        sigma_theta_rad: initial.sigma_theta_rad as f32,
    };
    let flashed = Flashed {
        image: out.join("map.image"),
        config: out.join("config.bin"),
        start_pose: out.join("start_pose.bin"),
    };
    let write = |p: &Path, bytes: &[u8]| {
        std::fs::write(p, bytes).map_err(|e| format!("cannot write {}: {e}", p.display()))
    };
    write(&flashed.image, &image)?;
    write(&flashed.config, &config)?;
    write(&flashed.start_pose, &start.to_bytes())?;
    Ok(flashed)
}
