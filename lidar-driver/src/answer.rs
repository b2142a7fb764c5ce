//! Sensor answers (`sRA sWA sAN sMA sEA sSN sFA`), typed per command where it matters, in both
//! dialects; and their encoder (for the emulator).

use core::fmt;

use crate::args::{ArgError, ArgErrorKind, ArgReader, EmitError, LenWidth, TelegramWriter};
use crate::frame::{Dialect, Frame};
use crate::request::{names, OutputRange, ScanConfig, ScanDataConfig};
use crate::scandata::{ScanData, ScanError};
use crate::sopas_error::SopasError;
use crate::telegram::{CommandType, Telegram, TelegramError};

/// `SCdevicestate`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceState {
    /// 0: still starting up (30–120 s after power-up); poll again.
    Busy,
    /// 1: ready to measure.
    Ready,
    /// 2: device error; check the device's diagnostics.
    Error,
}

impl DeviceState {
    /// From the wire value.
    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(DeviceState::Busy),
            1 => Some(DeviceState::Ready),
            2 => Some(DeviceState::Error),
            _ => None,
        }
    }
    /// Wire value.
    pub fn to_u8(self) -> u8 {
        match self {
            DeviceState::Busy => 0,
            DeviceState::Ready => 1,
            DeviceState::Error => 2,
        }
    }
}

/// Why `mLMPsetscancfg` refused a configuration (its `sAN` error byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScanConfigError {
    /// 1: frequency not supported.
    Frequency,
    /// 2: resolution not supported.
    Resolution,
    /// 3: frequency and resolution not supported.
    FrequencyAndResolution,
    /// 4: scan area not supported.
    Area,
    /// 5 or other: other error.
    Other(u8),
}

impl ScanConfigError {
    /// From the error byte; `None` for 0 (accepted).
    pub fn from_code(v: u8) -> Option<Self> {
        match v {
            0 => None,
            1 => Some(ScanConfigError::Frequency),
            2 => Some(ScanConfigError::Resolution),
            3 => Some(ScanConfigError::FrequencyAndResolution),
            4 => Some(ScanConfigError::Area),
            c => Some(ScanConfigError::Other(c)),
        }
    }
    /// The error byte.
    pub fn code(self) -> u8 {
        match self {
            ScanConfigError::Frequency => 1,
            ScanConfigError::Resolution => 2,
            ScanConfigError::FrequencyAndResolution => 3,
            ScanConfigError::Area => 4,
            ScanConfigError::Other(c) => c,
        }
    }
}

impl fmt::Display for ScanConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanConfigError::Frequency => f.write_str("scan frequency not supported"),
            ScanConfigError::Resolution => f.write_str("angular resolution not supported"),
            ScanConfigError::FrequencyAndResolution => {
                f.write_str("scan frequency and angular resolution not supported")
            }
            ScanConfigError::Area => f.write_str("scan area not supported"),
            ScanConfigError::Other(c) => write!(f, "scan configuration refused (code {c})"),
        }?;
        f.write_str(": use a pair the model supports (LMS511: 25 Hz/0.1667°, 35/0.25°, 50/0.3333°, 75/0.5°, 100/0.6667°)")
    }
}

