//! The per-scan chain of `loc-core`, run stage by stage with each stage's cost read from the
//! board's counter: the same calls, in the same order and with the same configuration, as
//! [`loc_core::localizer::Localizer::update_scan`] makes (the benchmark checks both end at the
//! same pose), plus the conversion of the raw ranges before and the odometry prediction.
//!
//! Stages: raw u16 mm → vehicle-frame points; wall stripping; match-point selection;
//! pre-aligned Hausdorff (or PL-ICP) matching; EKF prediction and update.

use loc_core::filter::{Ekf, FilterInitError, OdometryIncrement, OdometryRejection};
use loc_core::geometry::Pose2;
use loc_core::localizer::{position_sd_m, LocalizerConfig, RejectReason, Status};
use loc_core::map::MapQuery;
use loc_core::matching::{
    match_scan_with_prealign, select_match_points, MatchPoints, MatchWorkspace,
};
use loc_core::scan::{Scan, LMS511_MAX_BEAMS};
use loc_core::strip::{strip_walls, PointLabel, StripSummary};
use nalgebra::Matrix3;

use crate::board::Board;

/// One stage of the per-scan chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Stage {
    /// Raw u16 millimetre ranges to vehicle-frame points (`Scan::load_raw_mm`).
    ScanConversion,
    /// RANSAC cubic wall fits and point labels (`strip_walls`).
    Strip,
    /// Match points: every landmark point and decimated wall points (`select_match_points`).
    Select,
    /// Landmark pre-alignment along the tunnel and scan-to-map matching, re-run once after a
    /// second pre-alignment when that moves the pose (`match_scan_with_prealign`; modified
    /// Hausdorff by default).
    Match,
    /// EKF odometry prediction and match update (`Ekf::predict`, `Ekf::update_with_match`).
    Filter,
}

impl Stage {
    /// Every stage, in execution order.
    pub const ALL: [Stage; 5] = [
        Stage::ScanConversion,
        Stage::Strip,
        Stage::Select,
        Stage::Match,
        Stage::Filter,
    ];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::ScanConversion => "scan",
            Stage::Strip => "strip",
            Stage::Select => "select",
            Stage::Match => "match",
            Stage::Filter => "filter",
        }
    }
}

/// Cost of each stage for one scan, in the board's counter unit, indexed like [`Stage::ALL`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageCosts(pub [u64; Stage::ALL.len()]);

impl StageCosts {
    /// Sum over the stages: the end-to-end cost of the scan.
    pub fn end_to_end(&self) -> u64 {
        self.0.iter().sum()
    }
}

/// What one scan produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanOutcome {
    /// Per-stage cost.
    pub costs: StageCosts,
    /// The walls found and the label counts.
    pub strip: StripSummary,
    /// The status the [`loc_core::localizer::Localizer`] would report after this scan.
    pub status: Status,
    /// Whether the odometry increment was accepted (a rejected one leaves the state as it was).
    pub odometry: Result<(), OdometryRejection>,
}

/// The chain's state between scans (≈ 38 KiB: keep it in a static).
pub struct StagedPipeline {
    config: LocalizerConfig,
    ekf: Ekf,
    labels: [PointLabel; LMS511_MAX_BEAMS],
    match_points: MatchPoints,
    workspace: MatchWorkspace,
}

impl StagedPipeline {
    /// A chain with `config`, starting at `initial_pose` (world frame) with covariance
    /// `initial_cov` of `(x_m, y_m, theta_rad)`.
    pub fn new(
        config: LocalizerConfig,
        initial_pose: Pose2,
        initial_cov: Matrix3<f32>,
    ) -> Result<Self, FilterInitError> {
        Ok(Self {
            config,
            ekf: Ekf::new(initial_pose, initial_cov)?,
            labels: [PointLabel::Outlier; LMS511_MAX_BEAMS],
            match_points: MatchPoints::new(),
            workspace: MatchWorkspace::new(),
        })
    }

    /// The pose estimate, world frame.
    pub fn pose(&self) -> Pose2 {
        self.ekf.pose()
    }

    /// Predicts with `odometry`, converts `raw_mm` (0 = no echo) into `scan` (a reused
    /// buffer), runs every stage against `map`, and returns each stage's cost on `board`'s
    /// counter.
    pub fn process<B: Board, M: MapQuery>(
        &mut self,
        board: &B,
        map: &M,
        scan: &mut Scan,
        raw_mm: &[u16],
        odometry: &OdometryIncrement,
    ) -> ScanOutcome {
        let cfg = &self.config;
        let t0 = board.counter_now();
        // A rejected increment leaves the state unchanged, as in the Localizer.
        let odometry = self.ekf.predict(odometry, &cfg.odometry);
        let t1 = board.counter_now();
        scan.load_raw_mm(&cfg.sensor, raw_mm, 1.0, 0.0);
        let t2 = board.counter_now();
        let points = scan.points();
        let n = points.len().min(self.labels.len());
        let labels = self.labels.get_mut(..n).unwrap_or_default();
        let strip = strip_walls(points, &cfg.strip, labels);
        let t3 = board.counter_now();
        select_match_points(
            points,
            labels,
            cfg.max_wall_points,
            cfg.wall_range_m(&self.ekf.covariance()),
            &mut self.match_points,
        );
        let t4 = board.counter_now();
        let matched = match_scan_with_prealign(
            map,
            points,
            labels,
            &strip,
            &self.match_points,
            self.ekf.pose(),
            position_sd_m(&self.ekf.covariance()),
            &cfg.prealign,
            &cfg.matching,
            &mut self.workspace,
        );
        let t5 = board.counter_now();
        let status = match matched {
            Err(e) => Status::MatchRejected { reason: e.into() },
            Ok(guided) => {
                let result = guided.result;
                let mut update = cfg.update;
                update.min_information_per_m2 = cfg.matching.min_information_per_m2();
                update.rotation_scale_m = cfg.matching.rotation_scale_m;
                match self.ekf.update_with_match(&result, &update) {
                    Err(e) => Status::MatchRejected {
                        reason: RejectReason::from(e),
                    },
                    Ok(_) if result.degeneracy.degenerate => Status::Degenerate {
                        direction_world: result.degeneracy.direction_world,
                        eigenvalue_per_m2: result.degeneracy.min_eigenvalue_per_m2,
                    },
                    Ok(_) => Status::Tracking,
                }
            }
        };
        let t6 = board.counter_now();
        ScanOutcome {
            costs: StageCosts([t2 - t1, t3 - t2, t4 - t3, t5 - t4, (t1 - t0) + (t6 - t5)]),
            strip,
            status,
            odometry,
        }
    }
}
