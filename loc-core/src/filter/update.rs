//! EKF update from a scan match, projected onto the directions the scan observes, with
//! chi-square gating and the Joseph-form covariance update.
//!
//! With `V` the observed eigenvectors of the scaled information (`S·I·S`, `S = diag(1, 1,
//! 1/L)`) and `λ` their eigenvalues, the scan measures `y = Vᵀ·S⁻¹·x` with noise
//! `diag(1/λ + floor²)`. `Hᵀ·R⁻¹·H` is then exactly the observed part of the information, so
//! an unobserved direction gets no information and, with an uncorrelated prior, no
//! correction. Unobserved rows of `H` are kept as zero rows (fixed 3×4 algebra; their
//! gain columns vanish). A *weakly* observed direction (the position along the tunnel from a
//! curve seen far ahead) is measured only where the match knows it better than the filter:
//! its errors are shared by successive scans. The odometry's scale (the state's fourth
//! component) is not measured by a scan: its column of `H` is zero and it is corrected through its
//! correlation with the position (a landmark fix after metres of odometry says how far the
//! odometry was off).

use core::fmt;

use nalgebra::{Matrix3, Matrix3x4, Matrix4, Vector3, Vector4};

use super::Ekf;
use crate::geometry::{Point2, Pose2};
use crate::matching::{MatchResult, Observability};
use crate::math;

/// The gate's false-rejection probability.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum GateProbability {
    /// Reject when a consistent match would be rejected 1 % of the time.
    P99,
    /// Reject when a consistent match would be rejected 0.1 % of the time (default).
    #[default]
    P999,
    /// Never reject (testing only: a wrong match then corrupts the estimate).
    Disabled,
}

impl GateProbability {
    /// The chi-square threshold for `dof` degrees of freedom (1–3).
    pub fn threshold(self, dof: usize) -> f32 {
        const P99: [f32; 3] = [6.635, 9.210, 11.345];
        const P999: [f32; 3] = [10.828, 13.816, 16.266];
        let table = match self {
            GateProbability::P99 => &P99,
            GateProbability::P999 => &P999,
            GateProbability::Disabled => return f32::INFINITY,
        };
        dof.checked_sub(1)
            .and_then(|i| table.get(i))
            .copied()
            .unwrap_or(f32::INFINITY)
    }
}

/// Tuning of the match update. Which directions a match observes is the matcher's
/// judgement ([`MatchResult::observability`]), not a setting of the update.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UpdateConfig {
    /// Chi-square gate.
    pub gate: GateProbability,
    /// Standard deviation added to each observed direction of the match, metres (scaled
    /// units: a heading error counts at `L`). The point-to-line covariance ignores map and
    /// model errors and would otherwise make the filter overconfident.
    pub min_measurement_sd_m: f32,
    /// A weakly observed direction ([`Observability::weak_below_per_m2`]) updates the filter
    /// only when the match's variance along it is at most this fraction of the filter's;
    /// otherwise it is held like an unobserved one. Successive matches fix such a
    /// direction from the same few features (a curve ahead), so their errors are shared:
    /// averaged as if independent, 150 scans approaching the curve at the end of
    /// `tunnel-1km`'s first straight put the position along 5–8 σ off. With the ratio, a
    /// fix is taken when it improves on what the filter knows, and the filter's variance
    /// never drops below `1 / (1 + ratio)` of the best match's.
    pub weak_refix_ratio: f32,
    /// At most this many scans' worth of the walls' share of a match's error across the
    /// tunnel is counted as one scan's (≥ 1; 1: every match independent). Successive
    /// matches see the same stretch of rough wall, so their errors across it are shared:
    /// [`shared_error_scans`] says how many scans share it at the vehicle's travel between
    /// them, and the match's variance across is counted that many times over. The cap is
    /// what a vehicle at rest, whose scans share everything, is held to.
    pub max_shared_scans: f32,
}

impl UpdateConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    /// Gate at 0.1 %, 5 mm measurement floor, at most 64 scans sharing an error.
    pub const DEFAULT: Self = Self {
        gate: GateProbability::P999,
        min_measurement_sd_m: 0.005,
        weak_refix_ratio: 0.5,
        max_shared_scans: 64.0,
    };
}

impl Default for UpdateConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What an accepted update did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport {
    /// Directions of state space updated (0–3; 2 in a smooth tunnel).
    pub observed_directions: u8,
    /// Squared Mahalanobis distance of the projected innovation.
    pub mahalanobis_sq: f32,
    /// The correction applied, `(dx_m, dy_m, dtheta_rad)`, world frame.
    pub correction: [f32; 3],
}

