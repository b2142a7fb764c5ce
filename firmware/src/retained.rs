//! What survives a reset: a few words of RAM that cortex-m-rt leaves alone (`.uninit`),
//! holding whether the controller was running and its last pose, so that after a watchdog
//! (or fault) reset it knows it was reset and starts from where the vehicle last was rather
//! than from the start-pose record.
//!
//! A power-up leaves RAM zero (QEMU) or random (silicon): the magic word and the checksum
//! tell a power-up from a reset.

use core::mem::MaybeUninit;
use loc_core::geometry::Pose2;

/// Words of the record: magic, resets, x, y, θ (f32 bits), checksum.
const WORDS: usize = 6;
/// Marks a record written by a running controller.
const MAGIC: u32 = 0x10CA_1A7E;

#[link_section = ".uninit.RETAINED"]
static mut RECORD: MaybeUninit<[u32; WORDS]> = MaybeUninit::uninit();

fn checksum(words: &[u32]) -> u32 {
    words
        .iter()
        .fold(0x5A5A_5A5A_u32, |acc, &w| acc.rotate_left(5) ^ w)
}

fn read() -> [u32; WORDS] {
    // SAFETY: RECORD is only accessed through these two functions, from the single thread
    // of the controller (no interrupt touches it); its bytes are any u32 values, so reading
    // uninitialised RAM here is reading whatever power-up left, which the checksum judges.
    unsafe { core::ptr::read_volatile(core::ptr::addr_of!(RECORD).cast::<[u32; WORDS]>()) }
}

fn write(words: [u32; WORDS]) {
    // SAFETY: as in `read`.
    unsafe {
        core::ptr::write_volatile(
            core::ptr::addr_of_mut!(RECORD).cast::<[u32; WORDS]>(),
            words,
        )
    }
}

/// What the record says at start-up.
#[derive(Debug, Clone, Copy, PartialEq, defmt::Format)]
pub struct Boot {
    /// Resets while running so far (0 after a power-up).
    pub resets: u32,
    /// The last pose stored before the reset (`None` after a power-up, or before the first
    /// scan of the run that was reset).
    pub last_pose: Option<(f32, f32, f32)>,
}

/// Reads the record left by the previous run and marks this one as running: after a reset
/// while running, `resets` counts it.
pub fn boot() -> Boot {
    let w = read();
    let valid = w[0] == MAGIC && checksum(&w[..WORDS - 1]) == w[WORDS - 1];
    let boot = if valid {
        let (x, y, th) = (
            f32::from_bits(w[2]),
            f32::from_bits(w[3]),
            f32::from_bits(w[4]),
        );
        Boot {
            resets: w[1].saturating_add(1),
            last_pose: (x.is_finite() && y.is_finite() && th.is_finite()).then_some((x, y, th)),
        }
    } else {
        Boot {
            resets: 0,
            last_pose: None,
        }
    };
    store(boot.resets, boot.last_pose);
    boot
}

fn store(resets: u32, pose: Option<(f32, f32, f32)>) {
    let (x, y, th) = pose.unwrap_or((f32::NAN, f32::NAN, f32::NAN));
    let mut w = [MAGIC, resets, x.to_bits(), y.to_bits(), th.to_bits(), 0];
    w[WORDS - 1] = checksum(&w[..WORDS - 1]);
    write(w);
}

/// Stores the controller's latest pose (world frame) with the reset count.
pub fn store_pose(resets: u32, pose: &Pose2) {
    store(resets, Some((pose.x_m, pose.y_m, pose.theta_rad)));
}
