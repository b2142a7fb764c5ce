//! Typed telegram arguments in either dialect: one reader and one writer, so every telegram
//! (requests, answers, scans) is described once and works in CoLa-A and CoLa-B alike.
//!
//! CoLa-B: big-endian u8/u16/u32/i16/i32/f32, strings as u16 length + bytes.
//! CoLa-A: one token per value, separated by one space. Numbers are uppercase hex without
//! leading zeros; negative integers two's complement hex of the field width (`FFFF3CB0` =
//! −50000); f32 always 8 hex digits of its bits (`3F800000`). The reader also accepts signed
//! decimal (`+2500`, `-50000`) as requests may use it. Strings: length token, one space, bytes.

use core::fmt;

use crate::command::CommandType;
use crate::frame::{xor_checksum, Dialect, COLA_B_HEADER_LEN, ETX, STX};

/// Width of a string's length prefix in CoLa-B (u16 is SOPAS' rule; some fields in some
/// firmware use a u8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LenWidth {
    /// One length byte.
    U8,
    /// Two length bytes, big-endian (the usual SOPAS string).
    #[default]
    U16,
}

/// What went wrong reading one argument.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ArgErrorKind {
    /// The telegram ends before this value.
    Truncated,
    /// CoLa-A token is not a number (hex or signed decimal).
    InvalidNumber,
    /// The number does not fit the field's type.
    OutOfRange,
    /// A fixed-size text field has the wrong length or non-ASCII bytes.
    BadText,
    /// A flag or enum field holds a value the protocol does not define.
    BadValue(u32),
    /// Bytes are left after the last field.
    TrailingData,
}

/// A failed argument read: what, and where (offset from the first frame byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ArgError {
    /// Byte offset from the first byte of the frame (the first `0x02`).
    pub offset: usize,
    /// What was wrong.
    pub kind: ArgErrorKind,
}

impl fmt::Display for ArgErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArgErrorKind::Truncated => f.write_str("telegram ends before this field"),
            ArgErrorKind::InvalidNumber => {
                f.write_str("CoLa-A token is not a hex or signed decimal number")
            }
            ArgErrorKind::OutOfRange => f.write_str("value does not fit the field's type"),
            ArgErrorKind::BadText => {
                f.write_str("text field has the wrong length or non-ASCII bytes")
            }
            ArgErrorKind::BadValue(v) => write!(f, "value {v} is not defined for this field"),
            ArgErrorKind::TrailingData => f.write_str("unexpected bytes after the last field"),
        }
    }
}

impl fmt::Display for ArgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at byte {}", self.kind, self.offset)
    }
}

/// Cursor over telegram arguments. Cheap to copy (to try alternatives and back-track).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArgReader<'a> {
    dialect: Dialect,
    buf: &'a [u8],
    pos: usize,
    base: usize,
}

impl<'a> ArgReader<'a> {
    /// A reader over `buf` (the argument bytes); `base` is their offset in the frame, used in
    /// error reports.
    pub fn new(dialect: Dialect, buf: &'a [u8], base: usize) -> Self {
        ArgReader {
            dialect,
            buf,
            pos: 0,
            base,
        }
    }

    /// Dialect read.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// Offset of the next unread byte from the first frame byte.
    pub fn offset(&self) -> usize {
        self.base + self.pos
    }

    /// Position of the next unread byte within the argument bytes.
    pub fn position(&self) -> usize {
        self.pos
    }

