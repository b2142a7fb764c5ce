//! `host-sim hil`: the firmware under QEMU driven by the simulator, in simulated time.
//!
//! 1. The scenario is run and recorded (`run --record`, into the output folder's
//!    `recording/`): the LMS511 telegrams, the odometry, the ground truth, and `run`'s own
//!    metrics to compare against.
//! 2. What a flasher writes goes into the board's map flash region ([`flash`]): the map image,
//!    the localiser's configuration record (the scenario's sensor mounting, matcher and noise
//!    models) and the start pose (the recording's initial pose).
//! 3. QEMU runs the controller (`mps2-an386`, the F407's memory layout) with UART0 wired to
//!    lidar-driver's LMS5xx emulator (CoLa-B or CoLa-A, the start-up sequence answered as the
//!    LMS511 does) and UART1, the vehicle port, wired to [`vehicle_port`].
//! 4. Lock step, so the loop runs in simulated time whatever the host's speed: for scan k the
//!    vehicle port sends the odometry frame at the scan's time, then lets the emulator send
//!    scan k, then waits for the controller's pose frame; only then comes scan k + 1.
//! 5. The pose frames become an estimates file scored by `host-sim replay` against the
//!    recording's ground truth (`replay::external`): the same metrics as `run`.
//!
//! Instructions per scan come from the same run: QEMU runs with `-icount shift=0` (one
//! virtual nanosecond per instruction, so the firmware's SysTick counter counts
//! instructions), and each pose frame carries the controller's work on its scan. Under
//! `-icount` QEMU moves one UART byte per main-loop turn — far slower than an LMS511 in real
//! time, but the lock step does not care: a 294-scan drive takes about a minute either way.

pub mod flash;
pub mod vehicle_port;

use std::fmt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use lms5xx_emulator::{DialectMode, Emulator, EmulatorConfig, RecordingSource};

use crate::closed_loop::RunOptions;
use crate::record::{self, files};
use crate::replay::{self, ReplayOptions, ReplaySources};
use crate::scenario::Scenario;
use crate::session::{run_scenario, EstimatorChoice};

/// How a HIL run runs.
#[derive(Debug, Clone)]
pub struct HilOptions {
    /// The controller ELF (built without `FW_CONTROLLER_SCANS`).
    pub elf: PathBuf,
    /// The CoLa dialect the emulated scanner speaks.
    pub dialect: DialectMode,
    /// Longest wait for one pose frame, and for QEMU to connect.
    pub timeout: Duration,
    /// Run QEMU with `-icount shift=0` (one virtual nanosecond per instruction), so the
    /// firmware's counter counts instructions.
    pub icount: bool,
}

/// Why a HIL run failed.
#[derive(Debug)]
pub enum HilError {
    /// The controller ELF is not there.
    NoFirmware(PathBuf),
    /// The simulation, the recording or the scoring failed.
    Host(String),
    /// QEMU could not be started (not installed: `bash scripts/setup.sh`).
    Qemu(std::io::Error),
    /// The vehicle port or the emulator failed.
    Io(std::io::Error),
    /// The firmware sent no pose for a scan in time.
    NoPose {
        /// The scan.
        scan: usize,
        /// What the firmware logged last (its defmt log is in the output folder).
        log: PathBuf,
    },
}

impl fmt::Display for HilError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HilError::NoFirmware(p) => write!(
                f,
                "no controller firmware at {}: build it with `cd firmware && cargo build --release --bin controller` (without FW_CONTROLLER_SCANS), or give --elf",
                p.display()
            ),
            HilError::Host(e) => write!(f, "{e}"),
            HilError::Qemu(e) => write!(
                f,
                "qemu-system-arm could not be started ({e}): install it with `bash scripts/setup.sh`"
            ),
            HilError::Io(e) => write!(f, "HIL link: {e}"),
            HilError::NoPose { scan, log } => write!(
                f,
                "the firmware sent no pose for scan {scan} in time (its log, raw defmt: {})",
                log.display()
            ),
        }
    }
}

impl std::error::Error for HilError {}

/// The outcome: the firmware's poses scored, and `run`'s for the same drive.
#[derive(Debug)]
pub struct HilResult {
    /// The firmware's run, scored like `replay` (its log and metrics).
    pub replay: replay::Replay,
    /// `run`'s own log of the same drive (the host localiser).
    pub run: crate::closed_loop::RunLog,
    /// The recording the firmware was fed.
    pub recording: PathBuf,
    /// Pose frames per status, in scan order.
    pub statuses: Vec<controller_wire::PoseStatus>,
    /// Scans predicted with the vehicle's odometry (the rest with constant velocity).
    pub with_odometry: usize,
    /// The firmware's work on each scan (its `PoseFrame::work`): instructions with
    /// [`HilOptions::icount`], else QEMU's virtual time in the counter's unit.
    pub work: Vec<u32>,
    /// The same work by stage on each scan (its `PoseFrame::stage_work`, indexed like
    /// `controller_wire::STAGE_NAMES`).
    pub stage_work: Vec<[u32; 5]>,
}

impl HilResult {
    /// Mean and maximum of the work per scan, end to end and by stage (in
    /// `controller_wire::STAGE_NAMES` order): `(mean, max)` each.
    pub fn work_summary(&self) -> ((f64, u32), [(f64, u32); 5]) {
        let mean_max = |v: &mut dyn Iterator<Item = u32>| {
            let (mut n, mut sum, mut max) = (0usize, 0.0f64, 0u32);
            for w in v {
                n += 1;
                sum += f64::from(w);
                max = max.max(w);
            }
            (sum / n.max(1) as f64, max)
        };
        let total = mean_max(&mut self.work.iter().copied());
        let stages = core::array::from_fn(|i| {
            mean_max(
                &mut self
                    .stage_work
                    .iter()
                    .map(|s| s.get(i).copied().unwrap_or(0)),
            )
        });
        (total, stages)
    }
}

