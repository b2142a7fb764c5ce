//! The controller loop: LMS511 telegrams in over the board's lidar port, wheel odometry in
//! and a pose frame out after every scan on its vehicle port.
//!
//! **Start-up.** The board's map flash region holds the stored map (loc-core's map flash
//! image, `LCMI`, from its first byte: `host-sim export-map --format image`), queried in
//! place — the map never comes into RAM, so RAM does not grow with the tunnel's length —
//! the localiser's configuration record in the [`CONFIG_BLOCK_BYTES`] before the start-pose
//! block (the sensor's layout and mounting, the matcher, the noise models: `host-sim
//! export-map --config-out`; without one, loc-core's defaults), and, in its last
//! [`START_POSE_BLOCK_BYTES`], the start pose
//! (a loc-core [`StartPose`] record, `LCSP`: where the vehicle stands at power-up and how
//! sure that is), all written by the flasher (`probe-rs download`, QEMU's `-device
//! loader`). Without a valid map the controller never localises: it logs why, sends a
//! [`PoseStatus::NoMap`] frame once a second and waits for a map to be flashed. Without a
//! start pose (erased block) it relocalises: it searches the map for where the landmarks it
//! sees while the vehicle drives fit (loc-core's `relocalise`) and sends
//! [`PoseStatus::Relocalising`] frames until one place wins; a damaged start pose is
//! reported and treated the same way. After a reset while running it starts from the last
//! pose it stored (`crate::retained`); if that turns out wrong (the vehicle moved on while
//! the controller was down), loc-core declares itself lost after a few metres of
//! unconfirmed scans and relocalises.
//!
//! **Motion prediction.** The vehicle's wheel odometry arrives on the board's vehicle port
//! (`controller_wire::OdometryFrame`, see [`crate::odometry`]); each scan is predicted with
//! the odometry's motion since the previous scan. Without fresh odometry (none wired, the
//! link down for more than [`ODOMETRY_STALE_MS`]) the scan is predicted with the motion
//! between the two previous estimates (constant velocity) and the uncertainty of an
//! unmeasured motion ([`UNMEASURED_MOTION_SIGMA`] per scan), and the pose frames say so
//! (`MotionSource::ConstantVelocity`).

use lidar_driver::session::{Event, Session, SessionConfig};
use lidar_driver::transport::FixedLink;
use lidar_driver::ScanData;
use loc_core::filter::FilterInitError;
use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::localizer::{
    Availability, ConfigRecordError, Localizer, LocalizerConfig, Protection, StageObserver,
    StartPose, StartPoseError, Status,
};
use loc_core::map::{MapError, MapImage};
use loc_core::scan::{Scan, SweepMotion};
use nalgebra::{Matrix3, Vector3};
use scan_input::{EchoSelection, ScanInputError};
use static_cell::ConstStaticCell;

use crate::board::{Board, ExitStatus};
use crate::flash_map::{FlashMap, MAP};
use crate::odometry::{OdometryInput, ODOMETRY_STALE_MS};
use crate::resume::{BridgeRefusal, Bridged};
use crate::retained::LastScan;
use crate::stage_costs::{ScanStage, StageTimer};
use controller_wire::{
    MotionSource, OdometryFrame, PoseAvailability, PoseFrame, PoseStatus, MAX_FRAME_BYTES,
};

/// Receive buffer of the LMS session, bytes: one LMS511 scan in either dialect (1141 beams:
/// DIST1 and RSSI ≈ 8.2 kB in CoLa-A; DIST1…DIST5 without RSSI 11.6 kB in CoLa-B). 12 KiB,
/// not 16: the controller's RAM (static plus stack) must stay within 96 KiB.
pub const SESSION_BUFFER_BYTES: usize = 12 * 1024;

/// Which echo of each beam the controller localises on: the last (the wall behind dust or
/// spray). The session asks the scanner for it ([`session_config`]: `FREchoFilter` 2, the
/// last echo in `DIST1`, no more bytes than one echo); a scanner set up for more echoes
/// instead (output channel `0x1F`, remission off: 11.6 kB per CoLa-B scan, within
/// [`SESSION_BUFFER_BYTES`]; not in CoLa-A) has its last echo taken here.
pub const ECHO_SELECTION: EchoSelection = EchoSelection::Last;