    /// The argument bytes not read yet.
    pub fn rest(&self) -> &'a [u8] {
        self.buf.get(self.pos..).unwrap_or(&[])
    }

    fn err(&self, kind: ArgErrorKind) -> ArgError {
        ArgError {
            offset: self.offset(),
            kind,
        }
    }

    /// True when nothing but (CoLa-A) separators is left.
    pub fn at_end(&self) -> bool {
        match self.dialect {
            Dialect::ColaB => self.pos >= self.buf.len(),
            Dialect::ColaA => self.rest().iter().all(|&b| b == b' '),
        }
    }

    /// Error unless everything was read.
    pub fn finish(&self) -> Result<(), ArgError> {
        if self.at_end() {
            Ok(())
        } else {
            Err(self.err(ArgErrorKind::TrailingData))
        }
    }

    /// Advances over `n` bytes the caller has already checked.
    pub(crate) fn skip_bytes(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.buf.len());
    }

    /// CoLa-B: the next `n` raw bytes.
    fn take(&mut self, n: usize) -> Result<&'a [u8], ArgError> {
        let s = self
            .buf
            .get(self.pos..self.pos.saturating_add(n))
            .ok_or(self.err(ArgErrorKind::Truncated))?;
        self.pos += n;
        Ok(s)
    }

    /// CoLa-A: the next token (skipping separating spaces).
    pub fn token(&mut self) -> Result<&'a [u8], ArgError> {
        let rest = self.rest();
        let skip = rest
            .iter()
            .position(|&b| b != b' ')
            .ok_or(self.err(ArgErrorKind::Truncated))?;
        self.pos += skip;
        let rest = self.rest();
        let len = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
        self.pos += len;
        Ok(rest.get(..len).unwrap_or(&[]))
    }

    /// Reads a CoLa-A number token as a 64-bit signed value (hex, or decimal with a sign).
    fn number_a(&mut self) -> Result<(i64, bool), ArgError> {
        let at = *self;
        let tok = self.token()?;
        parse_number(tok).ok_or(at.err_at_token(ArgErrorKind::InvalidNumber))
    }

    fn err_at_token(&self, kind: ArgErrorKind) -> ArgError {
        let skip = self.rest().iter().position(|&b| b != b' ').unwrap_or(0);
        ArgError {
            offset: self.offset() + skip,
            kind,
        }
    }

    /// Unsigned value of `bits` width.
    fn unsigned(&mut self, bytes: usize) -> Result<u64, ArgError> {
        match self.dialect {
            Dialect::ColaB => Ok(self
                .take(bytes)?
                .iter()
                .fold(0u64, |a, &b| (a << 8) | b as u64)),
            Dialect::ColaA => {
                let at = *self;
                let (v, _) = self.number_a()?;
                let max = (1u64 << (bytes * 8)) - 1;
                if v < 0 || v as u64 > max {
                    return Err(at.err_at_token(ArgErrorKind::OutOfRange));
                }
                Ok(v as u64)
            }
        }
    }

    /// Signed value of `bytes` width (two's complement hex or signed decimal in CoLa-A).
    fn signed(&mut self, bytes: usize) -> Result<i64, ArgError> {
        let bits = bytes * 8;
        let min = -(1i64 << (bits - 1));
        let max = (1i64 << (bits - 1)) - 1;
        match self.dialect {
            Dialect::ColaB => {
                let u = self
                    .take(bytes)?
                    .iter()
                    .fold(0u64, |a, &b| (a << 8) | b as u64);
                Ok(sign_extend(u, bits))
            }
            Dialect::ColaA => {
                let at = *self;
                let (v, decimal) = self.number_a()?;
                let v = if decimal {
                    v
                } else if (v as u64) < (1u64 << bits) {
                    sign_extend(v as u64, bits)
                } else if v as u64 <= u32::MAX as u64 {
                    // A narrow field sent as 32-bit two's complement.
                    sign_extend(v as u64, 32)
                } else {
                    return Err(at.err_at_token(ArgErrorKind::OutOfRange));
                };
                if v < min || v > max {
                    return Err(at.err_at_token(ArgErrorKind::OutOfRange));
                }
                Ok(v)
            }
        }
    }

    /// u8.
    pub fn u8(&mut self) -> Result<u8, ArgError> {
        self.unsigned(1).map(|v| v as u8)
    }
    /// u16.
    pub fn u16(&mut self) -> Result<u16, ArgError> {
        self.unsigned(2).map(|v| v as u16)
    }
    /// u32.
    pub fn u32(&mut self) -> Result<u32, ArgError> {
        self.unsigned(4).map(|v| v as u32)
    }
    /// i16.
    pub fn i16(&mut self) -> Result<i16, ArgError> {
        self.signed(2).map(|v| v as i16)
    }
    /// i32.
    pub fn i32(&mut self) -> Result<i32, ArgError> {
        self.signed(4).map(|v| v as i32)
    }
    /// f32: CoLa-B 4 bytes; CoLa-A 8 hex digits of its bits (or a signed decimal like `+1.5`).
    pub fn f32(&mut self) -> Result<f32, ArgError> {
        match self.dialect {
            Dialect::ColaB => {
                let b = self.take(4)?;
                Ok(f32::from_be_bytes([b[0], b[1], b[2], b[3]]))
            }
            Dialect::ColaA => {
                let at = *self;
                let tok = self.token()?;
                if matches!(tok.first(), Some(b'+' | b'-')) {
                    return core::str::from_utf8(tok)
                        .ok()
                        .and_then(|s| s.parse::<f32>().ok())
                        .ok_or(at.err_at_token(ArgErrorKind::InvalidNumber));
                }
                match parse_number(tok) {
                    Some((v, false)) if (0..=u32::MAX as i64).contains(&v) => {
                        Ok(f32::from_bits(v as u32))
                    }
                    Some(_) => Err(at.err_at_token(ArgErrorKind::OutOfRange)),
                    None => Err(at.err_at_token(ArgErrorKind::InvalidNumber)),
                }
            }
        }
    }

    /// A 0/1 flag (u8 in CoLa-B); other values are an error.
    pub fn flag_u8(&mut self) -> Result<bool, ArgError> {
        let at = *self;
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            v => Err(at.err_at_token(ArgErrorKind::BadValue(v as u32))),
        }
    }

    /// A 0/1 flag sent as u16 (the "block present" fields of `LMDscandata`).
    pub fn flag_u16(&mut self) -> Result<bool, ArgError> {
        let at = *self;
        match self.u16()? {
            0 => Ok(false),
            1 => Ok(true),
            v => Err(at.err_at_token(ArgErrorKind::BadValue(v as u32))),
        }
    }

    /// Fixed-length text such as a channel name (`DIST1`): CoLa-B `n` raw bytes, CoLa-A one
    /// token of `n` characters. Must be ASCII.
    pub fn fixed_text(&mut self, n: usize) -> Result<&'a [u8], ArgError> {
        let at = *self;
        let t = match self.dialect {
            Dialect::ColaB => self.take(n)?,
            Dialect::ColaA => self.token()?,
        };
        if t.len() != n || !t.iter().all(|b| b.is_ascii_graphic()) {
            return Err(at.err_at_token(ArgErrorKind::BadText));
        }
        Ok(t)
    }

    /// A length-prefixed string: CoLa-B `width` length + bytes; CoLa-A length token, one space,
    /// then exactly that many bytes (which may contain spaces).
    pub fn string(&mut self, width: LenWidth) -> Result<&'a [u8], ArgError> {
        let n = match (self.dialect, width) {
            (Dialect::ColaB, LenWidth::U8) => self.u8()? as usize,
            _ => self.u16()? as usize,
        };
        if self.dialect == Dialect::ColaA && n > 0 {
            match self.rest().first() {
                Some(b' ') => self.pos += 1,
                _ => return Err(self.err(ArgErrorKind::Truncated)),
            }
        }
        self.take(n)
    }

    /// Skips `n` values of `bytes` width each and returns the bytes (CoLa-B) or text (CoLa-A)
    /// that held them, checking in CoLa-A that each token is a number that fits.
    pub fn values_region(&mut self, n: usize, bytes: usize) -> Result<&'a [u8], ArgError> {
        match self.dialect {
            Dialect::ColaB => {
                let total = n
                    .checked_mul(bytes)
                    .ok_or(self.err(ArgErrorKind::OutOfRange))?;
                self.take(total)
            }
            Dialect::ColaA => {
                let start = self.pos;
                let max = (1u64 << (bytes * 8)) - 1;
                let text = self.rest();
                let mut i = 0usize;
                // One pass: skip separators, accumulate hex digits; a token with any other
                // character (a signed decimal) goes through the general parser.
                for _ in 0..n {
                    while text.get(i) == Some(&b' ') {
                        i += 1;
                    }
                    let tok_start = i;
                    let mut v: u64 = 0;
                    let mut plain_hex = true;
                    while let Some(&c) = text.get(i) {
                        if c == b' ' {
                            break;
                        }
                        let d = HEX_DIGIT[c as usize];
                        plain_hex &= d != 0xff;
                        v = (v << 4) | (d & 0x0f) as u64;
                        i += 1;
                    }
                    let tok = text.get(tok_start..i).unwrap_or(&[]);
                    let err = |kind| ArgError {
                        offset: self.base + start + tok_start,
                        kind,
                    };
                    if tok.is_empty() {
                        return Err(err(ArgErrorKind::Truncated));
                    }
                    let v = if plain_hex && tok.len() <= 15 {
                        v as i64
                    } else {
                        parse_number(tok)
                            .map(|(v, _)| v)
                            .ok_or(err(ArgErrorKind::InvalidNumber))?
                    };
                    if v < 0 || v as u64 > max {
                        return Err(err(ArgErrorKind::OutOfRange));
                    }
                }
                self.pos += i;
                Ok(self.buf.get(start..self.pos).unwrap_or(&[]))
            }
        }
    }
}

