//! EKF prediction from odometry increments.

use core::fmt;

use nalgebra::{Matrix3, Matrix4};

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

/// Odometry noise: the odometry's scale error as a state of the filter (see the module
/// docs of [`super`]) and what is random as a random walk in the distance travelled.
///
/// The random part's variance of a stretch of odometry grows with its length, whatever the
/// odometry rate. (A model proportional to each increment's own length would shrink with
/// the rate — at 100 Hz a tenth of its 10 Hz variance over the same metre — and make the
/// filter overconfident; `host-sim` measured that.) Variances of one increment of length
/// `d`, turn `dθ`, vehicle frame:
/// - forward: `f² · L · d` (so `f · L` of 1σ after driving `L`),
/// - sideways: `(a · f)² · L · d`,
/// - heading: `h² · L · d + (k · dθ)²`,
///
/// each plus a floor (`min_translation_var_m2`, `min_heading_var_rad2`); and the scale's
/// variance grows by `scale_drift_sd² · d / scale_drift_length_m`. A skid-steer loader's
/// odometry is 1–3 % off in scale (`scale_sd` 3 %, drifting 0.5 % per 10 m as load and
/// ground change); the rest, 1 % over 1 m forward and 16 mrad over 1 m in heading, covers
/// slip that varies within metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OdometryNoise {
    /// `f`: forward 1σ as a fraction of `drift_length_m` driven (dimensionless).
    pub drift_fraction: f32,
    /// `L`: the distance over which `drift_fraction` holds, metres.
    pub drift_length_m: f32,
    /// `a`: sideways 1σ as a multiple of the forward one (skid-steer side slip; see the
    /// default for why it is 3).
    pub across_to_along: f32,
    /// `h`: heading 1σ per metre of `drift_length_m`, rad/m.
    pub heading_drift_rad_per_m: f32,
    /// `k`: heading 1σ per radian turned.
    pub heading_fraction: f32,
    /// 1σ of the odometry's scale error before any scan has calibrated it (dimensionless;
    /// 0: the odometry's scale is exact).
    pub scale_sd: f32,
    /// 1σ change of the scale error over `scale_drift_length_m` driven (dimensionless).
    pub scale_drift_sd: f32,
    /// The distance over which `scale_drift_sd` holds, metres.
    pub scale_drift_length_m: f32,
    /// Variance added to each translation component of every increment, m².
    pub min_translation_var_m2: f32,
    /// Variance added to the heading of every increment, rad².
    pub min_heading_var_rad2: f32,
    /// Increments longer than this are rejected, metres (a scan period at 40 km/h is 0.5 m).
    pub max_step_m: f32,
    /// Increments turning more than this are rejected, radians.
    pub max_turn_rad: f32,
}

impl OdometryNoise {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    /// Scale 3 %, drifting 0.5 % over 10 m; random 1 % over 1 m forward, three times that
    /// sideways, 16 mrad over 1 m and 5 % of each turn in heading (the heading noise of the
    /// earlier model: with less, the bare `tunnel-1km`'s first 300 m went from 8.1 to
    /// 10.6 mrad heading RMS).
    ///
    /// The sideways noise is more than side slip: it also keeps the filter from averaging
    /// successive matches sideways as if their errors were independent. They are not —
    /// consecutive scans see the same metres of rough wall — and with a third of the
    /// forward noise (side slip alone) the filter claimed 2.5 mm across where it was off by
    /// 3 cm: on the S-bend 14 % of its tracked poses lay beyond 3σ (1.6–2.2 % with 3×,
    /// which costs 0.2–0.4 mm of the across-tunnel RMS that averaging would win).
    pub const DEFAULT: Self = Self {
        drift_fraction: 0.01,
        drift_length_m: 1.0,
        across_to_along: 3.0,
        heading_drift_rad_per_m: 0.016,
        heading_fraction: 0.05,
        scale_sd: 0.03,
        scale_drift_sd: 0.005,
        scale_drift_length_m: 10.0,
        min_translation_var_m2: 1.0e-10,
        min_heading_var_rad2: 1.0e-12,
        max_step_m: 5.0,
        max_turn_rad: 1.0,
    };
}

impl Default for OdometryNoise {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl OdometryNoise {
    /// The covariance of `increment`'s random part under this model, vehicle frame.
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