/// The scanner session the controller runs: lidar-driver's default start-up (CoLa-B, the
/// capture's `LMDscandatacfg`: DIST1 and RSSI, time block) with the echo filter set to the
/// last echo (`sWN FREchoFilter 2`): behind dust or spray the wall, not the cloud (a scanner
/// that refuses it fails the start-up with its `sFA` code, named in the log).
pub fn session_config() -> SessionConfig {
    SessionConfig {
        echo_filter: Some(lidar_driver::EchoFilter::Last),
        ..SessionConfig::default()
    }
}

/// The last bytes of the map flash region, where the start-pose record lives.
pub const START_POSE_BLOCK_BYTES: usize = 4096;

/// 1σ of the motion between two scans when no odometry is wired: forward and left metres,
/// heading radians (a loader at up to 10 m/s moves 0.4 m per 25 Hz scan).
pub const UNMEASURED_MOTION_SIGMA: [f32; 3] = [0.3, 0.1, 0.03];

/// 1σ of the start from the last pose stored before a reset: metres (each axis), radians.
pub const DEFAULT_START_SIGMA: [f32; 2] = [1.0, 0.1];

/// Where the controller's start pose came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum StartSource {
    /// The start-pose record of the map flash region.
    Record,
    /// No record (erased): no start pose, the controller relocalises.
    Relocalise,
    /// A damaged or unreadable record: ignored, the controller relocalises.
    RelocaliseRecordUnusable,
    /// After a reset while running: the last pose stored before it (`crate::retained`).
    LastPoseBeforeReset,
}

/// The block before the start-pose block, where the configuration record lives.
pub const CONFIG_BLOCK_BYTES: usize = 4096;

/// The parts of the map flash region.
#[derive(Debug, Clone, Copy)]
pub struct RegionParts<'r> {
    /// The map image (from the region's first byte) and its padding.
    pub map: &'r [u8],
    /// The configuration block: the [`CONFIG_BLOCK_BYTES`] before the start-pose block.
    pub config: &'r [u8],
    /// The start-pose block: the region's last [`START_POSE_BLOCK_BYTES`].
    pub start: &'r [u8],
}

/// The map flash region split into its parts.
pub fn split_region(region: &[u8]) -> RegionParts<'_> {
    let (rest, start) = region.split_at(region.len().saturating_sub(START_POSE_BLOCK_BYTES));
    let (map, config) = rest.split_at(rest.len().saturating_sub(CONFIG_BLOCK_BYTES));
    RegionParts { map, config, start }
}

