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
use crate::vehicle::odometry::GyroSpec;
use crate::vehicle::SimPose;
use crate::world::centerline::wrap_pi;

/// Half the stretch over which the odometry's scale is estimated, metres.
pub const SCALE_WINDOW_M: f64 = 25.0;

/// 1σ of the scale once estimated (dimensionless): centimetres of the localiser's error
/// over [`SCALE_WINDOW_M`] either side.
pub const ESTIMATED_SCALE_SD: f64 = 0.002;

/// Whether the step into keyframe `k` can calibrate the odometry against the localiser:
/// it tracked at both ends, and the step does not cross a gap in the odometry
/// (`gap_steps[k - 1]`).
fn calibrates(kfs: &[Keyframe], gap_steps: &[bool], k: usize) -> bool {
    kfs[k - 1].tracking && kfs[k].tracking && !gap_steps.get(k - 1).copied().unwrap_or(false)
}

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
        let used = calibrates(kfs, gap_steps, k);
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

/// The heading a yaw-rate gyro gives between keyframes (the vehicle's odometry heading
/// when it carries one, `odometry.gyro` of the recording's scenario): its angle random walk
/// over the step's time rather than the tracks' slip per metre, less the bias the drive
/// shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroHeading {
    /// The rate bias estimated from the drive, rad/s (subtracted from each step's turn).
    pub bias_radps: f64,
    /// 1σ of that estimate, rad/s.
    pub bias_sd_radps: f64,
    /// Angle random walk, rad/√s (the gyro's specification).
    pub noise_rad_per_sqrt_s: f64,
}

impl GyroHeading {
    /// The bias as the slope of the odometry's heading against the localiser's over the
    /// drive (least squares over the steps where both ends tracked, away from odometry
    /// gaps: the localiser's heading error is bounded by the landmarks, the gyro's bias
    /// grows without bound), with `spec`'s angle random walk. `None` with fewer than 10
    /// such steps.
    pub fn estimate(kfs: &[Keyframe], gap_steps: &[bool], spec: &GyroSpec) -> Option<Self> {
        // Cumulative time and heading difference over the used steps.
        let (mut t, mut r) = (0.0, 0.0);
        let mut samples = vec![(0.0, 0.0)];
        for k in 1..kfs.len() {
            if !calibrates(kfs, gap_steps, k) {
                continue;
            }
            let odo = kfs[k - 1].odometry.between(kfs[k].odometry).theta_rad;
            let est = kfs[k - 1].guess.between(kfs[k].guess).theta_rad;
            t += kfs[k].t_s - kfs[k - 1].t_s;
            r += wrap_pi(odo - est);
            samples.push((t, r));
        }
        if samples.len() < 11 {
            return None;
        }
        let n = samples.len() as f64;
        let (mt, mr) = samples
            .iter()
            .fold((0.0, 0.0), |(a, b), (t, r)| (a + t / n, b + r / n));
        let stt: f64 = samples.iter().map(|(t, _)| (t - mt).powi(2)).sum();
        let str_: f64 = samples.iter().map(|(t, r)| (t - mt) * (r - mr)).sum();
        let bias = str_ / stt;
        let resid: f64 = samples
            .iter()
            .map(|(t, r)| (r - mr - bias * (t - mt)).powi(2))
            .sum::<f64>()
            / (n - 2.0);
        // Consecutive residuals are correlated (the localiser's heading error persists over
        // metres): count one independent sample per 10 s of drive, not per keyframe.
        let independent = (t / 10.0).max(2.0);
        // The gyro's own random walk tilts the fitted line too (the slope of a random walk
        // over T seconds scatters by √(6/5)·ARW/√T).
        let walk = 1.2 * spec.noise_rad_per_sqrt_s.powi(2) / t.max(1.0);
        let bias_sd = (resid / stt * n / independent + walk).sqrt();
        Some(Self {
            bias_radps: bias,
            bias_sd_radps: bias_sd,
            noise_rad_per_sqrt_s: spec.noise_rad_per_sqrt_s,
        })
    }

    /// The step's turn less the bias over `dt_s`, and its variance (rad²).
    fn turn(&self, logged_rad: f64, dt_s: f64) -> (f64, f64) {
        let dt = dt_s.max(0.0);
        (
            logged_rad - self.bias_radps * dt,
            self.noise_rad_per_sqrt_s.powi(2) * dt + (self.bias_sd_radps * dt).powi(2),
        )
    }
}

