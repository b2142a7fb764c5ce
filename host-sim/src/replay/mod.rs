//! `host-sim replay DIR`: localises from a recording (one written by `run --record`, or a
//! real vehicle's) through lidar-driver and loc-core, driving the very estimator a live run
//! uses ([`LocCoreEstimator`]) in the same order (every odometry reading up to a scan's time,
//! then the scan), and scores it with the same metrics ([`crate::metrics`]) when ground truth
//! is there.
//!
//! A replay of a simulated run gives the run's figures: the scans carry the same `u16`
//! millimetre ranges the live localiser got, the odometry CSV and the initial pose hold the
//! run's `f64` values exactly, and the odometry-alone baseline is integrated from the same
//! readings by the same arc integration as the simulator's odometry.

pub mod bound;
pub mod external;
pub mod odometry_check;
pub mod scan_source;
pub mod truth;

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

use loc_core::map::{MapError, TunnelMap};

use crate::closed_loop::{Estimator, OdometryOnly, RunLog, WorldSummary};
use crate::estimator::LocCoreEstimator;
use crate::metrics::Sample;
use crate::record::csv_table::CsvError;
use crate::record::initial_pose::{self, InitialPose};
use crate::record::{files, odometry_csv, truth_csv};
use crate::scenario::{EchoChoice, Scenario, ScenarioError};
use crate::session::EstimatorChoice;
use crate::status::EstimatorStatus;
use crate::vehicle::SimPose;

use external::{EstimatesError, ExternalEstimates};
use odometry_check::OdometryError;
use scan_source::{ScanSourceError, ScanStream};

/// The files a replay reads.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplaySources {
    /// Scanner stream: raw CoLa bytes, pcap/pcapng or `.pcapng.json`.
    pub scanner: PathBuf,
    /// Scan receive times (`index, t_s`), if any.
    pub scanner_times: Option<PathBuf>,
    /// Odometry CSV.
    pub odometry: PathBuf,
    /// loc-core map file.
    pub map: PathBuf,
    /// Scenario TOML (sensor, localiser settings, tunnel for the metrics).
    pub scenario: PathBuf,
    /// Initial pose CSV; without it the first ground-truth row and the scenario's σ are used.
    pub initial_pose: Option<PathBuf>,
    /// Ground truth CSV; without it there are no metrics.
    pub ground_truth: Option<PathBuf>,
}

/// Scanner file names looked for in a directory, in this order.
pub const SCANNER_CANDIDATES: [&str; 5] = [
    files::SCANNER,
    "scanner.pcapng",
    "scanner.pcapng.json",
    "scanner.pcap",
    "scanner.colab.txt",
];

impl ReplaySources {
    /// The files of a recording directory by their standard names ([`files`]); the scanner
    /// stream may also be `scanner.pcapng`, `scanner.pcapng.json` or `scanner.pcap`.
    pub fn in_dir(dir: &Path) -> Result<Self, ReplayError> {
        if !dir.is_dir() {
            return Err(ReplayError::NotADirectory(dir.to_path_buf()));
        }
        let existing = |name: &str| Some(dir.join(name)).filter(|p| p.is_file());
        let required = |name: &'static str| {
            existing(name).ok_or(ReplayError::MissingFile {
                dir: dir.to_path_buf(),
                name,
            })
        };
        Ok(Self {
            scanner: SCANNER_CANDIDATES.iter().find_map(|n| existing(n)).ok_or(
                ReplayError::MissingFile {
                    dir: dir.to_path_buf(),
                    name: files::SCANNER,
                },
            )?,
            scanner_times: existing(files::SCANNER_TIMES),
            odometry: required(files::ODOMETRY)?,
            map: required(files::MAP)?,
            scenario: required(files::SCENARIO)?,
            initial_pose: existing(files::INITIAL_POSE),
            ground_truth: existing(files::GROUND_TRUTH),
        })
    }
}

