//! What the localizer reports after each call: [`Status`], and [`RejectReason`] when a scan
//! was not used.

use core::fmt;

use crate::filter::UpdateRejection;
use crate::geometry::Point2;
use crate::matching::MatchError;

/// Why the last scan did not update the pose: the matcher's or the filter's own reason.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RejectReason {
    /// The matcher found no pose (too few points or associations, no convergence,
    /// non-finite input).
    Match(MatchError),
    /// The filter refused the match (the gate, nothing observed, non-finite).
    Update(UpdateRejection),
}

impl From<MatchError> for RejectReason {
    fn from(e: MatchError) -> Self {
        RejectReason::Match(e)
    }
}

impl From<UpdateRejection> for RejectReason {
    fn from(e: UpdateRejection) -> Self {
        RejectReason::Update(e)
    }
}

impl fmt::Display for RejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RejectReason::Match(e) => write!(f, "{e}"),
            RejectReason::Update(e) => write!(f, "{e}"),
        }
    }
}

/// What the localizer knows after its last call.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Status {
    /// No initial pose yet: call [`Localizer::initialise`](super::Localizer::initialise).
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
    /// The last scan updated the pose, but the map is not confirmed
    /// ([`super::IntegrityMonitor`]): at start-up until the landmarks have fitted it over a
    /// few metres, later when they stop fitting it (another tunnel's map, landmarks moved or
    /// damaged since the survey). The pose and its covariance may be confidently wrong: do
    /// not rely on them until the status is tracking again.
    MapUnconfirmed {
        /// How much of the last scan's landmarks the map explained.
        integrity: super::Integrity,
    },
    /// The last scan was not used; the estimate continues on odometry.
    MatchRejected {
        /// Why.
        reason: RejectReason,
    },
    /// Searching the map for where the vehicle is, from the landmarks seen while driving
    /// ([`crate::relocalise`]): at start-up without a pose, or after the localizer declared
    /// itself lost. The pose (if any: the last one, carried on by odometry) is not to be
    /// relied on. Drive on: each landmark seen narrows the search.
    Relocalising {
        /// Where the search stands.
        progress: crate::relocalise::RelocaliseProgress,
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
            Status::MapUnconfirmed { integrity } => write!(
                f,
                "map not confirmed: the landmarks in view have not fitted it lately ({} of the last scan's {} did; at start-up, until they have over a few metres); if it lasts, is this the drive's map? (landmarks moved, or another tunnel) The pose may be confidently wrong",
                integrity.clusters_explained, integrity.clusters
            ),
            Status::MatchRejected { reason } => write!(f, "scan not used: {reason}"),
            Status::Relocalising { progress } => write!(
                f,
                "relocalising: {} landmarks seen over {:.1} m, {} search rounds, best placement explains {} with a lead of {:.1} (drive on: each landmark seen narrows the search)",
                progress.landmarks_seen,
                progress.distance_m,
                progress.rounds,
                progress.best_explained,
                progress.lead
            ),
        }
    }
}
