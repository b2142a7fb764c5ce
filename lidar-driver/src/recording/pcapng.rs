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

/// Where the next intact block after a damaged one at `at` starts: the first 4-byte aligned
/// offset whose type is a known block and whose leading and trailing lengths agree.
fn resync(b: &[u8], at: usize, le: bool) -> Option<usize> {
    let rd = |p: usize| -> Option<u32> {
        let s: [u8; 4] = b.get(p..p + 4)?.try_into().ok()?;
        Some(if le {
            u32::from_le_bytes(s)
        } else {
            u32::from_be_bytes(s)
        })
    };
    (at + 4..b.len()).step_by(4).find(|&p| {
        let (Some(t), Some(len)) = (rd(p), rd(p + 4)) else {
            return false;
        };
        let len = len as usize;
        (KNOWN_BLOCKS.contains(&t) || rd(p) == Some(SHB))
            && len >= 12
            && len % 4 == 0
            && p + len <= b.len()
            && rd(p + len - 4) == Some(len as u32)
    })
}

/// Calls `each` for every packet of every section. A damaged block (a bad length, a cut,
/// a packet naming no interface) is recorded in `damage` and skipped: reading resumes at the
/// next intact block, so only the damaged packets are lost; a file cut short ends at its
/// last complete block.
pub(crate) fn packets(
    b: &[u8],
    mut each: impl FnMut(&Packet<'_>),
    damage: &mut Vec<super::RecordingDamage>,
) -> Result<(), RecordingError> {
    let mut le = true;
    let mut ifaces: Vec<Interface> = Vec::new();
    let mut at = 0usize;
    while at < b.len() {
        match block(b, at, &mut le, &mut ifaces, &mut each) {
            Ok(len) => at += len,
            Err(what) => {
                let next = resync(b, at, le);
                damage.push(super::RecordingDamage {
                    offset: at,
                    what,
                    skipped_bytes: next.unwrap_or(b.len()) - at,
                });
                match next {
                    Some(p) => at = p,
                    None => break,
                }
            }
        }
    }
    Ok(())
}

/// Reads the block at `at`: its length, or what is wrong with it.
fn block(
    b: &[u8],
    at: usize,
    le: &mut bool,
    ifaces: &mut Vec<Interface>,
    each: &mut impl FnMut(&Packet<'_>),
) -> Result<usize, &'static str> {
    let rd = |le: bool, p: usize| -> Option<u32> {
        let s: [u8; 4] = b.get(p..p + 4)?.try_into().ok()?;
        Some(if le {
            u32::from_le_bytes(s)
        } else {
            u32::from_be_bytes(s)
        })
    };
    let raw_type = rd(true, at).ok_or("pcapng block header truncated")?;
    if raw_type == SHB {
        // Byte-order magic decides the endianness of this section.
        *le = match b.get(at + 8..at + 12) {
            Some([0x4d, 0x3c, 0x2b, 0x1a]) => true,
            Some([0x1a, 0x2b, 0x3c, 0x4d]) => false,
            _ => return Err("pcapng byte-order magic missing"),
        };
        ifaces.clear();
    }
    let le = *le;
    let btype = rd(le, at).ok_or("pcapng block truncated")?;
    let len = rd(le, at + 4).ok_or("pcapng block truncated")? as usize;
    if len < 12 || len % 4 != 0 || at + len > b.len() || rd(le, at + len - 4) != Some(len as u32) {
        return Err("pcapng block length invalid (or the file is cut inside the block)");
    }
    let body = b
        .get(at + 8..at + len - 4)
        .ok_or("pcapng block truncated")?;
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
            each(&Packet {
                time_s: Some(ticks as f64 * i.tick_s),
                linktype: i.linktype,
                data,
            });
        }
        SIMPLE_PACKET => {
            let i = ifaces.first().ok_or("packet before any interface block")?;
            let orig = u32_in(0).ok_or("packet block truncated")? as usize;
            let data = body.get(4..(4 + orig).min(body.len())).unwrap_or(&[]);
            each(&Packet {
                time_s: None,
                linktype: i.linktype,
                data,
            });
        }
        _ => {}
    }
    Ok(len)
}