    /// How much the scale error's variance grows over `increment` (dimensionless²; 0 for a
    /// model that is not finite and positive).
    pub fn scale_variance(&self, increment: &OdometryIncrement) -> f32 {
        let v = self.scale_drift_sd * self.scale_drift_sd * increment.distance_m()
            / self.scale_drift_length_m;
        if v.is_finite() && v > 0.0 {
            v
        } else {
            0.0
        }
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
        // The increment is checked (first) by `predict_with_covariance`.
        self.predict_with_covariance(increment, &noise.covariance(increment), noise)
    }

    /// Predicts with an odometry increment and its own covariance `q` (vehicle frame,
    /// `(dx_m, dy_m, dtheta_rad)`, the random part); `noise` gives the step limits and the
    /// scale's drift.
    pub fn predict_with_covariance(
        &mut self,
        increment: &OdometryIncrement,
        q: &Matrix3<f32>,
        noise: &OdometryNoise,
    ) -> Result<(), OdometryRejection> {
        let q = checked_motion(increment, q, noise)?;
        self.apply_motion(increment, &q, Some(noise.scale_variance(increment)));
        Ok(())
    }

    /// Predicts with motion that is not the odometry's (a constant-velocity guess, a
    /// model), so not scaled by the odometry's scale error: `increment` (vehicle frame)
    /// with covariance `q`; `limits` gives the step limits.
    pub fn predict_motion(
        &mut self,
        increment: &OdometryIncrement,
        q: &Matrix3<f32>,
        limits: &OdometryNoise,
    ) -> Result<(), OdometryRejection> {
        let q = checked_motion(increment, q, limits)?;
        self.apply_motion(increment, &q, None);
        Ok(())
    }

    /// Moves the pose by `increment` (vehicle frame) and adds its covariance `q` (checked
    /// finite, symmetric, non-negative diagonal by the caller). With `odometry_scale_var`
    /// the increment is odometry's: its translation is scaled by `1 + s` and the scale's
    /// variance grows by the value given.
    pub(super) fn apply_motion(
        &mut self,
        increment: &OdometryIncrement,
        q: &Matrix3<f32>,
        odometry_scale_var: Option<f32>,
    ) {
        let (s, c) = math::sin_cos(self.pose.theta_rad);
        let scaled = odometry_scale_var.is_some();
        let m = if scaled { 1.0 + self.scale } else { 1.0 };
        let (dx, dy) = (m * increment.dx_m, m * increment.dy_m);
        // The translation in the world, at the odometry's own scale (∂/∂s).
        let (tx, ty) = (
            c * increment.dx_m - s * increment.dy_m,
            s * increment.dx_m + c * increment.dy_m,
        );
        let (fx, fy) = if scaled { (tx, ty) } else { (0.0, 0.0) };
        // x' = x + (1 + s)·R(θ)·(dx, dy), θ' = θ + dθ, s' = s.
        #[rustfmt::skip]
        let f = Matrix4::new(
            1.0, 0.0, -s * dx - c * dy, fx,
            0.0, 1.0, c * dx - s * dy, fy,
            0.0, 0.0, 1.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
        );
        let g = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let mut q4 = Matrix4::zeros();
        q4.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(g * q * g.transpose()));
        q4.m44 = odometry_scale_var.unwrap_or(0.0);
        self.pose = Pose2::new(
            self.pose.x_m + c * dx - s * dy,
            self.pose.y_m + s * dx + c * dy,
            self.pose.theta_rad + increment.dtheta_rad,
        );
        self.covariance = f * self.covariance * f.transpose() + q4;
        self.condition();
    }
}

/// Checks an increment against the limits and its covariance; returns the covariance
/// symmetrised.
fn checked_motion(
    increment: &OdometryIncrement,
    q: &Matrix3<f32>,
    limits: &OdometryNoise,
) -> Result<Matrix3<f32>, OdometryRejection> {
    check_increment(increment, limits)?;
    if !q.iter().all(|v| v.is_finite()) {
        return Err(OdometryRejection::NonFinite);
    }
    let q = 0.5 * (q + q.transpose());
    if q.diagonal().iter().any(|v| *v < 0.0) {
        return Err(OdometryRejection::InvalidCovariance);
    }
    Ok(q)
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