/// Hex digit value of each byte, 0xff for non-digits.
static HEX_DIGIT: [u8; 256] = {
    let mut t = [0xffu8; 256];
    let mut i = 0;
    while i < 10 {
        t[b'0' as usize + i] = i as u8;
        i += 1;
    }
    let mut i = 0;
    while i < 6 {
        t[b'A' as usize + i] = 10 + i as u8;
        t[b'a' as usize + i] = 10 + i as u8;
        i += 1;
    }
    t
};

fn sign_extend(u: u64, bits: usize) -> i64 {
    let shift = 64 - bits;
    ((u << shift) as i64) >> shift
}

/// Hex digits only, up to 16 of them.
#[inline]
pub(crate) fn hex_fast(tok: &[u8]) -> Option<i64> {
    if tok.is_empty() || tok.len() > 15 {
        return None;
    }
    let mut v: i64 = 0;
    for &c in tok {
        let d = HEX_DIGIT[c as usize];
        if d == 0xff {
            return None;
        }
        v = (v << 4) | d as i64;
    }
    Some(v)
}

/// A CoLa-A number: hex (`FFFF3CB0`) or signed decimal (`+2500`, `-50000`). Returns the value
/// and whether it was decimal.
pub(crate) fn parse_number(tok: &[u8]) -> Option<(i64, bool)> {
    match tok.split_first() {
        Some((&s @ (b'+' | b'-'), digits)) => {
            if digits.is_empty() || digits.len() > 12 {
                return None;
            }
            let mut v: i64 = 0;
            for &c in digits {
                if !c.is_ascii_digit() {
                    return None;
                }
                v = v * 10 + (c - b'0') as i64;
            }
            Some((if s == b'-' { -v } else { v }, true))
        }
        _ => hex_fast(tok).map(|v| (v, false)),
    }
}

