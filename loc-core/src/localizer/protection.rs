//! The protection level: a bound on the horizontal position error that holds except with a
//! stated integrity risk per scan, and whether the pose is available for use (the bound
//! within the alert limit, no fault detected and left standing).
//!
//! Derivation (aviation's RAIM, adapted to a scan-matching EKF). The position error is the
//! sum of noise the filter models and the effect of a fault it did not detect:
//!
//! - **Fault-free part.** The error is Gaussian with the filter's position covariance `P`.
//!   Whatever its shape, `|e|² ≤ λ_max · χ²₂`, and `P(χ²₂ > k²) = exp(−k²/2)`, so
//!   `|e| ≤ k · σ_max` except with probability `exp(−k²/2)`: with the integrity risk `r`,
//!   `k = √(−2 ln r)` (4.80 at 10⁻⁵), `σ_max = √λ_max`.
//! - **Undetected faults**, one at a time, assumed present on every scan (no prior
//!   probability is credited, which is conservative): a landmark matched to the wrong map
//!   landmark is caught by the map's check ([`super::Integrity`]: the scan's other landmarks
//!   stop fitting) and by the gate, and relocalisation only locks on a spacing pattern that
//!   fits; a moved or missing landmark is caught by the same check once it misfits by more
//!   than its tolerance — below it, the landmark shifts the pose along the tunnel by at most
//!   [`ProtectionConfig::landmark_fault_m`]; a wrong wall model (a bend, a wall moved since
//!   the survey) is not checked (every tunnel has two walls) and shifts the pose across the
//!   tunnel by at most [`ProtectionConfig::wall_fault_m`]. The two act in perpendicular
//!   directions: the bias bound is their `hypot`.
//!
//! So `PL = k · σ_max + hypot(landmark_fault_m, wall_fault_m)`.
//!
//! **Not available**: without a pose (not initialised, relocalising); when a fault was
//! detected and not excluded — the map unconfirmed ([`super::Status::MapUnconfirmed`]:
//! the landmarks do not fit, so the pose may be confidently wrong, which is why no bound is
//! given) or the last match refused by the filter's gate (the pose and the scan disagree);
//! and when the bound exceeds the alert limit. What it does not cover: the vehicle moved
//! without the odometry seeing it (a tow, wheels sliding on mud) while no landmark is in
//! view: nothing in the scans can show it until one is (then the gate or the map's check
//! does); and faults of the odometry's scale beyond its modelled error.
//!
//! The fault bounds' defaults are measured (`host-sim`: landmarks moved after the survey,
//! bent walls; see the README's "Protection level").

use core::fmt;

use nalgebra::Matrix3;

use super::status::{RejectReason, Status};
use crate::filter::UpdateRejection;

/// The integrity requirement and the fault bounds the protection level is built from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProtectionConfig {
    /// Probability per scan that the error exceeds the protection level without the pose
    /// being flagged unavailable, `(0, 1)`.
    pub integrity_risk_per_scan: f32,
    /// Above this protection level the pose is [`Availability::AboveAlertLimit`], metres.
    pub alert_limit_m: f32,
    /// The largest shift along the tunnel a landmark fault the map's check does not detect
    /// (a landmark moved or damaged by less than the check's tolerance) gives the pose,
    /// metres.
    pub landmark_fault_m: f32,
    /// The largest shift across the tunnel a wrong wall model gives the pose, metres.
    pub wall_fault_m: f32,
}

impl ProtectionConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items: risk
    /// 10⁻⁵ per scan, alert limit 0.3 m, fault bounds 15 cm along (measured: landmarks moved
    /// 8–15 cm after the survey escape the map's check and pulled the pose up to 12.2 cm)
    /// and 2 cm across.
    pub const DEFAULT: Self = Self {
        integrity_risk_per_scan: 1e-5,
        alert_limit_m: 0.3,
        landmark_fault_m: 0.15,
        wall_fault_m: 0.02,
    };

    /// The fault-free multiplier `k = √(−2 ln r)` of the largest position standard deviation
    /// (see the module docs).
    pub fn fault_free_multiplier(&self) -> f32 {
        let r = self.integrity_risk_per_scan;
        crate::math::sqrt(-2.0 * crate::math::ln(r))
    }

    /// The values a configuration record must hold (risk in `(0, 1)`, the limit positive,
    /// fault bounds non-negative, all finite).
    pub fn is_usable(&self) -> bool {
        let r = self.integrity_risk_per_scan;
        r.is_finite()
            && r > 0.0
            && r < 1.0
            && self.alert_limit_m.is_finite()
            && self.alert_limit_m > 0.0
            && [self.landmark_fault_m, self.wall_fault_m]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0)
    }
}

impl Default for ProtectionConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Whether the pose may be used, and if not why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Availability {
    /// The protection level is within the alert limit and no fault stands: use the pose.
    Available,
    /// The protection level exceeds the alert limit (long without a landmark, or the
    /// covariance grown on odometry alone): the pose is bounded, but not well enough.
    AboveAlertLimit,
    /// A fault was detected and not excluded: the map's landmarks do not fit the scan, or
    /// the filter's gate refused the last match. No bound is given.
    FaultDetected,
    /// No pose to bound: not initialised, or relocalising.
    NoPose,
}

impl fmt::Display for Availability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Availability::Available => "available",
            Availability::AboveAlertLimit => {
                "unavailable: protection level above the alert limit (drive to a landmark)"
            }
            Availability::FaultDetected => {
                "unavailable: a fault was detected (landmarks not fitting the map, or the match refused by the gate)"
            }
            Availability::NoPose => "unavailable: no pose (not initialised, or relocalising)",
        })
    }
}