/// The odometry step from keyframe `a` (index `from`) to `b`, rescaled by `scale`
/// ([`local_scales`]; 1: the odometry as logged, its scale error counted as noise), with
/// `odometry`'s covariance; its heading the gyro's when `gyro` is given.
pub fn step(
    a: &Keyframe,
    b: &Keyframe,
    from: usize,
    scale: f64,
    odometry: &OdometryNoise,
    gyro: Option<&GyroHeading>,
) -> Relative {
    let logged = a.odometry.between(b.odometry);
    let gyro_turn = gyro.map(|g| g.turn(logged.theta_rad, b.t_s - a.t_s));
    let theta_rad = gyro_turn.map_or(logged.theta_rad, |(turn, _)| turn);
    let z = SimPose::new(logged.x_m * scale, logged.y_m * scale, theta_rad);
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
    if let Some((_, var)) = gyro_turn {
        covariance[(0, 0)] = var + f64::from(odometry.min_heading_var_rad2);
    }
    Relative {
        from,
        to: from + 1,
        z,
        covariance,
    }
}

/// Per step (keyframe `k` → `k + 1`), whether it crosses a gap `(from_s, to_s)` in the
/// odometry log.
pub fn gap_steps(kfs: &[Keyframe], gaps: &[(f64, f64)]) -> Vec<bool> {
    kfs.windows(2)
        .map(|w| gaps.iter().any(|g| g.1 > w[0].t_s && g.0 < w[1].t_s))
        .collect()
}

/// Every keyframe's step to the next: [`step`] with its `scales[k]`, or [`gap_step`] across
/// a gap in the odometry (`gap_steps[k]`).
pub fn odometry_steps(
    kfs: &[Keyframe],
    gap_steps: &[bool],
    scales: &[f64],
    odometry: &OdometryNoise,
    gyro: Option<&GyroHeading>,
) -> Vec<Relative> {
    (0..kfs.len().saturating_sub(1))
        .map(|k| {
            if gap_steps[k] {
                gap_step(&kfs[k], &kfs[k + 1], k)
            } else {
                step(&kfs[k], &kfs[k + 1], k, scales[k], odometry, gyro)
            }
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::rng::Pcg32;

    /// Keyframes of a 300 s drive at 3 m/s through a gentle S: the localiser's heading is
    /// the truth with 0.2 mrad of noise, the gyro's the truth plus `bias` rad/s and its
    /// angle random walk.
    fn drive(bias_radps: f64, spec: &GyroSpec) -> Vec<Keyframe> {
        let mut rng = Pcg32::new(11, 1);
        let (mut truth, mut odometry) = (SimPose::default(), SimPose::default());
        let dt = 0.25 / 3.0;
        (0..3600)
            .map(|k| {
                let t_s = k as f64 * dt;
                if k > 0 {
                    let turn = 0.002 * (t_s / 30.0).sin() * dt;
                    truth = truth.compose(SimPose::new(0.25, 0.0, turn));
                    let noise = spec.noise_rad_per_sqrt_s * dt.sqrt() * f64::from(rng.gaussian());
                    odometry =
                        odometry.compose(SimPose::new(0.25, 0.0, turn + bias_radps * dt + noise));
                }
                let guess = SimPose::new(
                    truth.x_m,
                    truth.y_m,
                    truth.theta_rad + 2e-4 * f64::from(rng.gaussian()),
                );
                Keyframe {
                    scan_index: k,
                    t_s,
                    guess,
                    tracking: true,
                    odometry,
                    points: Vec::new(),
                    labels: Vec::new(),
                }
            })
            .collect()
    }

    #[test]
    fn the_gyro_bias_is_estimated_from_the_drive_and_taken_off_each_step() {
        let spec = GyroSpec::default();
        let kfs = drive(2e-5, &spec);
        let gaps = vec![false; kfs.len() - 1];
        let g = GyroHeading::estimate(&kfs, &gaps, &spec).expect("enough tracked steps");
        assert!(
            (g.bias_radps - 2e-5).abs() < 3.0 * g.bias_sd_radps && g.bias_sd_radps < 5e-6,
            "bias {} ± {} rad/s, truth 2e-5",
            g.bias_radps,
            g.bias_sd_radps
        );
        let noise = OdometryNoise::DEFAULT;
        let with = step(&kfs[100], &kfs[101], 100, 1.0, &noise, Some(&g));
        let without = step(&kfs[100], &kfs[101], 100, 1.0, &noise, None);
        let dt = kfs[101].t_s - kfs[100].t_s;
        assert!((without.z.theta_rad - with.z.theta_rad - g.bias_radps * dt).abs() < 1e-12);
        // The gyro's angle random walk over 83 ms, not the tracks' 16 mrad/√m over 0.25 m.
        assert!(
            with.covariance[(0, 0)] < 1e-9,
            "{}",
            with.covariance[(0, 0)]
        );
        assert!(
            without.covariance[(0, 0)] > 5e-5,
            "{}",
            without.covariance[(0, 0)]
        );
    }

    #[test]
    fn no_gyro_bias_without_tracked_steps() {
        let spec = GyroSpec::default();
        let mut kfs = drive(2e-5, &spec);
        for kf in &mut kfs {
            kf.tracking = false;
        }
        let gaps = vec![false; kfs.len() - 1];
        assert!(GyroHeading::estimate(&kfs, &gaps, &spec).is_none());
    }
}