/// Why a match did not update the filter (the state is left unchanged).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum UpdateRejection {
    /// The match observes no direction: its information is below the threshold everywhere.
    NothingObserved,
    /// The match disagrees with the prediction beyond the chi-square gate: a wrong match (or
    /// an overconfident prediction); the estimate continues on odometry.
    FailedGate {
        /// Squared Mahalanobis distance.
        mahalanobis_sq: f32,
        /// The gate it exceeded.
        threshold: f32,
        /// Degrees of freedom (observed directions).
        dof: u8,
    },
    /// The match pose or information is NaN or infinite, or the innovation covariance is
    /// singular.
    NonFinite,
}

impl fmt::Display for UpdateRejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UpdateRejection::NothingObserved => {
                write!(f, "the match observes no direction of the pose")
            }
            UpdateRejection::FailedGate {
                mahalanobis_sq,
                threshold,
                dof,
            } => write!(
                f,
                "match rejected by the gate: Mahalanobis² {mahalanobis_sq} > {threshold} ({dof} dof)"
            ),
            UpdateRejection::NonFinite => write!(f, "non-finite match or singular innovation"),
        }
    }
}

/// How many scans' worth of independent error one match's shared error is, when
/// successive matches are `travel_m` apart and the error decorrelates over `correlation_m`
/// of travel (the walls' roughness, a Gauss–Markov process along them): `coth(d / 2L)`,
/// the factor by which the variance of a mean of such errors exceeds that of as many
/// independent ones (`(1 + ρ) / (1 − ρ)`, `ρ = e^(−d/L)`), at least 1 and at most `max`
/// (also for a vehicle at rest, or no correlation to speak of: `correlation_m` ≤ 0).
pub fn shared_error_scans(travel_m: f32, correlation_m: f32, max: f32) -> f32 {
    let max = if max.is_finite() {
        math::max(max, 1.0)
    } else {
        1.0
    };
    if correlation_m.is_nan() || correlation_m <= 0.0 || !travel_m.is_finite() {
        return 1.0;
    }
    let rho = math::exp(-math::max(travel_m, 0.0) / correlation_m);
    let denominator = 1.0 - rho;
    if denominator <= (1.0 + rho) / max {
        return max;
    }
    math::max((1.0 + rho) / denominator, 1.0)
}

/// `I − Σ e·eᵀ` over the held directions of travel (world frame; orthonormalised, the
/// heading and scale untouched), `None` when nothing is held.
fn hold_projection(directions: [Option<Point2>; 2]) -> Option<Matrix4<f32>> {
    let mut t = Matrix4::identity();
    let mut first: Option<Vector4<f32>> = None;
    for d in directions.into_iter().flatten() {
        let mut e = Vector4::new(d.x_m, d.y_m, 0.0, 0.0);
        if let Some(f) = first {
            e -= f * f.dot(&e);
        }
        let n = e.norm();
        if n.is_nan() || n <= 0.1 * d.norm() {
            continue;
        }
        e /= n;
        t -= e * e.transpose();
        first.get_or_insert(e);
    }
    first.map(|_| t)
}

impl Ekf {
    /// Updates with a match result: its pose and information, observed as the matcher
    /// judged ([`MatchResult::observability`]); a match cut short adds its
    /// [`MatchResult::unconverged_sd_m`] to the measurement floor. `shared_scans` (≥ 1,
    /// [`shared_error_scans`], at most [`UpdateConfig::max_shared_scans`]) is how many
    /// successive scans share this match's error across the tunnel (the direction across
    /// the filter's heading): its variance across is counted that many times over.
    pub fn update_with_match(
        &mut self,
        result: &MatchResult,
        config: &UpdateConfig,
        shared_scans: f32,
    ) -> Result<UpdateReport, UpdateRejection> {
        let d = &result.degeneracy;
        let hold = d.degenerate.then_some(d.direction_world);
        // A match stopped short of its optimum measures less well than its information says.
        let config = UpdateConfig {
            min_measurement_sd_m: math::hypot(config.min_measurement_sd_m, result.unconverged_sd_m),
            ..*config
        };
        let shared_scans = if shared_scans.is_finite() {
            shared_scans.clamp(1.0, math::max(config.max_shared_scans, 1.0))
        } else {
            1.0
        };
        self.update_shared(
            result.pose,
            &result.information,
            hold,
            &result.observability,
            &config,
            shared_scans,
        )
    }

