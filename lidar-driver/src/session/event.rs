//! What one `Session::poll` reports.

use crate::answer::DeviceState;
use crate::frame::{Dialect, FrameError};
use crate::request::{OutputRange, ScanConfig, ScanDataConfig};
use crate::scandata::{ScanData, ScanError};
use crate::sopas_error::SopasError;
use crate::telegram::CommandType;

use super::error::SessionError;
use super::step::Step;

/// Device facts read during start-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DeviceInfo<'a> {
    /// `FirmwareVersion` text (e.g. `V1.80    `).
    FirmwareVersion(&'a [u8]),
    /// `SCdevicestate` after login.
    DeviceState(DeviceState),
    /// `LocationName` text (the LMS511 sends `SN <serial>`).
    LocationName(&'a [u8]),
    /// `LMPoutputRange` in effect.
    OutputRange(OutputRange),
    /// `LMDscandatacfg` in effect.
    ScanDataConfig(ScanDataConfig),
    /// `LMPscancfg` in effect.
    ScanConfig(ScanConfig),
}

/// The outcome of one [`super::Session::poll`]. Borrowed data (scans, texts) live until the
/// next poll.
///
/// `Scan` holds the decoded fixed fields by value (~270 bytes); boxing needs a heap, which the
/// `no_std` session does not have, so the size difference is accepted.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event<'a> {
    /// Nothing happened: no data, or waiting for an answer / the re-connect delay. Poll again
    /// (the std transports already waited up to their `ready_wait`; on an MCU, sleep until the
    /// next UART interrupt or tick).
    Idle,
    /// The transport is open; attempt number (1 = first since the last scan).
    Connected {
        /// Consecutive attempt number.
        attempt: u32,
    },
    /// The probe is sent in this dialect.
    Probing(Dialect),
    /// The sensor answered in this dialect; the session speaks it from now on.
    DialectDetected(Dialect),
    /// The sensor accepted `sWN EIHstCola`: the session re-connects and speaks this dialect.
    DialectSwitched(Dialect),
    /// The device answered `SCdevicestate` busy (0: starting up, or in configuration mode) —
    /// the session logs in and starts the measurement anyway, as SICK's driver does, and waits
    /// only when a step is refused as busy (`sFA 13`) — or error (2): the session polls it
    /// again until the ready time-out.
    DeviceNotReady {
        /// Reported state.
        state: DeviceState,
        /// Waiting since the first not-ready answer, ms.
        waited_ms: u64,
    },
    /// A start-up step was acknowledged.
    StepDone(Step),
    /// A start-up read returned device facts.
    Info(DeviceInfo<'a>),
    /// The subscription is acknowledged: scans follow.
    Streaming,
    /// One scan, decoded zero-copy from the receive buffer.
    Scan(ScanData<'a>),
    /// A scan telegram that failed to decode; dropped, the stream goes on.
    BadScan(ScanError),
    /// A damaged frame was dropped by the framer (counted); good frames around it are kept.
    FrameDropped(FrameError),
    /// A good frame that is not what the session waits for (late answer, other event, scan
    /// during start-up): skipped.
    Ignored {
        /// Its command type (`None` if not even a telegram).
        kind: Option<CommandType>,
        /// Its name (empty if none).
        name: &'a str,
    },
    /// An `sFA` nobody waited for (while streaming).
    SensorError(SopasError),
    /// The attempt failed; the session re-connects after `retry_in_ms`.
    Reconnecting {
        /// What went wrong.
        error: SessionError,
        /// Consecutive failed attempts so far.
        failed_attempts: u32,
        /// Delay before the next connect, ms.
        retry_in_ms: u64,
    },
    /// The session gave up (`max_failed_attempts` reached). Every later poll returns this again;
    /// [`super::Session::restart`] starts over.
    Failed(SessionError),
}

/// Text as it came, with bytes outside printable ASCII escaped.
struct Text<'a>(&'a [u8]);

impl core::fmt::Display for Text<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        for &b in self.0 {
            if (0x20..0x7f).contains(&b) {
                write!(f, "{}", b as char)?;
            } else {
                write!(f, "\\x{b:02x}")?;
            }
        }
        Ok(())
    }
}

impl core::fmt::Display for DeviceInfo<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DeviceInfo::FirmwareVersion(v) => write!(f, "firmware {}", Text(v)),
            DeviceInfo::DeviceState(s) => {
                write!(f, "device state {s:?} (SCdevicestate {})", s.to_u8())
            }
            DeviceInfo::LocationName(v) => write!(f, "location name \"{}\"", Text(v)),
            DeviceInfo::OutputRange(r) => write!(
                f,
                "output range {}..{} deg, step {} deg",
                r.start_1e4_deg as f32 / 1e4,
                r.stop_1e4_deg as f32 / 1e4,
                r.step_1e4_deg as f32 / 1e4
            ),
            DeviceInfo::ScanDataConfig(c) => write!(
                f,
                "scan data: echo mask {:#04x}, RSSI {}{}, time block {}, every {} scan(s)",
                c.output_channel,
                if c.remission { "on" } else { "off" },
                if c.remission_16bit { " (16-bit)" } else { "" },
                if c.time { "on" } else { "off" },
                c.output_rate
            ),
            DeviceInfo::ScanConfig(c) => write!(
                f,
                "scan configuration {} Hz, step {} deg, {}..{} deg",
                c.frequency_1e2_hz as f32 / 100.0,
                c.step_1e4_deg as f32 / 1e4,
                c.start_1e4_deg as f32 / 1e4,
                c.stop_1e4_deg as f32 / 1e4
            ),
        }
    }
}

/// One line per event, for logs.
impl core::fmt::Display for Event<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Event::Idle => f.write_str("idle"),
            Event::Connected { attempt } => write!(f, "connected (attempt {attempt})"),
            Event::Probing(d) => write!(f, "probing in {d} (sRN SCdevicestate)"),
            Event::DialectDetected(d) => write!(f, "sensor speaks {d}"),
            Event::DialectSwitched(d) => write!(f, "sensor switched to {d}; re-connecting"),
            Event::DeviceNotReady { state, waited_ms } => match state {
                DeviceState::Busy => write!(
                    f,
                    "device busy (SCdevicestate 0: starting up or in configuration mode) for {waited_ms} ms; logging in and starting the measurement"
                ),
                _ => write!(
                    f,
                    "device not ready: {} (SCdevicestate {}) for {waited_ms} ms; polling",
                    if *state == DeviceState::Error { "error state" } else { "ready" },
                    state.to_u8()
                ),
            },
            Event::StepDone(s) => write!(f, "done: {s}"),
            Event::Info(i) => i.fmt(f),
            Event::Streaming => f.write_str("subscribed: scans follow"),
            Event::Scan(s) => write!(
                f,
                "scan {} ({} Hz)",
                s.header.scan_counter,
                s.header.scan_frequency_hz()
            ),
            Event::BadScan(e) => write!(f, "scan dropped: {e}"),
            Event::FrameDropped(e) => write!(f, "frame dropped: {e}"),
            Event::Ignored { kind, name } => match kind {
                Some(k) => write!(f, "skipped unrelated {k} {name}"),
                None => f.write_str("skipped a frame that is not a telegram"),
            },
            Event::SensorError(e) => write!(f, "unsolicited {e}"),
            Event::Reconnecting {
                error,
                failed_attempts,
                retry_in_ms,
            } => write!(
                f,
                "{error} (failed attempts: {failed_attempts}; re-connecting in {retry_in_ms} ms)"
            ),
            Event::Failed(e) => write!(f, "gave up: {e}"),
        }
    }
}
