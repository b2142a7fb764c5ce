//! Why a start-up attempt or a stream ended: each variant says what happened and what to do.

use core::fmt;

use crate::answer::{AnswerError, DeviceState, ScanConfigError};
use crate::args::EmitError;
use crate::request::ScanConfig;
use crate::sopas_error::SopasError;

use super::step::Step;

/// Which transport operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IoOp {
    /// Opening / re-opening the link.
    Connect,
    /// Reading.
    Read,
    /// Writing a request.
    Write,
}

/// Why the session left a start-up attempt or a stream (then re-connects, or gives up after
/// `max_failed_attempts`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SessionError {
    /// The transport failed.
    Transport {
        /// What was being done.
        op: IoOp,
        /// The transport's error kind.
        kind: embedded_io::ErrorKind,
    },
    /// The sensor closed the connection (end of stream).
    ConnectionClosed,
    /// Neither dialect got an answer to `sRN SCdevicestate`.
    NoAnswer {
        /// Wait per dialect, ms.
        waited_ms: u64,
    },
    /// A request got no answer in time.
    Timeout {
        /// The step that waited.
        step: Step,
        /// How long, ms.
        waited_ms: u64,
    },
    /// The sensor answered `sFA`.
    Refused {
        /// The refused step.
        step: Step,
        /// The code.
        error: SopasError,
    },
    /// `sAN SetAccessMode 0`: wrong password for the level.
    LoginRefused {
        /// Level asked for.
        level: u8,
    },
    /// `mLMPsetscancfg` refused the frequency / resolution / area.
    ScanConfigRefused(ScanConfigError),
    /// `LMPscancfg` read back differs from what was set (frequency or step).
    ScanConfigNotApplied {
        /// What was asked for.
        requested: ScanConfig,
        /// What the sensor reports.
        actual: ScanConfig,
    },
    /// `LMPoutputRange` read back differs from what was written.
    OutputRangeNotApplied,
    /// `sAN LMCstartmeas` reported failure.
    StartMeasurementFailed,
    /// `sAN Run` reported failure.
    RunFailed,
    /// `sEA LMDscandata 0`: subscription refused.
    SubscribeRefused,
    /// The device did not become ready within the ready time-out.
    DeviceNotReady {
        /// Last state reported.
        state: DeviceState,
        /// How long the session waited, ms.
        waited_ms: u64,
    },
    /// An answer of the awaited type that could not be decoded.
    BadAnswer {
        /// The step.
        step: Step,
        /// Why.
        error: AnswerError,
    },
    /// No scan arrived for the scan time-out while streaming (or, for the first scan, for the
    /// first-scan time-out after the subscription).
    ScanTimeout {
        /// Time since the last scan (or the subscription), ms.
        waited_ms: u64,
        /// No scan at all had arrived since the subscription.
        first: bool,
    },
    /// A request did not fit the session's transmit buffer (a bug: report it).
    Emit(EmitError),
}

impl fmt::Display for SessionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SessionError::Transport { op, kind } => {
                let what = match op {
                    IoOp::Connect => "cannot connect to the sensor",
                    IoOp::Read => "reading from the sensor failed",
                    IoOp::Write => "sending to the sensor failed",
                };
                write!(f, "{what} ({kind:?}): check power, cable, address and port (TCP 2112)")
            }
            SessionError::ConnectionClosed => f.write_str(
                "the sensor closed the connection (power cycle, another client, or network): re-connecting",
            ),
            SessionError::NoAnswer { waited_ms } => write!(
                f,
                "no answer to sRN SCdevicestate in CoLa-B or CoLa-A within {waited_ms} ms each: wrong port or device, or the sensor is still booting"
            ),
            SessionError::Timeout { step, waited_ms } => {
                write!(f, "no answer while {step} within {waited_ms} ms")
            }
            SessionError::Refused { step, error } => write!(f, "{step} refused: {error}"),
            SessionError::LoginRefused { level } => write!(
                f,
                "login to access level {level} refused (sAN SetAccessMode 0): wrong password for this level"
            ),
            SessionError::ScanConfigRefused(e) => write!(f, "mLMPsetscancfg refused: {e}"),
            SessionError::ScanConfigNotApplied { requested, actual } => write!(
                f,
                "scan configuration not applied: asked {} Hz / {}e-4°, sensor reports {} Hz / {}e-4°",
                requested.frequency_1e2_hz as f32 / 100.0,
                requested.step_1e4_deg,
                actual.frequency_1e2_hz as f32 / 100.0,
                actual.step_1e4_deg
            ),
            SessionError::OutputRangeNotApplied => f.write_str(
                "LMPoutputRange read back differs from what was written: check the angles are within -5°..185° and a multiple of the step",
            ),
            SessionError::StartMeasurementFailed => {
                f.write_str("sAN LMCstartmeas reported failure: the device cannot start measuring (check its state)")
            }
            SessionError::RunFailed => f.write_str("sAN Run reported failure: configuration not accepted"),
            SessionError::SubscribeRefused => {
                f.write_str("sEA LMDscandata 0: the sensor refused the scan subscription")
            }
            SessionError::DeviceNotReady { state, waited_ms } => match state {
                DeviceState::Error => write!(
                    f,
                    "device reports error state (SCdevicestate 2) after {waited_ms} ms: check the device's diagnostics (SOPAS), power-cycle it"
                ),
                _ => write!(
                    f,
                    "device still not ready (SCdevicestate {}) after {waited_ms} ms: it normally takes 30-120 s after power-up",
                    state.to_u8()
                ),
            },
            SessionError::BadAnswer { step, error } => {
                write!(f, "malformed answer while {step}: {error}")
            }
            SessionError::ScanTimeout { waited_ms, first: false } => write!(
                f,
                "no scan for {waited_ms} ms while streaming: re-connecting and re-initialising"
            ),
            SessionError::ScanTimeout { waited_ms, first: true } => write!(
                f,
                "no first scan {waited_ms} ms after subscribing (LMDscandata): re-connecting and re-initialising; raise Timeouts::first_scan_ms for a slow device"
            ),
            SessionError::Emit(e) => write!(f, "cannot encode request: {e}"),
        }
    }
}
