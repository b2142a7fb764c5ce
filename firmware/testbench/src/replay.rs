//! Replaying the recording through the product's [`Controller`]: the map and the start pose
//! read from their flashed bytes as the controller reads them, each recorded telegram
//! decoded and localised by the controller's own scan step (`Controller::on_scan`: predict
//! with the recorded odometry, load the scan, localise), with the cost of each stage as the
//! pose frames carry it (plus the telegram's check, the session's work on the vehicle) and
//! end to end, and the pose error against the recorded truth. Shared by the benchmark and
//! the self-tests.

use firmware::board::Board;
use firmware::controller::Controller;
use lidar_driver::{Frame, ScanData};
use loc_core::filter::OdometryIncrement;
use loc_core::localizer::{StartPose, StartPoseError, Status};
use loc_core::map::{MapError, MapImage};
use loc_core::scan::SweepMotion;

use crate::recorded::{self, ODOMETRY, SCAN_COUNT, TRUE_POSES};
use crate::stage_stats::StageStats;
use firmware::stage_costs::{ScanStage, StageCosts, StageTimer};

/// Results of one replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayReport {
    /// Cost of each stage per scan, indexed like [`ScanStage::ALL`].
    pub stages: [StageStats; ScanStage::ALL.len()],
    /// The controller's whole per-scan work: prediction, telegram to scan, localisation.
    pub end_to_end: StageStats,
    /// The same without the first scan (which pulls the start pose's error in, the
    /// acquisition case): the steady tracking cost.
    pub tracking: StageStats,
    /// The scan with the largest end-to-end cost, and its per-stage costs.
    pub worst_scan: (usize, StageCosts),
    /// Scans per status: tracking, degenerate, rejected, map unconfirmed, relocalising.
    pub statuses: [u32; 5],
    /// End-to-end cost of the scans the controller was relocalising on (the search in the
    /// match stage's place).
    pub relocalising: StageStats,
    /// The first scan reported tracking (`None`: none).
    pub first_tracking_scan: Option<usize>,
    /// Scans reported tracking with the position more than 0.3 m off the truth.
    pub wrong_tracking_scans: u32,
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
    /// The recorded start pose does not read (a bug in the build script).
    StartPose,
    /// The start covariance was rejected by the filter.
    InitialPose,
    /// A recorded telegram is missing or does not decode (a bug in the build script).
    Telegram(usize),
}

/// The recorded start pose, read as the controller reads its flash record.
pub fn start_pose() -> Result<StartPose, StartPoseError> {
    StartPose::from_bytes(recorded::START_POSE_BYTES)
}

/// Time between the recording's scans, seconds (25 Hz).
const SCAN_PERIOD_S: f32 = 0.04;

fn odometry(k: usize) -> OdometryIncrement {
    let [dx_m, dy_m, dtheta_rad] = ODOMETRY.get(k).copied().unwrap_or([0.0; 3]);
    OdometryIncrement {
        dx_m,
        dy_m,
        dtheta_rad,
    }
}

/// Opens the map image in the board's map flash region as the controller does (the
/// program's map, `firmware::flash_map::MAP`), returning it and the cost of its checks on
/// `board`'s counter (the first call's: the image is opened once).
pub fn load_map<B: Board>(board: &B) -> Result<(&'static MapImage<'static>, u64), MapError> {
    let t0 = board.counter_now();
    let map = firmware::controller::load_map(board.map_region())?;
    Ok((map, board.counter_now() - t0))
}

/// How a replay starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ReplayStart {
    /// At the recorded start pose (0.34 m and 0.02 rad off the truth), as from the
    /// start-pose record.
    RecordedPose,
    /// Without a pose: the controller relocalises, as without a start-pose record.
    Relocalise,
}

/// Replays every recorded telegram through `controller` (its map opened, see [`load_map`]),
/// started afresh as `start` says.
pub fn replay<B: Board>(
    board: &B,
    controller: &mut Controller<'_>,
    start: ReplayStart,
) -> Result<ReplayReport, ReplayError> {
    match start {
        ReplayStart::RecordedPose => {
            let start = start_pose().map_err(|_| ReplayError::StartPose)?;
            controller
                .start(&start)
                .map_err(|_| ReplayError::InitialPose)?;
        }
        ReplayStart::Relocalise => controller.relocalise(),
    }
    let mut report = ReplayReport {
        stages: [StageStats::new(); ScanStage::ALL.len()],
        end_to_end: StageStats::new(),
        tracking: StageStats::new(),
        worst_scan: (0, StageCosts::default()),
        statuses: [0; 5],
        relocalising: StageStats::new(),
        first_tracking_scan: None,
        wrong_tracking_scans: 0,
        final_error_m: f32::INFINITY,
        final_heading_error_rad: f32::INFINITY,
        max_late_error_m: 0.0,
    };
    for (k, &[x, y, th]) in TRUE_POSES.iter().enumerate() {
        let bytes = recorded::telegram(k).ok_or(ReplayError::Telegram(k))?;
        // The telegram's check (the session's work in the product) counts for the scan stage;
        // then the product's own scan step, timed by stage as in every pose frame.
        let mut timer = StageTimer::new(board);
        let t0 = board.counter_now();
        let telegram = Frame::new_checked(bytes)
            .ok()
            .and_then(|f| ScanData::new_checked(f).ok())
            .ok_or(ReplayError::Telegram(k))?;
        timer.add_since(ScanStage::Scan, t0);
        // The odometry's rate at the scan (the recording's vehicle is already moving at its
        // first: the rate there is the next interval's).
        if let Some(rate) = SweepMotion::from_motion(&odometry(k.max(1)).as_pose(), SCAN_PERIOD_S) {
            controller.hint_sweep_speed(&rate);
        }
        let frame = controller
            .on_scan(&telegram, Some(&odometry(k)), &mut timer)
            .map_err(|_| ReplayError::Telegram(k))?;
        let t3 = board.counter_now();

        let costs = timer.costs;
        for (s, c) in report.stages.iter_mut().zip(costs.0) {
            s.record(c);
        }
        let cost = t3 - t0;
        report.end_to_end.record(cost);
        if k > 0 {
            report.tracking.record(cost);
        }
        if costs.total() > report.worst_scan.1.total() {
            report.worst_scan = (k, costs);
        }
        let status = controller.localizer().status();
        report.statuses[match status {
            Status::Tracking => 0,
            Status::Degenerate { .. } => 1,
            Status::MapUnconfirmed { .. } => 3,
            Status::Relocalising { .. } => 4,
            _ => 2,
        }] += 1;
        if matches!(status, Status::Relocalising { .. }) {
            report.relocalising.record(cost);
        }
        defmt::info!(
            "scan {=usize}: {} stages {} pose ({=f32}, {=f32}, {=f32}) truth ({=f32}, {=f32}, {=f32})",
            k,
            frame.status,
            costs.0,
            frame.x_m,
            frame.y_m,
            frame.theta_rad,
            x,
            y,
            th
        );
        let err = loc_core::math::hypot(frame.x_m - x, frame.y_m - y);
        if status == Status::Tracking {
            report.first_tracking_scan.get_or_insert(k);
            if err > 0.3 {
                report.wrong_tracking_scans += 1;
            }
        }
        if k >= SCAN_COUNT / 2 {
            report.max_late_error_m = report.max_late_error_m.max(err);
        }
        report.final_error_m = err;
        report.final_heading_error_rad =
            loc_core::math::abs(loc_core::math::wrap_angle(frame.theta_rad - th));
    }
    Ok(report)
}
