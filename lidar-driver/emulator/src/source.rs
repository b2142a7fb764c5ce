//! Where the emulator's scans come from: a recording replayed in a loop, or the caller's
//! source (e.g. the simulator's ray caster).

use std::fmt;
use std::path::Path;

use lidar_driver::recording::{Recording, RecordingError};
use lidar_driver::scandata::ScanData;
use lidar_driver::ScanRepr;

/// Supplies the scans the emulator streams, one per scan period.
///
/// Called from the connection's thread; `None` skips this period (no scan sent). Any
/// `FnMut() -> Option<ScanRepr> + Send` closure is a source.
pub trait ScanSource: Send {
    /// The next scan.
    fn next_scan(&mut self) -> Option<ScanRepr>;
}

impl<F: FnMut() -> Option<ScanRepr> + Send> ScanSource for F {
    fn next_scan(&mut self) -> Option<ScanRepr> {
        self()
    }
}

/// Why a recording cannot be replayed.
#[derive(Debug)]
pub enum SourceError {
    /// The file could not be read or parsed.
    Recording(RecordingError),
    /// The recording holds no decodable scan.
    NoScans,
}

impl fmt::Display for SourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SourceError::Recording(e) => e.fmt(f),
            SourceError::NoScans => f.write_str(
                "the recording holds no LMDscandata scan to replay: record with the scan subscription on",
            ),
        }
    }
}

impl std::error::Error for SourceError {}

/// Replays scans in a loop.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingSource {
    scans: Vec<ScanRepr>,
    next: usize,
}

impl RecordingSource {
    /// Replays these scans (must not be empty).
    pub fn from_scans(scans: Vec<ScanRepr>) -> Result<Self, SourceError> {
        if scans.is_empty() {
            return Err(SourceError::NoScans);
        }
        Ok(RecordingSource { scans, next: 0 })
    }

    /// Every decodable scan of a recording (any format `Recording` reads), in order. Scans are
    /// re-sent as `sSN` (streamed) even if they were polled answers.
    pub fn from_recording(rec: &Recording) -> Result<Self, SourceError> {
        let scans = rec
            .frames()
            .frames
            .iter()
            .filter_map(|f| ScanData::new_checked(f.frame()).ok())
            .map(|s| {
                let mut r = ScanRepr::parse(&s);
                r.command_type = lidar_driver::telegram::CommandType::Event;
                r
            })
            .collect();
        Self::from_scans(scans)
    }

    /// Reads a recording file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, SourceError> {
        let rec = Recording::read_file(path).map_err(SourceError::Recording)?;
        Self::from_recording(&rec)
    }

    /// The scans, in replay order.
    pub fn scans(&self) -> &[ScanRepr] {
        &self.scans
    }
}

impl ScanSource for RecordingSource {
    fn next_scan(&mut self) -> Option<ScanRepr> {
        let s = self.scans.get(self.next).cloned();
        self.next = (self.next + 1) % self.scans.len().max(1);
        s
    }
}