/// Why a replay could not run.
#[derive(Debug)]
pub enum ReplayError {
    /// The path is not a directory.
    NotADirectory(PathBuf),
    /// A required file is missing.
    MissingFile {
        /// The directory.
        dir: PathBuf,
        /// The file's standard name.
        name: &'static str,
    },
    /// A file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The scanner stream is unusable.
    Scans(ScanSourceError),
    /// A CSV file is unusable.
    Csv(CsvError),
    /// The odometry log cannot be right.
    Odometry(OdometryError),
    /// The scenario is wrong.
    Scenario(ScenarioError),
    /// The map file is not a loc-core map.
    Map {
        /// The file.
        path: PathBuf,
        /// loc-core's reason.
        source: MapError,
    },
    /// Neither an initial pose nor ground truth to start from.
    NoInitialPose,
    /// Another localiser's estimates file cannot be scored.
    Estimates(EstimatesError),
    /// The odometry and the scans do not overlap in time.
    ClocksDisagree {
        /// First and last odometry time, s.
        odometry_s: (f64, f64),
        /// First and last scan time, s.
        scans_s: (f64, f64),
    },
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::NotADirectory(p) => write!(
                f,
                "{} is not a directory (give a directory written by `host-sim run --record`)",
                p.display()
            ),
            ReplayError::MissingFile { dir, name } => write!(
                f,
                "{} has no {name} (see README.txt of a recording for the files a replay needs)",
                dir.display()
            ),
            ReplayError::Io { path, source } => {
                write!(f, "cannot read {}: {source}", path.display())
            }
            ReplayError::Scans(e) => write!(f, "{e}"),
            ReplayError::Csv(e) => write!(f, "{e}"),
            ReplayError::Odometry(e) => write!(f, "{e}"),
            ReplayError::ClocksDisagree {
                odometry_s: (o0, o1),
                scans_s: (s0, s1),
            } => write!(
                f,
                "the odometry (t = {o0:.3}…{o1:.3} s) and the scans (t = {s0:.3}…{s1:.3} s) do not overlap: they are on different clocks; give the scans' receive times (--scanner-times) or put the odometry on the scans' clock"
            ),
            ReplayError::Scenario(e) => write!(f, "{e}"),
            ReplayError::Estimates(e) => write!(f, "{e}"),
            ReplayError::Map { path, source } => write!(
                f,
                "{} is not a usable loc-core map file: {source} (write one with `host-sim export-map`)",
                path.display()
            ),
            ReplayError::NoInitialPose => write!(
                f,
                "no initial_pose.csv and no ground truth: give the pose the vehicle starts at in initial_pose.csv"
            ),
        }
    }
}

impl std::error::Error for ReplayError {}

impl From<ScanSourceError> for ReplayError {
    fn from(e: ScanSourceError) -> Self {
        ReplayError::Scans(e)
    }
}

impl From<EstimatesError> for ReplayError {
    fn from(e: EstimatesError) -> Self {
        ReplayError::Estimates(e)
    }
}

impl From<CsvError> for ReplayError {
    fn from(e: CsvError) -> Self {
        ReplayError::Csv(e)
    }
}

impl From<OdometryError> for ReplayError {
    fn from(e: OdometryError) -> Self {
        ReplayError::Odometry(e)
    }
}

impl From<ScenarioError> for ReplayError {
    fn from(e: ScenarioError) -> Self {
        ReplayError::Scenario(e)
    }
}

/// The estimator's output after one recorded scan.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayStep {
    /// Scan time, seconds.
    pub t_s: f64,
    /// The estimate, world frame.
    pub estimate: SimPose,
    /// `(σx m, σy m, σθ rad)` of the estimate.
    pub sigma: (f64, f64, f64),
    /// What the estimator made of the scan.
    pub status: EstimatorStatus,
    /// The estimate's protection level (`None`: the estimator gives none).
    pub protection: Option<loc_core::localizer::Protection>,
    /// Dead reckoning from the odometry log alone at the scan.
    pub odometry: SimPose,
    /// Time the estimator took for the scan, microseconds.
    pub update_us: f64,
    /// The scan's Cramér–Rao bound at the true pose (with [`ReplayOptions::bound`] and
    /// ground truth at the scan; `None` where a direction is unobserved).
    pub bound: Option<nalgebra::Matrix3<f64>>,
}

