//! The per-scan processing chain the controller runs, stage by stage, with each stage's cost
//! read from the board's counter.
//!
//! Stages: raw u16 mm ranges → vehicle-frame points ([`loc_core::scan::Scan`]); wall
//! stripping ([`loc_core::strip::strip_walls`]).

use loc_core::geometry::Pose2;
use loc_core::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};
use loc_core::strip::{strip_walls, PointLabel, StripConfig, StripSummary};

use crate::board::Board;

/// One stage of the per-scan chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Stage {
    /// Raw u16 millimetre ranges to vehicle-frame points (`Scan::load_raw_mm`).
    ScanConversion,
    /// RANSAC cubic wall fits and point labels (`strip_walls`).
    Strip,
}

impl Stage {
    /// Every stage, in execution order.
    pub const ALL: [Stage; 2] = [Stage::ScanConversion, Stage::Strip];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::ScanConversion => "scan",
            Stage::Strip => "strip",
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
}

/// The state the chain keeps between scans (about 1.2 KiB plus the caller's [`Scan`]).
pub struct Pipeline {
    setup: SensorSetup,
    strip_config: StripConfig,
    labels: [PointLabel; LMS511_MAX_BEAMS],
    pose: Pose2,
}

impl Pipeline {
    /// A chain for an LMS511 mounted looking forward at the vehicle origin, starting at
    /// `initial_pose` (world frame).
    pub fn new(initial_pose: Pose2) -> Self {
        Self {
            setup: SensorSetup::lms511_forward(0.0, 0.0),
            strip_config: StripConfig::default(),
            labels: [PointLabel::Outlier; LMS511_MAX_BEAMS],
            pose: initial_pose,
        }
    }

    /// The current pose estimate, world frame.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// Labels of the last scan's points (beam order of [`Scan::points`]).
    pub fn labels(&self) -> &[PointLabel] {
        &self.labels
    }

    /// Processes one scan of raw ranges (mm, 0 = no echo) into `scan` (reused buffer) and
    /// returns what each stage cost on `board`'s counter.
    pub fn process<B: Board>(&mut self, board: &B, scan: &mut Scan, raw_mm: &[u16]) -> ScanOutcome {
        let mut costs = StageCosts::default();
        let t0 = board.counter_now();
        scan.load_raw_mm(&self.setup, raw_mm, 1.0, 0.0);
        let t1 = board.counter_now();
        let strip = strip_walls(scan.points(), &self.strip_config, &mut self.labels);
        let t2 = board.counter_now();
        costs.0 = [t1 - t0, t2 - t1];
        ScanOutcome { costs, strip }
    }
}
