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
    /// A scan telegram is malformed.
    Scan {
        /// Index of the scan telegram.
        index: usize,
        /// The decoder's reason.
        reason: String,
    },
    /// A scan has no DIST1 channel.
    NoDistances {
        /// Index of the scan.
        index: usize,
    },
    /// A scan has more beams than the localiser's scan holds.
    TooManyBeams {
        /// Index of the scan.
        index: usize,
        /// Beams in the telegram.
        beams: usize,
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
}

impl fmt::Display for ScanSourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanSourceError::Recording { path, source } => {
                write!(f, "{}: {source}", path.display())
            }
            ScanSourceError::Scan { index, reason } => {
                write!(f, "scan telegram {index} is malformed: {reason}")
            }
            ScanSourceError::NoDistances { index } => write!(
                f,
                "scan telegram {index} has no DIST1 channel (configure the scanner's output with LMDscandatacfg: first echo)"
            ),
            ScanSourceError::TooManyBeams { index, beams } => write!(
                f,
                "scan telegram {index} has {beams} beams, more than the {} a loc-core scan holds: configure the scanner for 0.1667 deg over 190 deg or coarser",
                loc_core::scan::LMS511_MAX_BEAMS
            ),
            ScanSourceError::NoScans { path } => {
                write!(f, "{} holds no LMDscandata telegram", path.display())
            }
            ScanSourceError::Sidecar(e) => write!(f, "{e}"),
            ScanSourceError::SidecarCount { rows, scans } => write!(
                f,
                "the scan times file has {rows} rows but the stream holds {scans} scans: they do not belong together"
            ),
        }
    }
}

impl std::error::Error for ScanSourceError {}

/// Reads the scans of `path`; `sidecar` is the optional times CSV.
pub fn read_scans(path: &Path, sidecar: Option<&Path>) -> Result<RecordedScans, ScanSourceError> {
    let rec = Recording::read_file(path).map_err(|source| ScanSourceError::Recording {
        path: path.to_path_buf(),
        source,
    })?;
    let frames = rec.frames();
    let mut scans = Vec::new();
    let mut capture_times = Vec::new();
    let mut clock_us = Vec::new();
    let mut other_frames = 0usize;
    for f in &frames.frames {
        if f.direction == Direction::HostToSensor {
            other_frames += 1;
            continue;
        }
        let index = scans.len();
        let scan = match ScanData::new_checked(f.frame()) {
            Ok(s) => s,
            Err(lidar_driver::ScanError::NotScanData { .. }) => {
                other_frames += 1;
                continue;
            }
            Err(e) => {
                return Err(ScanSourceError::Scan {
                    index,
                    reason: e.to_string(),
                })
            }
        };
        let dist = scan.dist1().ok_or(ScanSourceError::NoDistances { index })?;
        let h = dist.header;
        if dist.len() > loc_core::scan::LMS511_MAX_BEAMS {
            return Err(ScanSourceError::TooManyBeams {
                index,
                beams: dist.len(),
            });
        }
        scans.push(LidarScan {
            t_s: 0.0,
            dist1: dist.values().collect(),
            scale_factor: h.scale_factor,
            scale_offset_mm: h.scale_offset,
            layout: BeamLayout::of(&scan.header, &h),
        });
        capture_times.push(f.time_s);
        clock_us.push(scan.header.time_since_startup_us);
    }
    if scans.is_empty() {
        return Err(ScanSourceError::NoScans {
            path: path.to_path_buf(),
        });
    }
    let time_source = if let Some(p) = sidecar {
        let t = CsvTable::read(p).map_err(ScanSourceError::Sidecar)?;
        let c = t.column("t_s").map_err(ScanSourceError::Sidecar)?;
        if t.rows().len() != scans.len() {
            return Err(ScanSourceError::SidecarCount {
                rows: t.rows().len(),
                scans: scans.len(),
            });
        }
        for (s, r) in scans.iter_mut().zip(t.rows()) {
            s.t_s = cell(r, c);
        }
        TimeSource::Sidecar
    } else if capture_times.iter().all(Option::is_some) {
        for (s, t) in scans.iter_mut().zip(&capture_times) {
            s.t_s = t.unwrap_or(0.0);
        }
        TimeSource::Capture
    } else {
        // Unwrap the u32 µs counter.
        let mut wraps = 0u64;
        let mut prev = None;
        for (s, &us) in scans.iter_mut().zip(&clock_us) {
            if prev.is_some_and(|p| us < p) {
                wraps += 1;
            }
            prev = Some(us);
            s.t_s = (wraps * (1u64 << 32) + u64::from(us)) as f64 / 1e6;
        }
        TimeSource::ScannerClock
    };
    Ok(RecordedScans {
        scans,
        format: rec.format,
        time_source,
        other_frames,
        bad_frames: frames.errors.len(),
    })
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