    /// Updates with a measured vehicle pose (world frame) and its information matrix
    /// (`(x_m, y_m, theta_rad)`, m⁻², m⁻¹rad⁻¹, rad⁻²; may be singular); `observability`
    /// says which of its directions count as measured.
    ///
    /// `unobserved_direction` (unit, world frame), when given, is a direction of travel the
    /// scan does not observe (the tunnel axis with no landmark in view): the gain is
    /// projected so the update never moves the position along it nor the odometry's scale (`K ← T·K`, `T` removing
    /// that translation component; the Joseph form keeps the covariance exact for this
    /// gain). Position and variance along it then follow odometry alone, even in a curve,
    /// where the scan ties the along-tunnel position to the heading and an unprojected update
    /// would trade one for the other.
    ///
    /// A weakly observed direction ([`Observability::weak_below_per_m2`]) is measured only
    /// when the match's variance along it is at most [`UpdateConfig::weak_refix_ratio`]
    /// of the filter's; otherwise it is dropped and its direction of travel held the same
    /// way.
    pub fn update(
        &mut self,
        measured: Pose2,
        information: &Matrix3<f32>,
        unobserved_direction: Option<Point2>,
        observability: &Observability,
        config: &UpdateConfig,
    ) -> Result<UpdateReport, UpdateRejection> {
        self.update_shared(
            measured,
            information,
            unobserved_direction,
            observability,
            config,
            1.0,
        )
    }

    /// [`Ekf::update`] with the measurement's variance across the tunnel counted
    /// `shared_scans` (≥ 1) times over (see [`Ekf::update_with_match`]).
    pub(super) fn update_shared(
        &mut self,
        measured: Pose2,
        information: &Matrix3<f32>,
        unobserved_direction: Option<Point2>,
        observability: &Observability,
        config: &UpdateConfig,
        shared_scans: f32,
    ) -> Result<UpdateReport, UpdateRejection> {
        if !measured.is_finite() || !information.iter().all(|v| v.is_finite()) {
            return Err(UpdateRejection::NonFinite);
        }
        let mut obs = observability.subspace(information);
        if obs.rank == 0 {
            return Err(UpdateRejection::NothingObserved);
        }
        let floor_sq = config.min_measurement_sd_m * config.min_measurement_sd_m;
        let p = self.covariance;
        // A weakly observed direction is taken only where the match knows it better than
        // the filter (its errors are shared from scan to scan, see `weak_refix_ratio`);
        // otherwise it is held like an unobserved one.
        let mut weak_hold = None;
        if let Some((k, lambda)) = obs
            .weakest()
            .filter(|&(_, lambda)| lambda < observability.weak_below_per_m2)
        {
            // What the match measures of the state along it (`vᵀ·S⁻¹`, as `h3`'s rows).
            let row = obs.scaled_basis.column(k.min(2)).transpose() * obs.unscale();
            let p3 = p.fixed_view::<3, 3>(0, 0).into_owned();
            let predicted_m2 = (row * p3 * row.transpose()).x;
            let measured_m2 = 1.0 / lambda + floor_sq;
            let improves = measured_m2 <= config.weak_refix_ratio * predicted_m2;
            if !improves {
                let d = obs.state_direction(k);
                let t = Point2::new(d.x, d.y);
                if t.norm() > 0.1 * d.norm() {
                    weak_hold = Some(t);
                }
                obs = obs.without(k);
                if obs.rank == 0 {
                    return Err(UpdateRejection::NothingObserved);
                }
            }
        }
        let h3 = obs.scaled_basis.transpose() * obs.unscale();
        let mut h = Matrix3x4::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&h3);
        let mut r_diag = Vector3::repeat(1.0f32);
        for (k, (r, lambda)) in r_diag.iter_mut().zip(obs.eigenvalues.iter()).enumerate() {
            if k < obs.rank {
                *r = 1.0 / lambda + floor_sq;
            }
        }
        let mut r = Matrix3::from_diagonal(&r_diag);
        if shared_scans > 1.0 {
            // The match's variance across the tunnel, `nᵀ·C·n` with `C = Σ b·bᵀ / λ` over the
            // observed directions, added `shared_scans − 1` times more along `n` (in the
            // measurement's coordinates, `Vᵀ·n`).
            let n = Vector3::new(
                -math::sin(self.pose.theta_rad),
                math::cos(self.pose.theta_rad),
                0.0,
            );
            let mut n_measured = Vector3::zeros();
            let mut across_m2 = 0.0f32;
            for (k, (b, lambda)) in obs
                .scaled_basis
                .column_iter()
                .zip(obs.eigenvalues.iter())
                .enumerate()
                .take(obs.rank)
            {
                let c = b.dot(&n);
                if let Some(e) = n_measured.get_mut(k) {
                    *e = c;
                }
                across_m2 += c * c / lambda;
            }
            r += n_measured * n_measured.transpose() * ((shared_scans - 1.0) * across_m2);
        }
        let error = Vector3::new(
            measured.x_m - self.pose.x_m,
            measured.y_m - self.pose.y_m,
            math::wrap_angle(measured.theta_rad - self.pose.theta_rad),
        );
        let nu = h3 * error;
        let s = h * p * h.transpose() + r;
        let s_inv = s.try_inverse().ok_or(UpdateRejection::NonFinite)?;
        let d2 = (nu.transpose() * s_inv * nu).x;
        if !d2.is_finite() {
            return Err(UpdateRejection::NonFinite);
        }
        let dof = u8::try_from(obs.rank).unwrap_or(3);
        gate_check(d2, config.gate, dof)?;
        let mut k = p * h.transpose() * s_inv;
        let held = unobserved_direction.filter(|d| d.is_finite() && d.norm_sq() > 0.5);
        if let Some(t) = hold_projection([held, weak_hold]) {
            // Nor does it touch the odometry's scale: only fixes along the travel say how
            // far the odometry was off, and a scale learnt from heading and lateral
            // innovations in a curve would carry the along-tunnel error into them.
            let keep = Matrix4::from_diagonal(&Vector4::new(1.0, 1.0, 1.0, 0.0));
            k = keep * t * k;
        }
        let dx = k * nu;
        let i_kh = Matrix4::identity() - k * h;
        let p_new = i_kh * p * i_kh.transpose() + k * r * k.transpose();
        self.apply(dx, p_new)?;
        Ok(UpdateReport {
            observed_directions: dof,
            mahalanobis_sq: d2,
            correction: [dx.x, dx.y, dx.z],
        })
    }

    /// Takes an update's state correction `dx` and new covariance (both checked finite
    /// first: otherwise nothing changes).
    fn apply(&mut self, dx: Vector4<f32>, p_new: Matrix4<f32>) -> Result<(), UpdateRejection> {
        if !dx.iter().all(|v| v.is_finite()) || !p_new.iter().all(|v| v.is_finite()) {
            return Err(UpdateRejection::NonFinite);
        }
        self.pose = Pose2::new(
            self.pose.x_m + dx.x,
            self.pose.y_m + dx.y,
            self.pose.theta_rad + dx.z,
        );
        // A bound on what odometry can be off by: one wrong match must not make it absurd.
        self.scale = (self.scale + dx.w).clamp(-super::MAX_SCALE_ERROR, super::MAX_SCALE_ERROR);
        self.covariance = p_new;
        self.condition();
        Ok(())
    }
}