/// A sensor answer, typed where the start-up sequence needs it.
///
/// The `Scan` variant is large (the decoded fixed fields); boxing needs a heap, which the
/// `no_std` core does not have, so the size difference is accepted.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer<'a> {
    /// `sAN SetAccessMode <u8>`: 1 accepted, 0 refused (wrong password).
    AccessMode {
        /// Login accepted.
        accepted: bool,
    },
    /// `sRA FirmwareVersion <string>`.
    FirmwareVersion(&'a [u8]),
    /// `sRA SCdevicestate <u8>`.
    DeviceState(DeviceState),
    /// `sRA ODoprh <u32>`: operating hours counter as sent (SICK documents 1/10 h).
    OperatingHours(u32),
    /// `sRA ODpwrc <u32>`: power-on counter.
    PowerOnCount(u32),
    /// `sRA LocationName <string>`.
    LocationName(&'a [u8]),
    /// `sRA LMPoutputRange`.
    OutputRange(OutputRange),
    /// `sRA LMDscandatacfg`.
    ScanDataConfig(ScanDataConfig),
    /// `sRA LMPscancfg`.
    ScanConfig(ScanConfig),
    /// `sAN mLMPsetscancfg <u8> [<frequency> <sectors> <step> <start> <stop>]`: Ok or why it
    /// was refused, and the parameters in effect after it (the LMS5xx's telegram listing:
    /// the device answers the values it actually uses; `None` when a device sends the status
    /// byte alone).
    SetScanConfig {
        /// Ok, or why it was refused.
        result: Result<(), ScanConfigError>,
        /// The scan configuration in effect after the request.
        in_effect: Option<ScanConfig>,
    },
    /// `sAN LMCstartmeas <u8>`: 0 = ok.
    StartMeasurement {
        /// Measurement started.
        ok: bool,
    },
    /// `sAN LMCstopmeas <u8>`: 0 = ok.
    StopMeasurement {
        /// Measurement stopped.
        ok: bool,
    },
    /// `sAN Run <u8>`: 1 = ok.
    Run {
        /// Configuration mode left.
        ok: bool,
    },
    /// `sWA <variable>`: write acknowledged.
    WriteAck(&'a str),
    /// `sMA <method>`: method accepted, the `sAN` follows.
    MethodAccepted(&'a str),
    /// `sEA <event> <u8>`: subscription state.
    EventAck {
        /// Event name.
        event: &'a str,
        /// Now subscribed.
        enabled: bool,
    },
    /// `sSN LMDscandata` / `sRA LMDscandata`.
    Scan(ScanData<'a>),
    /// `sFA <code>`.
    Error(SopasError),
    /// Any other answer (fields, I/O states, …), untyped.
    Other(Telegram<'a>),
}

/// Why a frame is not a valid answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum AnswerError {
    /// Not a telegram.
    Telegram(TelegramError),
    /// A request (`sRN sWN sMN sEN`), not an answer.
    NotAnAnswer(CommandType),
    /// A known answer with malformed arguments.
    Args {
        /// Command type.
        kind: CommandType,
        /// What went wrong.
        error: ArgError,
    },
    /// A scan telegram that failed to decode.
    Scan(ScanError),
}

impl fmt::Display for AnswerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AnswerError::Telegram(e) => e.fmt(f),
            AnswerError::NotAnAnswer(k) => write!(f, "{k} is a host request, not a sensor answer"),
            AnswerError::Args { kind, error } => write!(f, "malformed {kind} answer: {error}"),
            AnswerError::Scan(e) => e.fmt(f),
        }
    }
}

impl<'a> Answer<'a> {
    /// Parses and types an answer frame.
    pub fn from_frame(frame: Frame<'a>) -> Result<Self, AnswerError> {
        let t = Telegram::parse(frame).map_err(AnswerError::Telegram)?;
        Self::parse(&t)
    }

    /// Types an answer telegram.
    pub fn parse(t: &Telegram<'a>) -> Result<Self, AnswerError> {
        use CommandType::*;
        if t.kind().is_request() {
            return Err(AnswerError::NotAnAnswer(t.kind()));
        }
        if ScanData::is_scan_telegram(t) {
            return ScanData::from_telegram(t)
                .map(Answer::Scan)
                .map_err(AnswerError::Scan);
        }
        let mut r = t.reader();
        let kind = t.kind();
        let wrap = |error| AnswerError::Args { kind, error };
        let a = (|| -> Result<Answer<'a>, ArgError> {
            let a = match (kind, t.name()) {
                (MethodAnswer, names::SET_ACCESS_MODE) => Answer::AccessMode {
                    accepted: r.u8()? != 0,
                },
                (ReadAnswer, names::FIRMWARE_VERSION) => {
                    Answer::FirmwareVersion(r.string(LenWidth::U16)?)
                }
                (ReadAnswer, names::DEVICE_STATE) => {
                    let at = r;
                    let v = r.u8()?;
                    Answer::DeviceState(DeviceState::from_u8(v).ok_or(bad(&at, v))?)
                }
                (ReadAnswer, names::OPERATING_HOURS) => Answer::OperatingHours(r.u32()?),
                (ReadAnswer, names::POWER_ON_COUNT) => Answer::PowerOnCount(r.u32()?),
                (ReadAnswer, names::LOCATION_NAME) => {
                    Answer::LocationName(r.string(LenWidth::U16)?)
                }
                (ReadAnswer, names::OUTPUT_RANGE) => {
                    Answer::OutputRange(OutputRange::read(&mut r)?)
                }
                (ReadAnswer, names::SCAN_DATA_CONFIG) => {
                    Answer::ScanDataConfig(ScanDataConfig::read(&mut r)?)
                }
                (ReadAnswer, names::SCAN_CONFIG) => Answer::ScanConfig(ScanConfig::read(&mut r)?),
                (MethodAnswer, names::SET_SCAN_CONFIG) => Answer::SetScanConfig {
                    result: ScanConfigError::from_code(r.u8()?).map_or(Ok(()), Err),
                    in_effect: if r.at_end() {
                        None
                    } else {
                        Some(ScanConfig::read(&mut r)?)
                    },
                },
                (MethodAnswer, names::START_MEASUREMENT) => {
                    Answer::StartMeasurement { ok: r.u8()? == 0 }
                }
                (MethodAnswer, names::STOP_MEASUREMENT) => {
                    Answer::StopMeasurement { ok: r.u8()? == 0 }
                }
                (MethodAnswer, names::RUN) => Answer::Run { ok: r.u8()? == 1 },
                (WriteAnswer, n) => Answer::WriteAck(n),
                (MethodAccepted, n) => Answer::MethodAccepted(n),
                (EventAnswer, event) => Answer::EventAck {
                    event,
                    enabled: r.flag_u8()?,
                },
                (Error, _) => Answer::Error(SopasError::from_code(r.u16()?)),
                _ => return Ok(Answer::Other(*t)),
            };
            r.finish()?;
            Ok(a)
        })();
        a.map_err(wrap)
    }

    /// Command type and name of this answer (`sFA` has an empty name).
    pub fn header(&self) -> (CommandType, &'a str) {
        use CommandType::*;
        match *self {
            Answer::AccessMode { .. } => (MethodAnswer, names::SET_ACCESS_MODE),
            Answer::FirmwareVersion(_) => (ReadAnswer, names::FIRMWARE_VERSION),
            Answer::DeviceState(_) => (ReadAnswer, names::DEVICE_STATE),
            Answer::OperatingHours(_) => (ReadAnswer, names::OPERATING_HOURS),
            Answer::PowerOnCount(_) => (ReadAnswer, names::POWER_ON_COUNT),
            Answer::LocationName(_) => (ReadAnswer, names::LOCATION_NAME),
            Answer::OutputRange(_) => (ReadAnswer, names::OUTPUT_RANGE),
            Answer::ScanDataConfig(_) => (ReadAnswer, names::SCAN_DATA_CONFIG),
            Answer::ScanConfig(_) => (ReadAnswer, names::SCAN_CONFIG),
            Answer::SetScanConfig { .. } => (MethodAnswer, names::SET_SCAN_CONFIG),
            Answer::StartMeasurement { .. } => (MethodAnswer, names::START_MEASUREMENT),
            Answer::StopMeasurement { .. } => (MethodAnswer, names::STOP_MEASUREMENT),
            Answer::Run { .. } => (MethodAnswer, names::RUN),
            Answer::WriteAck(n) => (WriteAnswer, n),
            Answer::MethodAccepted(n) => (MethodAccepted, n),
            Answer::EventAck { event, .. } => (EventAnswer, event),
            Answer::Scan(s) => (s.command_type(), names::SCAN_DATA),
            Answer::Error(_) => (Error, ""),
            Answer::Other(t) => (t.kind(), t.name()),
        }
    }

    /// Writes this answer as a complete frame into `buf` (the emulator's side) and returns its
    /// length. Scans are written with `ScanRepr` (this returns [`EmitError::NotEncodable`] for
    /// them); an untyped [`Answer::Other`] can only be re-emitted in its own dialect (its
    /// argument bytes are copied), else [`EmitError::NotEncodable`].
    pub fn emit(&self, dialect: Dialect, buf: &mut [u8]) -> Result<usize, EmitError> {
        let (kind, name) = self.header();
        let mut w = TelegramWriter::begin(dialect, buf, kind, name)?;
        match *self {
            Answer::AccessMode { accepted } => {
                w.u8(accepted as u8)?;
            }
            Answer::FirmwareVersion(s) | Answer::LocationName(s) => {
                w.string(s, LenWidth::U16)?;
            }
            Answer::DeviceState(s) => {
                w.u8(s.to_u8())?;
            }
            Answer::OperatingHours(v) | Answer::PowerOnCount(v) => {
                w.u32(v)?;
            }
            Answer::OutputRange(r) => r.write(&mut w)?,
            Answer::ScanDataConfig(c) => c.write(&mut w)?,
            Answer::ScanConfig(c) => c.write(&mut w)?,
            Answer::SetScanConfig { result, in_effect } => {
                w.u8(result.err().map_or(0, |e| e.code()))?;
                if let Some(c) = in_effect {
                    c.write(&mut w)?;
                }
            }
            Answer::StartMeasurement { ok } | Answer::StopMeasurement { ok } => {
                w.u8(if ok { 0 } else { 1 })?;
            }
            Answer::Run { ok } => {
                w.u8(ok as u8)?;
            }
            Answer::WriteAck(_) | Answer::MethodAccepted(_) => {}
            Answer::EventAck { enabled, .. } => {
                w.flag_u8(enabled)?;
            }
            Answer::Error(e) => {
                w.u16(e.code())?;
            }
            Answer::Scan(_) => return Err(EmitError::NotEncodable),
            Answer::Other(t) => {
                if t.dialect() != dialect {
                    return Err(EmitError::NotEncodable);
                }
                return w.finish_raw_args(t.args());
            }
        }
        w.finish()
    }
}

fn bad(at: &ArgReader<'_>, v: u8) -> ArgError {
    ArgError {
        offset: at.offset(),
        kind: ArgErrorKind::BadValue(v as u32),
    }
}