/// Why a telegram could not be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum EmitError {
    /// The output buffer is too small; `needed` is a lower bound of the bytes required.
    BufferTooSmall {
        /// Bytes needed so far (a lower bound).
        needed: usize,
    },
    /// A string or count is too long for its length field.
    TooLong,
    /// A CoLa-A string contains bytes that may not appear in CoLa-A (control bytes).
    InvalidText,
    /// This value has no encoding in the requested form (a scan is written with `ScanRepr`;
    /// an untyped answer only in the dialect it was received in).
    NotEncodable,
}

impl fmt::Display for EmitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EmitError::BufferTooSmall { needed } => {
                write!(f, "output buffer too small: at least {needed} bytes needed")
            }
            EmitError::TooLong => f.write_str("string or list too long for its length field"),
            EmitError::InvalidText => {
                f.write_str("text contains bytes not allowed in CoLa-A (only printable ASCII)")
            }
            EmitError::NotEncodable => f.write_str(
                "cannot encode this value here: write scans with ScanRepr, and untyped answers only in their own dialect",
            ),
        }
    }
}

/// Writes one complete telegram frame (framing included) into a caller buffer, in either dialect.
///
/// `begin` writes the start and `type SP name`; each value call appends one argument (CoLa-A:
/// space + token; CoLa-B: the first argument is preceded by one space, then packed bytes);
/// `finish` closes the frame (CoLa-B length and checksum) and returns its length.
#[derive(Debug)]
pub struct TelegramWriter<'a> {
    dialect: Dialect,
    kind: CommandType,
    buf: &'a mut [u8],
    pos: usize,
    args: usize,
}