/// The localiser's configuration from the region's configuration record
/// (`host-sim export-map --config-out`): the sensor's layout and mounting, the matcher,
/// the noise models. `Ok(None)` when none was written (erased): loc-core's defaults apply.
pub fn configuration(region: &[u8]) -> Result<Option<LocalizerConfig>, ConfigRecordError> {
    match LocalizerConfig::from_record(split_region(region).config) {
        Ok(c) => Ok(Some(c)),
        Err(ConfigRecordError::NotPresent) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Opens the map image at the start of `region` (the map flash region) in place as the
/// program's map ([`MAP`]), after checking it whole (CRC, every count, segment, index entry
/// and landmark). The map part of the region may hold padding after the image (erased
/// `0xFF` or `0x00`), nothing else.
pub fn load_map(region: &'static [u8]) -> Result<&'static MapImage<'static>, MapError> {
    MAP.open(split_region(region).map)
}

/// The start pose: the record in `region`'s start-pose block, else `None` (the controller
/// relocalises). Also says which, and the record's error when it was unusable.
pub fn start_pose(region: &[u8]) -> (StartSource, Option<StartPose>, Option<StartPoseError>) {
    match StartPose::from_bytes(split_region(region).start) {
        Ok(start) => (StartSource::Record, Some(start), None),
        Err(StartPoseError::NotPresent) => (StartSource::Relocalise, None, None),
        Err(e) => (StartSource::RelocaliseRecordUnusable, None, Some(e)),
    }
}

/// The localisation side of the controller (≈ 70 KiB), on the map image read in place
/// ([`MAP`]). There is one, built at compile time in a static: [`Controller::take`].
pub struct Controller<'m> {
    localizer: Localizer<'m, FlashMap>,
    scan: Scan,
    motion: OdometryIncrement,
    last_pose: Option<Pose2>,
    motion_source: MotionSource,
}

impl<'m> Controller<'m> {
    /// A controller on `map` with loc-core's default configuration, not started
    /// ([`Controller::start`]). A `const fn`, for the static of [`Controller::take`].
    pub const fn new(map: &'m FlashMap) -> Self {
        Self {
            localizer: Localizer::uninitialised(map, LocalizerConfig::DEFAULT),
            scan: Scan::new(),
            motion: OdometryIncrement {
                dx_m: 0.0,
                dy_m: 0.0,
                dtheta_rad: 0.0,
            },
            last_pose: None,
            motion_source: MotionSource::None,
        }
    }

    /// Takes the vehicle's configuration (before [`Controller::start`]).
    pub fn configure(&mut self, config: LocalizerConfig) {
        self.localizer.set_config(config);
    }

    /// (Re)starts localising at `start`, forgetting the motion so far. Also computes the
    /// beam directions of the configured sensor layout now rather than in the first scan's
    /// budget (the scanner's telegrams carry that layout when the configuration was written
    /// for it, as `host-sim export-map --config-out` does; a table already computed is kept).
    pub fn start(&mut self, start: &StartPose) -> Result<(), FilterInitError> {
        self.scan
            .prepare_directions(&self.localizer.config().sensor.geometry);
        self.localizer.initialise(start.pose, start.covariance())?;
        self.motion = OdometryIncrement::default();
        self.last_pose = None;
        self.motion_source = MotionSource::None;
        Ok(())
    }

    /// Starts localising without a pose (any pose so far is forgotten): loc-core's
    /// relocalisation searches the map for the landmarks seen while the vehicle drives
    /// (pose frames say [`PoseStatus::Relocalising`] until it locks). Also computes the
    /// beam directions, as [`Controller::start`] does.
    pub fn relocalise(&mut self) {
        self.scan
            .prepare_directions(&self.localizer.config().sensor.geometry);
        self.localizer.forget_pose();
        self.localizer.relocalise();
        self.motion = OdometryIncrement::default();
        self.last_pose = None;
        self.motion_source = MotionSource::None;
    }

    /// After a reset: starts again from `last` (the last tracked scan before it) carried
    /// over the outage to the vehicle's odometry reading `now` ([`crate::resume::bridge`]).
    /// The start is at `now`'s scan: predict that scan with no motion. On refusal the
    /// controller is left as it was.
    pub fn resume(
        &mut self,
        last: &LastScan,
        now: &OdometryFrame,
    ) -> Result<Bridged, BridgeRefusal> {
        let bridged = crate::resume::bridge(last, now, &self.localizer.config().odometry)?;
        self.start(&bridged.start)
            .map_err(|_| BridgeRefusal::StartRejected)?;
        Ok(bridged)
    }

    /// The localizer (status, pose, last strip and match).
    pub fn localizer(&self) -> &Localizer<'m, FlashMap> {
        &self.localizer
    }

    /// Predicts the motion since the last scan: with `odometry` (vehicle frame, loc-core's
    /// noise model) when the vehicle gives it, else with constant velocity and
    /// [`UNMEASURED_MOTION_SIGMA`]. A rejected (implausible) increment leaves the state as
    /// it was.
    pub fn predict(&mut self, odometry: Option<&OdometryIncrement>) {
        self.motion_source = match odometry {
            Some(_) => MotionSource::Odometry,
            None => MotionSource::ConstantVelocity,
        };
        let _ = match odometry {
            Some(inc) => self.localizer.predict_odometry(inc),
            None => {
                let [sx, sy, sth] = UNMEASURED_MOTION_SIGMA;
                let q = Matrix3::from_diagonal(&Vector3::new(sx * sx, sy * sy, sth * sth));
                self.localizer.predict_motion(&self.motion, &q)
            }
        };
    }

    /// The vehicle's speed by its odometry (`rate`, from the last two frames), for the
    /// sweep of the next scan when the localiser's own track does not reach back to an
    /// earlier one (the first scan after a start or a reset, a scan while relocalising):
    /// that scan is then carried over the mirror's sweep too (21 ms at 25 Hz).
    pub fn hint_sweep_speed(&mut self, rate: &SweepMotion) {
        self.localizer.hint_sweep_speed(*rate);
    }

    /// Turns `telegram`'s distance channels into the scan to localise on (scan-input: the
    /// telegram's own layout and scale, per beam the echo [`ECHO_SELECTION`] chooses).
    pub fn load_scan(&mut self, telegram: &ScanData<'_>) -> Result<(), ScanInputError> {
        let sensor = self.localizer.config().sensor;
        scan_input::load_scan(telegram, &sensor, ECHO_SELECTION, &mut self.scan).map(|_| ())
    }

    /// Localises on the loaded scan, reporting loc-core's stages to `observer`, and returns
    /// the pose frame to send (`sequence`: the telegram's scan counter).
    pub fn localise<O: StageObserver>(&mut self, sequence: u32, observer: &mut O) -> PoseFrame {
        let status = self
            .localizer
            .update_scan_observed(&mut self.scan, observer);
        let pose = self.localizer.pose().unwrap_or(Pose2::IDENTITY);
        if let Some(previous) = self.last_pose {
            self.motion = OdometryIncrement::between(&previous, &pose);
        }
        self.last_pose = Some(pose);
        let c = self.localizer.covariance().unwrap_or([[0.0; 3]; 3]);
        let protection = self.localizer.protection();
        PoseFrame {
            sequence,
            x_m: pose.x_m,
            y_m: pose.y_m,
            theta_rad: pose.theta_rad,
            covariance_upper: [c[0][0], c[0][1], c[0][2], c[1][1], c[1][2], c[2][2]],
            status: pose_status(&status),
            protection_m: protection.level_m.unwrap_or(f32::INFINITY),
            availability: pose_availability(&protection),
            motion: self.motion_source,
            // The run loop marks poses after a reset and times the scan.
            after_reset: false,
            work: 0,
            stage_work: [0; 5],
        }
    }

    /// One scan as the vehicle runs it: [`Controller::predict`] (with `odometry` when fresh
    /// odometry is at hand), [`Controller::load_scan`], [`Controller::localise`], each stage
    /// timed by `timer` (the frame's `stage_work` is what it measured).
    pub fn on_scan<B: Board>(
        &mut self,
        telegram: &ScanData<'_>,
        odometry: Option<&OdometryIncrement>,
        timer: &mut StageTimer<'_, B>,
    ) -> Result<PoseFrame, ScanInputError> {
        let t0 = timer.now();
        self.predict(odometry);
        timer.add_since(ScanStage::Filter, t0);
        let t1 = timer.now();
        self.load_scan(telegram)?;
        timer.add_since(ScanStage::Scan, t1);
        let mut frame = self.localise(u32::from(telegram.header.scan_counter), timer);
        frame.stage_work = timer.costs.to_wire();
        Ok(frame)
    }
}

