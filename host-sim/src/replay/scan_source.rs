//! Scans of a recorded scanner stream, decoded through lidar-driver into the simulator's
//! [`LidarScan`]: each telegram's own `DIST1` values, scale and beam layout
//! ([`scan_input::BeamLayout`]: start angle, step, exact step from the frequencies), so a
//! scanner at any layout is replayed with its own beam angles, and a simulated run's
//! telegrams give back exactly the scans the live run localised on. With their times.
//!
//! The stream may be raw CoLa-B or CoLa-A bytes, pcap/pcapng, or SICK's `.pcapng.json`
//! (lidar-driver's [`Recording`] detects which). Scan times come from, in this order:
//! 1. a sidecar CSV (`scanner.colab.times.csv`: `index, t_s`), one row per scan telegram;
//! 2. the capture's own time stamps (pcap/pcapng: seconds since the epoch; `.pcapng.json`:
//!    seconds since the capture started);
//! 3. the scanner's clock: its "time since start-up" field in seconds (wraps every 71.6 min;
//!    unwrapped here).
//!
//! The odometry log must be on the same clock as the scan times.

use std::fmt;
use std::path::{Path, PathBuf};

use lidar_driver::recording::{Direction, Recording, RecordingError, RecordingFormat};
use lidar_driver::ScanData;

use scan_input::BeamLayout;

use crate::lidar::LidarScan;
use crate::record::csv_table::{cell, CsvError, CsvTable};

/// Where the scan times came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeSource {
    /// The sidecar CSV's `t_s`.
    Sidecar,
    /// The capture file's time stamps.
    Capture,
    /// The scanner's time since start-up.
    ScannerClock,
}

/// The decoded scans of a recording.
#[derive(Debug, Clone)]
pub struct RecordedScans {
    /// Scans in stream order, `t_s` set from [`RecordedScans::time_source`].
    pub scans: Vec<LidarScan>,
    /// The recording's file format.
    pub format: RecordingFormat,
    /// Where the times came from.
    pub time_source: TimeSource,
    /// Frames in the recording that were not scans (answers, requests), skipped.
    pub other_frames: usize,
    /// Frames the framer dropped (bad checksum, bad length, truncated).
    pub bad_frames: usize,
    /// Bytes outside any frame the framer skipped (noise, the bytes of dropped frames).
    pub garbage_bytes: u64,
    /// Scan telegrams dropped because they are damaged (the others were kept).
    pub damaged: Vec<DamagedScan>,
    /// Damaged parts of the file that were read around (pcap / pcapng / JSON).
    pub file_damage: Vec<lidar_driver::recording::RecordingDamage>,
}

/// A scan telegram that was dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct DamagedScan {
    /// Its times file row when rows and telegrams are paired by telegram counter, else the
    /// count of scan telegrams before it in the stream.
    pub index: usize,
    /// Its byte offset in the stream, when known (from the times file).
    pub offset_bytes: Option<u64>,
    /// Why it was dropped.
    pub reason: String,
}

impl fmt::Display for DamagedScan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset_bytes {
            Some(o) => write!(
                f,
                "scan {} at byte {o} dropped: {}",
                self.index, self.reason
            ),
            None => write!(f, "scan {} dropped: {}", self.index, self.reason),
        }
    }
}

/// Why a scanner recording could not be used.
#[derive(Debug)]
pub enum ScanSourceError {
    /// The recording could not be read.
    Recording {
        /// The file.
        path: PathBuf,
        /// lidar-driver's reason.
        source: RecordingError,
    },
    /// The recording holds no scans.
    NoScans {
        /// The file.
        path: PathBuf,
    },
    /// The sidecar CSV is unreadable.
    Sidecar(CsvError),
    /// The sidecar has a different number of rows than there are scans.
    SidecarCount {
        /// Rows in the sidecar.
        rows: usize,
        /// Scans in the stream.
        scans: usize,
    },
    /// No telegram's counter is in the sidecar's `telegram_counter` column.
    SidecarUnpaired {
        /// Rows in the sidecar.
        rows: usize,
        /// Scan telegrams in the stream.
        scans: usize,
    },
}

impl fmt::Display for ScanSourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanSourceError::Recording { path, source } => {
                write!(f, "{}: {source}", path.display())
            }
            ScanSourceError::NoScans { path } => {
                write!(f, "{} holds no LMDscandata telegram", path.display())
            }
            ScanSourceError::Sidecar(e) => write!(f, "{e}"),
            ScanSourceError::SidecarCount { rows, scans } => write!(
                f,
                "the scan times file has {rows} rows but the stream holds {scans} scans: they do not belong together"
            ),
            ScanSourceError::SidecarUnpaired { rows, scans } => write!(
                f,
                "none of the stream's {scans} scan telegrams has its telegram counter in the {rows} rows of the scan times file: they do not belong together"
            ),
        }
    }
}