impl<'a> TelegramWriter<'a> {
    /// Starts a telegram `kind name` (name empty for `sFA`).
    pub fn begin(
        dialect: Dialect,
        buf: &'a mut [u8],
        kind: CommandType,
        name: &str,
    ) -> Result<Self, EmitError> {
        if !name.bytes().all(|b| b.is_ascii_graphic()) {
            return Err(EmitError::InvalidText);
        }
        let mut w = TelegramWriter {
            dialect,
            kind,
            buf,
            pos: 0,
            args: 0,
        };
        match dialect {
            Dialect::ColaA => w.put(&[STX])?,
            Dialect::ColaB => w.put(&[STX, STX, STX, STX, 0, 0, 0, 0])?,
        }
        w.put(kind.as_str().as_bytes())?;
        if !name.is_empty() {
            w.put(b" ")?;
            w.put(name.as_bytes())?;
        }
        Ok(w)
    }

    fn put(&mut self, b: &[u8]) -> Result<(), EmitError> {
        let end = self.pos + b.len();
        let dst = self
            .buf
            .get_mut(self.pos..end)
            .ok_or(EmitError::BufferTooSmall { needed: end })?;
        dst.copy_from_slice(b);
        self.pos = end;
        Ok(())
    }

    /// Separator before an argument.
    fn sep(&mut self) -> Result<(), EmitError> {
        let first = self.args == 0;
        self.args += 1;
        match self.dialect {
            Dialect::ColaA => self.put(b" "),
            // sFA's code follows the type directly in CoLa-B.
            Dialect::ColaB if first && self.kind != CommandType::Error => self.put(b" "),
            Dialect::ColaB => Ok(()),
        }
    }

    fn hex_token(&mut self, v: u64, min_digits: usize) -> Result<(), EmitError> {
        let mut tmp = [0u8; 16];
        let mut n = 0;
        let mut x = v;
        loop {
            let d = (x & 0xf) as u8;
            tmp[15 - n] = if d < 10 { b'0' + d } else { b'A' + d - 10 };
            n += 1;
            x >>= 4;
            if x == 0 && n >= min_digits {
                break;
            }
        }
        self.put(tmp.get(16 - n..).unwrap_or(&[]))
    }

    fn unsigned(&mut self, v: u64, bytes: usize) -> Result<(), EmitError> {
        self.sep()?;
        match self.dialect {
            Dialect::ColaA => self.hex_token(v, 1),
            Dialect::ColaB => {
                let be = v.to_be_bytes();
                self.put(be.get(8 - bytes..).unwrap_or(&[]))
            }
        }
    }