/// The program's controller, built at compile time (its ≈ 70 KiB are in `.bss`; building it
/// at run time would put a copy on the stack first).
static CONTROLLER: ConstStaticCell<Controller<'static>> =
    ConstStaticCell::new(Controller::new(&MAP));

impl Controller<'static> {
    /// The program's controller on [`MAP`], once: `None` when taken before.
    pub fn take() -> Option<&'static mut Self> {
        CONTROLLER.try_take()
    }
}

/// The wire status of a localiser status.
pub fn pose_status(status: &Status) -> PoseStatus {
    match status {
        Status::Tracking => PoseStatus::Tracking,
        Status::Degenerate { .. } => PoseStatus::Degenerate,
        Status::NotInitialised => PoseStatus::NotInitialised,
        Status::MapUnconfirmed { .. } => PoseStatus::MapUnconfirmed,
        Status::Relocalising { .. } => PoseStatus::Relocalising,
        // Any other status (a newer loc-core's): the scan did not update the pose.
        _ => PoseStatus::OdometryOnly,
    }
}

/// The wire availability of a localiser's protection level.
pub fn pose_availability(protection: &Protection) -> PoseAvailability {
    match protection.availability {
        Availability::Available => PoseAvailability::Available,
        Availability::AboveAlertLimit => PoseAvailability::AboveAlertLimit,
        Availability::FaultDetected => PoseAvailability::FaultDetected,
        // Any other reason (a newer loc-core's) leaves no pose to act on.
        _ => PoseAvailability::NoPose,
    }
}

