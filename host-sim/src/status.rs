//! What an estimator says about each scan, kept typed from the localiser to the report:
//! counted, filtered and compared as values, printed as a label only at the output.

use std::fmt;

use loc_core::filter::UpdateRejection;
use loc_core::localizer::{RejectReason, Status};
use loc_core::matching::MatchError;
use scan_input::ScanInputError;

/// An estimator's status after one scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EstimatorStatus {
    /// loc-core's localiser status.
    Localizer(Status),
    /// The scan's telegram could not be turned into a loc-core scan (the localiser carried
    /// on with odometry).
    ScanUnusable(ScanInputError),
    /// The odometry-only baseline: scans are not used.
    Odometry,
    /// Another localiser's pose, read from its estimates file (`replay --estimates`).
    External,
    /// No pose for this scan in that file (a controller restarting after a reset sent
    /// none): the scan is not scored.
    NoEstimate,
}

impl EstimatorStatus {
    /// The short label of output files and reports (`tracking`, `degenerate`,
    /// `rejected:gate`, …).
    pub fn label(&self) -> &'static str {
        match self {
            EstimatorStatus::Localizer(s) => match s {
                Status::NotInitialised => "not-initialised",
                Status::DeadReckoning => "dead-reckoning",
                Status::Tracking => "tracking",
                Status::Degenerate { .. } => "degenerate",
                Status::MapUnconfirmed { .. } => "map-unconfirmed",
                Status::Relocalising { .. } => "relocalising",
                Status::MatchRejected { reason } => match reason {
                    RejectReason::Match(e) => match e {
                        MatchError::TooFewPoints { .. } => "rejected:too-few-points",
                        MatchError::TooFewAssociations { .. } => "rejected:too-few-associations",
                        MatchError::DidNotConverge { .. } => "rejected:no-convergence",
                        _ => "rejected:non-finite",
                    },
                    RejectReason::Update(e) => match e {
                        UpdateRejection::FailedGate { .. } => "rejected:gate",
                        UpdateRejection::NothingObserved => "rejected:nothing-observed",
                        _ => "rejected:non-finite",
                    },
                    _ => "rejected:other",
                },
                _ => "other",
            },
            EstimatorStatus::ScanUnusable(_) => "scan-unusable",
            EstimatorStatus::Odometry => "odometry",
            EstimatorStatus::External => "external",
            EstimatorStatus::NoEstimate => "no-estimate",
        }
    }

    /// The localiser's last scan updated every direction of the pose.
    pub fn is_tracking(&self) -> bool {
        matches!(self, EstimatorStatus::Localizer(Status::Tracking))
    }

    /// The scan updated the pose except along the tunnel.
    pub fn is_degenerate(&self) -> bool {
        matches!(self, EstimatorStatus::Localizer(Status::Degenerate { .. }))
    }

    /// The localiser is searching the map for where the vehicle is.
    pub fn is_relocalising(&self) -> bool {
        matches!(
            self,
            EstimatorStatus::Localizer(Status::Relocalising { .. })
        )
    }

    /// The scan was not used (refused by the matcher or the filter, or unusable).
    pub fn is_rejected(&self) -> bool {
        matches!(
            self,
            EstimatorStatus::Localizer(Status::MatchRejected { .. })
                | EstimatorStatus::ScanUnusable(_)
        )
    }
}

impl fmt::Display for EstimatorStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_predicates_agree() {
        let t = EstimatorStatus::Localizer(Status::Tracking);
        assert!(t.is_tracking() && !t.is_rejected());
        assert_eq!(t.to_string(), "tracking");
        let r = EstimatorStatus::Localizer(Status::MatchRejected {
            reason: RejectReason::Update(UpdateRejection::NothingObserved),
        });
        assert!(r.is_rejected());
        assert_eq!(r.label(), "rejected:nothing-observed");
        assert_eq!(EstimatorStatus::Odometry.label(), "odometry");
        assert!(EstimatorStatus::ScanUnusable(ScanInputError::NoDistanceChannel).is_rejected());
    }
}
