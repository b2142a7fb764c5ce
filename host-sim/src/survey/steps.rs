//! Keyframe to next keyframe: what the odometry says about the motion between two scans
//! (loc-core's odometry noise model). The walls' part, across and heading, is
//! [`super::scan_steps`]'s; along the tunnel the odometry is all a bare tunnel has.
//!
//! The odometry's scale error is not noise: wheels over-read and tracks slip by a few per
//! cent, the same way for metres on end, and counted as independent noise per step it
//! would shrink or stretch the map between landmarks. Each step is rescaled by the ratio
//! of the localiser's distance to the odometry's over the surrounding stretch
//! ([`local_scales`]; the localiser's poses are landmark-fixed to centimetres, so over
//! 50 m the ratio is known to a tenth of a per cent), and only the rest counts as noise.

use loc_core::filter::{OdometryIncrement, OdometryNoise};
use nalgebra::Matrix3;

use super::graph::Relative;
use super::keyframes::Keyframe;
use crate::vehicle::SimPose;

/// Half the stretch over which the odometry's scale is estimated, metres.
pub const SCALE_WINDOW_M: f64 = 25.0;

/// 1σ of the scale once estimated (dimensionless): centimetres of the localiser's error
/// over [`SCALE_WINDOW_M`] either side.
pub const ESTIMATED_SCALE_SD: f64 = 0.002;

/// Per keyframe, the localiser's distance over the odometry's within [`SCALE_WINDOW_M`]
/// of it (1 where the odometry did not move). Steps where the localiser was not tracking
/// at either end, or across a gap in the odometry (`gap_steps[k]`: step `k` → `k + 1`),
/// count as neither.
pub fn local_scales(kfs: &[Keyframe], gap_steps: &[bool]) -> Vec<f64> {
    let n = kfs.len();
    // Prefix sums of both distances per step (a step counts where both ends tracked).
    let mut odo = vec![0.0; n];
    let mut est = vec![0.0; n];
    for k in 1..n {
        let o = kfs[k - 1].odometry.between(kfs[k].odometry);
        let e = kfs[k - 1].guess.between(kfs[k].guess);
        let used = kfs[k - 1].tracking
            && kfs[k].tracking
            && !gap_steps.get(k - 1).copied().unwrap_or(false);
        odo[k] = odo[k - 1] + if used { o.x_m.hypot(o.y_m) } else { 0.0 };
        est[k] = est[k - 1] + if used { e.x_m.hypot(e.y_m) } else { 0.0 };
    }
    let (mut lo, mut hi) = (0usize, 0usize);
    (0..n)
        .map(|k| {
            while odo[k] - odo[lo] > SCALE_WINDOW_M {
                lo += 1;
            }
            while hi + 1 < n && odo[hi + 1] - odo[k] <= SCALE_WINDOW_M {
                hi += 1;
            }
            let (o, e) = (odo[hi] - odo[lo], est[hi] - est[lo]);
            // A ratio from a short stretch (the localiser lost) is not trusted.
            if o > SCALE_WINDOW_M && (0.8..1.25).contains(&(e / o)) {
                e / o
            } else {
                1.0
            }
        })
        .collect()
}

/// The odometry step from keyframe `a` (index `from`) to `b`, rescaled by `scale`
/// ([`local_scales`]; 1: the odometry as logged, its scale error counted as noise), with
/// `odometry`'s covariance.
pub fn step(
    a: &Keyframe,
    b: &Keyframe,
    from: usize,
    scale: f64,
    odometry: &OdometryNoise,
) -> Relative {
    let logged = a.odometry.between(b.odometry);
    let z = SimPose::new(logged.x_m * scale, logged.y_m * scale, logged.theta_rad);
    let inc = OdometryIncrement {
        dx_m: z.x_m as f32,
        dy_m: z.y_m as f32,
        dtheta_rad: z.theta_rad as f32,
    };
    let c = odometry.covariance(&inc);
    let scale_sd = if scale == 1.0 {
        f64::from(odometry.scale_sd)
    } else {
        ESTIMATED_SCALE_SD
    };
    // loc-core orders (x, y, θ); factrs (θ, x, y).
    let order = [2usize, 0, 1];
    let mut covariance = Matrix3::from_fn(|r, q| f64::from(c[(order[r], order[q])]));
    covariance[(1, 1)] += (scale_sd * z.x_m).powi(2);
    Relative {
        from,
        to: from + 1,
        z,
        covariance,
    }
}

/// 1σ of a step across a gap in the odometry: along (m), across (m), heading (rad). The
/// step is then the localiser's (which coasted across the gap and found the landmarks
/// again), held loosely: the landmarks and the scan matches place the keyframes.
pub const GAP_STEP_SD: (f64, f64, f64) = (0.5, 0.1, 0.05);

/// The step from keyframe `a` (index `from`) to `b` across a gap in the odometry: the
/// localiser's relative pose with [`GAP_STEP_SD`].
pub fn gap_step(a: &Keyframe, b: &Keyframe, from: usize) -> Relative {
    let (along, across, heading) = GAP_STEP_SD;
    Relative {
        from,
        to: from + 1,
        z: a.guess.between(b.guess),
        covariance: Matrix3::from_diagonal(&nalgebra::Vector3::new(
            heading * heading,
            along * along,
            across * across,
        )),
    }
}
