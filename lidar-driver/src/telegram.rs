//! The telegram inside a frame: command type, name, and the argument bytes.
//!
//! `sRN LMPoutputRange` → [`CommandType::ReadRequest`], name `LMPoutputRange`, no arguments.
//! CoLa-B: `type SP name SP` then packed big-endian arguments; `sFA` carries its u16 code with
//! no space and no name. CoLa-A: the same words as space-separated ASCII tokens.

use core::fmt;

use crate::args::ArgReader;
pub use crate::command::CommandType;
use crate::frame::{Dialect, Frame};

/// Why a frame's payload is not a telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TelegramError {
    /// The first three bytes are not one of the command types (`sRN`, `sAN`, …).
    UnknownCommandType,
    /// No space and name after the command type, or the name is not printable ASCII.
    BadName,
}

impl fmt::Display for TelegramError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TelegramError::UnknownCommandType => f.write_str(
                "payload does not start with a SOPAS command type (sRN sWN sMN sEN sRA sWA sAN sMA sEA sSN sFA)",
            ),
            TelegramError::BadName => {
                f.write_str("telegram has no valid name after its command type")
            }
        }
    }
}

/// A telegram: a zero-copy view of command type, name and argument bytes of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Telegram<'a> {
    dialect: Dialect,
    kind: CommandType,
    name: &'a str,
    args: &'a [u8],
    args_offset: usize,
    frame: &'a [u8],
}

impl<'a> Telegram<'a> {
    /// Splits a frame's payload into type, name and arguments.
    pub fn parse(frame: Frame<'a>) -> Result<Self, TelegramError> {
        let payload = frame.payload();
        let kind = payload
            .get(..3)
            .and_then(CommandType::from_bytes)
            .ok_or(TelegramError::UnknownCommandType)?;
        let base = frame.payload_offset();
        let rest = payload.get(3..).unwrap_or(&[]);
        let (name, args, args_at) = if kind == CommandType::Error {
            // CoLa-B: code follows with no space. CoLa-A: `sFA 11`.
            match (frame.dialect(), rest.first()) {
                (Dialect::ColaA, Some(b' ')) => ("", rest.get(1..).unwrap_or(&[]), 4),
                _ => ("", rest, 3),
            }
        } else {
            let rest = match rest.split_first() {
                Some((b' ', r)) => r,
                _ => return Err(TelegramError::BadName),
            };
            let name_len = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
            let name_bytes = rest.get(..name_len).unwrap_or(&[]);
            if name_bytes.is_empty() || !name_bytes.iter().all(|b| b.is_ascii_graphic()) {
                return Err(TelegramError::BadName);
            }
            let name = core::str::from_utf8(name_bytes).map_err(|_| TelegramError::BadName)?;
            let after = rest.get(name_len + 1..).unwrap_or(&[]);
            (name, after, 4 + name_len + 1)
        };
        Ok(Telegram {
            dialect: frame.dialect(),
            kind,
            name,
            args,
            args_offset: base + args_at,
            frame: frame.as_bytes(),
        })
    }

    /// Dialect of the frame.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// Command type.
    pub fn kind(&self) -> CommandType {
        self.kind
    }

    /// Variable, method or event name (`""` for `sFA`).
    pub fn name(&self) -> &'a str {
        self.name
    }

    /// The argument bytes (CoLa-B: packed binary; CoLa-A: tokens, without the leading space).
    pub fn args(&self) -> &'a [u8] {
        self.args
    }

    /// Offset of the first argument byte from the first frame byte (for error reports).
    pub fn args_offset(&self) -> usize {
        self.args_offset
    }

    /// The whole frame these bytes came from.
    pub fn frame_bytes(&self) -> &'a [u8] {
        self.frame
    }

    /// A reader over the arguments in this telegram's dialect.
    pub fn reader(&self) -> ArgReader<'a> {
        ArgReader::new(self.dialect, self.args, self.args_offset)
    }
}
