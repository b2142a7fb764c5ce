//! Recorded telegrams (feature `std`): raw byte streams, pcap and pcapng (Ethernet/IPv4/TCP,
//! reassembled per direction) and SICK's `.pcapng.json`. The format is detected from content.
//!
//! [`Recording::frames`] frames every direction separately and classifies frames whose direction
//! the file does not say (raw streams, JSON records) by command type: `sRN sWN sMN sEN` are host
//! requests, everything else a sensor answer.
//!
//! [`RecordingReader`] and [`FrameReader`] do the same as streams, in memory bounded by the
//! largest record whatever the file's size; [`Recording`] collects them.

mod pcap;
mod pcapng;
mod sick_json;
mod stream;
mod tcp;
mod window;

use std::fmt;
use std::path::Path;

pub use stream::{ChunkSource, FrameItem, FrameReader, RecordingReader};
pub use tcp::{TcpStats, SICK_PORTS};

use crate::frame::{Dialect, Frame, FrameError};
use crate::framer::FramerStats;
use crate::telegram::Telegram;

/// Which way bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Host → sensor (requests).
    HostToSensor,
    /// Sensor → host (answers, scans).
    SensorToHost,
    /// Not recorded (raw streams, SICK JSON): classified per frame by command type.
    Unknown,
}

/// Recording file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RecordingFormat {
    /// Bytes as they came off the wire, one direction or mixed.
    Raw,
    /// libpcap.
    Pcap,
    /// pcapng.
    Pcapng,
    /// SICK's `.pcapng.json`.
    SickJson,
}

impl RecordingFormat {
    /// Detects the format from the first bytes.
    pub fn detect(bytes: &[u8]) -> Self {
        if pcapng::is_pcapng(bytes) {
            RecordingFormat::Pcapng
        } else if pcap::is_pcap(bytes) {
            RecordingFormat::Pcap
        } else if sick_json::is_json(bytes) {
            RecordingFormat::SickJson
        } else {
            RecordingFormat::Raw
        }
    }
}

/// A piece of a recorded stream.
#[derive(Debug, Clone, PartialEq)]
pub struct Chunk {
    /// Direction, if the file says.
    pub direction: Direction,
    /// Capture time, s (pcap: epoch; JSON: relative to the capture start).
    pub time_s: Option<f64>,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// Why a recording could not be read.
#[derive(Debug)]
#[non_exhaustive]
pub enum RecordingError {
    /// The file could not be read.
    Io(std::io::Error),
    /// pcap / pcapng structure broken at this offset.
    Capture {
        /// Byte offset in the file.
        offset: usize,
        /// What is wrong.
        what: &'static str,
    },
    /// Not valid SICK JSON.
    Json(String),
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordingError::Io(e) => write!(f, "cannot read recording: {e}"),
            RecordingError::Capture { offset, what } => {
                write!(f, "capture file broken at byte {offset}: {what} (file truncated or not a capture)")
            }
            RecordingError::Json(e) => write!(f, "not a SICK .pcapng.json recording: {e}"),
        }
    }
}

impl std::error::Error for RecordingError {}

/// A recording: ordered chunks of bytes with direction and time.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Detected file format.
    pub format: RecordingFormat,
    /// The chunks in capture order.
    pub chunks: Vec<Chunk>,
    /// TCP reassembly counters (pcap / pcapng only).
    pub tcp: Option<TcpStats>,
    /// Damaged parts of the file that were skipped (the rest was read).
    pub damage: Vec<RecordingDamage>,
}

/// A damaged part of a recording file, skipped: the frames before and after it are kept.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingDamage {
    /// Byte offset of the damage in the file.
    pub offset: usize,
    /// What is wrong there.
    pub what: &'static str,
    /// Bytes skipped until reading could resume (to the end of the file for a cut).
    pub skipped_bytes: usize,
}

impl fmt::Display for RecordingDamage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "damaged at byte {}: {}; {} bytes skipped",
            self.offset, self.what, self.skipped_bytes
        )
    }
}

/// One frame of a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedFrame {
    /// Direction (recorded, or classified by command type).
    pub direction: Direction,
    /// Time of the chunk that completed the frame, s.
    pub time_s: Option<f64>,
    /// Dialect.
    pub dialect: Dialect,
    /// The whole frame.
    pub bytes: Vec<u8>,
}

impl RecordedFrame {
    /// The checked frame view.
    pub fn frame(&self) -> Frame<'_> {
        Frame::from_checked(self.dialect, &self.bytes)
    }
}

/// All frames of a recording, with the framers' counters.
#[derive(Debug, Clone, Default)]
pub struct RecordedFrames {
    /// Good frames in capture order.
    pub frames: Vec<RecordedFrame>,
    /// Dropped frames, in order.
    pub errors: Vec<(Direction, FrameError)>,
    /// Counters summed over the directions.
    pub stats: FramerStats,
}

