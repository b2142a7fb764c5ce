//! One complete CoLa telegram on the wire: the dialect, the framing bytes, the checksum.
//!
//! CoLa-A: `0x02`, printable ASCII payload, `0x03`.
//! CoLa-B: `02 02 02 02`, payload length as u32 big-endian, payload, XOR of the payload bytes.
//! [`Frame`] is a checked, zero-copy view of such bytes; the streaming [`crate::Framer`] produces
//! them from arbitrary chunks.

use core::fmt;

/// Start of a CoLa-A frame, and each of the four bytes of the CoLa-B magic.
pub const STX: u8 = 0x02;
/// End of a CoLa-A frame.
pub const ETX: u8 = 0x03;
/// The CoLa-B start marker.
pub const COLA_B_MAGIC: [u8; 4] = [STX; 4];
/// Bytes before the CoLa-B payload: magic (4) + length (4).
pub const COLA_B_HEADER_LEN: usize = 8;
/// Bytes a CoLa-B frame adds around its payload: header (8) + checksum (1).
pub const COLA_B_OVERHEAD: usize = COLA_B_HEADER_LEN + 1;
/// The shortest payload a real telegram has: a 3-letter command type (`sFA`).
pub const MIN_PAYLOAD_LEN: usize = 3;

/// Byte offsets of the CoLa-B framing fields, named in one place.
pub(crate) mod field {
    use core::ops::Range;
    /// The `02 02 02 02` magic.
    pub const MAGIC: Range<usize> = 0..4;
    /// Payload length, u32 big-endian.
    pub const LENGTH: Range<usize> = 4..8;
    /// First payload byte.
    pub const PAYLOAD: usize = 8;
}

/// The two CoLa dialects of SICK scanners.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Dialect {
    /// ASCII tokens between `0x02` and `0x03`.
    ColaA,
    /// Binary, big-endian, length-prefixed and XOR-checked.
    ColaB,
}

impl Dialect {
    /// Short display name, `CoLa-A` or `CoLa-B`.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::ColaA => "CoLa-A",
            Dialect::ColaB => "CoLa-B",
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// XOR of all bytes: the CoLa-B checksum over the payload.
///
/// Works eight bytes at a time (the XOR of the lanes folds to the byte XOR), so the framer
/// runs at memory speed on large scans.
pub fn xor_checksum(bytes: &[u8]) -> u8 {
    let mut chunks = bytes.chunks_exact(8);
    let mut acc = 0u64;
    for c in &mut chunks {
        let mut w = [0u8; 8];
        w.copy_from_slice(c);
        acc ^= u64::from_ne_bytes(w);
    }
    let mut x = acc.to_ne_bytes().iter().fold(0u8, |a, b| a ^ b);
    for b in chunks.remainder() {
        x ^= b;
    }
    x
}

/// Why a frame was dropped (by [`Frame::new_checked`] or the streaming framer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// CoLa-B checksum mismatch: the payload or the checksum byte was damaged in transit.
    /// The frame is dropped; the stream goes on with the next start marker.
    BadChecksum {
        /// XOR computed over the received payload.
        computed: u8,
        /// Checksum byte received.
        received: u8,
    },
    /// CoLa-B length field impossible: shorter than a command type, over the configured
    /// maximum or over the framer's buffer. Usually a damaged length or garbage that looks like
    /// a magic; if real telegrams are this long, give the framer a larger buffer / maximum.
    BadLength {
        /// Length the frame claimed (payload bytes).
        claimed: u32,
        /// Largest payload accepted.
        max: usize,
    },
    /// A CoLa-A frame did not end (`0x03`) within the buffer: the end marker was lost, or the
    /// buffer is too small for this telegram.
    Oversize {
        /// Largest frame the buffer holds, bytes.
        max: usize,
    },
    /// The stream ended (see [`crate::Framer::finish`]) inside a frame.
    Truncated {
        /// Bytes of the incomplete frame that were dropped.
        have: usize,
    },
    /// Bytes given to [`Frame::new_checked`] are not exactly one frame of either dialect.
    NotAFrame,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            FrameError::BadChecksum { computed, received } => write!(
                f,
                "CoLa-B checksum mismatch (computed {computed:#04x}, received {received:#04x}): frame damaged in transit, dropped"
            ),
            FrameError::BadLength { claimed, max } => write!(
                f,
                "CoLa-B length {claimed} is impossible (accepted 3..={max}): damaged length or garbage; enlarge the framer buffer if real telegrams are this long"
            ),
            FrameError::Oversize { max } => write!(
                f,
                "CoLa-A frame without end marker within {max} bytes: end marker lost or buffer too small"
            ),
            FrameError::Truncated { have } => {
                write!(f, "stream ended inside a frame ({have} bytes dropped)")
            }
            FrameError::NotAFrame => f.write_str(
                "bytes are not one CoLa-A (02 .. 03) or CoLa-B (02 02 02 02 len .. xor) frame",
            ),
        }
    }
}

