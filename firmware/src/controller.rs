//! The controller loop: LMS511 telegrams in over the board's serial port, a pose frame out on
//! the same port after every scan.
//!
//! Start-up: the stored map is loaded from the board's map flash region; when that region
//! holds no map (erased: bad magic), the map built into the image (the recording's) is used.
//! A damaged map (checksum, version) stops the controller: it never localises on a wrong map.
//!
//! Motion prediction: this board has no odometry input yet, so each scan is predicted with
//! the motion between the two previous estimates (constant velocity) and the uncertainty of
//! an unmeasured motion ([`UNMEASURED_MOTION_SIGMA`] per scan); wire the wheel odometry into
//! [`Controller::on_scan`]'s prediction when the vehicle interface exists.

use lidar_driver::session::{Event, Session, SessionConfig};
use lidar_driver::ScanData;
use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::localizer::{Localizer, LocalizerConfig, Status};
use loc_core::map::{MapError, TunnelMap, WallSide};
use loc_core::scan::{Scan, LMS511_MAX_BEAMS};
use nalgebra::{Matrix3, Vector3};

use crate::board::{Board, ExitStatus};
use crate::pose_frame::{PoseFrame, PoseStatus, MAX_FRAME_BYTES};
use crate::recorded;
use crate::replay::{INITIAL_ERROR, INITIAL_SIGMA};
use crate::scan_input::{load_scan, ScanInputError};
use lidar_driver::transport::FixedLink;

/// Receive buffer of the LMS session, bytes (holds one LMS511 scan in either dialect).
pub const SESSION_BUFFER_BYTES: usize = 16 * 1024;

/// 1σ of the motion between two scans when no odometry is wired: forward and left metres,
/// heading radians (a loader at up to 10 m/s moves 0.4 m per 25 Hz scan).
pub const UNMEASURED_MOTION_SIGMA: [f32; 3] = [0.3, 0.1, 0.03];

/// Which map the controller runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum MapSource {
    /// The board's map flash region.
    FlashRegion,
    /// The map built into the image (the recording's tunnel).
    BuiltIn,
}

/// Loads the map: the flash region if it holds one, else the built-in map. Returns the map
/// source and the initial pose and covariance to start from: the recording's start pose
/// (with the replay's initial error) for the built-in map, the tunnel's start (chainage 0,
/// between the walls, heading along them, 1 m / 0.1 rad 1σ) for a flashed map.
pub fn load_map(
    region: &[u8],
    map: &mut TunnelMap,
) -> Result<(MapSource, Pose2, Matrix3<f32>), MapError> {
    match map.load_from_bytes(region) {
        Ok(()) => {
            let (Some(l), Some(r)) = (
                map.wall_frame_at(WallSide::Left, 0.0),
                map.wall_frame_at(WallSide::Right, 0.0),
            ) else {
                return Err(MapError::Corrupt {
                    part: "walls (no start point)",
                    index: 0,
                });
            };
            let mid = l.anchor.add(r.anchor).scale(0.5);
            let heading = loc_core::math::atan2(l.tangent.y_m, l.tangent.x_m);
            let cov = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.01));
            Ok((
                MapSource::FlashRegion,
                Pose2::new(mid.x_m, mid.y_m, heading),
                cov,
            ))
        }
        Err(MapError::BadMagic { .. }) => {
            map.load_from_bytes(recorded::MAP_BYTES)?;
            let [x, y, th] = recorded::TRUE_POSES[0];
            let [ex, ey, eth] = INITIAL_ERROR;
            let [sx, sy, sth] = INITIAL_SIGMA;
            let cov = Matrix3::from_diagonal(&Vector3::new(sx * sx, sy * sy, sth * sth));
            Ok((
                MapSource::BuiltIn,
                Pose2::new(x + ex, y + ey, th + eth),
                cov,
            ))
        }
        Err(e) => Err(e),
    }
}

/// The localisation side of the controller (≈ 50 KiB: keep it in a static).
pub struct Controller<'m> {
    localizer: Localizer<'m, TunnelMap>,
    scan: Scan,
    raw: [u16; LMS511_MAX_BEAMS],
    motion: OdometryIncrement,
    last_pose: Option<Pose2>,
}

impl<'m> Controller<'m> {
    /// A controller on `map`, starting at `pose` with covariance `cov`.
    pub fn new(map: &'m TunnelMap, pose: Pose2, cov: Matrix3<f32>) -> Option<Self> {
        let localizer = Localizer::new(map, LocalizerConfig::default(), pose, cov).ok()?;
        Some(Self {
            localizer,
            scan: Scan::new(),
            raw: [0; LMS511_MAX_BEAMS],
            motion: OdometryIncrement::default(),
            last_pose: None,
        })
    }