/// The result of a replay.
#[derive(Debug, Clone)]
pub struct Replay {
    /// Every scan's estimate.
    pub steps: Vec<ReplayStep>,
    /// The run log for the metrics, plots and output files: one sample (and its scan) per
    /// scan that has ground truth (none without ground truth).
    pub log: RunLog,
    /// The decoded scanner recording (scans dropped after use; counts and sources kept).
    pub source: ScanSummary,
    /// The stored map the localiser used.
    pub map: Box<TunnelMap>,
    /// Things in the inputs that look wrong but do not stop the replay (e.g. odometry and
    /// scans on different clocks), for the user to read.
    pub warnings: Vec<String>,
    /// The per-scan Cramér–Rao bound beside the error ([`ReplayOptions::bound`], with
    /// ground truth).
    pub bound: Option<bound::BoundSummary>,
    /// Time the odometry log leaves uncovered, `(from_s, to_s)`: motion nobody measured
    /// (the dead reckoning of [`ReplayStep::odometry`] misses it).
    pub odometry_gaps: Vec<(f64, f64)>,
}

/// Refuses odometry and scans that do not overlap in time: they are then on different
/// clocks (e.g. a raw stream timed by the scanner's clock since power-up), and the scans
/// would be localised without the motion between them.
fn check_clocks(
    odometry: &[crate::vehicle::odometry::OdometrySample],
    scans: &[ReplayStep],
) -> Result<(), ReplayError> {
    let (Some(o0), Some(o1)) = (odometry.first(), odometry.last()) else {
        return Ok(());
    };
    let (Some(s0), Some(s1)) = (scans.first(), scans.last()) else {
        return Ok(());
    };
    if o1.t_s < s0.t_s || o0.t_s > s1.t_s {
        return Err(ReplayError::ClocksDisagree {
            odometry_s: (o0.t_s, o1.t_s),
            scans_s: (s0.t_s, s1.t_s),
        });
    }
    Ok(())
}

/// What the scanner recording held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanSummary {
    /// Scans replayed.
    pub scans: usize,
    /// Odometry readings fed.
    pub odometry_readings: usize,
    /// Scans with ground truth (scored).
    pub scored_scans: usize,
    /// File format of the scanner recording.
    pub format: lidar_driver::recording::RecordingFormat,
    /// Where scan times came from.
    pub time_source: scan_source::TimeSource,
    /// Non-scan frames skipped.
    pub other_frames: usize,
    /// Damaged frames dropped by the framer.
    pub bad_frames: usize,
    /// Scan telegrams dropped because they do not decode (each one is in the warnings).
    pub damaged_scans: usize,
    /// Damaged parts of the capture file read around (each one is in the warnings).
    pub file_damage: usize,
    /// Odometry readings flagged (gaps, spikes, disagreeing increments; in the warnings).
    pub odometry_findings: usize,
    /// Of which left out of the replay (spikes, disagreeing increments).
    pub odometry_left_out: usize,
}

/// How a replay runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReplayOptions {
    /// Keep every scored scan in the log (for the MCAP file of `--out`; 2.3 kB per scan).
    /// Without it memory does not grow with the recording but for the per-scan results
    /// (≈ 0.3 kB per scan).
    pub keep_scans: bool,
    /// Score another localiser's poses from this estimates file ([`external`]) instead of
    /// running the chosen estimator: the recording, truth and metrics are the same.
    pub estimates: Option<PathBuf>,
    /// Compute each scan's Cramér–Rao bound at the true pose ([`bound`]; needs ground
    /// truth; about as costly as the localiser).
    pub bound: bool,
    /// Which echo of each beam the localiser takes; `None`: the scenario's
    /// (`localizer.echo`, the last by default).
    pub echo: Option<EchoChoice>,
    /// With `estimates`: scans without a row (a controller that lost them to a restart sent
    /// no pose) are left out of the scoring and counted in the warnings, instead of the file
    /// being refused.
    pub allow_missing_estimates: bool,
}

impl Default for ReplayOptions {
    /// Scans kept.
    fn default() -> Self {
        Self {
            keep_scans: true,
            estimates: None,
            bound: false,
            echo: None,
            allow_missing_estimates: false,
        }
    }
}

/// Runs a replay with the chosen estimator, the scans kept ([`ReplayOptions::default`]).
pub fn replay(sources: &ReplaySources, choice: EstimatorChoice) -> Result<Replay, ReplayError> {
    replay_with(sources, choice, &ReplayOptions::default())
}