impl std::error::Error for ScanSourceError {}

/// A scan telegram's DIST1 channel as a [`LidarScan`] (time still 0), or why it cannot be.
fn lidar_scan(scan: &ScanData<'_>) -> Result<LidarScan, String> {
    let dist = scan.dist1().ok_or(
        "no DIST1 channel (configure the scanner's output with LMDscandatacfg: first echo)",
    )?;
    if dist.len() > loc_core::scan::LMS511_MAX_BEAMS {
        return Err(format!(
            "{} beams, more than the {} a loc-core scan holds: configure the scanner for 0.1667 deg over 190 deg or coarser",
            dist.len(),
            loc_core::scan::LMS511_MAX_BEAMS
        ));
    }
    let h = dist.header;
    Ok(LidarScan {
        t_s: 0.0,
        dist1: dist.values().collect(),
        scale_factor: h.scale_factor,
        scale_offset_mm: h.scale_offset,
        layout: BeamLayout::of(&scan.header, &h),
    })
}

/// A decoded scan telegram with what times it.
struct Decoded {
    scan: LidarScan,
    telegram_counter: u16,
    capture_time_s: Option<f64>,
    clock_us: u32,
}

/// How many rows past the expected one a telegram is looked for (rows lost to damage in a
/// row before a telegram that survived).
const PAIRING_WINDOW_ROWS: usize = 4096;

/// Reads the scans of `path`; `sidecar` is the optional times CSV.
///
/// Damage loses only what is damaged: a telegram that does not frame or decode is dropped
/// (the framer resyncs on the next one); damaged parts of a capture file are read around
/// ([`RecordedScans::file_damage`]). With a times file that has a `telegram_counter` column
/// (as `host-sim run --record` writes) rows and telegrams are paired by that counter, so each
/// lost telegram is named by its row and offset ([`RecordedScans::damaged`]) and cannot shift
/// the times of the others; without it they are paired by count, which damage makes
/// impossible ([`ScanSourceError::SidecarCount`]).
pub fn read_scans(path: &Path, sidecar: Option<&Path>) -> Result<RecordedScans, ScanSourceError> {
    let unreadable = |source| ScanSourceError::Recording {
        path: path.to_path_buf(),
        source,
    };
    let bytes = std::fs::read(path).map_err(|e| unreadable(RecordingError::Io(e)))?;
    let rec = Recording::parse(&bytes).map_err(unreadable)?;
    let table = match sidecar {
        Some(p) => Some(CsvTable::read(p).map_err(ScanSourceError::Sidecar)?),
        None => None,
    };
    let frames = rec.frames();
    let mut decoded = Vec::new();
    let mut damaged = Vec::new();
    let mut other_frames = 0usize;
    for f in &frames.frames {
        if f.direction == Direction::HostToSensor {
            other_frames += 1;
            continue;
        }
        let index = decoded.len() + damaged.len();
        let result = match ScanData::new_checked(f.frame()) {
            Ok(s) => lidar_scan(&s).map(|scan| Decoded {
                scan,
                telegram_counter: s.header.telegram_counter,
                capture_time_s: f.time_s,
                clock_us: s.header.time_since_startup_us,
            }),
            Err(lidar_driver::ScanError::NotScanData { .. }) => {
                other_frames += 1;
                continue;
            }
            Err(e) => Err(e.to_string()),
        };
        match result {
            Ok(d) => decoded.push(d),
            Err(reason) => damaged.push(DamagedScan {
                index,
                offset_bytes: None,
                reason,
            }),
        }
    }
    if decoded.is_empty() {
        return Err(ScanSourceError::NoScans {
            path: path.to_path_buf(),
        });
    }
    let time_source = match &table {
        Some(t) if t.optional_column("telegram_counter").is_some() => {
            // Rows name the lost telegrams: the count-based list is replaced.
            damaged = pair_by_counter(&mut decoded, t)?;
            TimeSource::Sidecar
        }
        Some(t) => {
            let c = t.column("t_s").map_err(ScanSourceError::Sidecar)?;
            if t.rows().len() != decoded.len() {
                return Err(ScanSourceError::SidecarCount {
                    rows: t.rows().len(),
                    scans: decoded.len(),
                });
            }
            for (d, r) in decoded.iter_mut().zip(t.rows()) {
                d.scan.t_s = cell(r, c);
            }
            TimeSource::Sidecar
        }
        None if decoded.iter().all(|d| d.capture_time_s.is_some()) => {
            for d in &mut decoded {
                d.scan.t_s = d.capture_time_s.unwrap_or(0.0);
            }
            TimeSource::Capture
        }
        None => {
            // Unwrap the u32 µs counter.
            let mut wraps = 0u64;
            let mut prev = None;
            for d in &mut decoded {
                if prev.is_some_and(|p| d.clock_us < p) {
                    wraps += 1;
                }
                prev = Some(d.clock_us);
                d.scan.t_s = (wraps * (1u64 << 32) + u64::from(d.clock_us)) as f64 / 1e6;
            }
            TimeSource::ScannerClock
        }
    };
    Ok(RecordedScans {
        scans: decoded.into_iter().map(|d| d.scan).collect(),
        format: rec.format,
        time_source,
        other_frames,
        bad_frames: frames.errors.len(),
        garbage_bytes: frames.stats.garbage_bytes,
        damaged,
        file_damage: rec.damage.clone(),
    })
}

