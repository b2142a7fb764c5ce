//! Classic libpcap files (`.pcap`): global header, then timestamped packet records.

use super::tcp::Packet;
use super::RecordingError;

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

/// Calls `each` for every packet record. A file cut inside a record ends at the last
/// complete one, recorded in `damage` (pcap records carry no marker to resynchronise on).
pub(crate) fn packets(
    b: &[u8],
    mut each: impl FnMut(&Packet<'_>),
    damage: &mut Vec<super::RecordingDamage>,
) -> Result<(), RecordingError> {
    let bad = |offset, what| RecordingError::Capture { offset, what };
    let magic = b.get(..4).ok_or(bad(0, "pcap header truncated"))?;
    let le = matches!(magic, [0xd4, 0xc3, 0xb2, 0xa1] | [0x4d, 0x3c, 0xb2, 0xa1]);
    let nanos = matches!(magic, [0x4d, 0x3c, 0xb2, 0xa1] | [0xa1, 0xb2, 0x3c, 0x4d]);
    let u32_at = |at: usize| -> Option<u32> {
        let s: [u8; 4] = b.get(at..at + 4)?.try_into().ok()?;
        Some(if le {
            u32::from_le_bytes(s)
        } else {
            u32::from_be_bytes(s)
        })
    };
    let linktype = u32_at(20).ok_or(bad(20, "pcap header truncated"))? & 0x0fff_ffff;
    let mut at = 24;
    while at < b.len() {
        let cut = |what| super::RecordingDamage {
            offset: at,
            what,
            skipped_bytes: b.len() - at,
        };
        let (Some(sec), Some(frac), Some(incl)) = (u32_at(at), u32_at(at + 4), u32_at(at + 8))
        else {
            damage.push(cut("pcap record header truncated"));
            break;
        };
        let Some(data) = b.get(at + 16..at + 16 + incl as usize) else {
            damage.push(cut("pcap record data truncated"));
            break;
        };
        let time_s = sec as f64 + frac as f64 * if nanos { 1e-9 } else { 1e-6 };
        each(&Packet {
            time_s: Some(time_s),
            linktype,
            data,
        });
        at += 16 + incl as usize;
    }
    Ok(())
}