/// Sends `frame` on the board's vehicle port (a failed write is logged, not fatal).
fn send<B: Board>(board: &mut B, frame: &PoseFrame) {
    use embedded_io::Write;
    let mut buf = [0u8; MAX_FRAME_BYTES];
    if let Ok(bytes) = frame.encode(&mut buf) {
        if board.vehicle_serial().write_all(bytes).is_err() {
            defmt::warn!("pose frame not sent: UART error");
        }
    }
}

/// Without a usable map (or with a damaged configuration record): reports `error` once,
/// then sends a [`PoseStatus::NoMap`] frame every second, for ever (flash a map image, or
/// the configuration record, and reset).
pub fn wait_without_map<B: Board, E: defmt::Format>(board: &mut B, error: &E) -> ! {
    defmt::error!(
        "no usable map or configuration in the map flash region: {}; not localising (flash what host-sim export-map writes, then reset)",
        error
    );
    let mut sequence = 0u32;
    let mut next_ms = board.now_ms();
    loop {
        let now = board.now_ms();
        if now >= next_ms {
            send(board, &PoseFrame::no_map(sequence));
            sequence = sequence.wrapping_add(1);
            next_ms = now + 1000;
        }
        cortex_m::asm::nop();
    }
}

/// [`quiet_scanner`] drains the line until it has been silent this long, ms.
pub const QUIET_SILENCE_MS: u64 = 100;
/// ... or for this long at most, ms.
pub const QUIET_MAX_MS: u64 = 3000;

/// After a reset while running, the scanner on a serial line is still streaming the scans of
/// the previous run's subscription, and a backlog of them queues ahead of any answer to the
/// new session's first requests. Asks it to stop (`sEN LMDscandata 0`, in CoLa-B and CoLa-A:
/// the dialect of the previous run is unknown) and drains the line until it is silent for
/// [`QUIET_SILENCE_MS`] (at most [`QUIET_MAX_MS`]), so the new session starts on a quiet line.
pub fn quiet_scanner<B: Board>(board: &mut B) {
    use embedded_io::{Read, ReadReady, Write};
    use lidar_driver::request::{names, Request};
    let stop = Request::Subscribe {
        event: names::SCAN_DATA,
        enable: false,
    };
    let mut buf = [0u8; 64];
    for dialect in [lidar_driver::Dialect::ColaB, lidar_driver::Dialect::ColaA] {
        if let Ok(n) = stop.emit(dialect, &mut buf) {
            let _ = board.serial().write_all(buf.get(..n).unwrap_or(&[]));
        }
    }
    let _ = board.serial().flush();
    let start = board.now_ms();
    let mut last_byte_ms = start;
    let mut drained = 0usize;
    loop {
        let now = board.now_ms();
        if now - last_byte_ms >= QUIET_SILENCE_MS || now - start >= QUIET_MAX_MS {
            break;
        }
        let serial = board.serial();
        if matches!(serial.read_ready(), Ok(true)) {
            if let Ok(n) = serial.read(&mut buf) {
                drained += n;
                last_byte_ms = now;
            }
        }
    }
    defmt::info!(
        "scanner asked to stop streaming; {=usize} bytes drained from the line in {=u64} ms",
        drained,
        board.now_ms() - start
    );
}

/// How [`run`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOptions {
    /// Stop with success after this many scans (test runs); `None`: run for ever.
    pub scan_limit: Option<u32>,
    /// Resets while running before this start (`retained::boot`): poses are marked
    /// `after_reset` until the controller tracks again.
    pub resets: u32,
    /// After a reset: the last tracked scan before it (`retained::boot`), carried over the
    /// outage by the odometry at the first scan ([`Controller::resume`]).
    pub resume: Option<LastScan>,
    /// No scan for this long makes the controller send [`PoseStatus::Stale`] frames (the
    /// last pose), one per this period, milliseconds.
    pub stale_after_ms: u64,
    /// The hardware watchdog's time-out, milliseconds: a loop that stalls this long resets
    /// the controller.
    pub watchdog_ms: u32,
    /// Test runs only: stop feeding the watchdog (hang) after this many scans, on a run that
    /// was not itself started by a reset.
    pub stall_after_scans: Option<u32>,
}

