//! What the localizer reports after each call: [`Status`], and [`RejectReason`] when a scan
//! was not used.

use core::fmt;

use crate::filter::UpdateRejection;
use crate::geometry::Point2;
use crate::matching::MatchError;

/// Why the last scan did not update the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RejectReason {
    /// Too few points after stripping and selection.
    TooFewPoints {
        /// Points available.
        available: u16,
        /// Points required.
        required: u16,
    },
    /// Too few points near the map at the predicted pose.
    TooFewAssociations {
        /// Points associated.
        associated: u16,
        /// Points required.
        required: u16,
    },
    /// The matcher did not converge.
    DidNotConverge {
        /// Iterations run.
        iterations: u16,
    },
    /// The match disagreed with the prediction (squared Mahalanobis distance over the gate).
    FailedGate {
        /// Squared Mahalanobis distance.
        mahalanobis_sq: f32,
        /// Gate threshold.
        threshold: f32,
    },
    /// The match observed no direction of the pose.
    NothingObserved,
    /// Non-finite data reached the matcher or the filter.
    NonFinite,
}

impl From<MatchError> for RejectReason {
    fn from(e: MatchError) -> Self {
        match e {
            MatchError::TooFewPoints {
                available,
                required,
            } => RejectReason::TooFewPoints {
                available,
                required,
            },
            MatchError::TooFewAssociations {
                associated,
                required,
            } => RejectReason::TooFewAssociations {
                associated,
                required,
            },
            MatchError::DidNotConverge { iterations, .. } => {
                RejectReason::DidNotConverge { iterations }
            }
            MatchError::NonFiniteInput => RejectReason::NonFinite,
        }
    }
}

impl From<UpdateRejection> for RejectReason {
    fn from(e: UpdateRejection) -> Self {
        match e {
            UpdateRejection::NothingObserved => RejectReason::NothingObserved,
            UpdateRejection::FailedGate {
                mahalanobis_sq,
                threshold,
                ..
            } => RejectReason::FailedGate {
                mahalanobis_sq,
                threshold,
            },
            UpdateRejection::NonFinite => RejectReason::NonFinite,
        }
    }
}

impl fmt::Display for RejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RejectReason::TooFewPoints { available, required } => {
                write!(f, "too few scan points ({available} < {required})")
            }
            RejectReason::TooFewAssociations { associated, required } => write!(
                f,
                "too few points near the map ({associated} < {required}): prediction far off or outside the map"
            ),
            RejectReason::DidNotConverge { iterations } => {
                write!(f, "matcher did not converge in {iterations} iterations")
            }
            RejectReason::FailedGate { mahalanobis_sq, threshold } => write!(
                f,
                "match failed the gate (Mahalanobis² {mahalanobis_sq} > {threshold})"
            ),
            RejectReason::NothingObserved => write!(f, "the scan observes no direction of the pose"),
            RejectReason::NonFinite => write!(f, "non-finite data"),
        }
    }
}

/// What the localizer knows after its last call.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Status {
    /// No initial pose yet: call [`Localizer::initialise`].
    NotInitialised,
    /// Odometry only since the initial pose (no scan yet).
    DeadReckoning,
    /// The last scan updated every direction of the pose.
    Tracking,
    /// The last scan updated the pose except along `direction_world` (no landmark in view
    /// in a smooth tunnel): along it the estimate follows odometry.
    Degenerate {
        /// The unobserved direction, unit vector, world frame.
        direction_world: Point2,
        /// The information along it, m⁻².
        eigenvalue_per_m2: f32,
    },
    /// The last scan was not used; the estimate continues on odometry.
    MatchRejected {
        /// Why.
        reason: RejectReason,
    },
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Status::NotInitialised => write!(f, "not initialised: give an initial pose"),
            Status::DeadReckoning => write!(f, "dead reckoning (no scan yet)"),
            Status::Tracking => write!(f, "tracking"),
            Status::Degenerate {
                direction_world,
                eigenvalue_per_m2,
            } => write!(
                f,
                "degenerate along ({:.3}, {:.3}) (information {eigenvalue_per_m2:.1} m^-2): odometry there",
                direction_world.x_m, direction_world.y_m
            ),
            Status::MatchRejected { reason } => write!(f, "scan not used: {reason}"),
        }
    }
}
