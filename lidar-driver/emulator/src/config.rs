//! What the emulated LMS5xx is (identity, start-up delay, rate, dialect) and which faults it
//! injects.

use std::time::Duration;

use lidar_driver::answer::Answer;
use lidar_driver::frame::Dialect;
use lidar_driver::recording::Recording;
use lidar_driver::request::{OutputRange, ScanConfig, ScanDataConfig};

use crate::recorded::RecordedAnswers;

/// The LMS511's field of view, 1/10000° (−5° … +185°).
pub(crate) const LMS511_FOV_1E4_DEG: (i32, i32) = (-50_000, 1_850_000);

/// Which dialect the emulated device speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DialectMode {
    /// Whatever the first frame of each connection uses (frames of the other dialect are then
    /// ignored, as a real device would not understand them).
    Auto,
    /// Only this dialect (like a real device's `EIHstCola` setting); frames of the other are
    /// ignored, so a client's probe in the wrong dialect gets no answer.
    Only(Dialect),
}

/// The device's fixed answers. [`DeviceIdentity::lms511_capture`] holds exactly what the LMS511
/// of `lms511_20210302_colab.pcapng.json` answered.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceIdentity {
    /// `sRA FirmwareVersion`.
    pub firmware_version: Vec<u8>,
    /// `sRA LocationName`.
    pub location_name: Vec<u8>,
    /// `sRA ODoprh` (operating hours counter as sent).
    pub operating_hours: u32,
    /// `sRA ODpwrc` (power-on counter).
    pub power_on_count: u32,
    /// `LMPoutputRange` at power-up.
    pub output_range: OutputRange,
    /// `LMDscandatacfg` at power-up.
    pub scan_data: ScanDataConfig,
    /// `LMPscancfg` at power-up.
    pub scan_config: ScanConfig,
    /// Angles `LMPoutputRange` and `mLMPsetscancfg` may use, 1/10000° (start, stop).
    pub field_of_view_1e4_deg: (i32, i32),
    /// Every other answer and the events the recorded sensor sent (field definitions,
    /// input / output states, `LFErec`), replayed as recorded.
    pub recorded: RecordedAnswers,
}

impl DeviceIdentity {
    /// The LMS511 (firmware V1.80, serial 18110550) of the capture.
    pub fn lms511_capture() -> Self {
        DeviceIdentity {
            firmware_version: b"V1.80    ".to_vec(),
            location_name: b"SN 18110550".to_vec(),
            operating_hours: 0x04ab,
            power_on_count: 0x63,
            output_range: OutputRange {
                sectors: 1,
                step_1e4_deg: 1667,
                start_1e4_deg: -50_000,
                stop_1e4_deg: 1_850_000,
            },
            scan_data: lidar_driver::session::SessionConfig::CAPTURE_SCAN_DATA,
            scan_config: ScanConfig {
                frequency_1e2_hz: 2500,
                sectors: 1,
                step_1e4_deg: 1667,
                start_1e4_deg: -50_000,
                stop_1e4_deg: 1_850_000,
            },
            field_of_view_1e4_deg: LMS511_FOV_1E4_DEG,
            recorded: RecordedAnswers::lms511_capture(),
        }
    }

    /// The identity a recording shows: every answer the recorded sensor gave (FirmwareVersion,
    /// LocationName, ODoprh, ODpwrc, LMPoutputRange, LMDscandatacfg, LMPscancfg) and the scan
    /// geometry of its first scan (frequency, step, angles), and its other answers and events
    /// ([`RecordedAnswers`]); what the recording lacks keeps the LMS511 capture's values. The
    /// field of view and the scan angles are the first (power-up) output range.
    pub fn from_recording(rec: &Recording) -> Self {
        let mut id = Self::lms511_capture();
        let recorded = RecordedAnswers::from_recording(rec);
        // A recording with answers of its own (not just scans) answers with them.
        if recorded.requests().next().is_some() {
            id.recorded = recorded;
        }
        let mut range_seen = false;
        let mut scan_seen = false;
        for f in rec.frames().frames {
            let Ok(a) = Answer::from_frame(f.frame()) else {
                continue;
            };
            match a {
                Answer::FirmwareVersion(v) => id.firmware_version = v.to_vec(),
                Answer::LocationName(v) => id.location_name = v.to_vec(),
                Answer::OperatingHours(v) => id.operating_hours = v,
                Answer::PowerOnCount(v) => id.power_on_count = v,
                Answer::OutputRange(r) if !range_seen => {
                    range_seen = true;
                    id.output_range = r;
                }
                Answer::ScanDataConfig(c) => id.scan_data = c,
                Answer::ScanConfig(c) => id.scan_config = c,
                Answer::Scan(s) if !scan_seen => {
                    scan_seen = true;
                    id.scan_config.frequency_1e2_hz = s.header.scan_frequency_1e2_hz;
                    if let Some(d) = s.dist1() {
                        id.scan_config.step_1e4_deg = u32::from(d.header.step_1e4_deg);
                    }
                }
                _ => {}
            }
        }
        if range_seen {
            let r = id.output_range;
            id.scan_config.start_1e4_deg = r.start_1e4_deg;
            id.scan_config.stop_1e4_deg = r.stop_1e4_deg;
            id.field_of_view_1e4_deg = (r.start_1e4_deg, r.stop_1e4_deg);
        }
        id
    }
}

