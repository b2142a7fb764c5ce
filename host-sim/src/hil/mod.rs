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

use lidar_driver::recording::Recording;
use lms5xx_emulator::{DeviceIdentity, DialectMode, Emulator, EmulatorConfig, RecordingSource};

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
    /// When the controller restarts (a watchdog reset), the vehicle drives on for this long,
    /// seconds of the drive, before the controller takes scans again (the watchdog's
    /// timeout, the boot and the scanner's start-up): those scans are lost too. The
    /// simulation otherwise waits for the controller.
    pub restart_outage_s: f64,
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
                "the firmware sent no pose for scan {scan} in time (its log, raw defmt: {}); a controller built with FW_CONTROLLER_SCANS=N stops after N scans (the firmware's tests build one): rebuild the product with `cd firmware && cargo build --release --bin controller`",
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
    /// Pose frames per status, in scan order (scans lost to a restart left out).
    pub statuses: Vec<controller_wire::PoseStatus>,
    /// Each restart of the controller (a watchdog reset) in the run, in scan order.
    pub restarts: Vec<Restart>,
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

/// One restart of the controller during a HIL run, as the vehicle port saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Restart {
    /// The scan the controller was sent when it restarted (it answered with stale frames
    /// marked `after_reset`): the first scan lost.
    pub first_lost_scan: usize,
    /// Scans lost: that one and those of the outage after it (`HilOptions::restart_outage_s`).
    pub lost_scans: usize,
    /// Scans answered after the outage up to and including the first pose reported
    /// tracking (`None`: not tracking again within the run).
    pub scans_to_tracking: Option<usize>,
}

impl Restart {
    /// The restarts in `poses` (one entry per scan, `None` for a scan lost to a restart).
    fn find(poses: &[Option<controller_wire::PoseFrame>]) -> Vec<Self> {
        let mut restarts: Vec<Self> = Vec::new();
        let mut k = 0;
        while k < poses.len() {
            if poses[k].is_some() {
                k += 1;
                continue;
            }
            let lost_scans = poses[k..].iter().take_while(|p| p.is_none()).count();
            let after = k + lost_scans;
            let scans_to_tracking = poses[after..]
                .iter()
                .map_while(|p| p.as_ref())
                .position(|p| p.status == controller_wire::PoseStatus::Tracking)
                .map(|n| n + 1);
            restarts.push(Self {
                first_lost_scan: k,
                lost_scans,
                scans_to_tracking,
            });
            k = after;
        }
        restarts
    }
}

/// How long the emulator's scan source waits for the go of the next scan before it lets the
/// emulator's connection thread go on (host time; the scan follows in the next period).
const SOURCE_WAIT: Duration = Duration::from_millis(30);

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
    let scanner = Recording::read_file(recording.join(files::SCANNER)).map_err(|e| host(&e))?;
    let scans = RecordingSource::from_recording(&scanner)
        .map_err(|e| host(&e))?
        .scans()
        .to_vec();
    // The emulated scanner is set up as the recorded one was (its first scan's frequency and
    // angular step): with the LMS511 capture's 25 Hz and 1/6° it would resample a 50 Hz
    // drive's 1/3° scans onto twice the beams, each range at an angle up to 1/12° off its
    // own (≈ 1.5 mm a metre of range), and the firmware would localise on those.
    let identity = DeviceIdentity::from_recording(&scanner);
    drop(scanner);
    let times = vehicle_port::scan_times(&recording).map_err(|e| host(&e))?;
    let frames = vehicle_port::odometry_frames(&recording, &times).map_err(|e| host(&e))?;
    let (go, wait) = mpsc::channel::<usize>();
    // The emulator's connection thread asks for a scan each scan period while subscribed;
    // it waits for the go a little, never for ever, so that it keeps answering requests (a
    // controller restarting after a reset unsubscribes and sets the scanner up again while
    // no go comes).
    let source = move || {
        let k = wait.recv_timeout(SOURCE_WAIT).ok()?;
        scans.get(k).cloned()
    };
    let emulator = Emulator::start(
        EmulatorConfig {
            dialect: options.dialect,
            rate_hz: scenario.lidar.rate.frequency_hz() as f32,
            identity,
            // The recorded telegrams keep their own counters and µs stamps: the scanner's
            // clock in simulated time (restamped at the host's wall-clock pace, the
            // controller's sweep speed came out of the lock step's timing, not the drive's).
            restamp: false,
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
    let outage_scans =
        (options.restart_outage_s.max(0.0) * scenario.lidar.rate.frequency_hz()).round() as usize;
    let result = vehicle.run(&frames, &go, options.timeout, outage_scans);
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
            // A scan lost to a restart has no pose: the vehicle kept the last one.
            allow_missing_estimates: true,
            ..ReplayOptions::default()
        },
    )
    .map_err(|e| host(&e))?;
    let answered: Vec<&controller_wire::PoseFrame> = poses.iter().flatten().collect();
    Ok(HilResult {
        replay,
        run: log,
        recording,
        statuses: answered.iter().map(|p| p.status).collect(),
        restarts: Restart::find(&poses),
        with_odometry: answered
            .iter()
            .filter(|p| p.motion == controller_wire::MotionSource::Odometry)
            .count(),
        work: answered.iter().map(|p| p.work).collect(),
        stage_work: answered.iter().map(|p| p.stage_work).collect(),
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

#[cfg(test)]
mod tests {
    use super::Restart;
    use controller_wire::{PoseFrame, PoseStatus};

    fn frame(status: PoseStatus) -> Option<PoseFrame> {
        Some(PoseFrame {
            status,
            ..PoseFrame::no_map(0)
        })
    }

    #[test]
    fn restarts_are_runs_of_lost_scans_counted_to_the_next_tracking_pose() {
        use PoseStatus::{MapUnconfirmed, Tracking};
        let poses = [
            frame(Tracking),
            None,
            None,
            None,
            frame(MapUnconfirmed),
            frame(MapUnconfirmed),
            frame(Tracking),
            frame(Tracking),
            None,
            frame(MapUnconfirmed),
        ];
        assert_eq!(
            Restart::find(&poses),
            [
                Restart {
                    first_lost_scan: 1,
                    lost_scans: 3,
                    scans_to_tracking: Some(3),
                },
                Restart {
                    first_lost_scan: 8,
                    lost_scans: 1,
                    scans_to_tracking: None,
                },
            ]
        );
        assert!(Restart::find(&[frame(Tracking), frame(Tracking)]).is_empty());
    }
}
