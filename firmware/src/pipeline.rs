//! The per-scan processing chain the controller runs, stage by stage, with each stage's cost
//! read from the board's counter.
//!
//! Stages today: raw u16 mm ranges → vehicle-frame points ([`loc_core::scan::Scan`]), then
//! vehicle → world transform of every point at the current pose estimate.

use loc_core::geometry::{Point2, Pose2};
use loc_core::scan::{Scan, SensorSetup};

use crate::board::Board;

/// One stage of the per-scan chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Stage {
    /// Raw u16 millimetre ranges to vehicle-frame points (`Scan::load_raw_mm`).
    ScanConversion,
    /// Every valid point mapped into the world frame at the pose estimate.
    WorldTransform,
}

impl Stage {
    /// Every stage, in execution order.
    pub const ALL: [Stage; 2] = [Stage::ScanConversion, Stage::WorldTransform];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::ScanConversion => "scan",
            Stage::WorldTransform => "world",
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

/// The state the chain keeps between scans.
pub struct Pipeline {
    setup: SensorSetup,
    pose: Pose2,
    /// Sum of the world-frame points of the last scan (keeps the transform observable, so the
    /// optimiser cannot drop it).
    last_centroid: Point2,
}

impl Pipeline {
    /// A chain for an LMS511 mounted looking forward at the vehicle origin, starting at
    /// `initial_pose` (world frame).
    pub fn new(initial_pose: Pose2) -> Self {
        Self {
            setup: SensorSetup::lms511_forward(0.0, 0.0),
            pose: initial_pose,
            last_centroid: Point2::ORIGIN,
        }
    }

    /// The current pose estimate, world frame.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// Centroid of the last scan's points in the world frame, metres.
    pub fn last_centroid(&self) -> Point2 {
        self.last_centroid
    }

    /// Processes one scan of raw ranges (mm, 0 = no echo) into `scan` (reused buffer) and
    /// returns what each stage cost on `board`'s counter.
    pub fn process<B: Board>(&mut self, board: &B, scan: &mut Scan, raw_mm: &[u16]) -> StageCosts {
        let mut costs = StageCosts::default();
        let t0 = board.counter_now();
        scan.load_raw_mm(&self.setup, raw_mm, 1.0, 0.0);
        let t1 = board.counter_now();
        let mut sum = Point2::ORIGIN;
        for p in scan.points() {
            sum = sum.add(self.pose.transform_point(p.vehicle));
        }
        let n = scan.len().max(1) as f32;
        self.last_centroid = sum.scale(1.0 / n);
        let t2 = board.counter_now();
        costs.0[0] = t1 - t0;
        costs.0[1] = t2 - t1;
        costs
    }
}
