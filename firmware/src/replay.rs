//! Replaying the recording through `loc-core`: the map loaded from its flashed bytes, the
//! recorded scans and odometry fed to the [`Localizer`] facade and to the stage-by-stage
//! [`StagedPipeline`], with costs per stage and end to end and the pose error against the
//! recorded truth. Shared by the benchmark and the self-tests.

use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::localizer::{Localizer, LocalizerConfig, Status};
use loc_core::map::{MapError, TunnelMap};
use loc_core::scan::Scan;
use nalgebra::Matrix3;

use crate::board::Board;
use crate::pipeline::{Stage, StageCosts, StagedPipeline};
use crate::recorded::{self, BEAMS_PER_SCAN, ODOMETRY, SCAN_COUNT, TRUE_POSES};
use crate::stage_stats::StageStats;

/// Error of the initial pose given to the localiser: along x, along y (metres), heading
/// (radians). The filter must pull it in from the scans.
pub const INITIAL_ERROR: [f32; 3] = [0.3, -0.15, 0.02];

/// 1σ of the initial pose: metres, metres, radians.
pub const INITIAL_SIGMA: [f32; 3] = [0.5, 0.5, 0.05];

/// Results of one replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayReport {
    /// Cost of each stage per scan (stage-by-stage chain), indexed like [`Stage::ALL`].
    pub stages: [StageStats; Stage::ALL.len()],
    /// Sum of the stages per scan.
    pub staged_end_to_end: StageStats,
    /// The `Localizer` facade per scan: odometry prediction, range conversion and
    /// `update_scan`.
    pub localizer_end_to_end: StageStats,
    /// The `Localizer` per scan, without the first scan (which pulls the initial pose error
    /// in, the acquisition case): the steady tracking cost.
    pub localizer_tracking: StageStats,
    /// The scan with the largest staged end-to-end cost, and its per-stage costs.
    pub worst_scan: (usize, StageCosts),
    /// Scans after which the staged chain and the `Localizer` disagreed on the pose (they
    /// run the same code: must be 0).
    pub pose_mismatches: u32,
    /// Scans per status of the `Localizer`: tracking, degenerate, rejected.
    pub statuses: [u32; 3],
    /// Position error against the truth after the last scan, metres.
    pub final_error_m: f32,
    /// Heading error against the truth after the last scan, radians.
    pub final_heading_error_rad: f32,
    /// Largest position error over the second half of the scans, metres.
    pub max_late_error_m: f32,
}

/// Why a replay could not run.
#[derive(Debug, Clone, Copy, PartialEq, defmt::Format)]
pub enum ReplayError {
    /// The initial covariance was rejected by the filter (a bug in the constants above).
    InitialPose,
    /// A recorded scan is missing from flash (a bug in the build script).
    MissingScan(usize),
}

fn initial() -> (Pose2, Matrix3<f32>) {
    let [x, y, th] = TRUE_POSES[0];
    let [ex, ey, eth] = INITIAL_ERROR;
    let [sx, sy, sth] = INITIAL_SIGMA;
    (
        Pose2::new(x + ex, y + ey, th + eth),
        Matrix3::from_diagonal(&nalgebra::Vector3::new(sx * sx, sy * sy, sth * sth)),
    )
}

fn odometry(k: usize) -> OdometryIncrement {
    let [dx_m, dy_m, dtheta_rad] = ODOMETRY.get(k).copied().unwrap_or([0.0; 3]);
    OdometryIncrement {
        dx_m,
        dy_m,
        dtheta_rad,
    }
}

/// Loads the map from its flashed bytes into `map` (in place: a `TunnelMap` is ≈ 140 KiB),
/// returning the cost on `board`'s counter.
pub fn load_map<B: Board>(board: &B, map: &mut TunnelMap) -> Result<u64, MapError> {
    let t0 = board.counter_now();
    map.load_from_bytes(recorded::MAP_BYTES)?;
    Ok(board.counter_now() - t0)
}