/// Reads a loc-core map file (the firmware's format: versioned, checksummed) from `path`.
pub fn read_map(path: &Path) -> Result<Box<TunnelMap>, ReplayError> {
    let bytes = std::fs::read(path).map_err(|source| ReplayError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut map = Box::<TunnelMap>::default();
    map.load_from_bytes(&bytes)
        .map_err(|source| ReplayError::Map {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(map)
}

/// Runs a replay with the chosen estimator and options.
pub fn replay_with(
    sources: &ReplaySources,
    choice: EstimatorChoice,
    options: &ReplayOptions,
) -> Result<Replay, ReplayError> {
    let wall = Instant::now();
    let mut scenario = Scenario::from_file(&sources.scenario)?;
    if let Some(echo) = options.echo {
        scenario.localizer.echo = echo;
    }
    // The centre line alone (for the along/across split): no simulated world is built.
    let line = scenario.centerline()?;
    let map = read_map(&sources.map)?;
    // The scanner recording is streamed through the estimator: memory holds one record of
    // it, the per-scan results and (for `--out`'s MCAP file) the scans only when asked.
    let mut stream = ScanStream::open(&sources.scanner, sources.scanner_times.as_deref())?;
    let checked = odometry_check::check(&odometry_csv::read(&sources.odometry)?)?;
    let odometry_gaps: Vec<(f64, f64)> = checked
        .findings
        .iter()
        .filter(|f| f.kind == odometry_check::FindingKind::Gap)
        .map(|f| (f.t_s - f.value, f.t_s))
        .collect();
    let odometry = &checked.readings;
    let truth = match &sources.ground_truth {
        Some(p) => Some(truth_csv::read(p)?),
        None => None,
    };
    let initial = match &sources.initial_pose {
        Some(p) => initial_pose::read(p)?,
        None => None,
    };
    let initial = match (initial, truth.as_ref().and_then(|t| t.first())) {
        (Some(i), _) => i,
        (None, Some(first)) => InitialPose {
            pose: first.pose,
            sigma_xy_m: scenario.localizer.initial_sigma_m.max(0.01),
            sigma_theta_rad: scenario.localizer.initial_sigma_rad.max(0.002),
        },
        (None, None) => return Err(ReplayError::NoInitialPose),
    };
    // Dead reckoning starts where the truth starts (as the simulator's odometry does), or at
    // the initial pose without truth.
    let start = truth
        .as_ref()
        .and_then(|t| t.first())
        .map_or(initial.pose, |r| r.pose);

    let keep = options.keep_scans;
    let mut bounds = match (&truth, options.bound) {
        (Some(rows), true) => Some((bound::ScanBound::new(&map, &scenario), rows.as_slice())),
        _ => None,
    };
    let mut drive = |est: &mut dyn Estimator, stream: &mut ScanStream| {
        drive(est, initial, start, odometry, stream, keep, bounds.as_mut())
    };
    let mut missing_estimates = None;
    let (steps, kept, name) = match (&options.estimates, choice) {
        (Some(path), _) => {
            let mut est = ExternalEstimates::read(path)?;
            let (steps, kept) = drive(&mut est, &mut stream)?;
            match est.check_complete() {
                Err(e) if options.allow_missing_estimates => missing_estimates = Some(e),
                r => r?,
            }
            (steps, kept, est.name())
        }
        (None, EstimatorChoice::OdometryOnly) => {
            let mut est = OdometryOnly::default();
            let (steps, kept) = drive(&mut est, &mut stream)?;
            (steps, kept, est.name())
        }
        (None, EstimatorChoice::Localizer) => {
            let mut est = LocCoreEstimator::new(&map, &scenario);
            let (steps, kept) = drive(&mut est, &mut stream)?;
            (steps, kept, est.name())
        }
    };
    let recorded = stream.summary();
    check_clocks(odometry, &steps)?;
    // Damage is reported, not fatal: the replay ran on every scan that survived it.
    let mut warnings: Vec<String> = checked
        .warnings()
        .into_iter()
        .chain(
            recorded
                .file_damage
                .iter()
                .map(|d| format!("scanner recording: {d}")),
        )
        .chain(
            recorded
                .damaged
                .iter()
                .map(|d| format!("scanner recording: {d}")),
        )
        .collect();
    if recorded.bad_frames > 0 || recorded.garbage_bytes > 0 {
        warnings.push(format!(
            "scanner recording: {} damaged frames dropped and {} bytes outside any telegram skipped (the framer resynchronised on the next start marker)",
            recorded.bad_frames, recorded.garbage_bytes
        ));
    }
    warnings.extend(coverage_warning(odometry, &steps));
    warnings.extend(missing_estimates.map(|e| format!("{e} (those scans are not scored)")));
    let mut scored = match &truth {
        Some(rows) => truth::samples(&steps, rows, &line, scenario.drive.start_m),
        None => Vec::new(),
    };
    // A scan the estimates file gave no pose for is not scored (it had none).
    scored.retain(|(i, _)| {
        steps
            .get(*i)
            .is_some_and(|s| s.status != EstimatorStatus::NoEstimate)
    });
    let statuses = scored
        .iter()
        .filter_map(|(i, _)| steps.get(*i).map(|x| x.status))
        .collect();
    // The scored scans stay with their samples (for the MCAP file), when kept.
    let scans = scored
        .iter()
        .filter_map(|(i, _)| kept.get(*i).cloned())
        .collect();
    let scored_index: Vec<usize> = scored.iter().map(|(i, _)| *i).collect();
    let samples: Vec<Sample> = scored.into_iter().map(|(_, s)| s).collect();
    let source = ScanSummary {
        scans: steps.len(),
        odometry_readings: odometry.len(),
        scored_scans: samples.len(),
        format: recorded.format,
        time_source: recorded.time_source,
        other_frames: recorded.other_frames,
        bad_frames: recorded.bad_frames,
        damaged_scans: recorded.damaged.len(),
        file_damage: recorded.file_damage.len(),
        odometry_findings: checked.findings.len(),
        odometry_left_out: checked.findings.len()
            - checked
                .findings
                .iter()
                .filter(|f| f.kind == odometry_check::FindingKind::Gap)
                .count(),
    };
    let world = WorldSummary::of_design(&line, scenario.tunnel.width_m, &map);
    let log = RunLog {
        scenario,
        estimator: name,
        world,
        centerline: line,
        samples,
        statuses,
        scans,
        odometry: Vec::new(),
        start,
        initial_estimate: (initial.pose, initial.sigma_xy_m, initial.sigma_theta_rad),
        wall_time_s: wall.elapsed().as_secs_f64(),
        raycast_time_s: 0.0,
        echo_counts: crate::lidar::EchoCounts::default(),
    };
    warnings.extend(map_warning(&steps));
    let bound = if options.bound {
        let per_sample: Vec<_> = scored_index
            .iter()
            .map(|i| steps.get(*i).and_then(|s| s.bound))
            .collect();
        bound::summarise(&log.centerline, &log.samples, &per_sample)
    } else {
        None
    };
    Ok(Replay {
        steps,
        log,
        source,
        map,
        warnings,
        bound,
        odometry_gaps,
    })
}

/// Says so when scans come before the first or after the last odometry reading (by more
/// than two reading intervals): those are coasted across, with growing uncertainty.
fn coverage_warning(
    odometry: &[crate::vehicle::odometry::OdometrySample],
    scans: &[ReplayStep],
) -> Option<String> {
    let (first, last) = (odometry.first()?, odometry.last()?);
    let (s0, s1) = (scans.first()?.t_s, scans.last()?.t_s);
    let slack = 2.0 * last.dt_s;
    let after = scans.iter().filter(|s| s.t_s > last.t_s + slack).count();
    let before = scans
        .iter()
        .filter(|s| s.t_s < first.t_s - first.dt_s - slack)
        .count();
    (after + before > 0).then(|| {
        format!(
            "odometry covers t = {:.3}…{:.3} s, the scans t = {s0:.3}…{s1:.3} s: {before} scans before it and {after} after it are localised without odometry (coasted on the last speed, with growing uncertainty)",
            first.t_s - first.dt_s,
            last.t_s
        )
    })
}

/// Says so when the localiser did not confirm the map on a tenth of the scans or more: the
/// landmarks in view did not fit it (another tunnel's map, landmarks moved or damaged), and
/// it reported the map unconfirmed or, having declared itself lost, searched it again.
fn map_warning(steps: &[ReplayStep]) -> Option<String> {
    use loc_core::localizer::Status;
    let unconfirmed = steps
        .iter()
        .filter(|s| {
            matches!(
                s.status,
                EstimatorStatus::Localizer(
                    Status::MapUnconfirmed { .. } | Status::Relocalising { .. }
                )
            )
        })
        .count();
    (unconfirmed > 0 && unconfirmed * 10 >= steps.len()).then(|| {
        format!(
            "the map was not confirmed on {unconfirmed} of {} scans ({:.0} %): the landmarks in view did not fit it, and those poses are reported map-unconfirmed or relocalising, not tracking. Is this the drive's map? (another tunnel's, or landmarks moved or damaged since the survey)",
            steps.len(),
            100.0 * unconfirmed as f64 / steps.len().max(1) as f64
        )
    })
}

/// Feeds the estimator like the closed loop does: reset, then per scan every odometry
/// reading up to the scan's time (inclusive) and the scan; the scans are kept (returned)
/// only with `keep_scans`.
fn drive(
    est: &mut dyn Estimator,
    initial: InitialPose,
    start: SimPose,
    odometry: &[crate::vehicle::odometry::OdometrySample],
    scans: &mut ScanStream,
    keep_scans: bool,
    mut bound: Option<&mut (bound::ScanBound<'_>, &[truth_csv::TruthRow])>,
) -> Result<(Vec<ReplayStep>, Vec<crate::lidar::LidarScan>), ScanSourceError> {
    let mut truth_cursor = 0usize;
    est.reset(initial.pose, initial.sigma_xy_m, initial.sigma_theta_rad);
    let mut odo_pose = start;
    let mut last_reading = None;
    let mut next = 0usize;
    let mut steps = Vec::new();
    let mut kept = Vec::new();
    while let Some(scan) = scans.next_scan()? {
        while let Some(r) = odometry.get(next).filter(|r| r.t_s <= scan.t_s) {
            est.odometry(r);
            // The simulator's odometry integrates its readings the same way.
            odo_pose = odo_pose.integrate(r.v_mps, 0.0, r.omega_radps, r.dt_s);
            last_reading = Some(r);
            next += 1;
        }
        let t0 = Instant::now();
        let out = est.scan(&scan);
        let update_us = est
            .last_update_us()
            .unwrap_or_else(|| t0.elapsed().as_secs_f64() * 1e6);
        steps.push(ReplayStep {
            t_s: scan.t_s,
            estimate: out.pose,
            sigma: out.sigma,
            status: out.status,
            protection: out.protection,
            odometry: crate::odometry_gaps::dead_reckoned_at(odo_pose, last_reading, scan.t_s),
            update_us,
            bound: bound.as_mut().and_then(|(b, rows)| {
                truth::pose_at(rows, scan.t_s, &mut truth_cursor).and_then(|p| b.at(&scan, p))
            }),
        });
        if keep_scans {
            kept.push(scan);
        }
    }
    Ok((steps, kept))
}

/// Writes the estimates (`estimates.csv`: one row per scan, with or without ground truth).
pub fn write_estimates_csv(
    steps: &[ReplayStep],
    w: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    writeln!(
        w,
        "t_s,est_x_m,est_y_m,est_theta_rad,sigma_x_m,sigma_y_m,sigma_theta_rad,odo_x_m,odo_y_m,odo_theta_rad,status,update_us"
    )?;
    for s in steps {
        writeln!(
            w,
            "{:.6},{:.5},{:.5},{:.6},{:.5},{:.5},{:.6},{:.5},{:.5},{:.6},{},{:.1}",
            s.t_s,
            s.estimate.x_m,
            s.estimate.y_m,
            s.estimate.theta_rad,
            s.sigma.0,
            s.sigma.1,
            s.sigma.2,
            s.odometry.x_m,
            s.odometry.y_m,
            s.odometry.theta_rad,
            s.status,
            s.update_us
        )?;
    }
    Ok(())
}
