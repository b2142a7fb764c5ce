//! Classic libpcap files (`.pcap`): global header, then timestamped packet records, read one
//! record at a time.

use std::io::Read;

use super::window::Window;
use super::{CapturedPacket, RecordingDamage, RecordingError};

/// Largest packet record accepted, bytes (pcap's usual snap length is 256 KiB); a larger
/// length field is damage.
pub const MAX_RECORD_BYTES: u32 = 1 << 20;

/// True if `b` starts with a pcap magic (µs or ns timestamps, either byte order).
pub fn is_pcap(b: &[u8]) -> bool {
    matches!(
        b.get(..4),
        Some(
            [0xd4, 0xc3, 0xb2, 0xa1]
                | [0xa1, 0xb2, 0xc3, 0xd4]
                | [0x4d, 0x3c, 0xb2, 0xa1]
                | [0xa1, 0xb2, 0x3c, 0x4d]
        )
    )
}

/// The state of a pcap read: the global header's byte order, time unit and link type.
pub(crate) struct PcapReader {
    header: Option<(bool, bool, u32)>,
    ended: bool,
}

impl PcapReader {
    pub fn new() -> Self {
        Self {
            header: None,
            ended: false,
        }
    }

    /// The next packet record. A file cut inside a record, or a record length no capture
    /// has, ends the read at the last complete record, recorded in `damage` (pcap records
    /// carry no marker to resynchronise on).
    pub fn next_packet<R: Read>(
        &mut self,
        w: &mut Window<R>,
        damage: &mut Vec<RecordingDamage>,
    ) -> Result<Option<CapturedPacket>, RecordingError> {
        if self.ended {
            return Ok(None);
        }
        let (le, nanos, linktype) = match self.header {
            Some(h) => h,
            None => {
                let bad = |offset, what| RecordingError::Capture { offset, what };
                let h = w.peek(24).map_err(RecordingError::Io)?;
                let magic = h.get(..4).ok_or(bad(0, "pcap header truncated"))?;
                let le = matches!(magic, [0xd4, 0xc3, 0xb2, 0xa1] | [0x4d, 0x3c, 0xb2, 0xa1]);
                let nanos = matches!(magic, [0x4d, 0x3c, 0xb2, 0xa1] | [0xa1, 0xb2, 0x3c, 0x4d]);
                let lt = h
                    .get(20..24)
                    .map(|s| u32_of(s, le))
                    .ok_or(bad(20, "pcap header truncated"))?;
                w.consume(24);
                let hdr = (le, nanos, lt & 0x0fff_ffff);
                self.header = Some(hdr);
                hdr
            }
        };
        if w.at_end().map_err(RecordingError::Io)? {
            return Ok(None);
        }
        let offset = w.offset() as usize;
        let mut cut = |w: &mut Window<R>, what| -> Result<Option<CapturedPacket>, RecordingError> {
            let skipped = w.skip_to_end().map_err(RecordingError::Io)?;
            damage.push(RecordingDamage {
                offset,
                what,
                skipped_bytes: skipped as usize,
            });
            self.ended = true;
            Ok(None)
        };
        let head = w.peek(16).map_err(RecordingError::Io)?;
        if head.len() < 16 {
            return cut(w, "pcap record header truncated");
        }
        let (sec, frac, incl) = (
            u32_of(&head[0..4], le),
            u32_of(&head[4..8], le),
            u32_of(&head[8..12], le),
        );
        if incl > MAX_RECORD_BYTES {
            return cut(w, "pcap record length impossible (damaged record header)");
        }
        let whole = 16 + incl as usize;
        let rec = w.peek(whole).map_err(RecordingError::Io)?;
        if rec.len() < whole {
            return cut(w, "pcap record data truncated");
        }
        let data = rec[16..].to_vec();
        w.consume(whole);
        Ok(Some(CapturedPacket {
            time_s: Some(f64::from(sec) + f64::from(frac) * if nanos { 1e-9 } else { 1e-6 }),
            linktype,
            data,
        }))
    }
}

fn u32_of(s: &[u8], le: bool) -> u32 {
    let a: [u8; 4] = s.try_into().unwrap_or([0; 4]);
    if le {
        u32::from_le_bytes(a)
    } else {
        u32::from_be_bytes(a)
    }
}