/// Where a replay works: large buffers the caller keeps in statics.
pub struct ReplaySlots<'a, 'm> {
    /// The scan buffer (≈ 32 KiB, with its beam-direction table).
    pub scan: &'a mut Scan,
    /// Scratch for the staged chain (≈ 38 KiB).
    pub staged: &'a mut Option<StagedPipeline>,
    /// Scratch for the `Localizer` (≈ 38 KiB).
    pub localizer: &'a mut Option<Localizer<'m, TunnelMap>>,
}

/// Replays every recorded scan through both the staged chain and the `Localizer` against
/// `map` (already loaded, see [`load_map`]).
pub fn replay<'m, B: Board>(
    board: &B,
    map: &'m TunnelMap,
    slots: ReplaySlots<'_, 'm>,
) -> Result<ReplayReport, ReplayError> {
    let ReplaySlots {
        scan,
        staged,
        localizer: localizer_slot,
    } = slots;
    let config = LocalizerConfig::default();
    let (pose0, cov0) = initial();
    let chain = staged
        .insert(StagedPipeline::new(config, pose0, cov0).map_err(|_| ReplayError::InitialPose)?);
    let localizer = localizer_slot
        .insert(Localizer::new(map, config, pose0, cov0).map_err(|_| ReplayError::InitialPose)?);
    let mut report = ReplayReport {
        stages: [StageStats::new(); Stage::ALL.len()],
        staged_end_to_end: StageStats::new(),
        localizer_end_to_end: StageStats::new(),
        localizer_tracking: StageStats::new(),
        worst_scan: (0, StageCosts::default()),
        pose_mismatches: 0,
        statuses: [0; 3],
        final_error_m: f32::INFINITY,
        final_heading_error_rad: f32::INFINITY,
        max_late_error_m: 0.0,
    };
    let mut raw = [0u16; BEAMS_PER_SCAN];
    for (k, &[x, y, th]) in TRUE_POSES.iter().enumerate() {
        if !recorded::load_scan_mm(k, &mut raw) {
            return Err(ReplayError::MissingScan(k));
        }
        let inc = odometry(k);
        let outcome = chain.process(board, map, scan, &raw, &inc);
        for (s, c) in report.stages.iter_mut().zip(outcome.costs.0) {
            s.record(c);
        }
        if outcome.costs.end_to_end() > report.worst_scan.1.end_to_end() {
            report.worst_scan = (k, outcome.costs);
        }
        report.staged_end_to_end.record(outcome.costs.end_to_end());

        let t0 = board.counter_now();
        // A rejected increment leaves the state unchanged; the staged chain does the same.
        let _ = localizer.predict_odometry(&inc);
        scan.load_raw_mm(&localizer.config().sensor, &raw, 1.0, 0.0);
        let status = localizer.update_scan(scan);
        let cost = board.counter_now() - t0;
        report.localizer_end_to_end.record(cost);
        if k > 0 {
            report.localizer_tracking.record(cost);
        }

        let slot = match status {
            Status::Tracking => 0,
            Status::Degenerate { .. } => 1,
            _ => 2,
        };
        report.statuses[slot] += 1;
        let pose = localizer.pose().unwrap_or(Pose2::IDENTITY);
        defmt::info!(
            "scan {=usize}: {} stages {} pose ({=f32}, {=f32}, {=f32}) truth ({=f32}, {=f32}, {=f32})",
            k,
            defmt::Debug2Format(&status),
            outcome.costs.0,
            pose.x_m,
            pose.y_m,
            pose.theta_rad,
            x,
            y,
            th
        );
        if pose != chain.pose() {
            let c = chain.pose();
            defmt::warn!(
                "scan {=usize}: staged chain at ({=f32}, {=f32}, {=f32}) {}",
                k,
                c.x_m,
                c.y_m,
                c.theta_rad,
                defmt::Debug2Format(&outcome.status)
            );
            report.pose_mismatches += 1;
        }
        let err = loc_core::math::hypot(pose.x_m - x, pose.y_m - y);
        if k >= SCAN_COUNT / 2 {
            report.max_late_error_m = report.max_late_error_m.max(err);
        }
        report.final_error_m = err;
        report.final_heading_error_rad =
            loc_core::math::abs(loc_core::math::wrap_angle(pose.theta_rad - th));
    }
    Ok(report)
}