/// Default place of the controller ELF: the firmware workspace's release build.
pub fn default_elf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../firmware/target/thumbv7em-none-eabihf/release/controller")
}

/// Runs `scenario` with the firmware in the loop, writing into `out`.
pub fn run(scenario: &Scenario, options: &HilOptions, out: &Path) -> Result<HilResult, HilError> {
    if !options.elf.is_file() {
        return Err(HilError::NoFirmware(options.elf.clone()));
    }
    let host = |e: &dyn fmt::Display| HilError::Host(e.to_string());
    // 1. The drive, recorded.
    let log = run_scenario(
        scenario,
        EstimatorChoice::Localizer,
        &RunOptions {
            keep_scans: true,
            progress: None,
            ..Default::default()
        },
    )
    .map_err(|e| host(&e))?;
    let recording = out.join("recording");
    let (map, map_file) = record::scenario_map(scenario).map_err(|e| host(&e))?;
    record::write_recording(&recording, &log, &map_file, None).map_err(|e| host(&e))?;
    // 2. The map flash region's contents.
    let flashed = flash::write(scenario, &map, &recording, out).map_err(|e| host(&e))?;
    // 3. The links and QEMU.
    let scans = RecordingSource::from_file(recording.join(files::SCANNER))
        .map_err(|e| host(&e))?
        .scans()
        .to_vec();
    let times = vehicle_port::scan_times(&recording).map_err(|e| host(&e))?;
    let frames = vehicle_port::odometry_frames(&recording, &times).map_err(|e| host(&e))?;
    let (go, wait) = mpsc::channel::<()>();
    let mut pending = scans.into_iter();
    let source = move || {
        wait.recv().ok()?;
        pending.next()
    };
    let emulator = Emulator::start(
        EmulatorConfig {
            dialect: options.dialect,
            ..EmulatorConfig::default()
        },
        source,
    )
    .map_err(HilError::Io)?;
    let lidar = emulator
        .addr()
        .ok_or_else(|| HilError::Host("the emulator has no address".into()))?;
    let vehicle = vehicle_port::VehiclePort::bind().map_err(HilError::Io)?;
    let defmt_log = out.join("firmware.defmt");
    let mut qemu = start_qemu(
        options.icount,
        &options.elf,
        lidar.port(),
        vehicle.port(),
        &flashed,
        &defmt_log,
    )?;
    // 4. Lock step.
    let result = vehicle.run(&frames, &go, options.timeout);
    let _ = qemu.kill();
    let _ = qemu.wait();
    drop(go);
    emulator.stop();
    let poses = result.map_err(|e| match e {
        vehicle_port::PortError::NoPose { scan } => HilError::NoPose {
            scan,
            log: defmt_log.clone(),
        },
        vehicle_port::PortError::Io(e) => HilError::Io(e),
    })?;
    // 5. Scored like replay.
    let estimates = recording.join("firmware_estimates.csv");
    vehicle_port::write_estimates(&estimates, &times, &poses).map_err(|e| host(&e))?;
    vehicle_port::write_frames(&out.join("firmware_frames.csv"), &times, &poses)
        .map_err(|e| host(&e))?;
    let sources = ReplaySources::in_dir(&recording).map_err(|e| host(&e))?;
    let replay = replay::replay_with(
        &sources,
        EstimatorChoice::Localizer,
        &ReplayOptions {
            keep_scans: false,
            estimates: Some(estimates),
            ..ReplayOptions::default()
        },
    )
    .map_err(|e| host(&e))?;
    Ok(HilResult {
        replay,
        run: log,
        recording,
        statuses: poses.iter().map(|p| p.status).collect(),
        with_odometry: poses
            .iter()
            .filter(|p| p.motion == controller_wire::MotionSource::Odometry)
            .count(),
        work: poses.iter().map(|p| p.work).collect(),
        stage_work: poses.iter().map(|p| p.stage_work).collect(),
    })
}

/// QEMU with the controller: UART0 to the emulator, UART1 to the vehicle port, the map
/// region loaded; its stdout (defmt over semihosting) into `defmt_log`.
fn start_qemu(
    icount: bool,
    elf: &Path,
    lidar_port: u16,
    vehicle_port: u16,
    flashed: &flash::Flashed,
    defmt_log: &Path,
) -> Result<Child, HilError> {
    let log = std::fs::File::create(defmt_log).map_err(HilError::Io)?;
    let loader =
        |file: &Path, addr: u32| format!("loader,file={},addr={addr:#010x}", file.display());
    let mut qemu = Command::new("qemu-system-arm");
    if icount {
        qemu.args(["-icount", "shift=0"]);
    }
    qemu.args(["-machine", "mps2-an386", "-nographic"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-serial", &format!("tcp:127.0.0.1:{lidar_port}")])
        .args(["-serial", &format!("tcp:127.0.0.1:{vehicle_port}")])
        .args(["-device", &loader(&flashed.image, flash::MAP_REGION_ADDR)])
        .args(["-device", &loader(&flashed.config, flash::CONFIG_ADDR)])
        .args([
            "-device",
            &loader(&flashed.start_pose, flash::START_POSE_ADDR),
        ])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(Stdio::null())
        .spawn()
        .map_err(HilError::Qemu)
}
