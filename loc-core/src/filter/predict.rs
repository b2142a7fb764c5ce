//! EKF prediction from odometry increments.

use core::fmt;

use nalgebra::Matrix3;

use super::Ekf;
use crate::geometry::Pose2;
use crate::math;

/// The motion since the last prediction, in the vehicle frame at the previous pose (x
/// forward, y left): the previous-to-current vehicle pose, as wheel odometry reports it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometryIncrement {
    /// Forward motion, metres.
    pub dx_m: f32,
    /// Leftward motion, metres (≈ 0 for a vehicle without side slip).
    pub dy_m: f32,
    /// Heading change, radians (counter-clockwise positive).
    pub dtheta_rad: f32,
}

impl OdometryIncrement {
    /// The increment as a relative pose.
    pub fn as_pose(&self) -> Pose2 {
        Pose2::new(self.dx_m, self.dy_m, self.dtheta_rad)
    }

    /// The increment between two odometry poses (`previous⁻¹ ∘ current`).
    pub fn between(previous: &Pose2, current: &Pose2) -> Self {
        let d = previous.between(current);
        Self {
            dx_m: d.x_m,
            dy_m: d.y_m,
            dtheta_rad: d.theta_rad,
        }
    }

    /// Distance travelled, metres.
    pub fn distance_m(&self) -> f32 {
        math::hypot(self.dx_m, self.dy_m)
    }
}

/// Odometry noise as a random walk in the distance travelled: the variance of a stretch of
/// odometry grows with its length, whatever the odometry rate. (A model proportional to each
/// increment's own length would shrink with the rate — at 100 Hz a tenth of its 10 Hz
/// variance over the same metre — and make the filter overconfident; `host-sim` measured
/// that.) Variances of one increment of length `d`, turn `dθ`, vehicle frame:
/// - forward: `f² · L · d` (so `f · L` of 1σ after driving `L`),
/// - sideways: `(a · f)² · L · d`,
/// - heading: `h² · L · d + (k · dθ)²`,
///
/// each plus a floor (`min_translation_var_m2`, `min_heading_var_rad2`). A skid-steer loader
/// drifts 1–5 % of the distance travelled: the default `f = 3 %` over `L = 10 m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryNoise {
    /// `f`: forward 1σ as a fraction of `drift_length_m` driven (dimensionless).
    pub drift_fraction: f32,
    /// `L`: the distance over which `drift_fraction` holds, metres.
    pub drift_length_m: f32,
    /// `a`: sideways 1σ as a fraction of the forward one (skid-steer side slip).
    pub across_to_along: f32,
    /// `h`: heading 1σ per metre of `drift_length_m`, rad/m.
    pub heading_drift_rad_per_m: f32,
    /// `k`: heading 1σ per radian turned.
    pub heading_fraction: f32,
    /// Variance added to each translation component of every increment, m².
    pub min_translation_var_m2: f32,
    /// Variance added to the heading of every increment, rad².
    pub min_heading_var_rad2: f32,
    /// Increments longer than this are rejected, metres (a scan period at 40 km/h is 0.5 m).
    pub max_step_m: f32,
    /// Increments turning more than this are rejected, radians.
    pub max_turn_rad: f32,
}

impl Default for OdometryNoise {
    /// 3 % over 10 m forward, a third of that sideways, 0.005 rad/m and 5 % of each turn in
    /// heading.
    fn default() -> Self {
        Self {
            drift_fraction: 0.03,
            drift_length_m: 10.0,
            across_to_along: 1.0 / 3.0,
            heading_drift_rad_per_m: 0.005,
            heading_fraction: 0.05,
            min_translation_var_m2: 1.0e-10,
            min_heading_var_rad2: 1.0e-12,
            max_step_m: 5.0,
            max_turn_rad: 1.0,
        }
    }
}

impl OdometryNoise {
    /// The covariance of `increment` under this model, vehicle frame.
    pub fn covariance(&self, increment: &OdometryIncrement) -> Matrix3<f32> {
        let walk_m = self.drift_length_m * increment.distance_m();
        let along = self.drift_fraction * self.drift_fraction * walk_m;
        let across = along * self.across_to_along * self.across_to_along;
        let turn = self.heading_fraction * increment.dtheta_rad;
        let heading =
            self.heading_drift_rad_per_m * self.heading_drift_rad_per_m * walk_m + turn * turn;
        Matrix3::from_diagonal(&nalgebra::Vector3::new(
            along + self.min_translation_var_m2,
            across + self.min_translation_var_m2,
            heading + self.min_heading_var_rad2,
        ))
    }
}

