//! Errors of the `LMDscandata` decoder: which field, at which byte, what was wrong.

use core::fmt;

use crate::args::{ArgError, ArgErrorKind};
use crate::telegram::{CommandType, TelegramError};

/// The fields of an `LMDscandata` telegram, in wire order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
#[allow(missing_docs)] // each variant is the field of the same name in the telegram notes
pub enum ScanField {
    Version,
    DeviceNumber,
    SerialNumber,
    DeviceStatus,
    TelegramCounter,
    ScanCounter,
    TimeSinceStartup,
    TimeOfTransmission,
    InputStatus,
    OutputStatus,
    ReservedLayerAngle,
    ScanFrequency,
    MeasurementFrequency,
    EncoderCount,
    Encoder,
    Channel16Count,
    Channel8Count,
    ChannelName,
    ScaleFactor,
    ScaleOffset,
    StartAngle,
    AngularStep,
    ValueCount,
    Values,
    PositionFlag,
    Position,
    DeviceNameFlag,
    DeviceName,
    CommentFlag,
    Comment,
    TimeFlag,
    Time,
    EventFlag,
    Event,
    /// After the last field: bytes left over.
    End,
}

impl ScanField {
    /// Human name as in the telegram notes.
    pub fn name(self) -> &'static str {
        use ScanField::*;
        match self {
            Version => "version",
            DeviceNumber => "device number",
            SerialNumber => "serial number",
            DeviceStatus => "device status",
            TelegramCounter => "telegram counter",
            ScanCounter => "scan counter",
            TimeSinceStartup => "time since start-up",
            TimeOfTransmission => "time of transmission",
            InputStatus => "input status",
            OutputStatus => "output status",
            ReservedLayerAngle => "reserved / layer angle",
            ScanFrequency => "scan frequency",
            MeasurementFrequency => "measurement frequency",
            EncoderCount => "number of encoders",
            Encoder => "encoder",
            Channel16Count => "number of 16-bit channels",
            Channel8Count => "number of 8-bit channels",
            ChannelName => "channel name",
            ScaleFactor => "scale factor",
            ScaleOffset => "scale offset",
            StartAngle => "start angle",
            AngularStep => "angular step",
            ValueCount => "number of values",
            Values => "channel values",
            PositionFlag => "position block present",
            Position => "position block",
            DeviceNameFlag => "device name present",
            DeviceName => "device name",
            CommentFlag => "comment present",
            Comment => "comment",
            TimeFlag => "time block present",
            Time => "time block",
            EventFlag => "event info present",
            Event => "event info",
            End => "end of telegram",
        }
    }
}

/// Why a frame could not be decoded as `LMDscandata`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ScanError {
    /// The frame's payload is not a telegram.
    Telegram(TelegramError),
    /// A telegram, but not `sSN LMDscandata` or `sRA LMDscandata`.
    NotScanData {
        /// Its command type.
        kind: CommandType,
    },
    /// A field is missing, malformed or out of range.
    Field {
        /// Which field.
        field: ScanField,
        /// Byte offset from the first frame byte.
        offset: usize,
        /// What was wrong.
        kind: ArgErrorKind,
    },
}

impl ScanError {
    pub(crate) fn at(field: ScanField) -> impl Fn(ArgError) -> ScanError {
        move |e| ScanError::Field {
            field,
            offset: e.offset,
            kind: e.kind,
        }
    }
}

impl fmt::Display for ScanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanError::Telegram(e) => e.fmt(f),
            ScanError::NotScanData { kind } => {
                write!(f, "{kind} telegram is not LMDscandata (expected sSN or sRA LMDscandata)")
            }
            ScanError::Field { field, offset, kind } => write!(
                f,
                "LMDscandata field '{}' at byte {offset}: {kind}; the telegram is damaged or from a device/firmware this decoder does not know",
                field.name()
            ),
        }
    }
}
