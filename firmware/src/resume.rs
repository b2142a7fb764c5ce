//! Starting again after a reset: the last tracked pose (`crate::retained`) carried over the
//! outage by the vehicle's odometry.
//!
//! While the watchdog times out, the controller boots and the scanner's session is set up
//! again (1–2 s), the vehicle drives on: at 10 m/s that is 10–20 m, far beyond the 1 m a
//! start from the last pose alone allows (the controller would find the map disagreeing and
//! relocalise, seconds more). The vehicle's odometry frames carry its cumulative pose, so
//! the reading kept with the last pose and the first one after the reset give the motion
//! over the outage; the start's uncertainty grows with it by loc-core's odometry model
//! (random walk, scale error, and the heading error of the last pose swung over the
//! distance). A start that is still wrong is caught by loc-core's map check as any start
//! is.

use controller_wire::OdometryFrame;
use loc_core::filter::{OdometryIncrement, OdometryNoise};
use loc_core::geometry::Pose2;
use loc_core::localizer::StartPose;
use loc_core::math;

use crate::odometry::pose;
use crate::retained::LastScan;

/// Faster than a loader drives, m/s: odometry saying the vehicle went farther over the
/// outage is not believed.
pub const MAX_SPEED_M_PER_S: f32 = 20.0;

/// The longest outage bridged, seconds: beyond it the odometry's drift makes relocalising
/// the better start.
pub const MAX_OUTAGE_S: f32 = 120.0;

/// A start carried over the outage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bridged {
    /// Where to start (world frame) and how sure.
    pub start: StartPose,
    /// The distance the odometry says the vehicle drove over the outage, metres.
    pub distance_m: f32,
    /// The outage by the vehicle's clock, seconds.
    pub outage_s: f32,
}

/// Why the outage could not be bridged (the controller starts from the last pose with
/// [`crate::controller::DEFAULT_START_SIGMA`], or relocalises, instead).
#[derive(Debug, Clone, Copy, PartialEq, defmt::Format)]
pub enum BridgeRefusal {
    /// The last tracked scan had no fresh odometry reading to bridge from.
    NoOdometryAtLastScan,
    /// The reading after the reset is not after the kept one by the sender's sequence
    /// number or clock: the vehicle computer restarted too, its odometry started again.
    SenderRestarted,
    /// The outage lasted longer than [`MAX_OUTAGE_S`], seconds.
    OutageTooLong {
        /// The outage by the vehicle's clock, seconds.
        outage_s: f32,
    },
    /// The odometry says the vehicle went faster than [`MAX_SPEED_M_PER_S`].
    Implausible {
        /// The distance the odometry says, metres.
        distance_m: f32,
        /// The outage by the vehicle's clock, seconds.
        outage_s: f32,
    },
    /// The filter refused the carried start (not finite).
    StartRejected,
}

/// Carries `last` (the last tracked scan before the reset) to the vehicle's odometry
/// reading `now` by the motion between the two readings, with `noise` (the localiser's
/// odometry model) for the uncertainty it adds.
pub fn bridge(
    last: &LastScan,
    now: &OdometryFrame,
    noise: &OdometryNoise,
) -> Result<Bridged, BridgeRefusal> {
    let before = last.odometry.ok_or(BridgeRefusal::NoOdometryAtLastScan)?;
    let ahead = now.sequence.wrapping_sub(before.sequence);
    if ahead == 0 || ahead >= u32::MAX / 2 || now.time_us <= before.time_us {
        return Err(BridgeRefusal::SenderRestarted);
    }
    let outage_s = (now.time_us - before.time_us) as f32 * 1e-6;
    if outage_s > MAX_OUTAGE_S {
        return Err(BridgeRefusal::OutageTooLong { outage_s });
    }
    let inc = OdometryIncrement::between(&pose(&before), &pose(now));
    let distance_m = inc.distance_m();
    if distance_m.is_nan() || distance_m > MAX_SPEED_M_PER_S * outage_s + 0.5 {
        return Err(BridgeRefusal::Implausible {
            distance_m,
            outage_s,
        });
    }
    // Vehicle frame: along, across, heading variances of the drive's random part.
    let q = noise.covariance(&inc);
    let scale_m = noise.scale_sd * distance_m;
    let swing_m = distance_m * last.sigma_theta_rad;
    // The heading's random walk bends the path: about a third of its variance over the
    // distance ends up sideways at the end.
    let bend_var_m2 = distance_m * distance_m * q[(2, 2)] / 3.0;
    let position_var_m2 = last.sigma_xy_m * last.sigma_xy_m
        + math::max(q[(0, 0)] + scale_m * scale_m, q[(1, 1)])
        + swing_m * swing_m
        + bend_var_m2;
    let heading_var_rad2 = last.sigma_theta_rad * last.sigma_theta_rad + q[(2, 2)];
    Ok(Bridged {
        start: StartPose {
            pose: last
                .pose
                .compose(&Pose2::new(inc.dx_m, inc.dy_m, inc.dtheta_rad)),
            sigma_xy_m: math::sqrt(position_var_m2),
            sigma_theta_rad: math::sqrt(heading_var_rad2),
        },
        distance_m,
        outage_s,
    })
}