/// Why an odometry increment was not applied (the state is left unchanged).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum OdometryRejection {
    /// A component (or its covariance) is NaN or infinite: check the odometry source.
    NonFinite,
    /// The step is longer than `max_step_m` or turns more than `max_turn_rad`: a glitch or a
    /// missed reset of the odometry counter; re-initialise if the vehicle really moved.
    StepTooLarge {
        /// Distance of the increment, metres.
        distance_m: f32,
        /// Turn of the increment, radians.
        turn_rad: f32,
    },
    /// The increment's covariance is not symmetric positive semi-definite.
    InvalidCovariance,
}

impl fmt::Display for OdometryRejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OdometryRejection::NonFinite => {
                write!(f, "odometry increment is not finite: check the odometry source")
            }
            OdometryRejection::StepTooLarge {
                distance_m,
                turn_rad,
            } => write!(
                f,
                "odometry step of {distance_m} m / {turn_rad} rad exceeds the limits: glitch or counter reset"
            ),
            OdometryRejection::InvalidCovariance => write!(
                f,
                "odometry covariance is not symmetric positive semi-definite"
            ),
        }
    }
}

impl Ekf {
    /// Predicts with an odometry increment whose covariance comes from `noise`.
    pub fn predict(
        &mut self,
        increment: &OdometryIncrement,
        noise: &OdometryNoise,
    ) -> Result<(), OdometryRejection> {
        check_increment(increment, noise)?;
        self.predict_with_covariance(increment, &noise.covariance(increment), noise)
    }

    /// Predicts with an odometry increment and its own covariance `q` (vehicle frame,
    /// `(dx_m, dy_m, dtheta_rad)`); `limits` gives the step limits.
    pub fn predict_with_covariance(
        &mut self,
        increment: &OdometryIncrement,
        q: &Matrix3<f32>,
        limits: &OdometryNoise,
    ) -> Result<(), OdometryRejection> {
        check_increment(increment, limits)?;
        if !q.iter().all(|v| v.is_finite()) {
            return Err(OdometryRejection::NonFinite);
        }
        let q = 0.5 * (q + q.transpose());
        if q.diagonal().iter().any(|v| *v < 0.0) {
            return Err(OdometryRejection::InvalidCovariance);
        }
        self.apply_motion(increment, &q);
        Ok(())
    }

    /// Moves the pose by `increment` (vehicle frame) and adds its covariance `q` (checked
    /// finite, symmetric, non-negative diagonal by the caller).
    pub(super) fn apply_motion(&mut self, increment: &OdometryIncrement, q: &Matrix3<f32>) {
        let (s, c) = math::sin_cos(self.pose.theta_rad);
        let (dx, dy) = (increment.dx_m, increment.dy_m);
        // x' = x + R(θ)·(dx, dy), θ' = θ + dθ.
        let f = Matrix3::new(
            1.0,
            0.0,
            -s * dx - c * dy,
            0.0,
            1.0,
            c * dx - s * dy,
            0.0,
            0.0,
            1.0,
        );
        let g = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        self.pose = Pose2::new(
            self.pose.x_m + c * dx - s * dy,
            self.pose.y_m + s * dx + c * dy,
            self.pose.theta_rad + increment.dtheta_rad,
        );
        self.covariance = f * self.covariance * f.transpose() + g * q * g.transpose();
        self.condition();
    }
}

fn check_increment(
    increment: &OdometryIncrement,
    limits: &OdometryNoise,
) -> Result<(), OdometryRejection> {
    if !(increment.dx_m.is_finite()
        && increment.dy_m.is_finite()
        && increment.dtheta_rad.is_finite())
    {
        return Err(OdometryRejection::NonFinite);
    }
    let distance_m = increment.distance_m();
    let turn_rad = math::abs(increment.dtheta_rad);
    if distance_m > limits.max_step_m || turn_rad > limits.max_turn_rad {
        return Err(OdometryRejection::StepTooLarge {
            distance_m,
            turn_rad,
        });
    }
    Ok(())
}