/// Times the decoded telegrams from the rows with their telegram counter (u16, wrapping:
/// matched in stream order) and returns the rows no telegram answered, with their offsets.
/// A telegram with no row is dropped and listed too.
fn pair_by_counter(
    decoded: &mut Vec<Decoded>,
    t: &CsvTable,
) -> Result<Vec<DamagedScan>, ScanSourceError> {
    let col = |name| t.column(name).map_err(ScanSourceError::Sidecar);
    let (c_t, c_counter) = (col("t_s")?, col("telegram_counter")?);
    let c_offset = t.optional_column("offset_bytes");
    let rows = t.rows();
    let lost = |index: usize, reason: &str| DamagedScan {
        index,
        offset_bytes: c_offset
            .and_then(|c| rows.get(index).map(|r| cell(r, c)))
            .filter(|o| *o >= 0.0)
            .map(|o| o as u64),
        reason: reason.to_string(),
    };
    let mut damaged = Vec::new();
    let mut next_row = 0usize;
    let mut kept = Vec::with_capacity(decoded.len());
    for (k, mut d) in decoded.drain(..).enumerate() {
        let found = rows
            .iter()
            .enumerate()
            .skip(next_row)
            .take(PAIRING_WINDOW_ROWS)
            .find(|(_, r)| cell(r, c_counter) == f64::from(d.telegram_counter));
        match found {
            Some((row, r)) => {
                for missing in next_row..row {
                    damaged.push(lost(
                        missing,
                        "its telegram is not in the stream (damaged, cut or lost)",
                    ));
                }
                d.scan.t_s = cell(r, c_t);
                kept.push(d);
                next_row = row + 1;
            }
            None => damaged.push(DamagedScan {
                index: k,
                offset_bytes: None,
                reason: format!(
                    "telegram counter {} is in no row of the times file after row {next_row}",
                    d.telegram_counter
                ),
            }),
        }
    }
    for missing in next_row..rows.len() {
        damaged.push(lost(
            missing,
            "its telegram is not in the stream (damaged, cut or lost)",
        ));
    }
    if kept.is_empty() {
        return Err(ScanSourceError::SidecarUnpaired {
            rows: rows.len(),
            scans: damaged.len().saturating_sub(rows.len()),
        });
    }
    *decoded = kept;
    Ok(damaged)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_lms511_capture_decodes_in_both_formats_with_their_clocks() {
        let raw = read_scans(&sick_captures::path(sick_captures::LMS511_S2H), None).unwrap();
        let json = read_scans(&sick_captures::path(sick_captures::LMS511_JSON), None).unwrap();
        assert_eq!(raw.scans.len(), 174);
        assert_eq!(json.scans.len(), 174);
        assert_eq!(raw.time_source, TimeSource::ScannerClock);
        assert_eq!(json.time_source, TimeSource::Capture);
        assert_eq!(raw.scans[0].dist1[..3], [1305, 1299, 1307]);
        for (a, b) in raw.scans.iter().zip(&json.scans) {
            assert_eq!((&a.dist1, a.layout), (&b.dist1, b.layout));
        }
        // 25 Hz on the scanner's clock.
        let dt = raw.scans[1].t_s - raw.scans[0].t_s;
        assert!((dt - 0.04).abs() < 0.002, "{dt}");
        // The telegram's own layout, with the exact 1/6° step.
        let l = raw.scans[0].layout;
        assert_eq!(
            (l.start_angle_1e4_deg, l.step_1e4_deg, l.beams),
            (-50_000, 1667, 1141)
        );
        assert!((l.step_used_1e4_deg() - 10_000.0 / 6.0).abs() < 1e-9);
    }

    #[test]
    fn the_lms111_is_read_at_its_own_layout() {
        let s = read_scans(&sick_captures::path(sick_captures::LMS111_S2H), None).unwrap();
        let l = s.scans[0].layout;
        assert_eq!(
            (l.start_angle_1e4_deg, l.step_1e4_deg, l.beams),
            (-450_000, 5000, 541)
        );
    }
}
