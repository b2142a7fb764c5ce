//! Recordings read as streams: [`RecordingReader`] hands out the chunks of any format one
//! at a time, and [`FrameReader`] the frames of those chunks, so a recording of any size is
//! read in the memory of its largest record (a pcap record ≤ 1 MiB, a pcapng block ≤ 16 MiB,
//! a JSON record ≤ 16 MiB, TCP reassembly ≤ 4 MiB held back per flow, 256 KiB of framer
//! per direction). [`super::Recording`] is the same read, collected.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use super::pcap::PcapReader;
use super::pcapng::PcapngReader;
use super::sick_json::JsonReader;
use super::tcp::{Reassembler, TcpStats};
use super::window::Window;
use super::{
    collect_frame, Chunk, Direction, RecordedFrame, RecordingDamage, RecordingError,
    RecordingFormat, FRAMER_BUFFER_LEN,
};
use crate::frame::FrameError;
use crate::framer::{Framer, FramerStats};

/// How many bytes decide the format.
const DETECT_BYTES: usize = 64;

enum Parser {
    Raw,
    Capture(CaptureReader, Reassembler),
    Json(JsonReader),
}

/// The packet reader of a pcap or pcapng file.
enum CaptureReader {
    Pcap(PcapReader),
    Pcapng(PcapngReader),
}

impl CaptureReader {
    fn next_packet<R: Read>(
        &mut self,
        w: &mut Window<R>,
        damage: &mut Vec<RecordingDamage>,
    ) -> Result<Option<super::CapturedPacket>, RecordingError> {
        match self {
            CaptureReader::Pcap(p) => p.next_packet(w, damage),
            CaptureReader::Pcapng(p) => p.next_packet(w, damage),
        }
    }
}

/// The chunks of a recording of any supported format, read as they are needed.
pub struct RecordingReader<R> {
    window: Window<R>,
    format: RecordingFormat,
    parser: Parser,
    /// Chunks completed by TCP reassembly, not handed out yet.
    ready: VecDeque<Chunk>,
    finished: bool,
    damage: Vec<RecordingDamage>,
}

impl RecordingReader<BufReader<File>> {
    /// Opens a recording file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, RecordingError> {
        Self::new(BufReader::new(
            File::open(path).map_err(RecordingError::Io)?,
        ))
    }
}

impl<R: Read> RecordingReader<R> {
    /// Reads a recording from `source` (the format is detected from its first bytes).
    pub fn new(source: R) -> Result<Self, RecordingError> {
        let mut window = Window::new(source);
        let head = window.peek(DETECT_BYTES).map_err(RecordingError::Io)?;
        let format = RecordingFormat::detect(head);
        let parser = match format {
            RecordingFormat::Raw => Parser::Raw,
            RecordingFormat::Pcap => Parser::Capture(
                CaptureReader::Pcap(PcapReader::new()),
                Reassembler::default(),
            ),
            RecordingFormat::Pcapng => Parser::Capture(
                CaptureReader::Pcapng(PcapngReader::new()),
                Reassembler::default(),
            ),
            RecordingFormat::SickJson => Parser::Json(JsonReader::new()),
        };
        Ok(Self {
            window,
            format,
            parser,
            ready: VecDeque::new(),
            finished: false,
            damage: Vec::new(),
        })
    }

    /// The detected format.
    pub fn format(&self) -> RecordingFormat {
        self.format
    }

    /// Damaged parts read around so far.
    pub fn damage(&self) -> &[RecordingDamage] {
        &self.damage
    }

    /// TCP reassembly counters so far (pcap / pcapng only).
    pub fn tcp_stats(&self) -> Option<TcpStats> {
        match &self.parser {
            Parser::Capture(_, r) => Some(r.stats),
            _ => None,
        }
    }

    /// The next chunk, `None` at the end.
    pub fn next_chunk(&mut self) -> Result<Option<Chunk>, RecordingError> {
        loop {
            if let Some(c) = self.ready.pop_front() {
                return Ok(Some(c));
            }
            if self.finished {
                return Ok(None);
            }
            let w = &mut self.window;
            match &mut self.parser {
                Parser::Raw => {
                    let bytes = w.peek(64 * 1024).map_err(RecordingError::Io)?.to_vec();
                    w.consume(bytes.len());
                    if bytes.is_empty() {
                        self.finished = true;
                    } else {
                        return Ok(Some(Chunk {
                            direction: Direction::Unknown,
                            time_s: None,
                            bytes,
                        }));
                    }
                }
                Parser::Json(j) => {
                    let c = j.next_chunk(w, &mut self.damage)?;
                    self.finished = c.is_none();
                    return Ok(c);
                }
                Parser::Capture(p, tcp) => match p.next_packet(w, &mut self.damage)? {
                    Some(packet) => {
                        tcp.push(&packet);
                        self.ready.extend(tcp.take_chunks());
                    }
                    None => {
                        tcp.finish();
                        self.ready.extend(tcp.take_chunks());
                        self.finished = true;
                    }
                },
            }
        }
    }
}

