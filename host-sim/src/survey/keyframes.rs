//! The survey's front end: the recorded drive localised against the prior map by loc-core's
//! localiser (exactly `host-sim replay`), then, at a keyframe every few decimetres driven,
//! the scan's points in the vehicle frame with loc-core's wall stripping of them — the same
//! conversion ([`scan_input::load_values`]) and the same stripper the localiser ran.
//!
//! The localiser's poses only start the joint estimate ([`super::graph`]) and pair the scans'
//! landmarks with the map's; the map the survey writes comes from the scans.

use loc_core::geometry::Pose2;
use loc_core::scan::{Scan, SweepMotion};
use loc_core::strip::{strip_walls, PointLabel};

use crate::estimator::{localizer_config, scan_stamp_us};
use crate::replay::scan_source::ScanStream;
use crate::replay::{replay_with, Replay, ReplayOptions, ReplaySources, ReplayStep};
use crate::scenario::Scenario;
use crate::session::EstimatorChoice;
use crate::status::EstimatorStatus;
use crate::vehicle::SimPose;

use super::SurveyError;

/// One scan the survey uses.
#[derive(Debug, Clone)]
pub struct Keyframe {
    /// Index of the scan in the recording.
    pub scan_index: usize,
    /// Scan time, seconds.
    pub t_s: f64,
    /// The estimator's pose (the localiser's against the prior map, or dead reckoning),
    /// world frame.
    pub guess: SimPose,
    /// Whether the localiser was tracking at this scan.
    pub tracking: bool,
    /// Dead reckoning from the odometry log at the scan, world frame.
    pub odometry: SimPose,
    /// Every usable echo, vehicle frame, metres.
    pub points: Vec<(f64, f64)>,
    /// loc-core's label of each point.
    pub labels: Vec<PointLabel>,
}

/// The front end's result.
#[derive(Debug)]
pub struct FrontEnd {
    /// The keyframes, in time order.
    pub keyframes: Vec<Keyframe>,
    /// The localiser's replay against the prior map (its warnings, its map).
    pub replay: Replay,
    /// Scans in the recording.
    pub scans: usize,
}

/// Runs `estimator` over the drive — the localiser against the prior map, or
/// dead reckoning from the odometry alone for a survey without one ([`super::bootstrap`]) —
/// and keeps a keyframe whenever the odometry has moved `spacing_m` (or turned 0.05 rad)
/// since the last one. `progress(fraction)` is called as the scans are read again.
pub fn run(
    sources: &ReplaySources,
    scenario: &Scenario,
    spacing_m: f64,
    estimator: EstimatorChoice,
    progress: &dyn Fn(f64),
) -> Result<FrontEnd, SurveyError> {
    let options = ReplayOptions {
        keep_scans: false,
        ..ReplayOptions::default()
    };
    let replay = replay_with(sources, estimator, &options)?;
    let config = localizer_config(scenario);
    let mut stream = ScanStream::open(&sources.scanner, sources.scanner_times.as_deref())
        .map_err(crate::replay::ReplayError::from)?;
    let mut scan = Box::new(Scan::new());
    let mut labels = vec![PointLabel::Outlier; loc_core::scan::LMS511_MAX_BEAMS];
    let mut keyframes: Vec<Keyframe> = Vec::new();
    let total = replay.steps.len().max(1);
    let mut index = 0usize;
    while let Some(lidar) = stream
        .next_scan()
        .map_err(crate::replay::ReplayError::from)?
    {
        let Some(step) = replay.steps.get(index) else {
            return Err(SurveyError::ScansChanged);
        };
        if step.t_s != lidar.t_s {
            return Err(SurveyError::ScansChanged);
        }
        index += 1;
        if index % 256 == 0 {
            progress(index as f64 / total as f64);
        }
        if let Some(last) = keyframes.last() {
            let moved = last.odometry.between(step.odometry);
            if moved.x_m.hypot(moved.y_m) < spacing_m && moved.theta_rad.abs() < 0.05 {
                continue;
            }
        }
        if scan_input::load_values(
            &lidar.layout,
            lidar.selected(scenario.localizer.echo.selection()),
            lidar.scale_factor,
            lidar.scale_offset_mm,
            &config.sensor,
            &mut scan,
        )
        .is_err()
        {
            continue;
        }
        // A sweeping scanner's scan, carried to its last beam as the localiser carried it,
        // at the speed the estimates around it give (hindsight).
        if config.deskew {
            scan.set_timing(lidar.layout.timing(scan_stamp_us(lidar.t_s)));
            if let Some(m) = sweep_motion(&replay.steps, index - 1) {
                scan.deskew(&m);
            }
        }
        let points = scan.points();
        strip_walls(points, &config.strip, &mut labels);
        keyframes.push(Keyframe {
            scan_index: index - 1,
            t_s: step.t_s,
            guess: step.estimate,
            tracking: matches!(
                step.status,
                EstimatorStatus::Localizer(loc_core::localizer::Status::Tracking)
            ),
            odometry: step.odometry,
            points: points
                .iter()
                .map(|p| (f64::from(p.vehicle.x_m), f64::from(p.vehicle.y_m)))
                .collect(),
            labels: labels.iter().take(points.len()).copied().collect(),
        });
    }
    progress(1.0);
    Ok(FrontEnd {
        keyframes,
        scans: index,
        replay,
    })
}

/// Half the span of the estimates a keyframe's sweep speed is taken over, seconds.
const SWEEP_HALF_SPAN_S: f64 = 0.1;
/// Longest span used, seconds (across a gap the estimates say nothing of the sweep).
const MAX_SWEEP_SPAN_S: f64 = 0.5;

/// The vehicle's speed over the sweep of scan `index`: the constant twist between the
/// estimates about [`SWEEP_HALF_SPAN_S`] before and after it (the first or last scan on
/// the edges of the drive).
fn sweep_motion(steps: &[ReplayStep], index: usize) -> Option<SweepMotion> {
    let t_s = steps.get(index)?.t_s;
    let (earlier, later) = (steps.get(..index)?, steps.get(index..)?);
    let before = earlier
        .iter()
        .rev()
        .find(|s| t_s - s.t_s >= SWEEP_HALF_SPAN_S)
        .or(earlier.first())
        .or(later.first())?;
    let after = later
        .iter()
        .find(|s| s.t_s - t_s >= SWEEP_HALF_SPAN_S)
        .or(later.last())?;
    let span_s = after.t_s - before.t_s;
    if span_s > MAX_SWEEP_SPAN_S {
        return None;
    }
    let m = before.estimate.between(after.estimate);
    SweepMotion::from_motion(
        &Pose2::new(m.x_m as f32, m.y_m as f32, m.theta_rad as f32),
        span_s as f32,
    )
}