impl Default for DeviceIdentity {
    fn default() -> Self {
        Self::lms511_capture()
    }
}

/// Faults to inject, for tests of the client's recovery.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Faults {
    /// Close a connection after this many scans on it.
    pub drop_after_scans: Option<u64>,
    /// How many connections are dropped that way at most (then streams run on); `None` =
    /// every connection.
    pub max_drops: Option<u32>,
    /// Before every n-th scan, send garbage bytes (including stray start markers and a
    /// CoLa-B header with an impossible length).
    pub garbage_every: Option<u64>,
    /// Damage every n-th scan frame (CoLa-B: its checksum; CoLa-A: a control byte inside).
    pub corrupt_every: Option<u64>,
    /// Accept connections but never answer (a hung device).
    pub silent: bool,
}

/// Emulator settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorConfig {
    /// TCP port on 127.0.0.1; 0 = any free port (see [`crate::Emulator::addr`]).
    pub port: u16,
    /// Dialect behaviour.
    pub dialect: DialectMode,
    /// Scan rate at power-up, Hz (25 like the LMS511); `mLMPsetscancfg` changes it.
    pub rate_hz: f32,
    /// `SCdevicestate` answers busy (0) and other requests `sFA 13` for this long after start.
    pub startup_delay: Duration,
    /// Fixed answers.
    pub identity: DeviceIdentity,
    /// Overwrite the scans' counters, timestamps and frequency as a live device would (off:
    /// send the source's scans unchanged).
    pub restamp: bool,
    /// Fault injection.
    pub faults: Faults,
    /// Resource bounds: connections, idle and half-sent-telegram time-outs.
    pub limits: Limits,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        EmulatorConfig {
            port: 0,
            dialect: DialectMode::Auto,
            rate_hz: 25.0,
            startup_delay: Duration::ZERO,
            identity: DeviceIdentity::default(),
            restamp: true,
            faults: Faults::default(),
            limits: Limits::default(),
        }
    }
}

/// What the emulator spends on its clients at most, so that a client which opens many
/// connections, goes quiet, or sends half a telegram cannot exhaust it or stall the next
/// requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// TCP connections served at once; one more is closed as soon as it is accepted
    /// ([`EmulatorStats::refused_connections`](crate::EmulatorStats::refused_connections)).
    /// Default 8: a host, SOPAS ET and a few diagnostic clients, more than any test opens;
    /// the LMS511 itself takes only a few host connections (SICK's documents at hand give no
    /// exact number).
    pub max_connections: usize,
    /// A connection that sends nothing for this long and is not streaming scans is closed
    /// ([`EmulatorStats::idle_closed`](crate::EmulatorStats::idle_closed)). Default 60 s:
    /// far longer than a driver's gap between requests (its answer time-out is seconds), short
    /// enough that forgotten connections go. Not applied to [`Emulator::start_on_stream`](crate::Emulator::start_on_stream)
    /// (a serial line has no connection to close).
    pub idle_timeout: Duration,
    /// A telegram begun (CoLa-B header with its length, or a CoLa-A STX) and not completed
    /// within this time is dropped, and the bytes after its start are read again as new
    /// telegrams ([`EmulatorStats::partial_frames_dropped`](crate::EmulatorStats::partial_frames_dropped)),
    /// so a length longer than what follows does not swallow the next requests. Default 2 s:
    /// a request is tens of bytes and arrives within milliseconds, even at 9600 Bd.
    pub partial_frame_timeout: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_connections: 8,
            idle_timeout: Duration::from_secs(60),
            partial_frame_timeout: Duration::from_secs(2),
        }
    }
}
