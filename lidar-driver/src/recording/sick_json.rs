//! SICK's `.pcapng.json` (sick_scan_xd's pcap-to-json converter): a JSON list of records, each
//! `_source.layers.tcp."tcp.payload"` one complete CoLa message as colon-separated hex, with its
//! time in `_source.layers.tcp.Timestamps."tcp.time_relative"` (seconds, as a string).
//! Records carry no direction.

use super::{Chunk, Direction, RecordingError};

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

/// Splits the top-level list into its elements' byte ranges, brace-matched (strings and
/// escapes respected); returns the ranges of the complete elements and, if the list is cut
/// (a truncated file), the offset where the first incomplete element starts.
fn elements(b: &[u8]) -> (Vec<(usize, usize)>, Option<usize>) {
    let mut out = Vec::new();
    let Some(open) = b.iter().position(|&c| c == b'[') else {
        return (out, Some(0));
    };
    let (mut depth, mut in_str, mut esc, mut start) = (0usize, false, false, None);
    for (i, &c) in b.iter().enumerate().skip(open + 1) {
        if in_str {
            match (esc, c) {
                (true, _) => esc = false,
                (false, b'\\') => esc = true,
                (false, b'"') => in_str = false,
                _ => {}
            }
            continue;
        }
        match c {
            b'"' => in_str = true,
            b'{' | b'[' => {
                if depth == 0 {
                    start = Some(i);
                }
                depth += 1;
            }
            b'}' | b']' if depth > 0 => {
                depth -= 1;
                if depth == 0 {
                    if let Some(s) = start.take() {
                        out.push((s, i + 1));
                    }
                }
            }
            b']' => return (out, None),
            _ => {}
        }
    }
    (out, Some(start.unwrap_or(b.len())))
}

/// Parses the records into chunks (direction unknown: classified per frame later). A file
/// cut short keeps its complete records (the cut is recorded in `damage`); a record that is
/// not valid JSON or whose payload is not hex is skipped and recorded.
pub(crate) fn chunks(
    b: &[u8],
    damage: &mut Vec<super::RecordingDamage>,
) -> Result<Vec<Chunk>, RecordingError> {
    let (records, cut) = elements(b);
    if records.is_empty() {
        // Nothing readable at all: say why, as a whole-file parse would.
        return Err(RecordingError::Json(
            match serde_json::from_slice::<serde_json::Value>(b) {
                Err(e) => e.to_string(),
                Ok(_) => "the list holds no record".into(),
            },
        ));
    }
    if let Some(at) = cut {
        damage.push(super::RecordingDamage {
            offset: at,
            what: "the list is cut short (truncated file)",
            skipped_bytes: b.len() - at,
        });
    }
    let mut out = Vec::with_capacity(records.len());
    for &(from, to) in &records {
        let bad = |what| super::RecordingDamage {
            offset: from,
            what,
            skipped_bytes: to - from,
        };
        let Ok(rec) = serde_json::from_slice::<serde_json::Value>(&b[from..to]) else {
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
        out.push(Chunk {
            direction: Direction::Unknown,
            time_s,
            bytes,
        });
    }
    Ok(out)
}
