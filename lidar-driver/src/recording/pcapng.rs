//! pcapng files (Wireshark's default): section, interface and packet blocks, read one
//! block at a time.

use std::io::Read;

use super::window::Window;
use super::{CapturedPacket, RecordingDamage, RecordingError};

/// Section header block type, also the file magic.
const SHB: u32 = 0x0A0D_0D0A;
const IDB: u32 = 1;
const OBSOLETE_PACKET: u32 = 2;
const SIMPLE_PACKET: u32 = 3;
const ENHANCED_PACKET: u32 = 6;

/// True if `b` starts with a pcapng section header.
pub fn is_pcapng(b: &[u8]) -> bool {
    b.get(..4) == Some(&[0x0a, 0x0d, 0x0d, 0x0a])
}

struct Interface {
    linktype: u32,
    /// Seconds per timestamp unit.
    tick_s: f64,
}

/// Block types a resynchronisation accepts as the start of a block (section, interface,
/// packet, name resolution, statistics).
const KNOWN_BLOCKS: [u32; 7] = [
    SHB,
    IDB,
    OBSOLETE_PACKET,
    SIMPLE_PACKET,
    4,
    5,
    ENHANCED_PACKET,
];

/// Largest block accepted, bytes; a larger length field is damage.
pub const MAX_BLOCK_BYTES: usize = 16 << 20;

fn u32_of(s: &[u8], le: bool) -> Option<u32> {
    let a: [u8; 4] = s.get(..4)?.try_into().ok()?;
    Some(if le {
        u32::from_le_bytes(a)
    } else {
        u32::from_be_bytes(a)
    })
}

/// The state of a pcapng read: the section's byte order and its interfaces.
pub(crate) struct PcapngReader {
    le: bool,
    ifaces: Vec<Interface>,
}

/// What the block at the window's start is.
enum Block {
    /// Intact, `len` bytes; a packet if it carried one.
    Read(usize, Option<CapturedPacket>),
    /// Damaged: what is wrong.
    Damaged(&'static str),
}

impl PcapngReader {
    pub fn new() -> Self {
        Self {
            le: true,
            ifaces: Vec::new(),
        }
    }

    /// The next packet of any section. A damaged block (a bad length, a cut, a packet
    /// naming no interface) is recorded in `damage` and skipped: reading resumes at the
    /// next intact block, so only the damaged packets are lost; a file cut short ends at
    /// its last complete block.
    pub fn next_packet<R: Read>(
        &mut self,
        w: &mut Window<R>,
        damage: &mut Vec<RecordingDamage>,
    ) -> Result<Option<CapturedPacket>, RecordingError> {
        loop {
            if w.at_end().map_err(RecordingError::Io)? {
                return Ok(None);
            }
            match self.block(w).map_err(RecordingError::Io)? {
                Block::Read(len, packet) => {
                    w.consume(len);
                    if packet.is_some() {
                        return Ok(packet);
                    }
                }
                Block::Damaged(what) => {
                    let offset = w.offset();
                    let skipped = self.resync(w).map_err(RecordingError::Io)?;
                    damage.push(RecordingDamage {
                        offset: offset as usize,
                        what,
                        skipped_bytes: skipped as usize,
                    });
                }
            }
        }
    }

    /// The block's length if one intact block of a known type starts the window (its
    /// leading and trailing lengths agree).
    fn intact_len<R: Read>(&self, w: &mut Window<R>) -> std::io::Result<Option<usize>> {
        let h = w.peek(8)?;
        let (Some(raw), Some(t), Some(len)) = (
            u32_of(h, true),
            u32_of(h, self.le),
            h.get(4..).and_then(|l| u32_of(l, self.le)),
        ) else {
            return Ok(None);
        };
        let len = len as usize;
        if !(KNOWN_BLOCKS.contains(&t) || raw == SHB)
            || len < 12
            || len % 4 != 0
            || len > MAX_BLOCK_BYTES
        {
            return Ok(None);
        }
        let b = w.peek(len)?;
        let ok =
            b.len() == len && b.get(len - 4..).and_then(|l| u32_of(l, self.le)) == Some(len as u32);
        Ok(ok.then_some(len))
    }

    /// Skips to the next intact block (4-byte aligned), consuming as it goes so the window
    /// stays small; returns the bytes skipped.
    fn resync<R: Read>(&self, w: &mut Window<R>) -> std::io::Result<u64> {
        let start = w.offset();
        w.consume(4);
        loop {
            if w.at_end()? {
                return Ok(w.offset() - start);
            }
            if self.intact_len(w)?.is_some() {
                return Ok(w.offset() - start);
            }
            w.consume(4);
        }
    }

