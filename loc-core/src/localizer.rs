//! The facade the firmware and the simulator drive: feed odometry and scans, read the pose,
//! its covariance and a status.
//!
//! One scan runs four public stages, each callable on its own (benchmarks and the firmware
//! time them separately):
//! 1. [`crate::strip::strip_walls`]: label points wall / landmark / outlier (vehicle frame);
//! 2. [`crate::matching::select_match_points`]: the points to match;
//! 3. [`crate::matching::match_scan_with_prealign`]: landmark pre-alignment
//!    ([`crate::matching::prealign_along_tunnel`]) and Hausdorff or PL-ICP matching
//!    ([`crate::matching::match_scan`]) against the map;
//! 4. [`crate::filter::Ekf::update_with_match`]: the EKF update on the observed directions.
//!
//! Memory: a `Localizer` holds its scratch buffers (≈ 38 KiB: point labels, selected
//! points, the match workspace); keep it in a `static` or on a large stack. No allocation,
//! no panics, bounded time per call.

use core::fmt;

use nalgebra::Matrix3;

use crate::filter::{
    Ekf, FilterInitError, OdometryIncrement, OdometryNoise, OdometryRejection, UpdateConfig,
    UpdateRejection,
};
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::matching::{
    match_scan_with_prealign, select_match_points, MatchConfig, MatchError, MatchPoints,
    MatchResult, MatchWorkspace, PrealignConfig,
};
use crate::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};
use crate::strip::{strip_walls, PointLabel, StripConfig, StripSummary};

/// Everything a [`Localizer`] is tuned by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalizerConfig {
    /// The scanner's beam layout and mounting on the vehicle. Informational for the
    /// localizer (scans arrive as [`Scan`]s already in the vehicle frame); build scans with
    /// the same setup.
    pub sensor: SensorSetup,
    /// Wall stripping.
    pub strip: StripConfig,
    /// Wall points kept for matching (landmark points are all kept).
    pub max_wall_points: u16,
    /// Wall points farther than `wall_range_scale_m2 / σ` are not matched, where σ is the
    /// predicted position's largest standard deviation (metres; in a smooth tunnel the
    /// along-tunnel one): with the position along the tunnel uncertain by σ, the stored
    /// walls far ahead may bend where the scanned ones do not (or run straight where they
    /// bend), and those points bias the lateral and heading fit. m².
    pub wall_range_scale_m2: f32,
    /// The wall range above never drops below this, metres (near walls fix the lateral
    /// position and the heading).
    pub min_wall_range_m: f32,
    /// Along-tunnel pre-alignment on landmarks.
    pub prealign: PrealignConfig,
    /// Matcher choice (Hausdorff | ICP), K fraction, range noise, iteration limits.
    pub matching: MatchConfig,
    /// Odometry noise model and step limits.
    pub odometry: OdometryNoise,
    /// Chi-square gate probability and measurement floor of the match update; the
    /// observability threshold and θ scale are taken from `matching`.
    pub update: UpdateConfig,
}

impl Default for LocalizerConfig {
    fn default() -> Self {
        let matching = MatchConfig::default();
        Self {
            sensor: SensorSetup::default(),
            strip: StripConfig::default(),
            max_wall_points: 100,
            wall_range_scale_m2: 10.0,
            min_wall_range_m: 15.0,
            prealign: PrealignConfig::default(),
            matching,
            odometry: OdometryNoise::default(),
            update: UpdateConfig::for_matcher(&matching),
        }
    }
}

/// Why the last scan did not update the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// The localisation pipeline over a map `M`.
pub struct Localizer<'m, M: MapQuery> {
    map: &'m M,
    config: LocalizerConfig,
    ekf: Option<Ekf>,
    status: Status,
    labels: [PointLabel; LMS511_MAX_BEAMS],
    match_points: MatchPoints,
    workspace: MatchWorkspace,
    last_strip: Option<StripSummary>,
    last_match: Option<MatchResult>,
}

impl<'m, M: MapQuery> Localizer<'m, M> {
    /// A localizer at `initial_pose` (vehicle in world) with covariance `initial_cov` of
    /// `(x_m, y_m, theta_rad)`.
    pub fn new(
        map: &'m M,
        config: LocalizerConfig,
        initial_pose: Pose2,
        initial_cov: Matrix3<f32>,
    ) -> Result<Self, FilterInitError> {
        let mut l = Self::uninitialised(map, config);
        l.initialise(initial_pose, initial_cov)?;
        Ok(l)
    }