    /// u8.
    pub fn u8(&mut self, v: u8) -> Result<&mut Self, EmitError> {
        self.unsigned(v as u64, 1).map(|_| self)
    }
    /// u16.
    pub fn u16(&mut self, v: u16) -> Result<&mut Self, EmitError> {
        self.unsigned(v as u64, 2).map(|_| self)
    }
    /// u32.
    pub fn u32(&mut self, v: u32) -> Result<&mut Self, EmitError> {
        self.unsigned(v as u64, 4).map(|_| self)
    }
    /// i16 (CoLa-A: 16-bit two's complement hex when negative).
    pub fn i16(&mut self, v: i16) -> Result<&mut Self, EmitError> {
        self.unsigned(v as u16 as u64, 2).map(|_| self)
    }
    /// i32 (CoLa-A: 32-bit two's complement hex when negative, as the sensor sends it).
    pub fn i32(&mut self, v: i32) -> Result<&mut Self, EmitError> {
        self.unsigned(v as u32 as u64, 4).map(|_| self)
    }
    /// f32 (CoLa-A: always 8 hex digits of the bits).
    pub fn f32(&mut self, v: f32) -> Result<&mut Self, EmitError> {
        self.sep()?;
        match self.dialect {
            Dialect::ColaA => self.hex_token(v.to_bits() as u64, 8)?,
            Dialect::ColaB => self.put(&v.to_be_bytes())?,
        }
        Ok(self)
    }
    /// Many u16 values (a channel's data) in one pass.
    pub fn u16_values(&mut self, values: &[u16]) -> Result<&mut Self, EmitError> {
        match self.dialect {
            Dialect::ColaB => {
                if !values.is_empty() {
                    self.sep()?;
                    self.args += values.len() - 1;
                }
                let end = self.pos + 2 * values.len();
                let dst = self
                    .buf
                    .get_mut(self.pos..end)
                    .ok_or(EmitError::BufferTooSmall { needed: end })?;
                for (d, v) in dst.chunks_exact_mut(2).zip(values) {
                    d.copy_from_slice(&v.to_be_bytes());
                }
                self.pos = end;
            }
            Dialect::ColaA => {
                for &v in values {
                    self.u16(v)?;
                }
            }
        }
        Ok(self)
    }

    /// Many u8 values (a channel's data) in one pass.
    pub fn u8_values(&mut self, values: &[u8]) -> Result<&mut Self, EmitError> {
        match self.dialect {
            Dialect::ColaB => {
                if !values.is_empty() {
                    self.sep()?;
                    self.args += values.len() - 1;
                }
                self.put(values)?;
            }
            Dialect::ColaA => {
                for &v in values {
                    self.u8(v)?;
                }
            }
        }
        Ok(self)
    }

    /// 0/1 flag as u8.
    pub fn flag_u8(&mut self, v: bool) -> Result<&mut Self, EmitError> {
        self.u8(v as u8)
    }
    /// 0/1 flag as u16.
    pub fn flag_u16(&mut self, v: bool) -> Result<&mut Self, EmitError> {
        self.u16(v as u16)
    }
    /// Fixed-length ASCII text (`DIST1`): raw in CoLa-B, one token in CoLa-A.
    pub fn fixed_text(&mut self, t: &[u8]) -> Result<&mut Self, EmitError> {
        if !t.iter().all(|b| b.is_ascii_graphic()) {
            return Err(EmitError::InvalidText);
        }
        self.sep()?;
        self.put(t)?;
        Ok(self)
    }
    /// Length-prefixed string (CoLa-B `width` length; CoLa-A length token, space, bytes).
    pub fn string(&mut self, t: &[u8], width: LenWidth) -> Result<&mut Self, EmitError> {
        match (self.dialect, width) {
            (Dialect::ColaB, LenWidth::U8) => {
                let n = u8::try_from(t.len()).map_err(|_| EmitError::TooLong)?;
                self.u8(n)?;
            }
            _ => {
                let n = u16::try_from(t.len()).map_err(|_| EmitError::TooLong)?;
                self.u16(n)?;
            }
        }
        if self.dialect == Dialect::ColaA {
            if !t.iter().all(|&b| crate::frame::is_cola_a_byte(b)) {
                return Err(EmitError::InvalidText);
            }
            if !t.is_empty() {
                self.put(b" ")?;
            }
        }
        self.put(t)?;
        Ok(self)
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.pos
    }

    /// True if nothing was written (never, after `begin`).
    pub fn is_empty(&self) -> bool {
        self.pos == 0
    }