/// The protection level of the pose after a scan.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Protection {
    /// Bound on the horizontal position error (world frame), metres, holding except with
    /// the configured integrity risk; `None` when there is no bound (no pose, or a fault
    /// detected).
    pub level_m: Option<f32>,
    /// Whether the pose may be used.
    pub availability: Availability,
}

impl Protection {
    /// Whether the pose may be used.
    pub fn is_available(&self) -> bool {
        self.availability == Availability::Available
    }

    /// The protection level of a pose with covariance `covariance` (`(x, y, θ)`, world
    /// frame; `None` without a pose) reported with `status`.
    pub fn of(
        status: &Status,
        covariance: Option<&Matrix3<f32>>,
        config: &ProtectionConfig,
    ) -> Self {
        let none = |availability| Self {
            level_m: None,
            availability,
        };
        let Some(cov) = covariance else {
            return none(Availability::NoPose);
        };
        match status {
            Status::NotInitialised | Status::Relocalising { .. } => {
                return none(Availability::NoPose)
            }
            Status::MapUnconfirmed { .. }
            | Status::MatchRejected {
                reason: RejectReason::Update(UpdateRejection::FailedGate { .. }),
            } => return none(Availability::FaultDetected),
            _ => {}
        }
        let sd_m = super::largest_position_sd_m(cov);
        let level_m = config.fault_free_multiplier() * sd_m
            + crate::math::hypot(config.landmark_fault_m, config.wall_fault_m);
        // The eigenvalue's `max` hides a NaN: the block itself must be finite.
        let finite = [cov.m11, cov.m12, cov.m22].iter().all(|v| v.is_finite());
        if !finite || !level_m.is_finite() {
            return none(Availability::AboveAlertLimit);
        }
        let availability = if level_m <= config.alert_limit_m {
            Availability::Available
        } else {
            Availability::AboveAlertLimit
        };
        Self {
            level_m: Some(level_m),
            availability,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::Integrity;

    fn cov(sx_m: f32, sy_m: f32) -> Matrix3<f32> {
        Matrix3::from_diagonal(&nalgebra::Vector3::new(sx_m * sx_m, sy_m * sy_m, 1e-6))
    }

    #[test]
    fn the_multiplier_is_the_rayleigh_quantile_of_the_risk() {
        let k = ProtectionConfig::DEFAULT.fault_free_multiplier();
        assert!((k - 4.7985).abs() < 1e-3, "{k}");
        // exp(-k²/2) is the risk again.
        assert!((libm::expf(-k * k / 2.0) - 1e-5).abs() < 1e-7);
    }

    #[test]
    fn tracking_is_bounded_by_the_largest_sd_plus_the_fault_bounds() {
        let c = ProtectionConfig::DEFAULT;
        let p = Protection::of(&Status::Tracking, Some(&cov(0.004, 0.010)), &c);
        let expected = c.fault_free_multiplier() * 0.010 + libm::hypotf(0.15, 0.02);
        let level = p.level_m.unwrap();
        assert!((level - expected).abs() < 1e-5, "{level} vs {expected}");
        assert!(p.is_available());
    }

    #[test]
    fn a_large_covariance_is_above_the_alert_limit() {
        let p = Protection::of(
            &Status::DeadReckoning,
            Some(&cov(0.01, 0.08)),
            &ProtectionConfig::DEFAULT,
        );
        assert!(p.level_m.unwrap() > 0.3);
        assert_eq!(p.availability, Availability::AboveAlertLimit);
    }

    #[test]
    fn detected_faults_and_no_pose_give_no_bound() {
        let c = ProtectionConfig::DEFAULT;
        let small = cov(0.002, 0.002);
        let unconfirmed = Status::MapUnconfirmed {
            integrity: Integrity::default(),
        };
        let gate = Status::MatchRejected {
            reason: RejectReason::Update(UpdateRejection::FailedGate {
                mahalanobis_sq: 40.0,
                threshold: 11.3,
                dof: 3,
            }),
        };
        for (status, expected) in [
            (unconfirmed, Availability::FaultDetected),
            (gate, Availability::FaultDetected),
            (Status::NotInitialised, Availability::NoPose),
        ] {
            let p = Protection::of(&status, Some(&small), &c);
            assert_eq!((p.level_m, p.availability), (None, expected), "{status:?}");
        }
        let p = Protection::of(&Status::Tracking, None, &c);
        assert_eq!(p.availability, Availability::NoPose);
        // A match the matcher could not make leaves a bounded prediction.
        let no_match = Status::MatchRejected {
            reason: RejectReason::Match(crate::matching::MatchError::TooFewPoints {
                available: 3,
                required: 20,
            }),
        };
        assert!(Protection::of(&no_match, Some(&small), &c).is_available());
    }

    #[test]
    fn a_non_finite_covariance_is_not_available() {
        let p = Protection::of(
            &Status::Tracking,
            Some(&cov(f32::NAN, 0.01)),
            &ProtectionConfig::DEFAULT,
        );
        assert!(!p.is_available());
    }

    #[test]
    fn unusable_configurations_are_refused() {
        assert!(ProtectionConfig::DEFAULT.is_usable());
        for bad in [
            ProtectionConfig {
                integrity_risk_per_scan: 0.0,
                ..ProtectionConfig::DEFAULT
            },
            ProtectionConfig {
                integrity_risk_per_scan: 1.0,
                ..ProtectionConfig::DEFAULT
            },
            ProtectionConfig {
                alert_limit_m: f32::NAN,
                ..ProtectionConfig::DEFAULT
            },
            ProtectionConfig {
                landmark_fault_m: -0.1,
                ..ProtectionConfig::DEFAULT
            },
        ] {
            assert!(!bad.is_usable(), "{bad:?}");
        }
    }
}
