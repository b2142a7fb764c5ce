//! Prediction across time without odometry (a gap in the wheel log, a dropped CAN link): the
//! vehicle is assumed to keep the speed and yaw rate it last reported, and the uncertainty
//! grows with the time unobserved, so a pose after a gap is never as sure as before it.

use core::fmt;

use nalgebra::{Matrix3, Vector3};

use super::{Ekf, OdometryIncrement};
use crate::math;

/// How uncertain the motion is while no odometry arrives: a constant-velocity guess whose
/// speed and yaw rate are each off by up to these 1σ. Over `t` seconds unobserved, the
/// forward and sideways 1σ grow by `speed_sd_mps · t` and the heading 1σ by
/// `yaw_rate_sd_radps · t` (vehicle frame at the start of the gap).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CoastNoise {
    /// 1σ of the speed over the gap, m/s (a loader changes speed by ~0.5 m/s in a second).
    pub speed_sd_mps: f32,
    /// 1σ of the yaw rate over the gap, rad/s.
    pub yaw_rate_sd_radps: f32,
}

impl CoastNoise {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    /// 0.5 m/s and 0.05 rad/s.
    pub const DEFAULT: Self = Self {
        speed_sd_mps: 0.5,
        yaw_rate_sd_radps: 0.05,
    };
}

impl Default for CoastNoise {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why a coast was not applied (the state is left unchanged).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CoastRejection {
    /// The time, speed or yaw rate is NaN or infinite: check the clock and the last reading.
    NonFinite,
    /// The unobserved time is negative: the clock went back.
    NegativeTime,
}

impl fmt::Display for CoastRejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CoastRejection::NonFinite => write!(
                f,
                "coast time, speed or yaw rate is not finite: check the clock and the last odometry reading"
            ),
            CoastRejection::NegativeTime => {
                write!(f, "coast time is negative: the clock went back")
            }
        }
    }
}

impl CoastNoise {
    /// The motion and its covariance (vehicle frame) over `unobserved_s` at `v_mps`,
    /// `omega_radps`: the exact arc, and the variances of the speed and yaw-rate errors
    /// integrated over the time.
    pub fn motion(
        &self,
        unobserved_s: f32,
        v_mps: f32,
        omega_radps: f32,
    ) -> Result<(OdometryIncrement, Matrix3<f32>), CoastRejection> {
        if !(unobserved_s.is_finite() && v_mps.is_finite() && omega_radps.is_finite()) {
            return Err(CoastRejection::NonFinite);
        }
        if unobserved_s < 0.0 {
            return Err(CoastRejection::NegativeTime);
        }
        let dtheta = omega_radps * unobserved_s;
        let distance = v_mps * unobserved_s;
        // Arc of length `distance` turning by `dtheta`: chord along the mean heading.
        let half = 0.5 * dtheta;
        let chord = if math::abs(half) < 1e-6 {
            distance
        } else {
            distance * math::sin(half) / half
        };
        let (s, c) = math::sin_cos(half);
        let increment = OdometryIncrement {
            dx_m: chord * c,
            dy_m: chord * s,
            dtheta_rad: dtheta,
        };
        let translation = self.speed_sd_mps * unobserved_s;
        let heading = self.yaw_rate_sd_radps * unobserved_s;
        let q = Matrix3::from_diagonal(&Vector3::new(
            translation * translation,
            translation * translation,
            heading * heading,
        ));
        Ok((increment, q))
    }
}

impl Ekf {
    /// Predicts across `unobserved_s` seconds without odometry at the last known speed
    /// `v_mps` and yaw rate `omega_radps`, with `noise`'s growing uncertainty. There is no
    /// step limit: a long gap gives a large covariance (capped at
    /// [`super::MAX_VARIANCE`]), which is what the pose then honestly is.
    pub fn coast(
        &mut self,
        unobserved_s: f32,
        v_mps: f32,
        omega_radps: f32,
        noise: &CoastNoise,
    ) -> Result<(), CoastRejection> {
        let (increment, q) = noise.motion(unobserved_s, v_mps, omega_radps)?;
        if !q.iter().all(|v| v.is_finite()) {
            return Err(CoastRejection::NonFinite);
        }
        // Coasting moves at the last speed, not by odometry: no scale applies.
        self.apply_motion(&increment, &q, None);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::OdometryNoise;
    use crate::geometry::Pose2;

    fn ekf() -> Ekf {
        let p = Matrix3::from_diagonal(&Vector3::new(25e-6, 25e-6, 1e-6));
        Ekf::new(Pose2::new(0.0, 0.0, 0.0), p).unwrap()
    }

    #[test]
    fn uncertainty_grows_with_the_time_unobserved() {
        let noise = CoastNoise::default();
        let mut sds = [0.0f32; 3];
        for (k, t) in [0.1f32, 1.0, 5.0].iter().enumerate() {
            let mut e = ekf();
            e.coast(*t, 2.0, 0.0, &noise).unwrap();
            let sd = e.covariance()[(0, 0)].sqrt();
            // 5 mm before, plus speed_sd × t.
            let expected = (25e-6f32 + (0.5 * t) * (0.5 * t)).sqrt();
            assert!(
                (sd - expected).abs() < 1e-4 * expected.max(1.0),
                "{t}: {sd}"
            );
            sds[k] = sd;
            // Constant velocity: 2 m/s for t.
            assert!((e.pose().x_m - 2.0 * t).abs() < 1e-4, "{t}");
        }
        assert!(sds[0] < sds[1] && sds[1] < sds[2]);
        // A 1 s gap leaves nothing of the 5 mm: half a metre.
        assert!(sds[1] > 0.45);
    }

    #[test]
    fn the_arc_matches_odometry_integration() {
        // A turn of 0.5 rad/s at 1 m/s for 2 s: the same arc as 200 odometry increments.
        let noise = CoastNoise::default();
        let mut coasted = ekf();
        coasted.coast(2.0, 1.0, 0.5, &noise).unwrap();
        let mut driven = ekf();
        let (inc, _) = noise.motion(0.01, 1.0, 0.5).unwrap();
        for _ in 0..200 {
            driven.predict(&inc, &OdometryNoise::default()).unwrap();
        }
        let (a, b) = (coasted.pose(), driven.pose());
        assert!((a.x_m - b.x_m).abs() < 1e-4 && (a.y_m - b.y_m).abs() < 1e-4);
        assert!((a.theta_rad - b.theta_rad).abs() < 1e-5);
    }

    #[test]
    fn bad_times_are_refused_and_change_nothing() {
        let noise = CoastNoise::default();
        let mut e = ekf();
        let before = e;
        assert_eq!(
            e.coast(f32::NAN, 1.0, 0.0, &noise),
            Err(CoastRejection::NonFinite)
        );
        assert_eq!(
            e.coast(1.0, f32::INFINITY, 0.0, &noise),
            Err(CoastRejection::NonFinite)
        );
        assert_eq!(
            e.coast(-0.5, 1.0, 0.0, &noise),
            Err(CoastRejection::NegativeTime)
        );
        assert_eq!(e, before);
        // A very long gap saturates the covariance instead of overflowing it.
        e.coast(1.0e9, 1.0, 0.0, &noise).unwrap();
        assert!(e.covariance().iter().all(|v| v.is_finite()));
    }
}