    /// Closes the frame and returns its total length. With `trailing_space`, a CoLa-B telegram
    /// without arguments ends with a space after its name, as the sensor's argument-less answers
    /// do (`sWA LMPoutputRange `); host requests without arguments have none.
    pub fn finish_with(mut self, trailing_space: bool) -> Result<usize, EmitError> {
        match self.dialect {
            Dialect::ColaA => self.put(&[ETX])?,
            Dialect::ColaB => {
                if self.args == 0 && trailing_space {
                    self.put(b" ")?;
                }
                let payload_len = self.pos - COLA_B_HEADER_LEN;
                let len = u32::try_from(payload_len).map_err(|_| EmitError::TooLong)?;
                let cs = xor_checksum(self.buf.get(COLA_B_HEADER_LEN..self.pos).unwrap_or(&[]));
                if let Some(l) = self.buf.get_mut(4..8) {
                    l.copy_from_slice(&len.to_be_bytes());
                }
                self.put(&[cs])?;
            }
        }
        Ok(self.pos)
    }

    /// Appends already-encoded argument bytes of this dialect (as read by
    /// [`crate::Telegram::args`]) and closes the frame. Used to forward untyped telegrams.
    pub fn finish_raw_args(mut self, args: &[u8]) -> Result<usize, EmitError> {
        if !args.is_empty() {
            self.sep()?;
            self.put(args)?;
        }
        self.finish()
    }

    /// Closes the frame: answers (sensor side) get the trailing space of argument-less CoLa-B
    /// telegrams, requests do not (both as seen on the wire).
    pub fn finish(self) -> Result<usize, EmitError> {
        let trailing = !self.kind.is_request();
        self.finish_with(trailing)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cola_a_numbers() {
        let mut r = ArgReader::new(
            Dialect::ColaA,
            b"FFFF3CB0 683 +2500 -50000 3F800000 B SN 18110550 x",
            0,
        );
        assert_eq!(r.i32().unwrap(), -50000);
        assert_eq!(r.u16().unwrap(), 0x683);
        assert_eq!(r.u32().unwrap(), 2500);
        assert_eq!(r.i32().unwrap(), -50000);
        assert_eq!(r.f32().unwrap(), 1.0);
        assert_eq!(r.string(LenWidth::U16).unwrap(), b"SN 18110550");
        assert_eq!(r.u8().unwrap_err().kind, ArgErrorKind::InvalidNumber);
    }

    #[test]
    fn cola_a_range_checks() {
        let mut r = ArgReader::new(Dialect::ColaA, b"100 FFFF FFFFFFFF 1FFFFFFFF", 10);
        assert_eq!(
            r.u8().unwrap_err(),
            ArgError {
                offset: 10,
                kind: ArgErrorKind::OutOfRange
            }
        );
        let mut r = ArgReader::new(Dialect::ColaA, b"FFFF FFFFFFFF 1FFFFFFFF", 0);
        assert_eq!(r.i16().unwrap(), -1);
        assert_eq!(r.i16().unwrap(), -1);
        assert_eq!(r.i32().unwrap_err().kind, ArgErrorKind::OutOfRange);
    }

    #[test]
    fn writer_both_dialects() {
        let mut buf = [0u8; 64];
        let login = |dialect, buf: &mut [u8]| {
            let mut w =
                TelegramWriter::begin(dialect, buf, CommandType::MethodRequest, "SetAccessMode")
                    .unwrap();
            w.u8(3).unwrap().u32(0xF472_4744).unwrap();
            w.finish().unwrap()
        };
        let n = login(Dialect::ColaA, &mut buf);
        assert_eq!(&buf[..n], b"\x02sMN SetAccessMode 3 F4724744\x03");
        let n = login(Dialect::ColaB, &mut buf);
        assert_eq!(n, 32);
        assert_eq!(&buf[4..8], &[0, 0, 0, 0x17]);
        assert_eq!(buf[31], 0xB3);
        let mut w = TelegramWriter::begin(Dialect::ColaA, &mut buf, CommandType::WriteRequest, "x")
            .unwrap();
        w.i32(-50000).unwrap().f32(0.0).unwrap().i16(-2).unwrap();
        let n = w.finish().unwrap();
        assert_eq!(&buf[..n], b"\x02sWN x FFFF3CB0 00000000 FFFE\x03");
        let mut small = [0u8; 5];
        assert!(matches!(
            TelegramWriter::begin(
                Dialect::ColaB,
                &mut small,
                CommandType::MethodRequest,
                "Run"
            ),
            Err(EmitError::BufferTooSmall { .. })
        ));
    }
}
