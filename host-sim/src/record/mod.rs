//! `host-sim run … --record DIR`: the drive written as a real vehicle would log it, so that
//! `host-sim replay DIR` (or anyone's tool) can localise from it offline.
//!
//! | file | what |
//! |---|---|
//! | `scanner.colab.bin` | the LMS511's CoLa-B byte stream: one `sSN LMDscandata` telegram per scan ([`scanner_telegram`]) |
//! | `scanner.colab.times.csv` | per telegram: `index, t_s` (host receive time), `offset_bytes, length_bytes` in the stream, `telegram_counter` (the telegram's own counter, pairs rows and telegrams around damage) |
//! | `odometry.csv` | per odometry reading: `t_s, dt_s, v_mps, omega_radps, dx_m, dy_m, dtheta_rad` ([`odometry_csv`]) |
//! | `ground_truth.csv` | `t_s, x_m, y_m, theta_rad, distance_m, chainage_m`: the start (t = 0), then one row per scan ([`truth_csv`]) |
//! | `initial_pose.csv` | the pose the localiser starts from and its σ ([`initial_pose`]) |
//! | `map.postcard` | the stored map, loc-core's map file (what `export-map` writes) |
//! | `as_built.postcard` | simulation only, like the ground truth: the true as-built map (walls every metre, landmarks where installed; `export-map --as-built`), to score a survey against |
//! | `scenario.toml` | the scenario: sensor mounting, localiser settings, the tunnel (for the metrics) |
//! | `README.txt` | this table for the person who opens the directory |
//!
//! All times are seconds on one clock: the run's, starting at 0 when the vehicle starts.

pub mod csv_table;
pub mod initial_pose;
pub mod odometry_csv;
pub mod readme;
pub mod scanner_telegram;
pub mod truth_csv;

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

use loc_core::map::TunnelMap;

use crate::closed_loop::RunLog;
use crate::scenario::Scenario;
use crate::stored_map;

/// File names inside a recording directory.
pub mod files {
    /// The scanner's CoLa-B byte stream.
    pub const SCANNER: &str = "scanner.colab.bin";
    /// Receive time and position of each telegram in the stream.
    pub const SCANNER_TIMES: &str = "scanner.colab.times.csv";
    /// Odometry readings.
    pub const ODOMETRY: &str = "odometry.csv";
    /// Ground truth.
    pub const GROUND_TRUTH: &str = "ground_truth.csv";
    /// Initial pose of the localiser.
    pub const INITIAL_POSE: &str = "initial_pose.csv";
    /// loc-core's map file.
    pub const MAP: &str = "map.postcard";
    /// The true as-built map (simulation only).
    pub const AS_BUILT_MAP: &str = "as_built.postcard";
    /// The scenario.
    pub const SCENARIO: &str = "scenario.toml";
    /// The description.
    pub const README: &str = "README.txt";
}

/// Why a recording could not be written.
#[derive(Debug)]
pub enum RecordError {
    /// A file could not be written.
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A scan could not be encoded as a telegram (more beams than a telegram holds).
    Telegram {
        /// Index of the scan.
        index: usize,
        /// The encoder's complaint.
        error: lidar_driver::EmitError,
    },
    /// The run did not keep its scans and odometry readings (run with `keep_scans`).
    ScansNotKept,
    /// The scenario's world could not be built again for its map.
    Scenario(crate::scenario::ScenarioError),
    /// The design does not fit loc-core's stored map.
    Map(loc_core::map::MapError),
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::Io { path, source } => write!(
                f,
                "cannot write {}: {source} (check that the directory is writable)",
                path.display()
            ),
            RecordError::Telegram { index, error } => {
                write!(
                    f,
                    "scan {index} cannot be encoded as an LMS511 telegram: {error}"
                )
            }
            RecordError::Scenario(e) => write!(f, "{e}"),
            RecordError::Map(e) => write!(f, "the stored map cannot be written: {e}"),
            RecordError::ScansNotKept => write!(
                f,
                "the run kept no scans: record with RunOptions {{ keep_scans: true, .. }}"
            ),
        }
    }
}

impl std::error::Error for RecordError {}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn write_with(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), RecordError> {
    let file = std::fs::File::create(path).map_err(io_err(path))?;
    let mut w = std::io::BufWriter::new(file);
    f(&mut w).map_err(io_err(path))?;
    w.flush().map_err(io_err(path))
}