/// Defaults: run for ever, stale after 500 ms without a scan (12 scans at 25 Hz), a 1 s
/// watchdog.
pub const DEFAULT_RUN: RunOptions = RunOptions {
    scan_limit: None,
    resets: 0,
    resume: None,
    stale_after_ms: 500,
    watchdog_ms: 1000,
    stall_after_scans: None,
};

/// Runs the controller on `board` for ever (or as `options` say for test runs).
/// `session_buf` is the LMS session's receive buffer.
pub fn run<B: Board>(
    board: &mut B,
    controller: &mut Controller<'_>,
    session_buf: &mut [u8],
    options: &RunOptions,
) -> ! {
    let mut session = Session::new(session_buf, session_config());
    let mut odometry = OdometryInput::new();
    let mut resume = options.resume;
    if let Some(reading) = resume.and_then(|last| last.odometry) {
        odometry.resume_from(reading);
    }
    let mut scans = 0u32;
    // Whether the previous scan had odometry (`None` before the first scan): each change is
    // logged once.
    let mut had_odometry: Option<bool> = None;
    let mut after_reset = options.resets > 0;
    let mut last_scan_ms = board.now_ms();
    let mut next_stale_ms = last_scan_ms + options.stale_after_ms;
    let mut last_frame: Option<PoseFrame> = None;
    board.start_watchdog(options.watchdog_ms);
    loop {
        board.feed_watchdog();
        // The session reads the clock a few times per poll; one reading per poll suffices.
        let now_ms = board.now_ms();
        let clock = move || now_ms;
        odometry.poll(board.vehicle_serial(), now_ms);
        let telegram = match session.poll(&mut FixedLink(board.serial()), &clock) {
            Event::Scan(telegram) => Some(telegram),
            Event::Failed(e) => {
                defmt::warn!("LMS session failed: {}", e);
                None
            }
            Event::Idle => None,
            other => {
                defmt::info!("LMS session: {}", defmt::Display2Format(&other));
                None
            }
        };
        let Some(telegram) = telegram else {
            if now_ms >= next_stale_ms {
                next_stale_ms = now_ms + options.stale_after_ms;
                send_stale(board, &mut last_frame, now_ms - last_scan_ms, after_reset);
            }
            continue;
        };
        let mut increment = odometry.increment_for_scan(now_ms);
        if let Some(last) = resume.take() {
            increment = resume_after_reset(controller, &last, odometry.at_last_scan());
        }
        if let (Some(_), Some(rate)) = (increment, odometry.rate()) {
            controller.hint_sweep_speed(&rate);
        }
        if had_odometry != Some(increment.is_some()) {
            had_odometry = Some(increment.is_some());
            log_odometry_change(increment.is_some(), &odometry);
        }
        let t0 = board.counter_now();
        let result =
            controller.on_scan(&telegram, increment.as_ref(), &mut StageTimer::new(&*board));
        let cost = board.counter_now() - t0;
        let mut frame = match result {
            Ok(frame) => frame,
            Err(e) => {
                defmt::warn!("scan telegram not used: {}", e);
                continue;
            }
        };
        last_scan_ms = now_ms;
        next_stale_ms = now_ms + options.stale_after_ms;
        frame.after_reset = after_reset;
        frame.work = u32::try_from(cost).unwrap_or(u32::MAX);
        after_reset &= frame.status != PoseStatus::Tracking;
        defmt::info!(
            "scan {=u32}: ({=f32}, {=f32}, {=f32}) {} in {=u64} {}, motion {}, after reset {=bool}",
            frame.sequence,
            frame.x_m,
            frame.y_m,
            frame.theta_rad,
            frame.status,
            cost,
            B::COUNTER_UNIT,
            frame.motion,
            frame.after_reset
        );
        if frame.status == PoseStatus::OdometryOnly {
            defmt::info!("  scan not used: {}", controller.localizer().status());
        }
        // What a reset would start from: only a tracked pose is worth carrying over.
        if frame.status == PoseStatus::Tracking {
            let localizer = controller.localizer();
            if let (Some(pose), Some(c)) = (localizer.pose(), localizer.covariance()) {
                let last = LastScan::new(pose, &c, odometry.at_last_scan());
                crate::retained::store_scan(options.resets, &last);
            }
        }
        send(board, &frame);
        last_frame = Some(frame);
        scans += 1;
        if options.resets == 0 && options.stall_after_scans == Some(scans) {
            defmt::warn!(
                "test run: stalling after {=u32} scans (the watchdog must reset)",
                scans
            );
            loop {
                cortex_m::asm::nop();
            }
        }
        if options.scan_limit.is_some_and(|limit| scans >= limit) {
            finish_test_run::<B>(scans, &odometry);
        }
    }
}

