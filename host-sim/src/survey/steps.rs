//! Keyframe to next keyframe: what the odometry and the walls say about the motion between
//! two scans.
//!
//! The odometry gives the whole motion, loosely (loc-core's odometry noise model, with the
//! unknown scale error counted as noise: the landmarks fix the scale). Where both scans see
//! a wall, the walls give the across-tunnel offset and the heading change far better: the
//! same stretch of wall, fitted by loc-core's stripper in each scan, seen from both poses.
//! Along the tunnel the walls say nothing, which is what keeps a survey without landmarks
//! honest: its along-tunnel extent rests on the odometry alone.
//!
//! The odometry's scale error is not noise: wheels over-read and tracks slip by a few per
//! cent, the same way for metres on end, and counted as independent noise per step it
//! would shrink or stretch the map between landmarks. Each step is rescaled by the ratio
//! of the localiser's distance to the odometry's over the surrounding stretch
//! ([`local_scales`]; the localiser's poses are landmark-fixed to centimetres, so over
//! 50 m the ratio is known to a tenth of a per cent), and only the rest counts as noise.

use loc_core::filter::{OdometryIncrement, OdometryNoise};
use loc_core::strip::Cubic;
use nalgebra::Matrix3;

use super::graph::Relative;
use super::keyframes::Keyframe;
use crate::vehicle::SimPose;

/// How much the step factors are trusted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepNoise {
    /// The odometry's noise model (the localiser's).
    pub odometry: OdometryNoise,
    /// 1σ of the across-tunnel offset between two keyframes from their walls, metres.
    pub wall_lateral_sd_m: f64,
    /// 1σ of the heading change between two keyframes from their walls, radians.
    pub wall_heading_sd_rad: f64,
    /// Left and right wall disagreeing by more than this across, metres: a wall fit is
    /// off (a cross-cut, a vehicle alongside), and the step falls back to the odometry.
    pub wall_disagreement_m: f64,
    /// The same in heading, radians.
    pub wall_disagreement_rad: f64,
}

impl StepNoise {
    /// The odometry model given, the wall figures of the LMS511 on shotcrete (the spread of
    /// the wall steps against the truth on `tunnel-1km`, see the README).
    pub fn with_odometry(odometry: OdometryNoise) -> Self {
        Self {
            odometry,
            wall_lateral_sd_m: 0.003,
            wall_heading_sd_rad: 0.0005,
            wall_disagreement_m: 0.02,
            wall_disagreement_rad: 0.005,
        }
    }
}

/// The offset across (metres, along the wall's normal) and heading change (radians) of
/// `b` relative to `a` that one wall seen by both implies, given the motion along `dx_m`.
fn wall_step(a: &Cubic, b: &Cubic, dx_m: f64) -> (f64, f64) {
    let x = dx_m as f32;
    let alpha_a = f64::from(a.slope(x)).atan();
    let alpha_b = f64::from(b.slope(0.0)).atan();
    // b's signed distance to the wall, as b sees it and as a sees b's origin.
    let e_b = f64::from(b.eval(0.0)) * alpha_b.cos();
    let dy = f64::from(a.eval(x)) - e_b / alpha_a.cos();
    (dy, alpha_a - alpha_b)
}

/// Whether the walls of two keyframes were seen, and what they gave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepSource {
    /// Across and heading from the walls, along from the odometry.
    Walls,
    /// The odometry alone (no wall in both scans, or the walls disagree).
    Odometry,
}

/// Half the stretch over which the odometry's scale is estimated, metres.
pub const SCALE_WINDOW_M: f64 = 25.0;

/// 1σ of the scale once estimated (dimensionless): centimetres of the localiser's error
/// over [`SCALE_WINDOW_M`] either side.
pub const ESTIMATED_SCALE_SD: f64 = 0.002;

/// Per keyframe, the localiser's distance over the odometry's within [`SCALE_WINDOW_M`]
/// of it (1 where the odometry did not move). With `None` for keyframes the localiser was
/// not tracking, those steps count as neither.
pub fn local_scales(kfs: &[Keyframe]) -> Vec<f64> {
    let n = kfs.len();
    // Prefix sums of both distances per step (a step counts where both ends tracked).
    let mut odo = vec![0.0; n];
    let mut est = vec![0.0; n];
    for k in 1..n {
        let o = kfs[k - 1].odometry.between(kfs[k].odometry);
        let e = kfs[k - 1].guess.between(kfs[k].guess);
        let used = kfs[k - 1].tracking && kfs[k].tracking;
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

/// The step factor from keyframe `a` (index `from`) to `b`, the odometry rescaled by
/// `scale` ([`local_scales`]; 1: the odometry as logged, its scale error counted as noise).
pub fn step(
    a: &Keyframe,
    b: &Keyframe,
    from: usize,
    scale: f64,
    noise: &StepNoise,
) -> (Relative, StepSource) {
    let logged = a.odometry.between(b.odometry);
    let odo = SimPose::new(logged.x_m * scale, logged.y_m * scale, logged.theta_rad);
    let inc = OdometryIncrement {
        dx_m: odo.x_m as f32,
        dy_m: odo.y_m as f32,
        dtheta_rad: odo.theta_rad as f32,
    };
    let c = noise.odometry.covariance(&inc);
    let scale_sd = if scale == 1.0 {
        f64::from(noise.odometry.scale_sd)
    } else {
        ESTIMATED_SCALE_SD
    };
    let scale_var = (scale_sd * odo.x_m).powi(2);
    // loc-core orders (x, y, θ); factrs (θ, x, y).
    let order = [2usize, 0, 1];
    let mut cov = Matrix3::from_fn(|r, q| f64::from(c[(order[r], order[q])]));
    cov[(1, 1)] += scale_var;
    let mut z = odo;
    let walls: Vec<(f64, f64)> = [(&a.left, &b.left), (&a.right, &b.right)]
        .into_iter()
        .filter_map(|(wa, wb)| Some(wall_step(wa.as_ref()?, wb.as_ref()?, odo.x_m)))
        .collect();
    let agree = match walls.as_slice() {
        [l, r] => {
            (l.0 - r.0).abs() <= noise.wall_disagreement_m
                && (l.1 - r.1).abs() <= noise.wall_disagreement_rad
        }
        [_] => true,
        _ => false,
    };
    let source = if agree {
        let n = walls.len() as f64;
        let (dy, dth) = walls
            .iter()
            .fold((0.0, 0.0), |s, w| (s.0 + w.0 / n, s.1 + w.1 / n));
        z = SimPose::new(odo.x_m, dy, dth);
        // Across and heading now come from the walls, independent of the odometry's.
        let along = cov[(1, 1)];
        cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(
            noise.wall_heading_sd_rad.powi(2),
            along,
            noise.wall_lateral_sd_m.powi(2),
        ));
        StepSource::Walls
    } else {
        StepSource::Odometry
    };
    (
        Relative {
            from,
            to: from + 1,
            z,
            covariance: cov,
        },
        source,
    )
}
