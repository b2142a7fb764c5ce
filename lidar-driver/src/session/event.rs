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
    /// The device answered `SCdevicestate` busy or error: the session polls it again until the
    /// ready time-out.
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
