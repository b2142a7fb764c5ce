//! Ethernet / IPv4 / TCP decoding and per-direction TCP stream reassembly by sequence number.
//!
//! Retransmitted bytes (sequence numbers already delivered) are dropped; segments that arrive
//! early wait until the gap before them is filled. At the end, still-waiting segments are
//! delivered in order across their gaps (the framer resynchronises over a lost piece).

use std::collections::{BTreeMap, HashMap};

use super::{CapturedPacket, Chunk, Direction};

/// TCP ports SICK scanners serve CoLa on (2112 both dialects, 2111 CoLa-A).
pub const SICK_PORTS: [u16; 2] = [2111, 2112];

/// Counters of the reassembly.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TcpStats {
    /// Packets seen.
    pub packets: u64,
    /// Packets that were not Ethernet/IPv4/TCP (or truncated).
    pub skipped: u64,
    /// TCP segments with payload.
    pub segments: u64,
    /// Segments wholly retransmitted (dropped).
    pub retransmissions: u64,
    /// Segments received ahead of a gap (held back, then delivered in order).
    pub out_of_order: u64,
    /// Gaps never filled (bytes lost in the capture).
    pub gaps: u64,
}

/// Bytes a flow holds back waiting for a gap to fill before it delivers across the gap:
/// a segment lost from the capture must not make the reassembly keep the rest of the file.
const MAX_HELD_BYTES: usize = 4 << 20;

/// Flows followed at most; packets of further flows are skipped (a capture of a busy
/// network, or garbage read as packets).
const MAX_FLOWS: usize = 1024;

/// (source address, source port, destination address, destination port)
type FlowKey = ([u8; 4], u16, [u8; 4], u16);

struct Flow {
    next_seq: Option<u32>,
    held: BTreeMap<u32, (Option<f64>, Vec<u8>)>,
    held_bytes: usize,
    direction: Direction,
}

/// Reassembles the TCP streams of a packet sequence into ordered chunks.
#[derive(Default)]
pub(crate) struct Reassembler {
    flows: HashMap<FlowKey, Flow>,
    pub stats: TcpStats,
    pub chunks: Vec<Chunk>,
}

struct Segment<'a> {
    key: FlowKey,
    seq: u32,
    syn: bool,
    payload: &'a [u8],
}

fn be16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

fn be32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_be_bytes([
        *b.get(at)?,
        *b.get(at + 1)?,
        *b.get(at + 2)?,
        *b.get(at + 3)?,
    ]))
}

/// Link layer → IPv4 packet bytes.
fn ipv4_of(linktype: u32, data: &[u8]) -> Option<&[u8]> {
    match linktype {
        // Ethernet, with optional 802.1Q tags.
        1 => {
            let mut at = 12;
            let mut ethertype = be16(data, at)?;
            while ethertype == 0x8100 || ethertype == 0x88a8 {
                at += 4;
                ethertype = be16(data, at)?;
            }
            (ethertype == 0x0800).then(|| data.get(at + 2..)).flatten()
        }
        // Raw IP.
        101 | 228 => Some(data),
        // Linux cooked capture (SLL).
        113 => (be16(data, 14)? == 0x0800)
            .then(|| data.get(16..))
            .flatten(),
        _ => None,
    }
}

fn parse_segment(linktype: u32, data: &[u8]) -> Option<Segment<'_>> {
    let ip = ipv4_of(linktype, data)?;
    let ver_ihl = *ip.first()?;
    if ver_ihl >> 4 != 4 || *ip.get(9)? != 6 {
        return None;
    }
    let ihl = (ver_ihl & 0x0f) as usize * 4;
    let total = (be16(ip, 2)? as usize).min(ip.len());
    let src: [u8; 4] = ip.get(12..16)?.try_into().ok()?;
    let dst: [u8; 4] = ip.get(16..20)?.try_into().ok()?;
    let tcp = ip.get(ihl..total)?;
    let sport = be16(tcp, 0)?;
    let dport = be16(tcp, 2)?;
    let seq = be32(tcp, 4)?;
    let off = ((*tcp.get(12)? >> 4) as usize) * 4;
    let flags = *tcp.get(13)?;
    Some(Segment {
        key: (src, sport, dst, dport),
        seq,
        syn: flags & 0x02 != 0,
        payload: tcp.get(off..)?,
    })
}

