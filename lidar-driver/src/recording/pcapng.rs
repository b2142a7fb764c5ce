//! pcapng files (Wireshark's default): section, interface and packet blocks.

use super::tcp::Packet;
use super::RecordingError;

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

/// Calls `each` for every packet of every section.
pub(crate) fn packets(b: &[u8], mut each: impl FnMut(&Packet<'_>)) -> Result<(), RecordingError> {
    let bad = |offset, what| RecordingError::Capture { offset, what };
    let mut le = true;
    let mut ifaces: Vec<Interface> = Vec::new();
    let mut at = 0usize;
    while at < b.len() {
        let rd = |le: bool, p: usize| -> Option<u32> {
            let s: [u8; 4] = b.get(p..p + 4)?.try_into().ok()?;
            Some(if le {
                u32::from_le_bytes(s)
            } else {
                u32::from_be_bytes(s)
            })
        };
        let raw_type = rd(true, at).ok_or(bad(at, "pcapng block header truncated"))?;
        if raw_type == SHB {
            // Byte-order magic decides the endianness of this section.
            le = match b.get(at + 8..at + 12) {
                Some([0x4d, 0x3c, 0x2b, 0x1a]) => true,
                Some([0x1a, 0x2b, 0x3c, 0x4d]) => false,
                _ => return Err(bad(at + 8, "pcapng byte-order magic missing")),
            };
            ifaces.clear();
        }
        let btype = rd(le, at).ok_or(bad(at, "pcapng block truncated"))?;
        let len = rd(le, at + 4).ok_or(bad(at, "pcapng block truncated"))? as usize;
        if len < 12 || len % 4 != 0 || at + len > b.len() {
            return Err(bad(at, "pcapng block length invalid"));
        }
        let body = b
            .get(at + 8..at + len - 4)
            .ok_or(bad(at, "pcapng block truncated"))?;
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
                let linktype = u16_in(0).ok_or(bad(at, "interface block truncated"))? as u32;
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
                    return Err(bad(at, "packet block truncated"));
                };
                let i = ifaces
                    .get(iface as usize)
                    .ok_or(bad(at, "packet block names an unknown interface"))?;
                let data = body
                    .get(data_at..data_at + cap as usize)
                    .ok_or(bad(at, "packet data truncated"))?;
                let ticks = ((hi as u64) << 32) | lo as u64;
                each(&Packet {
                    time_s: Some(ticks as f64 * i.tick_s),
                    linktype: i.linktype,
                    data,
                });
            }
            SIMPLE_PACKET => {
                let i = ifaces
                    .first()
                    .ok_or(bad(at, "packet before any interface block"))?;
                let orig = u32_in(0).ok_or(bad(at, "packet block truncated"))? as usize;
                let data = body.get(4..(4 + orig).min(body.len())).unwrap_or(&[]);
                each(&Packet {
                    time_s: None,
                    linktype: i.linktype,
                    data,
                });
            }
            _ => {}
        }
        at += len;
    }
    Ok(())
}