    /// A localizer without a pose: scans are ignored ([`Status::NotInitialised`]) until
    /// [`Localizer::initialise`].
    pub fn uninitialised(map: &'m M, config: LocalizerConfig) -> Self {
        Self {
            map,
            config,
            ekf: None,
            status: Status::NotInitialised,
            labels: [PointLabel::Outlier; LMS511_MAX_BEAMS],
            match_points: MatchPoints::new(),
            workspace: MatchWorkspace::new(),
            last_strip: None,
            last_match: None,
        }
    }

    /// Sets (or resets) the pose and its covariance.
    pub fn initialise(
        &mut self,
        pose: Pose2,
        covariance: Matrix3<f32>,
    ) -> Result<(), FilterInitError> {
        self.ekf = Some(Ekf::new(pose, covariance)?);
        self.status = Status::DeadReckoning;
        Ok(())
    }

    /// Predicts with an odometry increment (vehicle frame at the previous pose: metres
    /// forward, metres left, radians counter-clockwise) and the configured noise model.
    /// A rejected increment leaves the state unchanged.
    pub fn predict_odometry(
        &mut self,
        increment: &OdometryIncrement,
    ) -> Result<(), OdometryRejection> {
        match self.ekf.as_mut() {
            Some(ekf) => ekf.predict(increment, &self.config.odometry),
            None => Ok(()),
        }
    }

    /// Predicts with an odometry increment and its own covariance (vehicle frame).
    pub fn predict_odometry_with_covariance(
        &mut self,
        increment: &OdometryIncrement,
        covariance: &Matrix3<f32>,
    ) -> Result<(), OdometryRejection> {
        match self.ekf.as_mut() {
            Some(ekf) => ekf.predict_with_covariance(increment, covariance, &self.config.odometry),
            None => Ok(()),
        }
    }

    /// Runs strip → select → pre-align → match → update on one scan (vehicle-frame points
    /// in beam order, as [`Scan`] holds them) and returns the new status.
    pub fn update_scan(&mut self, scan: &Scan) -> Status {
        let Some(ekf) = self.ekf.as_mut() else {
            self.status = Status::NotInitialised;
            return self.status;
        };
        let cfg = &self.config;
        let points = scan.points();
        let n = points.len().min(self.labels.len());
        let labels = self.labels.get_mut(..n).unwrap_or_default();
        let strip = strip_walls(points, &cfg.strip, labels);
        self.last_strip = Some(strip);
        select_match_points(
            points,
            labels,
            cfg.max_wall_points,
            cfg.wall_range_m(&ekf.covariance()),
            &mut self.match_points,
        );
        let result = match match_scan_with_prealign(
            self.map,
            points,
            labels,
            &strip,
            &self.match_points,
            ekf.pose(),
            position_sd_m(&ekf.covariance()),
            &cfg.prealign,
            &cfg.matching,
            &mut self.workspace,
        ) {
            Ok(r) => r.result,
            Err(e) => {
                self.last_match = None;
                self.status = Status::MatchRejected { reason: e.into() };
                return self.status;
            }
        };
        self.last_match = Some(result);
        let mut update = cfg.update;
        update.min_information_per_m2 = cfg.matching.min_information_per_m2();
        update.rotation_scale_m = cfg.matching.rotation_scale_m;
        self.status = match ekf.update_with_match(&result, &update) {
            Err(e) => Status::MatchRejected { reason: e.into() },
            Ok(_) if result.degeneracy.degenerate => Status::Degenerate {
                direction_world: result.degeneracy.direction_world,
                eigenvalue_per_m2: result.degeneracy.min_eigenvalue_per_m2,
            },
            Ok(_) => Status::Tracking,
        };
        self.status
    }

    /// The pose estimate (vehicle frame in the world frame); `None` before initialisation.
    pub fn pose(&self) -> Option<Pose2> {
        self.ekf.as_ref().map(Ekf::pose)
    }

    /// The covariance of `(x_m, y_m, theta_rad)` as rows (m², m·rad, rad²); `None` before
    /// initialisation.
    pub fn covariance(&self) -> Option<[[f32; 3]; 3]> {
        self.ekf.as_ref().map(|e| {
            let c = e.covariance();
            [
                [c.m11, c.m12, c.m13],
                [c.m21, c.m22, c.m23],
                [c.m31, c.m32, c.m33],
            ]
        })
    }

    /// The covariance as a matrix; `None` before initialisation.
    pub fn covariance_matrix(&self) -> Option<Matrix3<f32>> {
        self.ekf.as_ref().map(Ekf::covariance)
    }

    /// The status after the last call.
    pub fn status(&self) -> Status {
        self.status
    }