/// The chi-square gate: `Err(FailedGate)` when `d2` (squared Mahalanobis distance with
/// `dof` degrees of freedom) exceeds `gate`'s threshold.
fn gate_check(d2: f32, gate: GateProbability, dof: u8) -> Result<(), UpdateRejection> {
    let threshold = gate.threshold(usize::from(dof));
    if d2 > threshold {
        return Err(UpdateRejection::FailedGate {
            mahalanobis_sq: d2,
            threshold,
            dof,
        });
    }
    Ok(())
}

impl Ekf {
    /// Updates with a measurement of the position along the unit world-frame direction
    /// `direction` (a wall's end seen along the tunnel): `innovation_m` is measured minus
    /// predicted, `variance_m2` its noise. Position and the odometry's scale are corrected
    /// (the scale through its correlation with the position: a fix along the travel says
    /// how far the odometry was off, as a landmark's does); the heading is not. Such a fix
    /// says next to nothing about the heading (a lever of the wall's distance across, a few
    /// metres, against a measurement good to centimetres), and where the heading is poorly
    /// known a biased fix would otherwise be taken out on it. Gated at `gate` with one
    /// degree of freedom; the Joseph form keeps the covariance exact for the gain used.
    pub fn update_position_along(
        &mut self,
        direction: Point2,
        innovation_m: f32,
        variance_m2: f32,
        gate: GateProbability,
    ) -> Result<UpdateReport, UpdateRejection> {
        let n = direction.norm();
        if !(direction.is_finite()
            && n > 0.5
            && innovation_m.is_finite()
            && variance_m2.is_finite()
            && variance_m2 > 0.0)
        {
            return Err(UpdateRejection::NonFinite);
        }
        let h = Vector4::new(direction.x_m / n, direction.y_m / n, 0.0, 0.0);
        let p = self.covariance;
        let ph = p * h;
        let s = h.dot(&ph) + variance_m2;
        if !(s.is_finite() && s > 0.0) {
            return Err(UpdateRejection::NonFinite);
        }
        let d2 = innovation_m * innovation_m / s;
        gate_check(d2, gate, 1)?;
        let mut k = ph / s;
        k.z = 0.0;
        let dx = k * innovation_m;
        // The Joseph form `(I − k·hᵀ)·P·(I − k·hᵀ)ᵀ + k·r·kᵀ`, exact for this gain (it is not
        // the optimal one), expanded for a scalar measurement: three outer products.
        let p_new = p - k * ph.transpose() - ph * k.transpose() + k * k.transpose() * s;
        self.apply(dx, p_new)?;
        Ok(UpdateReport {
            observed_directions: 1,
            mahalanobis_sq: d2,
            correction: [dx.x, dx.y, 0.0],
        })
    }
}
