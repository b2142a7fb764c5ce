//! The pose filter (paper §4.3): an extended Kalman filter over the vehicle pose
//! `(x_m, y_m, theta_rad)` in the world frame and the odometry's scale error.
//!
//! - [`Ekf::predict`]: odometry increments (vehicle frame) with a covariance given or from an
//!   [`OdometryNoise`] model, their translation scaled by the estimated `1 + s`.
//! - [`Ekf::predict_motion`]: motion from elsewhere (a constant-velocity guess), unscaled.
//! - [`Ekf::coast`]: time without odometry, at the last speed with a [`CoastNoise`]
//!   uncertainty growing with the time.
//! - [`Ekf::update`]: a scan-match pose with its point-to-line information. Only the
//!   directions the scan observes are updated: the information is split into eigen-directions
//!   (θ scaled by a length, see [`crate::matching::observable_subspace`]) and those below the
//!   threshold are dropped, i.e. the update is projected onto the observable subspace. In a
//!   smooth tunnel with no landmark in view the along-tunnel direction is unobserved, so the
//!   estimate along it follows odometry alone and its variance keeps growing like odometry's
//!   (a Kalman update never increases any variance: the filter is never worse than odometry).
//! - Chi-square gating of the projected innovation (dof = observed directions); Joseph-form
//!   covariance update; covariance kept symmetric, positive definite and bounded.
//!
//! ## Why the odometry's scale is a state
//! Wheel and track odometry is wrong mostly by a scale: track wear, load and slip make the
//! distance it reports 1–3 % off, the same way for many metres. Per-increment noise cannot
//! model that: the errors of successive increments add up linearly, not in quadrature, so a
//! noise model honest about a 2 % scale error over 10 m must claim centimetres over one
//! scan's few centimetres of travel, and the filter then cannot average scans over time and
//! opens its gate to wrong matches. With `s` in the state (true translation = `(1 + s)` ×
//! odometry's) the landmarks calibrate the odometry as the vehicle drives, and the
//! per-increment noise is left with what is random. The public covariance is the pose's
//! 3×3 block; [`Ekf::scale`] and [`Ekf::scale_sd`] give the scale's estimate.

mod coast;
mod predict;
mod update;

pub use coast::{CoastNoise, CoastRejection};
pub use predict::{OdometryIncrement, OdometryNoise, OdometryRejection};
pub use update::{
    shared_error_scans, GateProbability, UpdateConfig, UpdateRejection, UpdateReport,
};

use core::fmt;

use nalgebra::{Matrix3, Matrix4, Vector4};

use crate::geometry::Pose2;
use crate::math;

/// Largest variance the filter keeps, m² (and rad² for heading): variances are clamped here
/// so a long run without scans stays finite.
pub const MAX_VARIANCE: f32 = 1.0e6;

/// Smallest variance the filter keeps on the diagonal, m² / rad² (keeps P positive definite
/// in f32).
pub const MIN_VARIANCE: f32 = 1.0e-10;

/// The EKF state: the vehicle pose in the world, the odometry's scale error and their
/// covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ekf {
    pose: Pose2,
    /// `s`: the true translation is `(1 + s)` × the odometry's (dimensionless).
    scale: f32,
    /// Covariance of `(x_m, y_m, theta_rad, s)`.
    covariance: Matrix4<f32>,
}

/// Largest odometry scale error the filter estimates (dimensionless): odometry more than
/// 20 % off is broken, not miscalibrated.
pub const MAX_SCALE_ERROR: f32 = 0.2;

/// Why a filter could not be created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FilterInitError {
    /// The pose has a NaN or infinite component: give a finite initial pose.
    NonFinitePose,
    /// The covariance is not finite, symmetric and positive definite: give e.g. a diagonal
    /// of positive variances.
    InvalidCovariance,
}

impl fmt::Display for FilterInitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FilterInitError::NonFinitePose => write!(f, "initial pose is not finite"),
            FilterInitError::InvalidCovariance => write!(
                f,
                "initial covariance must be finite, symmetric and positive definite"
            ),
        }
    }
}

impl Ekf {
    /// A filter at `pose` (vehicle in world) with covariance `covariance` of
    /// `(x_m, y_m, theta_rad)`, the odometry's scale taken as exact (it is learnt only as
    /// far as an [`OdometryNoise`]'s scale drift lets it wander; see [`Ekf::with_scale`]).
    pub fn new(pose: Pose2, covariance: Matrix3<f32>) -> Result<Self, FilterInitError> {
        Self::with_scale(pose, covariance, 0.0)
    }

    /// A filter at `pose` with covariance `covariance` of `(x_m, y_m, theta_rad)` and an
    /// odometry scale error of zero ± `scale_sd` (dimensionless, e.g. 0.03 for 3 %; 0: exact).
    pub fn with_scale(
        pose: Pose2,
        covariance: Matrix3<f32>,
        scale_sd: f32,
    ) -> Result<Self, FilterInitError> {
        if !pose.is_finite() {
            return Err(FilterInitError::NonFinitePose);
        }
        let sym_err = (covariance - covariance.transpose()).abs().max();
        if !covariance.iter().all(|v| v.is_finite())
            || sym_err > 1e-6 * math::max(covariance.abs().max(), 1.0)
            || covariance.cholesky().is_none()
            || !(scale_sd.is_finite() && scale_sd >= 0.0)
        {
            return Err(FilterInitError::InvalidCovariance);
        }
        let mut full = Matrix4::zeros();
        full.fixed_view_mut::<3, 3>(0, 0).copy_from(&covariance);
        full.m44 = scale_sd * scale_sd;
        let mut ekf = Self {
            pose,
            scale: 0.0,
            covariance: full,
        };
        ekf.condition();
        Ok(ekf)
    }

    /// The pose estimate (vehicle frame in the world frame).
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// The covariance of `(x_m, y_m, theta_rad)`: m², m·rad, rad².
    pub fn covariance(&self) -> Matrix3<f32> {
        self.covariance.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// The estimated odometry scale error `s` (the true translation is `(1 + s)` × the
    /// odometry's; dimensionless).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The standard deviation of [`Ekf::scale`] (dimensionless).
    pub fn scale_sd(&self) -> f32 {
        math::sqrt(math::max(self.covariance.m44, 0.0))
    }

    /// Keeps P symmetric, its diagonal in `[MIN_VARIANCE, MAX_VARIANCE]` and positive
    /// definite. Clamping scales rows and columns together (`D·P·D`), which keeps P positive
    /// semi-definite; a failed Cholesky adds a small diagonal load.
    fn condition(&mut self) {
        let mut p = 0.5 * (self.covariance + self.covariance.transpose());
        if !p.iter().all(|v| v.is_finite()) {
            // Unreachable with finite inputs; recover to "know nothing" rather than go NaN.
            p = Matrix4::identity() * MAX_VARIANCE;
        }
        let d = Vector4::from_iterator(p.diagonal().iter().map(|&v| {
            if v > MAX_VARIANCE {
                crate::math::sqrt(MAX_VARIANCE / v)
            } else {
                1.0
            }
        }));
        let dm = Matrix4::from_diagonal(&d);
        p = dm * p * dm;
        for (i, v) in p.diagonal().iter().enumerate() {
            if *v < MIN_VARIANCE {
                if let Some(e) = p.get_mut((i, i)) {
                    *e = MIN_VARIANCE;
                }
            }
        }
        if p.cholesky().is_none() {
            let load = p.diagonal().max() * 1e-6 + MIN_VARIANCE;
            p += Matrix4::identity() * load;
        }
        self.covariance = p;
    }
}

#[cfg(test)]
mod tests;