    /// The filter itself (for inspection).
    pub fn filter(&self) -> Option<&Ekf> {
        self.ekf.as_ref()
    }

    /// The stripping summary of the last scan.
    pub fn last_strip(&self) -> Option<&StripSummary> {
        self.last_strip.as_ref()
    }

    /// The match of the last scan, if it succeeded (even if the filter then rejected it).
    pub fn last_match(&self) -> Option<&MatchResult> {
        self.last_match.as_ref()
    }

    /// The point labels of the last scan (one per point of the scan).
    pub fn last_labels(&self) -> &[PointLabel] {
        let n = self.last_strip.map_or(0, |s| {
            let c = s.counts;
            usize::from(c.left_wall)
                + usize::from(c.right_wall)
                + usize::from(c.landmark)
                + usize::from(c.outlier)
                + usize::from(c.out_of_range)
        });
        self.labels.get(..n).unwrap_or_default()
    }

    /// The configuration.
    pub fn config(&self) -> &LocalizerConfig {
        &self.config
    }
}

/// A bound on the position's standard deviation, metres: `√(σx² + σy²)`.
pub fn position_sd_m(p: &Matrix3<f32>) -> f32 {
    crate::math::sqrt(crate::math::max(p.m11 + p.m22, 0.0))
}

/// The largest standard deviation of the position, metres: the square root of the larger
/// eigenvalue of the covariance's `(x, y)` block (`p` as the filter keeps it, world frame).
pub fn largest_position_sd_m(p: &Matrix3<f32>) -> f32 {
    let (a, b, c) = (p.m11, p.m12, p.m22);
    let half_diff = 0.5 * (a - c);
    let lambda = 0.5 * (a + c) + crate::math::sqrt(half_diff * half_diff + b * b);
    crate::math::sqrt(crate::math::max(lambda, 0.0))
}

impl LocalizerConfig {
    /// How far out wall points are matched for a prediction with position covariance
    /// `covariance` (see [`LocalizerConfig::wall_range_scale_m2`]), metres;
    /// `f32::INFINITY` when the prediction is certain (or the covariance is not finite).
    pub fn wall_range_m(&self, covariance: &Matrix3<f32>) -> f32 {
        let sd_m = largest_position_sd_m(covariance);
        if sd_m > 0.0 && sd_m.is_finite() {
            crate::math::max(self.wall_range_scale_m2 / sd_m, self.min_wall_range_m)
        } else {
            f32::INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn memory_is_what_the_docs_say() {
        use crate::map::TunnelMap;
        let localizer = core::mem::size_of::<Localizer<'static, TunnelMap>>();
        let scan = core::mem::size_of::<Scan>();
        let workspace = core::mem::size_of::<MatchWorkspace>();
        // Module docs: ≈ 38 KiB; Scan ≈ 32 KiB; MatchWorkspace 32 KiB.
        assert!((37 * 1024..40 * 1024).contains(&localizer), "{localizer}");
        assert!((31 * 1024..34 * 1024).contains(&scan), "{scan}");
        assert_eq!(workspace, 512 * 56 + 512 * 8);
    }

    #[test]
    fn wall_range_shrinks_with_the_position_uncertainty() {
        let cfg = LocalizerConfig::default();
        let cov = |sx: f32, sy: f32| Matrix3::from_diagonal(&Vector3::new(sx * sx, sy * sy, 1e-4));
        // Tracking (1 cm): no practical limit; 0.5 m along: 20 m; metres: the floor.
        assert!(cfg.wall_range_m(&cov(0.01, 0.005)) >= 1000.0);
        assert!((cfg.wall_range_m(&cov(0.5, 0.01)) - 20.0).abs() < 1e-3);
        assert_eq!(cfg.wall_range_m(&cov(5.0, 0.01)), cfg.min_wall_range_m);
        // The largest deviation counts, whatever the axes (a tunnel along the diagonal).
        let mut rotated = cov(0.5, 0.01);
        let (c, s) = (
            core::f32::consts::FRAC_1_SQRT_2,
            core::f32::consts::FRAC_1_SQRT_2,
        );
        let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        rotated = r * rotated * r.transpose();
        assert!((largest_position_sd_m(&rotated) - 0.5).abs() < 1e-4);
        // No information: no limit, never NaN.
        assert_eq!(cfg.wall_range_m(&Matrix3::zeros()), f32::INFINITY);
        assert_eq!(
            cfg.wall_range_m(&Matrix3::from_element(f32::NAN)),
            f32::INFINITY
        );
    }
}
