//! SICK's `.pcapng.json` (sick_scan_xd's pcap-to-json converter): a JSON list of records, each
//! `_source.layers.tcp."tcp.payload"` one complete CoLa message as colon-separated hex, with its
//! time in `_source.layers.tcp.Timestamps."tcp.time_relative"` (seconds, as a string).
//! Records carry no direction.

use std::io::Read;

use super::window::Window;
use super::{Chunk, Direction, RecordingDamage, RecordingError};

/// True if the content looks like a JSON list.
pub fn is_json(b: &[u8]) -> bool {
    b.iter().find(|c| !c.is_ascii_whitespace()) == Some(&b'[')
}

fn hex_pairs(s: &str) -> Option<Vec<u8>> {
    s.split(':')
        .filter(|p| !p.is_empty())
        .map(|p| u8::from_str_radix(p, 16).ok())
        .collect()
}

/// Largest record accepted, bytes; a larger one is skipped as damage.
pub const MAX_RECORD_BYTES: usize = 16 << 20;

/// The state of a streamed read of the list: brace depth, string and escape state, the
/// record being gathered.
pub(crate) struct JsonReader {
    opened: bool,
    closed: bool,
    depth: usize,
    in_str: bool,
    esc: bool,
    record: Vec<u8>,
    /// The record being gathered outgrew [`MAX_RECORD_BYTES`]: it is skipped to its end.
    oversize: bool,
    record_offset: u64,
    records: usize,
}

impl JsonReader {
    pub fn new() -> Self {
        Self {
            opened: false,
            closed: false,
            depth: 0,
            in_str: false,
            esc: false,
            record: Vec::new(),
            oversize: false,
            record_offset: 0,
            records: 0,
        }
    }

    /// The next chunk (a record with a payload). A record that is not valid JSON, or whose
    /// payload is not hex, is skipped and recorded in `damage`; a file cut short keeps its
    /// complete records (the cut is recorded too). Nothing readable at all is an error.
    pub fn next_chunk<R: Read>(
        &mut self,
        w: &mut Window<R>,
        damage: &mut Vec<RecordingDamage>,
    ) -> Result<Option<Chunk>, RecordingError> {
        loop {
            let Some(range) = self.next_record(w).map_err(RecordingError::Io)? else {
                if self.depth > 0 && !self.closed {
                    damage.push(RecordingDamage {
                        offset: self.record_offset as usize,
                        what: "the list is cut short (truncated file)",
                        skipped_bytes: (w.offset() - self.record_offset) as usize,
                    });
                    self.depth = 0;
                }
                if self.records == 0 {
                    return Err(RecordingError::Json(if self.opened {
                        "the list holds no record".into()
                    } else {
                        "no JSON list".into()
                    }));
                }
                return Ok(None);
            };
            self.records += 1;
            let (offset, len) = range;
            let bad = |what| RecordingDamage {
                offset: offset as usize,
                what,
                skipped_bytes: len,
            };
            if self.oversize {
                self.oversize = false;
                damage.push(bad("record larger than 16 MiB"));
                continue;
            }
            let Ok(rec) = serde_json::from_slice::<serde_json::Value>(&self.record) else {
                damage.push(bad("record is not valid JSON"));
                continue;
            };
            let tcp = &rec["_source"]["layers"]["tcp"];
            let Some(payload) = tcp["tcp.payload"].as_str() else {
                // Records without payload (pure ACKs) carry nothing.
                continue;
            };
            let Some(bytes) = hex_pairs(payload) else {
                damage.push(bad("tcp.payload is not colon-separated hex"));
                continue;
            };
            let time_s = match &tcp["Timestamps"]["tcp.time_relative"] {
                serde_json::Value::String(s) => s.parse::<f64>().ok(),
                serde_json::Value::Number(n) => n.as_f64(),
                _ => None,
            };
            return Ok(Some(Chunk {
                direction: Direction::Unknown,
                time_s,
                bytes,
            }));
        }
    }

    /// Gathers the next complete top-level element into `record` (brace-matched, strings
    /// and escapes respected); returns its file offset and length, `None` at the end.
    fn next_record<R: Read>(&mut self, w: &mut Window<R>) -> std::io::Result<Option<(u64, usize)>> {
        self.record.clear();
        let mut len = 0usize;
        loop {
            if self.closed {
                return Ok(None);
            }
            let base = w.offset();
            let bytes = w.peek(64 * 1024)?;
            if bytes.is_empty() {
                return Ok(None);
            }
            let mut used = bytes.len();
            let mut done = false;
            for (i, &c) in bytes.iter().enumerate() {
                if !self.opened {
                    if c == b'[' {
                        self.opened = true;
                    } else if !c.is_ascii_whitespace() {
                        // Not a list: nothing to read.
                        self.closed = true;
                        used = i;
                        break;
                    }
                    continue;
                }
                if self.depth > 0 {
                    len += 1;
                    if self.record.len() < MAX_RECORD_BYTES {
                        self.record.push(c);
                    } else {
                        self.oversize = true;
                    }
                }
                if self.in_str {
                    match (self.esc, c) {
                        (true, _) => self.esc = false,
                        (false, b'\\') => self.esc = true,
                        (false, b'"') => self.in_str = false,
                        _ => {}
                    }
                    continue;
                }
                match c {
                    b'"' if self.depth > 0 => self.in_str = true,
                    b'{' | b'[' => {
                        if self.depth == 0 {
                            self.record_offset = base + i as u64;
                            self.record.push(c);
                            len = 1;
                        }
                        self.depth += 1;
                    }
                    b'}' | b']' if self.depth > 0 => {
                        self.depth -= 1;
                        if self.depth == 0 {
                            used = i + 1;
                            done = true;
                            break;
                        }
                    }
                    b']' => {
                        self.closed = true;
                        used = i + 1;
                        break;
                    }
                    _ => {}
                }
            }
            w.consume(used);
            if done {
                return Ok(Some((self.record_offset, len)));
            }
        }
    }
}
