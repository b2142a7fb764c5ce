//! `sFA` error codes: what the sensor refused, and what to do about it.

use core::fmt;

/// An `sFA` error answer's code (CoLa-B u16 after `sFA` with no space; CoLa-A hex token).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SopasError {
    /// 1: the current access level may not do this.
    AccessDenied,
    /// 2: the method name is unknown to this device.
    UnknownMethod,
    /// 3: the variable name is unknown to this device.
    UnknownVariable,
    /// 4: a local condition failed (e.g. value outside the allowed range, wrong device state).
    LocalConditionFailed,
    /// 5: the data sent are invalid.
    InvalidData,
    /// 7: buffer overflow (too many arguments).
    BufferOverflow,
    /// 8: buffer underflow (too few arguments).
    BufferUnderflow,
    /// 10: write access denied for this variable.
    WriteAccessDenied,
    /// 11: unknown command for the name server.
    UnknownCommandForNameServer,
    /// 12: unknown CoLa command.
    UnknownColaCommand,
    /// 13: the server is busy.
    ServerBusy,
    /// 16: a CoLa-A value overflows its field.
    ColaAValueOverflow,
    /// 17 (`sFA 11` in hex): invalid character in a CoLa-A telegram.
    ColaAInvalidCharacter,
    /// Any other code.
    Other(u16),
}

impl SopasError {
    /// From the numeric code.
    pub fn from_code(code: u16) -> Self {
        match code {
            1 => SopasError::AccessDenied,
            2 => SopasError::UnknownMethod,
            3 => SopasError::UnknownVariable,
            4 => SopasError::LocalConditionFailed,
            5 => SopasError::InvalidData,
            7 => SopasError::BufferOverflow,
            8 => SopasError::BufferUnderflow,
            10 => SopasError::WriteAccessDenied,
            11 => SopasError::UnknownCommandForNameServer,
            12 => SopasError::UnknownColaCommand,
            13 => SopasError::ServerBusy,
            16 => SopasError::ColaAValueOverflow,
            17 => SopasError::ColaAInvalidCharacter,
            c => SopasError::Other(c),
        }
    }

    /// The numeric code.
    pub fn code(self) -> u16 {
        match self {
            SopasError::AccessDenied => 1,
            SopasError::UnknownMethod => 2,
            SopasError::UnknownVariable => 3,
            SopasError::LocalConditionFailed => 4,
            SopasError::InvalidData => 5,
            SopasError::BufferOverflow => 7,
            SopasError::BufferUnderflow => 8,
            SopasError::WriteAccessDenied => 10,
            SopasError::UnknownCommandForNameServer => 11,
            SopasError::UnknownColaCommand => 12,
            SopasError::ServerBusy => 13,
            SopasError::ColaAValueOverflow => 16,
            SopasError::ColaAInvalidCharacter => 17,
            SopasError::Other(c) => c,
        }
    }

    /// What the code means.
    pub fn meaning(self) -> &'static str {
        match self {
            SopasError::AccessDenied => "access denied",
            SopasError::UnknownMethod => "unknown method",
            SopasError::UnknownVariable => "unknown variable",
            SopasError::LocalConditionFailed => "local condition failed",
            SopasError::InvalidData => "invalid data",
            SopasError::BufferOverflow => "buffer overflow (too many arguments)",
            SopasError::BufferUnderflow => "buffer underflow (too few arguments)",
            SopasError::WriteAccessDenied => "write access denied",
            SopasError::UnknownCommandForNameServer => "unknown command for name server",
            SopasError::UnknownColaCommand => "unknown CoLa command",
            SopasError::ServerBusy => "server busy",
            SopasError::ColaAValueOverflow => "CoLa-A value overflow",
            SopasError::ColaAInvalidCharacter => "CoLa-A invalid character",
            SopasError::Other(_) => "undocumented error code",
        }
    }

    /// What to do about it.
    pub fn advice(self) -> &'static str {
        match self {
            SopasError::AccessDenied | SopasError::WriteAccessDenied => {
                "log in first with sMN SetAccessMode (level 3, password F4724744) and check it answered 1"
            }
            SopasError::UnknownMethod | SopasError::UnknownVariable => {
                "this device or firmware does not have that name: check the model and firmware version"
            }
            SopasError::LocalConditionFailed | SopasError::InvalidData => {
                "a value is outside what the device allows (e.g. frequency/resolution pair, angle range): check the arguments"
            }
            SopasError::BufferOverflow | SopasError::BufferUnderflow => {
                "wrong number or width of arguments for this command and firmware"
            }
            SopasError::UnknownCommandForNameServer | SopasError::UnknownColaCommand => {
                "the telegram is malformed or not supported in this dialect"
            }
            SopasError::ServerBusy => "wait (the sensor may take 30-120 s after power-up) and retry",
            SopasError::ColaAValueOverflow => "a CoLa-A number is too large for its field",
            SopasError::ColaAInvalidCharacter => {
                "a CoLa-A telegram contained a non-ASCII or misplaced character (e.g. binary arguments in an ASCII telegram)"
            }
            SopasError::Other(_) => "see the device's telegram listing",
        }
    }
}

impl fmt::Display for SopasError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "sensor error {} ({}): {}",
            self.code(),
            self.meaning(),
            self.advice()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip() {
        for c in 0..40u16 {
            assert_eq!(SopasError::from_code(c).code(), c);
        }
        assert_eq!(
            SopasError::from_code(0x11),
            SopasError::ColaAInvalidCharacter
        );
    }
}
