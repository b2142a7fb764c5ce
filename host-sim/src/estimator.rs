//! loc-core's `Localizer` as the estimator of a closed-loop run, fed exactly as on the
//! vehicle: each odometry reading becomes an `OdometryIncrement` prediction, each scan's
//! `u16` millimetre ranges become a `Scan` (through the same `SensorSetup` the firmware
//! would use) and go through `update_scan`.
//!
//! The localiser is configured for the simulated sensor: the beam layout of the scan (start
//! angle and exact step), the mounting pose, the range noise σ, and the chosen matcher.
//! Everything else is loc-core's default tuning.

use loc_core::filter::{OdometryIncrement, UpdateConfig};
use loc_core::geometry::Pose2;
use loc_core::localizer::{Localizer, LocalizerConfig, RejectReason, Status};
use loc_core::map::TunnelMap;
use loc_core::matching::MatcherKind;
use loc_core::scan::{Scan, ScanGeometry, SensorSetup};
use nalgebra::Matrix3;

use crate::closed_loop::{Estimator, EstimatorOutput};
use crate::lidar::{first_beam_angle_rad, LidarScan, LidarSpec};
use crate::scenario::{MatcherChoice, Scenario};
use crate::vehicle::odometry::OdometrySample;
use crate::vehicle::SimPose;

/// The sensor setup loc-core gets for a simulated LMS511.
pub fn sensor_setup(lidar: &LidarSpec) -> SensorSetup {
    SensorSetup {
        geometry: ScanGeometry {
            start_angle_rad: first_beam_angle_rad() as f32,
            step_rad: lidar.rate.step_rad() as f32,
            min_range_m: ScanGeometry::LMS511_MIN_RANGE_M,
            max_range_m: lidar.max_range_m as f32,
        },
        mounting: Pose2::new(
            lidar.mount_x_m as f32,
            lidar.mount_y_m as f32,
            lidar.mount_yaw_rad as f32,
        ),
    }
}

/// The localiser configuration for a scenario.
pub fn localizer_config(scenario: &Scenario) -> LocalizerConfig {
    let mut cfg = LocalizerConfig {
        sensor: sensor_setup(&scenario.lidar),
        ..LocalizerConfig::default()
    };
    cfg.matching.matcher = match scenario.localizer.matcher {
        MatcherChoice::Hausdorff => MatcherKind::Hausdorff,
        MatcherChoice::Icp => MatcherKind::Icp,
    };
    // The matcher's covariance is scaled by the sensor's noise (floored: a noiseless
    // simulation must not claim infinite precision).
    cfg.matching.range_noise_sigma_m = (scenario.lidar.range_noise_m as f32).max(0.003);
    cfg.update = UpdateConfig::for_matcher(&cfg.matching);
    cfg
}

/// A short label for a status (the run log's per-scan status).
pub fn status_label(status: &Status) -> String {
    match status {
        Status::NotInitialised => "not-initialised".into(),
        Status::DeadReckoning => "dead-reckoning".into(),
        Status::Tracking => "tracking".into(),
        Status::Degenerate { .. } => "degenerate".into(),
        Status::MatchRejected { reason } => match reason {
            RejectReason::TooFewPoints { .. } => "rejected:too-few-points".into(),
            RejectReason::TooFewAssociations { .. } => "rejected:too-few-associations".into(),
            RejectReason::DidNotConverge { .. } => "rejected:no-convergence".into(),
            RejectReason::FailedGate { .. } => "rejected:gate".into(),
            RejectReason::NothingObserved => "rejected:nothing-observed".into(),
            RejectReason::NonFinite => "rejected:non-finite".into(),
        },
    }
}

/// The covariance of one odometry increment the vehicle integration hands the localiser
/// (vehicle frame, `(dx, dy, dθ)`): a random walk in distance travelled, so the variance
/// of a stretch of odometry grows with its length whatever the odometry rate (a model
/// proportional to each increment's own length would shrink with the rate and make the
/// filter overconfident at 100 Hz). Along: `f² · L · d`; across: a third of that in σ;
/// heading: `h² · L · d` plus 5 % of the turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryCovarianceModel {
    /// `f`: 1σ drift as a fraction of distance over the correlation length.
    pub drift_fraction: f64,
    /// `L`: correlation length, metres.
    pub drift_length_m: f64,
    /// `h`: heading drift, rad/m.
    pub heading_drift_rad_per_m: f64,
}