impl Reassembler {
    /// Adds one captured packet; the chunks it completes are in `chunks` (take them with
    /// [`Reassembler::take_chunks`]).
    pub fn push(&mut self, p: &CapturedPacket) {
        self.stats.packets += 1;
        let Some(seg) = parse_segment(p.linktype, &p.data) else {
            self.stats.skipped += 1;
            return;
        };
        if self.flows.len() >= MAX_FLOWS && !self.flows.contains_key(&seg.key) {
            self.stats.skipped += 1;
            return;
        }
        let flow = self.flows.entry(seg.key).or_insert_with(|| Flow {
            next_seq: None,
            held: BTreeMap::new(),
            held_bytes: 0,
            direction: if SICK_PORTS.contains(&seg.key.1) {
                Direction::SensorToHost
            } else if SICK_PORTS.contains(&seg.key.3) {
                Direction::HostToSensor
            } else {
                Direction::Unknown
            },
        });
        if seg.syn {
            flow.next_seq = Some(seg.seq.wrapping_add(1));
        }
        if seg.payload.is_empty() {
            return;
        }
        self.stats.segments += 1;
        let next = *flow.next_seq.get_or_insert(seg.seq);
        let rel = seg.seq.wrapping_sub(next) as i32;
        if rel > 0 {
            self.stats.out_of_order += 1;
            flow.held_bytes += seg.payload.len();
            if let Some((_, old)) = flow.held.insert(seg.seq, (p.time_s, seg.payload.to_vec())) {
                flow.held_bytes -= old.len();
            }
            if flow.held_bytes > MAX_HELD_BYTES {
                drain_held(flow, &mut self.chunks, &mut self.stats, true);
            }
            return;
        }
        let skip = rel.unsigned_abs() as usize;
        if skip >= seg.payload.len() {
            self.stats.retransmissions += 1;
            return;
        }
        let fresh = seg.payload.get(skip..).unwrap_or(&[]);
        deliver(flow, &mut self.chunks, p.time_s, fresh);
        drain_held(flow, &mut self.chunks, &mut self.stats, false);
    }

    /// The chunks completed so far, in capture order.
    pub fn take_chunks(&mut self) -> std::vec::Drain<'_, Chunk> {
        self.chunks.drain(..)
    }

    /// Delivers what is still held back (across gaps) into `chunks`.
    pub fn finish(&mut self) {
        let mut keys: Vec<FlowKey> = self.flows.keys().copied().collect();
        keys.sort_unstable();
        for k in keys {
            if let Some(flow) = self.flows.get_mut(&k) {
                drain_held(flow, &mut self.chunks, &mut self.stats, true);
            }
        }
    }
}

fn deliver(flow: &mut Flow, chunks: &mut Vec<Chunk>, time_s: Option<f64>, bytes: &[u8]) {
    flow.next_seq = flow.next_seq.map(|n| n.wrapping_add(bytes.len() as u32));
    chunks.push(Chunk {
        direction: flow.direction,
        time_s,
        bytes: bytes.to_vec(),
    });
}

/// Delivers held segments that have become contiguous; with `force`, jumps gaps.
fn drain_held(flow: &mut Flow, chunks: &mut Vec<Chunk>, stats: &mut TcpStats, force: bool) {
    loop {
        let Some(next) = flow.next_seq else { return };
        // The held segment closest after `next` (sequence space wraps).
        let Some((&seq, _)) = flow
            .held
            .iter()
            .min_by_key(|(&s, _)| s.wrapping_sub(next) as i32 as i64)
        else {
            return;
        };
        let rel = seq.wrapping_sub(next) as i32;
        if rel > 0 && !force {
            return;
        }
        let Some((time_s, data)) = flow.held.remove(&seq) else {
            return;
        };
        flow.held_bytes -= data.len();
        if rel > 0 {
            stats.gaps += 1;
            flow.next_seq = Some(seq);
            deliver(flow, chunks, time_s, &data);
            continue;
        }
        let skip = rel.unsigned_abs() as usize;
        if skip >= data.len() {
            stats.retransmissions += 1;
            continue;
        }
        deliver(flow, chunks, time_s, data.get(skip..).unwrap_or(&[]));
    }
}