/// The packets of a pcap or pcapng source, one at a time (no TCP processing).
pub(crate) fn next_packet<R: Read>(
    reader: &mut RecordingReader<R>,
) -> Result<Option<super::CapturedPacket>, RecordingError> {
    let w = &mut reader.window;
    match &mut reader.parser {
        Parser::Capture(p, _) => p.next_packet(w, &mut reader.damage),
        _ => Err(RecordingError::Capture {
            offset: 0,
            what: "not a pcap or pcapng file",
        }),
    }
}

/// What [`FrameReader::next_frame`] gives: a frame, or a frame the framer dropped.
pub type FrameItem = Result<RecordedFrame, (Direction, FrameError)>;

/// Where a [`FrameReader`] gets its chunks: a [`RecordingReader`], or any closure handing
/// them out (`Ok(None)` at the end).
pub trait ChunkSource {
    /// The next chunk, `None` at the end.
    fn next_chunk(&mut self) -> Result<Option<Chunk>, RecordingError>;
}

impl<R: Read> ChunkSource for RecordingReader<R> {
    fn next_chunk(&mut self) -> Result<Option<Chunk>, RecordingError> {
        RecordingReader::next_chunk(self)
    }
}

impl<F: FnMut() -> Result<Option<Chunk>, RecordingError>> ChunkSource for F {
    fn next_chunk(&mut self) -> Result<Option<Chunk>, RecordingError> {
        self()
    }
}

/// The frames of a stream of chunks, each direction framed separately; frames of unknown
/// direction are classified by command type.
pub struct FrameReader<C> {
    chunks: C,
    framers: [Framer<Vec<u8>>; 3],
    queue: VecDeque<FrameItem>,
    finished: bool,
}

const DIRECTIONS: [Direction; 3] = [
    Direction::HostToSensor,
    Direction::SensorToHost,
    Direction::Unknown,
];

impl<C: ChunkSource> FrameReader<C> {
    /// Frames the chunks `chunks` hands out.
    pub fn new(chunks: C) -> Self {
        Self {
            chunks,
            framers: DIRECTIONS.map(|_| Framer::new(vec![0u8; FRAMER_BUFFER_LEN])),
            queue: VecDeque::new(),
            finished: false,
        }
    }

    /// The next frame (or dropped frame), `None` at the end.
    pub fn next_frame(&mut self) -> Result<Option<FrameItem>, RecordingError> {
        loop {
            if let Some(f) = self.queue.pop_front() {
                return Ok(Some(f));
            }
            if self.finished {
                return Ok(None);
            }
            let queue = &mut self.queue;
            match self.chunks.next_chunk()? {
                Some(chunk) => {
                    let i = DIRECTIONS
                        .iter()
                        .position(|&d| d == chunk.direction)
                        .unwrap_or(2);
                    if let Some(framer) = self.framers.get_mut(i) {
                        framer.feed(&chunk.bytes, |r| {
                            queue.push_back(collect_frame(chunk.direction, chunk.time_s, r))
                        });
                    }
                }
                None => {
                    for (d, framer) in DIRECTIONS.iter().zip(self.framers.iter_mut()) {
                        framer.finish();
                        while let Some(r) = framer.next_frame() {
                            queue.push_back(collect_frame(*d, None, r));
                        }
                    }
                    self.finished = true;
                }
            }
        }
    }

    /// The chunk source (a [`RecordingReader`]'s format, damage and TCP counters).
    pub fn source(&self) -> &C {
        &self.chunks
    }

    /// The framers' counters, summed over the directions.
    pub fn stats(&self) -> FramerStats {
        let mut t = FramerStats::default();
        for s in self.framers.iter().map(Framer::stats) {
            t.bytes_in += s.bytes_in;
            t.garbage_bytes += s.garbage_bytes;
            t.frames_cola_a += s.frames_cola_a;
            t.frames_cola_b += s.frames_cola_b;
            t.bad_checksum += s.bad_checksum;
            t.bad_length += s.bad_length;
            t.oversize += s.oversize;
            t.truncated += s.truncated;
        }
        t
    }
}