impl OdometryCovarianceModel {
    /// The model a scenario specifies.
    pub fn of(scenario: &Scenario) -> Self {
        let c = &scenario.localizer;
        Self {
            drift_fraction: c.odometry_drift_fraction,
            drift_length_m: c.odometry_drift_length_m,
            heading_drift_rad_per_m: c.odometry_heading_drift_rad_per_m,
        }
    }

    /// The covariance of an increment `(dx, dy, dθ)`.
    pub fn covariance(&self, delta: (f64, f64, f64)) -> Matrix3<f32> {
        let d = delta.0.hypot(delta.1);
        let along = self.drift_fraction.powi(2) * self.drift_length_m * d + 1e-10;
        let across = along / 9.0;
        let heading = self.heading_drift_rad_per_m.powi(2) * self.drift_length_m * d
            + (0.05 * delta.2).powi(2)
            + 1e-12;
        Matrix3::from_diagonal(&nalgebra::Vector3::new(
            along as f32,
            across as f32,
            heading as f32,
        ))
    }
}

/// loc-core's localiser over a stored map, driven like on the vehicle.
pub struct LocCoreEstimator<'m> {
    localizer: Box<Localizer<'m, TunnelMap>>,
    setup: SensorSetup,
    scan: Box<Scan>,
    matcher: MatcherChoice,
    odometry_model: OdometryCovarianceModel,
    last_reset: SimPose,
}

impl<'m> LocCoreEstimator<'m> {
    /// A localiser over `map`, configured for `scenario`'s sensor and matcher.
    pub fn new(map: &'m TunnelMap, scenario: &Scenario) -> Self {
        let cfg = localizer_config(scenario);
        Self {
            localizer: Box::new(Localizer::uninitialised(map, cfg)),
            setup: cfg.sensor,
            scan: Box::new(Scan::new()),
            matcher: scenario.localizer.matcher,
            odometry_model: OdometryCovarianceModel::of(scenario),
            last_reset: SimPose::default(),
        }
    }

    /// The localiser (for inspection: last strip, last match).
    pub fn localizer(&self) -> &Localizer<'m, TunnelMap> {
        &self.localizer
    }
}

impl Estimator for LocCoreEstimator<'_> {
    fn name(&self) -> String {
        format!("loc-core {}", self.matcher.name())
    }

    fn reset(&mut self, pose: SimPose, sigma_m: f64, sigma_rad: f64) {
        self.last_reset = pose;
        let (v, w) = ((sigma_m * sigma_m) as f32, (sigma_rad * sigma_rad) as f32);
        let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(v, v, w));
        let p = Pose2::new(pose.x_m as f32, pose.y_m as f32, pose.theta_rad as f32);
        // Only a non-finite pose is refused; the run then reports "not-initialised".
        let _ = self.localizer.initialise(p, cov);
    }

    fn odometry(&mut self, s: &OdometrySample) {
        let inc = OdometryIncrement {
            dx_m: s.delta.0 as f32,
            dy_m: s.delta.1 as f32,
            dtheta_rad: s.delta.2 as f32,
        };
        // A rejected increment leaves the state unchanged, as on the vehicle.
        let q = self.odometry_model.covariance(s.delta);
        let _ = self.localizer.predict_odometry_with_covariance(&inc, &q);
    }

    fn scan(&mut self, scan: &LidarScan) -> EstimatorOutput {
        self.scan
            .load_raw_mm(&self.setup, &scan.ranges_mm, 1.0, 0.0);
        let status = self.localizer.update_scan(&self.scan);
        let pose = self.localizer.pose().map_or(self.last_reset, |p| SimPose {
            x_m: f64::from(p.x_m),
            y_m: f64::from(p.y_m),
            theta_rad: f64::from(p.theta_rad),
        });
        let sigma = self.localizer.covariance().map_or((0.0, 0.0, 0.0), |c| {
            (
                f64::from(c[0][0]).max(0.0).sqrt(),
                f64::from(c[1][1]).max(0.0).sqrt(),
                f64::from(c[2][2]).max(0.0).sqrt(),
            )
        });
        EstimatorOutput {
            pose,
            sigma,
            status: status_label(&status),
        }
    }
}