/// One captured link-layer packet of a pcap / pcapng file.
#[derive(Debug, Clone, PartialEq)]
pub struct CapturedPacket {
    /// Capture time, s since the epoch (`None` for pcapng simple packet blocks).
    pub time_s: Option<f64>,
    /// Link type (1 = Ethernet).
    pub linktype: u32,
    /// Packet bytes from the link layer on.
    pub data: Vec<u8>,
}

/// The packets of a pcap or pcapng file, in file order (no TCP processing); a damaged file
/// is an error (`Recording::parse` reads around the damage instead).
pub fn capture_packets(bytes: &[u8]) -> Result<Vec<CapturedPacket>, RecordingError> {
    let mut reader = RecordingReader::new(bytes)?;
    let mut out = Vec::new();
    while let Some(p) = stream::next_packet(&mut reader)? {
        out.push(p);
    }
    // This one gives the packets exactly or not at all: damage is an error here.
    match reader.damage().first() {
        Some(d) => Err(RecordingError::Capture {
            offset: d.offset,
            what: d.what,
        }),
        None => Ok(out),
    }
}

/// Writes packets as a classic pcap file (µs timestamps, little-endian), e.g. to record a
/// simulated or emulated session for Wireshark. All packets must share the first one's link
/// type.
pub fn write_pcap(packets: &[CapturedPacket]) -> Vec<u8> {
    let linktype = packets.first().map_or(1, |p| p.linktype);
    let mut v = Vec::new();
    v.extend_from_slice(&0xa1b2_c3d4u32.to_le_bytes());
    v.extend_from_slice(&2u16.to_le_bytes());
    v.extend_from_slice(&4u16.to_le_bytes());
    v.extend_from_slice(&0i32.to_le_bytes());
    v.extend_from_slice(&0u32.to_le_bytes());
    v.extend_from_slice(&262_144u32.to_le_bytes());
    v.extend_from_slice(&linktype.to_le_bytes());
    for p in packets {
        let t = p.time_s.unwrap_or(0.0).max(0.0);
        let sec = t.floor();
        let usec = ((t - sec) * 1e6).round().min(999_999.0);
        let len = p.data.len() as u32;
        v.extend_from_slice(&(sec as u32).to_le_bytes());
        v.extend_from_slice(&(usec as u32).to_le_bytes());
        v.extend_from_slice(&len.to_le_bytes());
        v.extend_from_slice(&len.to_le_bytes());
        v.extend_from_slice(&p.data);
    }
    v
}

/// Framer buffer per direction: room for the largest telegrams of both dialects.
const FRAMER_BUFFER_LEN: usize = 256 * 1024;

impl Recording {
    /// Reads and parses a recording file of any supported format.
    pub fn read_file(path: impl AsRef<Path>) -> Result<Self, RecordingError> {
        let bytes = std::fs::read(path).map_err(RecordingError::Io)?;
        Self::parse(&bytes)
    }

    /// Parses recording bytes of any supported format.
    pub fn parse(bytes: &[u8]) -> Result<Self, RecordingError> {
        let mut reader = RecordingReader::new(bytes)?;
        let mut chunks = Vec::new();
        while let Some(c) = reader.next_chunk()? {
            chunks.push(c);
        }
        Ok(Recording {
            format: reader.format(),
            chunks,
            tcp: reader.tcp_stats(),
            damage: reader.damage().to_vec(),
        })
    }

    /// Frames every direction separately; frames of unknown direction are classified by type.
    pub fn frames(&self) -> RecordedFrames {
        let mut chunks = self.chunks.iter().cloned();
        let mut reader = FrameReader::new(move || Ok(chunks.next()));
        let mut out = RecordedFrames::default();
        while let Ok(Some(item)) = reader.next_frame() {
            match item {
                Ok(f) => out.frames.push(f),
                Err(e) => out.errors.push(e),
            }
        }
        out.stats = reader.stats();
        out
    }
}

/// A framer's result as a recorded frame, the direction classified when unknown.
fn collect_frame(
    dir: Direction,
    time_s: Option<f64>,
    r: Result<Frame<'_>, FrameError>,
) -> FrameItem {
    match r {
        Ok(f) => {
            let direction = match dir {
                Direction::Unknown => match Telegram::parse(f) {
                    Ok(t) if t.kind().is_request() => Direction::HostToSensor,
                    Ok(_) => Direction::SensorToHost,
                    Err(_) => Direction::Unknown,
                },
                d => d,
            };
            Ok(RecordedFrame {
                direction,
                time_s,
                dialect: f.dialect(),
                bytes: f.as_bytes().to_vec(),
            })
        }
        Err(e) => Err((dir, e)),
    }
}