/// The first scan after a reset: restarts the controller from `last` carried over the
/// outage to `now` (the odometry reading at this scan) when it can, and returns the motion
/// to predict this scan with (none after a carried start: it is at this scan; no odometry
/// when the start was not carried — the increment from the kept reading would span the
/// outage, or the sender's restart).
fn resume_after_reset(
    controller: &mut Controller<'_>,
    last: &LastScan,
    now: Option<OdometryFrame>,
) -> Option<OdometryIncrement> {
    let Some(now) = now else {
        defmt::warn!(
            "no fresh odometry at the first scan after the reset: starting from the last pose before it"
        );
        return None;
    };
    match controller.resume(last, &now) {
        Ok(b) => {
            defmt::warn!(
                "outage bridged by odometry: {=f32} m in {=f32} s; start at ({=f32}, {=f32}, {=f32}) with sigma {=f32} m, {=f32} rad",
                b.distance_m,
                b.outage_s,
                b.start.pose.x_m,
                b.start.pose.y_m,
                b.start.pose.theta_rad,
                b.start.sigma_xy_m,
                b.start.sigma_theta_rad
            );
            Some(OdometryIncrement::default())
        }
        Err(e) => {
            defmt::warn!(
                "outage not bridged ({}): starting from the last pose before the reset",
                e
            );
            None
        }
    }
}

/// Sends the last pose as [`PoseStatus::Stale`] (`silent_ms` without a scan), marked
/// `after_reset` while the controller has not tracked since a reset (so the vehicle side
/// sees a restart even before the first scan after it); logs the first of a run of them.
fn send_stale<B: Board>(
    board: &mut B,
    last: &mut Option<PoseFrame>,
    silent_ms: u64,
    after_reset: bool,
) {
    let mut frame = last.unwrap_or(PoseFrame::no_map(0));
    frame.after_reset = after_reset;
    if frame.status != PoseStatus::Stale {
        defmt::warn!(
            "no scan for {=u64} ms: the pose is stale (check the scanner and its link)",
            silent_ms
        );
    }
    frame.status = PoseStatus::Stale;
    frame.availability = PoseAvailability::Stale;
    send(board, &frame);
    *last = Some(frame);
}

fn log_odometry_change(has_odometry: bool, odometry: &OdometryInput) {
    if has_odometry {
        defmt::info!("odometry: predicting with the vehicle's odometry");
    } else {
        defmt::warn!(
            "odometry: none within {=u64} ms: predicting with constant velocity ({})",
            ODOMETRY_STALE_MS,
            odometry.counts()
        );
    }
}

/// The end of a test run: what it used, then success.
fn finish_test_run<B: Board>(scans: u32, odometry: &OdometryInput) -> ! {
    let ram = crate::ram::usage();
    defmt::println!("controller: odometry {}", odometry.counts());
    defmt::println!(
        "controller: {=u32} scans localised, stopping (test run); ram: static {=u32} bytes + stack high-water mark {=u32} bytes = {=u32} bytes (headroom left: {=bool})",
        scans,
        ram.static_bytes,
        ram.stack_high_water_bytes,
        ram.total_bytes(),
        ram.headroom_left
    );
    B::exit(ExitStatus::Success)
}