/// A complete, checked telegram frame: a zero-copy view over its bytes, framing included.
///
/// Invariants: CoLa-A frames start with `0x02`, end with `0x03` and hold at least
/// [`MIN_PAYLOAD_LEN`] printable ASCII bytes between; CoLa-B frames have the magic, a length equal
/// to the payload length (≥ [`MIN_PAYLOAD_LEN`]) and a correct checksum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    dialect: Dialect,
    bytes: &'a [u8],
}

impl<'a> Frame<'a> {
    /// Checks that `bytes` is exactly one frame of either dialect.
    pub fn new_checked(bytes: &'a [u8]) -> Result<Self, FrameError> {
        if bytes.get(field::MAGIC) == Some(&COLA_B_MAGIC[..]) {
            let len = be_u32(bytes, field::LENGTH.start).ok_or(FrameError::NotAFrame)?;
            let total = (len as usize).checked_add(COLA_B_OVERHEAD);
            if total != Some(bytes.len()) {
                return Err(FrameError::NotAFrame);
            }
            if (len as usize) < MIN_PAYLOAD_LEN {
                return Err(FrameError::BadLength {
                    claimed: len,
                    max: bytes.len() - COLA_B_OVERHEAD,
                });
            }
            let payload = bytes
                .get(field::PAYLOAD..bytes.len() - 1)
                .ok_or(FrameError::NotAFrame)?;
            let computed = xor_checksum(payload);
            let received = *bytes.last().ok_or(FrameError::NotAFrame)?;
            if computed != received {
                return Err(FrameError::BadChecksum { computed, received });
            }
            return Ok(Frame {
                dialect: Dialect::ColaB,
                bytes,
            });
        }
        match bytes {
            [STX, inner @ .., ETX]
                if inner.len() >= MIN_PAYLOAD_LEN && inner.iter().all(|&b| is_cola_a_byte(b)) =>
            {
                Ok(Frame {
                    dialect: Dialect::ColaA,
                    bytes,
                })
            }
            _ => Err(FrameError::NotAFrame),
        }
    }

    /// Wraps bytes the framer has already checked.
    pub(crate) fn from_checked(dialect: Dialect, bytes: &'a [u8]) -> Self {
        Frame { dialect, bytes }
    }

    /// The dialect of this frame.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// The whole frame, markers (and CoLa-B length and checksum) included.
    pub fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Offset of the first payload byte from the first frame byte (1 or 8).
    pub fn payload_offset(&self) -> usize {
        match self.dialect {
            Dialect::ColaA => 1,
            Dialect::ColaB => field::PAYLOAD,
        }
    }

    /// The payload: `type SP name …` without framing.
    pub fn payload(&self) -> &'a [u8] {
        let end = self.bytes.len().saturating_sub(1);
        self.bytes.get(self.payload_offset()..end).unwrap_or(&[])
    }
}

/// Bytes allowed inside a CoLa-A frame: printable ASCII.
#[inline]
pub(crate) fn is_cola_a_byte(b: u8) -> bool {
    (0x20..=0x7e).contains(&b)
}

pub(crate) fn be_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_be_bytes([s[0], s[1], s[2], s[3]]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_checksums_from_the_notes() {
        // sEN LMDscandata 01 -> 0x33 ; sMN SetAccessMode 03 F4724744 -> 0xB3, length 23.
        let mut p = b"sEN LMDscandata ".to_vec();
        p.push(1);
        assert_eq!(xor_checksum(&p), 0x33);
        let mut p = b"sMN SetAccessMode ".to_vec();
        p.extend_from_slice(&[0x03, 0xF4, 0x72, 0x47, 0x44]);
        assert_eq!(p.len(), 23);
        assert_eq!(xor_checksum(&p), 0xB3);
    }

    #[test]
    fn checksum_matches_bytewise_for_all_lengths() {
        let data: Vec<u8> = (0..100u32).map(|i| (i * 37 + 11) as u8).collect();
        for n in 0..data.len() {
            let slow = data[..n].iter().fold(0, |a, b| a ^ b);
            assert_eq!(xor_checksum(&data[..n]), slow);
        }
    }

    #[test]
    fn checked_frames() {
        let a = b"\x02sRN SCdevicestate\x03";
        let f = Frame::new_checked(a).unwrap();
        assert_eq!(f.dialect(), Dialect::ColaA);
        assert_eq!(f.payload(), b"sRN SCdevicestate");
        let mut b = vec![2, 2, 2, 2, 0, 0, 0, 17];
        b.extend_from_slice(b"sEN LMDscandata \x01");
        b.push(0x33);
        let f = Frame::new_checked(&b).unwrap();
        assert_eq!(f.dialect(), Dialect::ColaB);
        assert_eq!(f.payload().len(), 17);
        let n = b.len();
        b[n - 1] = 0x34;
        assert_eq!(
            Frame::new_checked(&b),
            Err(FrameError::BadChecksum {
                computed: 0x33,
                received: 0x34
            })
        );
        assert_eq!(
            Frame::new_checked(b"\x02s\x01x\x03"),
            Err(FrameError::NotAFrame)
        );
        assert_eq!(Frame::new_checked(b""), Err(FrameError::NotAFrame));
    }
}
