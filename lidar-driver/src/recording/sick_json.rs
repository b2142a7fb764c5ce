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

/// Parses the records into chunks (direction unknown: classified per frame later).
pub(crate) fn chunks(b: &[u8]) -> Result<Vec<Chunk>, RecordingError> {
    let v: serde_json::Value =
        serde_json::from_slice(b).map_err(|e| RecordingError::Json(e.to_string()))?;
    let list = v
        .as_array()
        .ok_or_else(|| RecordingError::Json("top level is not a list".into()))?;
    let mut out = Vec::with_capacity(list.len());
    for (i, rec) in list.iter().enumerate() {
        let tcp = &rec["_source"]["layers"]["tcp"];
        let Some(payload) = tcp["tcp.payload"].as_str() else {
            // Records without payload (pure ACKs) carry nothing.
            continue;
        };
        let bytes = hex_pairs(payload).ok_or_else(|| {
            RecordingError::Json(format!(
                "record {i}: tcp.payload is not colon-separated hex"
            ))
        })?;
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
