//! What survives a reset: a few words of RAM that cortex-m-rt leaves alone (`.uninit`),
//! holding whether the controller was running and what it knew at its last tracked scan
//! (pose, uncertainty, the vehicle's odometry reading), so that after a watchdog (or fault)
//! reset it knows it was reset and starts from where the vehicle last was — carried over
//! the outage by the odometry when it can (`crate::resume`) — rather than from the
//! start-pose record.
//!
//! A power-up leaves RAM zero (QEMU) or random (silicon): the magic word and the checksum
//! tell a power-up from a reset.

use controller_wire::OdometryFrame;
use core::mem::MaybeUninit;
use loc_core::geometry::Pose2;

/// Words of the record: magic, resets, x, y, θ, σ position, σ heading (f32 bits),
/// odometry sequence, time (low, high words), x, y, θ (f32 bits), checksum.
const WORDS: usize = 14;
/// Marks a record written by a running controller (this layout; an older layout's record
/// reads as a power-up).
const MAGIC: u32 = 0x10CA_1A80;

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

/// What the controller knew at its last tracked scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LastScan {
    /// The pose, world frame: x, y metres, θ radians.
    pub pose: Pose2,
    /// 1σ of the position, the larger of x's and y's (world frame), metres.
    pub sigma_xy_m: f32,
    /// 1σ of the heading, radians.
    pub sigma_theta_rad: f32,
    /// The vehicle's odometry reading the scan was predicted to (`None`: the scan had no
    /// fresh odometry).
    pub odometry: Option<OdometryFrame>,
}

impl LastScan {
    /// The last scan of a localiser's `pose` and `covariance` (world frame, x, y, θ) with
    /// the odometry reading it used.
    pub fn new(pose: Pose2, covariance: &[[f32; 3]; 3], odometry: Option<OdometryFrame>) -> Self {
        Self {
            pose,
            sigma_xy_m: loc_core::math::sqrt(covariance[0][0].max(covariance[1][1]).max(0.0)),
            sigma_theta_rad: loc_core::math::sqrt(covariance[2][2].max(0.0)),
            odometry,
        }
    }

    fn to_words(self, resets: u32) -> [u32; WORDS] {
        let p = self.pose;
        let o = self.odometry;
        let nan = f32::NAN.to_bits();
        let mut w = [
            MAGIC,
            resets,
            p.x_m.to_bits(),
            p.y_m.to_bits(),
            p.theta_rad.to_bits(),
            self.sigma_xy_m.to_bits(),
            self.sigma_theta_rad.to_bits(),
            o.map_or(0, |o| o.sequence),
            o.map_or(0, |o| o.time_us as u32),
            o.map_or(0, |o| (o.time_us >> 32) as u32),
            o.map_or(nan, |o| o.x_m.to_bits()),
            o.map_or(nan, |o| o.y_m.to_bits()),
            o.map_or(nan, |o| o.theta_rad.to_bits()),
            0,
        ];
        w[WORDS - 1] = checksum(&w[..WORDS - 1]);
        w
    }

    /// The last scan in a valid record's words, `None` when they hold none (or a value that
    /// is not finite).
    fn from_words(w: &[u32; WORDS]) -> Option<Self> {
        let f = |i: usize| f32::from_bits(w[i]);
        let pose = Pose2::new(f(2), f(3), f(4));
        let (sigma_xy_m, sigma_theta_rad) = (f(5), f(6));
        let odometry = OdometryFrame {
            sequence: w[7],
            time_us: u64::from(w[8]) | (u64::from(w[9]) << 32),
            x_m: f(10),
            y_m: f(11),
            theta_rad: f(12),
        };
        (pose.is_finite() && sigma_xy_m.is_finite() && sigma_theta_rad.is_finite()).then_some(
            Self {
                pose,
                sigma_xy_m,
                sigma_theta_rad,
                odometry: odometry.is_finite().then_some(odometry),
            },
        )
    }
}

/// What the record says at start-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Boot {
    /// Resets while running so far (0 after a power-up).
    pub resets: u32,
    /// The last tracked scan before the reset (`None` after a power-up, or when the run
    /// that was reset never tracked).
    pub last: Option<LastScan>,
}

/// Reads the record left by the previous run and marks this one as running: after a reset
/// while running, `resets` counts it.
pub fn boot() -> Boot {
    let w = read();
    let valid = w[0] == MAGIC && checksum(&w[..WORDS - 1]) == w[WORDS - 1];
    let boot = if valid {
        Boot {
            resets: w[1].saturating_add(1),
            last: LastScan::from_words(&w),
        }
    } else {
        Boot {
            resets: 0,
            last: None,
        }
    };
    store(boot.resets, boot.last);
    boot
}

fn store(resets: u32, last: Option<LastScan>) {
    let none = LastScan {
        pose: Pose2::new(f32::NAN, f32::NAN, f32::NAN),
        sigma_xy_m: f32::NAN,
        sigma_theta_rad: f32::NAN,
        odometry: None,
    };
    write(last.unwrap_or(none).to_words(resets));
}

/// Stores the controller's last tracked scan with the reset count (a few hundred
/// instructions: every tracked scan stores it).
pub fn store_scan(resets: u32, last: &LastScan) {
    store(resets, Some(*last));
}