    /// The localizer's status after the last scan.
    pub fn status(&self) -> Status {
        self.localizer.status()
    }

    /// Localises on one scan telegram and returns the pose frame to send.
    pub fn on_scan(&mut self, telegram: &ScanData<'_>) -> Result<PoseFrame, ScanInputError> {
        // A rejected (implausible) increment leaves the state unchanged.
        let [sx, sy, sth] = UNMEASURED_MOTION_SIGMA;
        let motion_cov = Matrix3::from_diagonal(&Vector3::new(sx * sx, sy * sy, sth * sth));
        let _ = self
            .localizer
            .predict_odometry_with_covariance(&self.motion, &motion_cov);
        let sensor = self.localizer.config().sensor;
        load_scan(telegram, &sensor, &mut self.raw, &mut self.scan)?;
        let status = self.localizer.update_scan(&self.scan);
        let pose = self.localizer.pose().unwrap_or(Pose2::IDENTITY);
        if let Some(previous) = self.last_pose {
            self.motion = OdometryIncrement::between(&previous, &pose);
        }
        self.last_pose = Some(pose);
        let c = self.localizer.covariance().unwrap_or([[0.0; 3]; 3]);
        Ok(PoseFrame {
            sequence: u32::from(telegram.header.scan_counter),
            x_m: pose.x_m,
            y_m: pose.y_m,
            theta_rad: pose.theta_rad,
            covariance_upper: [c[0][0], c[0][1], c[0][2], c[1][1], c[1][2], c[2][2]],
            status: match status {
                Status::Tracking => PoseStatus::Tracking,
                Status::Degenerate { .. } => PoseStatus::Degenerate,
                Status::NotInitialised => PoseStatus::NotInitialised,
                Status::DeadReckoning | Status::MatchRejected { .. } => PoseStatus::OdometryOnly,
            },
        })
    }
}

/// Runs the controller on `board` for ever, or until `scan_limit` scans were localised
/// (test runs), then exits with success. `session_buf` is the LMS session's receive buffer.
pub fn run<B: Board>(
    board: &mut B,
    controller: &mut Controller<'_>,
    session_buf: &mut [u8],
    scan_limit: Option<u32>,
) -> ! {
    let mut session = Session::new(session_buf, SessionConfig::default());
    let mut scans = 0u32;
    let mut frame_buf = [0u8; MAX_FRAME_BYTES];
    loop {
        // The session reads the clock a few times per poll; one reading per poll suffices.
        let now_ms = board.now_ms();
        let clock = move || now_ms;
        let frame = match session.poll(&mut FixedLink(board.serial()), &clock) {
            Event::Scan(telegram) => {
                let t0 = board.counter_now();
                let result = controller.on_scan(&telegram);
                let cost = board.counter_now() - t0;
                match result {
                    Ok(frame) => {
                        defmt::info!(
                            "scan {=u32}: ({=f32}, {=f32}, {=f32}) {} in {=u64} {}",
                            frame.sequence,
                            frame.x_m,
                            frame.y_m,
                            frame.theta_rad,
                            frame.status,
                            cost,
                            B::COUNTER_UNIT
                        );
                        if frame.status == PoseStatus::OdometryOnly {
                            defmt::info!(
                                "  scan not used: {}",
                                defmt::Debug2Format(&controller.status())
                            );
                        }
                        Some(frame)
                    }
                    Err(e) => {
                        defmt::warn!("scan telegram not used: {}", e);
                        None
                    }
                }
            }
            Event::Failed(e) => {
                defmt::warn!("LMS session failed: {}", defmt::Display2Format(&e));
                None
            }
            Event::Idle => None,
            other => {
                defmt::info!("LMS session: {}", defmt::Debug2Format(&other));
                None
            }
        };
        if let Some(frame) = frame {
            if let Ok(bytes) = frame.encode(&mut frame_buf) {
                use embedded_io::Write;
                if board.serial().write_all(bytes).is_err() {
                    defmt::warn!("pose frame not sent: UART error");
                }
            }
            scans += 1;
            if scan_limit.is_some_and(|limit| scans >= limit) {
                defmt::println!(
                    "controller: {=u32} scans localised, stopping (test run)",
                    scans
                );
                B::exit(ExitStatus::Success);
            }
        }
    }
}