    /// Reads the block at the window's start (without consuming it).
    fn block<R: Read>(&mut self, w: &mut Window<R>) -> std::io::Result<Block> {
        let h = w.peek(12)?;
        if u32_of(h, true) == Some(SHB) {
            // Byte-order magic decides the endianness of this section.
            self.le = match h.get(8..12) {
                Some([0x4d, 0x3c, 0x2b, 0x1a]) => true,
                Some([0x1a, 0x2b, 0x3c, 0x4d]) => false,
                _ => return Ok(Block::Damaged("pcapng byte-order magic missing")),
            };
            self.ifaces.clear();
        }
        let Some(len) = self.intact_len(w)? else {
            return Ok(Block::Damaged(
                "pcapng block length invalid (or the file is cut inside the block)",
            ));
        };
        let le = self.le;
        let b = w.peek(len)?;
        let btype = u32_of(b, le).unwrap_or(0);
        let body = b.get(8..len - 4).unwrap_or(&[]);
        Ok(match parse_body(btype, body, le, &mut self.ifaces) {
            Ok(packet) => Block::Read(len, packet),
            Err(what) => Block::Damaged(what),
        })
    }
}

/// The packet a block's body carries, if any (interface blocks are added to `ifaces`).
fn parse_body(
    btype: u32,
    body: &[u8],
    le: bool,
    ifaces: &mut Vec<Interface>,
) -> Result<Option<CapturedPacket>, &'static str> {
    // An unsigned field of `n` bytes (2 or 4) of the block, in the section's byte order.
    let uint_in = |p: usize, n: usize| -> Option<u32> {
        let bytes = body.get(p..p + n)?;
        let be = |acc: u32, &b: &u8| (acc << 8) | u32::from(b);
        Some(if le {
            bytes.iter().rev().fold(0, be)
        } else {
            bytes.iter().fold(0, be)
        })
    };
    let u16_in = |p: usize| uint_in(p, 2).map(|v| v as u16);
    let u32_in = |p: usize| uint_in(p, 4);
    match btype {
        IDB => {
            let linktype = u16_in(0).ok_or("interface block truncated")? as u32;
            // Options: if_tsresol (code 9) sets the timestamp unit; default µs.
            let mut tick_s = 1e-6;
            let mut p = 8;
            while let (Some(code), Some(olen)) = (u16_in(p), u16_in(p + 2)) {
                if code == 0 {
                    break;
                }
                if code == 9 {
                    if let Some(&r) = body.get(p + 4) {
                        let exp = (r & 0x7f) as i32;
                        tick_s = if r & 0x80 != 0 {
                            2f64.powi(-exp)
                        } else {
                            10f64.powi(-exp)
                        };
                    }
                }
                p += 4 + (olen as usize).div_ceil(4) * 4;
            }
            ifaces.push(Interface { linktype, tick_s });
        }
        ENHANCED_PACKET | OBSOLETE_PACKET => {
            let (iface, hi, lo, cap, data_at) = if btype == ENHANCED_PACKET {
                (u32_in(0), u32_in(4), u32_in(8), u32_in(12), 20)
            } else {
                (
                    u16_in(0).map(u32::from),
                    u32_in(4),
                    u32_in(8),
                    u32_in(12),
                    20,
                )
            };
            let (Some(iface), Some(hi), Some(lo), Some(cap)) = (iface, hi, lo, cap) else {
                return Err("packet block truncated");
            };
            let i = ifaces
                .get(iface as usize)
                .ok_or("packet block names an unknown interface")?;
            let data = body
                .get(data_at..data_at + cap as usize)
                .ok_or("packet data truncated")?;
            let ticks = ((hi as u64) << 32) | lo as u64;
            return Ok(Some(CapturedPacket {
                time_s: Some(ticks as f64 * i.tick_s),
                linktype: i.linktype,
                data: data.to_vec(),
            }));
        }
        SIMPLE_PACKET => {
            let i = ifaces.first().ok_or("packet before any interface block")?;
            let orig = u32_in(0).ok_or("packet block truncated")? as usize;
            let data = body.get(4..(4 + orig).min(body.len())).unwrap_or(&[]);
            return Ok(Some(CapturedPacket {
                time_s: None,
                linktype: i.linktype,
                data: data.to_vec(),
            }));
        }
        _ => {}
    }
    Ok(None)
}