/// Writes the recording of a run into `dir` (created if needed): the run must have kept its
/// scans and odometry; `map_file` is loc-core's map file of the run's stored map,
/// `as_built_file` the true as-built map's (simulated drives). Returns the paths written.
pub fn write_recording(
    dir: &Path,
    log: &RunLog,
    map_file: &[u8],
    as_built_file: Option<&[u8]>,
) -> Result<Vec<PathBuf>, RecordError> {
    if log.scans.len() != log.samples.len() || (log.odometry.is_empty() && !log.samples.is_empty())
    {
        return Err(RecordError::ScansNotKept);
    }
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let path = |name: &str| dir.join(name);
    let mut written = Vec::new();

    // The scanner stream and its receive times.
    let lidar = &log.scenario.lidar;
    let mut telegrams = scanner_telegram::Lms511Telegrams::with_output_channel(
        lidar.rate,
        scanner_telegram::output_channel_for(lidar.dust.fraction),
    );
    let mut stream = Vec::new();
    let mut times = String::from("index,t_s,offset_bytes,length_bytes,telegram_counter\n");
    for (index, scan) in log.scans.iter().enumerate() {
        let frame = telegrams
            .next_frame(scan)
            .map_err(|error| RecordError::Telegram { index, error })?;
        times.push_str(&format!(
            "{index},{},{},{},{}\n",
            scan.t_s,
            stream.len(),
            frame.len(),
            telegrams.telegram_counter()
        ));
        stream.extend_from_slice(&frame);
    }
    let p = path(files::SCANNER);
    std::fs::write(&p, &stream).map_err(io_err(&p))?;
    written.push(p);
    let p = path(files::SCANNER_TIMES);
    std::fs::write(&p, times).map_err(io_err(&p))?;
    written.push(p);

    let p = path(files::ODOMETRY);
    write_with(&p, |w| odometry_csv::write(w, &log.odometry))?;
    written.push(p);
    let p = path(files::GROUND_TRUTH);
    write_with(&p, |w| truth_csv::write_run(w, log))?;
    written.push(p);
    let p = path(files::INITIAL_POSE);
    write_with(&p, |w| {
        initial_pose::write(w, &initial_pose::InitialPose::of(log))
    })?;
    written.push(p);
    let p = path(files::MAP);
    std::fs::write(&p, map_file).map_err(io_err(&p))?;
    written.push(p);
    if let Some(bytes) = as_built_file {
        let p = path(files::AS_BUILT_MAP);
        std::fs::write(&p, bytes).map_err(io_err(&p))?;
        written.push(p);
    }
    // With a copy of a CSV centre line: everything a replay needs is in the recording.
    let p = path(files::SCENARIO);
    written.extend(
        log.scenario
            .write_self_contained(dir, "")
            .map_err(io_err(&p))?,
    );
    let p = path(files::README);
    std::fs::write(&p, readme::text(log, stream.len(), map_file.len())).map_err(io_err(&p))?;
    written.push(p);
    Ok(written)
}

/// The stored map of a scenario (the one its run's localiser gets) and its map file bytes.
pub fn scenario_map(scenario: &Scenario) -> Result<(Box<TunnelMap>, Vec<u8>), RecordError> {
    let world = scenario.build_world().map_err(RecordError::Scenario)?;
    let choice = scenario.landmark_choice().map_err(RecordError::Scenario)?;
    let map = stored_map::build(&world, &choice).map_err(RecordError::Map)?;
    let bytes = stored_map::to_file_bytes(&map).map_err(RecordError::Map)?;
    Ok((map, bytes))
}

/// The true as-built map of a scenario's world ([`stored_map::build_as_built`]) as map file
/// bytes.
pub fn scenario_as_built_map(scenario: &Scenario) -> Result<Vec<u8>, RecordError> {
    let world = scenario.build_world().map_err(RecordError::Scenario)?;
    let choice = scenario.landmark_choice().map_err(RecordError::Scenario)?;
    let map = stored_map::build_as_built(&world, &choice).map_err(RecordError::Map)?;
    stored_map::to_file_bytes(&map).map_err(RecordError::Map)
}
