//! Scans of a recorded scanner stream, decoded through lidar-driver into the simulator's
//! [`LidarScan`]: each telegram's own distance channels (`DIST1`…`DIST5`, the echoes of
//! each beam), scale and beam layout
//! ([`scan_input::BeamLayout`]: start angle, step, exact step from the frequencies), so a
//! scanner at any layout is replayed with its own beam angles, and a simulated run's
//! telegrams give back exactly the scans the live run localised on. With their times.
//!
//! The stream may be raw CoLa-B or CoLa-A bytes, pcap/pcapng, or SICK's `.pcapng.json`
//! (lidar-driver's [`Recording`](lidar_driver::recording::Recording) detects which). Scan times come from, in this order:
//! 1. a sidecar CSV (`scanner.colab.times.csv`: `index, t_s`), one row per scan telegram;
//! 2. the capture's own time stamps (pcap/pcapng: seconds since the epoch; `.pcapng.json`:
//!    seconds since the capture started);
//! 3. the scanner's clock: its "time since start-up" field in seconds (wraps every 71.6 min;
//!    unwrapped here).
//!
//! The odometry log must be on the same clock as the scan times.

use std::fmt;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use lidar_driver::recording::{
    Direction, FrameReader, RecordingError, RecordingFormat, RecordingReader,
};
use lidar_driver::{ChannelKind, ScanData};

use scan_input::BeamLayout;

use crate::lidar::{LidarScan, MAX_ECHOES};
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

/// A scan telegram's distance channels (`DIST1`…`DIST5`) as a [`LidarScan`] (time still 0),
/// or why they cannot be: `DIST1` is needed, the others must have its layout and scale.
/// Echo `n` is kept at index `n − 1` (a channel not sent reads as no echo); the channels
/// after the last one with an echo are left out.
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
    let mut echoes = vec![Vec::new(); MAX_ECHOES];
    for c in scan.channels16() {
        let ChannelKind::Distance(n) = c.header.kind() else {
            continue;
        };
        let same = (
            c.header.scale_factor,
            c.header.scale_offset,
            c.header.start_angle_1e4_deg,
        ) == (h.scale_factor, h.scale_offset, h.start_angle_1e4_deg)
            && (c.header.step_1e4_deg, c.header.count) == (h.step_1e4_deg, h.count);
        if !same {
            return Err(format!(
                "{}'s layout or scale differs from DIST1's: not echoes of the same beams",
                c.name()
            ));
        }
        if let Some(slot) = echoes.get_mut(usize::from(n) - 1) {
            if slot.is_empty() {
                *slot = c.values().collect();
            }
        }
    }
    let used = echoes
        .iter()
        .rposition(|e| e.iter().any(|&v| v != 0))
        .map_or(1, |k| k + 1);
    echoes.truncate(used);
    for e in &mut echoes {
        e.resize(dist.len(), 0);
    }
    Ok(LidarScan {
        t_s: 0.0,
        echoes,
        scale_factor: h.scale_factor,
        scale_offset_mm: h.scale_offset,
        layout: BeamLayout::of(&scan.header, &h),
    })
}

/// How rows of the times file are paired with scan telegrams.
enum Pairing {
    /// No times file.
    None,
    /// By telegram counter (u16, wrapping: matched in stream order).
    Counter {
        t: usize,
        counter: usize,
        offset: Option<usize>,
    },
    /// By count: the n-th scan telegram gets the n-th row.
    Count { t: usize },
}

/// How many rows past the expected one a telegram is looked for (rows lost to damage in a
/// row before a telegram that survived).
const PAIRING_WINDOW_ROWS: usize = 4096;

/// The scans of a recording, decoded one at a time as the file is read (memory: the largest
/// record, and the times file).
///
/// Damage loses only what is damaged: a telegram that does not frame or decode is dropped
/// (the framer resyncs on the next one); damaged parts of a capture file are read around
/// ([`RecordedScans::file_damage`]). With a times file that has a `telegram_counter` column
/// (as `host-sim run --record` writes) rows and telegrams are paired by that counter, so
/// each lost telegram is named by its row and offset ([`RecordedScans::damaged`]) and cannot
/// shift the times of the others; without it they are paired by count, which damage makes
/// impossible ([`ScanSourceError::SidecarCount`]).
pub struct ScanStream {
    path: PathBuf,
    frames: FrameReader<RecordingReader<BufReader<File>>>,
    table: Option<CsvTable>,
    pairing: Pairing,
    next_row: usize,
    time_source: TimeSource,
    /// Scanner clock unwrapping: wraps so far and the last value.
    wraps: u64,
    last_clock_us: Option<u32>,
    /// Scan telegrams seen (decoded or not).
    telegrams: usize,
    /// Of which decoded.
    decoded: usize,
    scans: usize,
    other_frames: usize,
    bad_frames: usize,
    damaged: Vec<DamagedScan>,
    ended: bool,
}

impl ScanStream {
    /// Opens the stream `path`; `sidecar` is the optional times CSV.
    pub fn open(path: &Path, sidecar: Option<&Path>) -> Result<Self, ScanSourceError> {
        let unreadable = |source| ScanSourceError::Recording {
            path: path.to_path_buf(),
            source,
        };
        let reader = RecordingReader::open(path).map_err(unreadable)?;
        let format = reader.format();
        let table = match sidecar {
            Some(p) => Some(CsvTable::read(p).map_err(ScanSourceError::Sidecar)?),
            None => None,
        };
        let col = |t: &CsvTable, name| t.column(name).map_err(ScanSourceError::Sidecar);
        let (pairing, time_source) = match &table {
            Some(t) if t.optional_column("telegram_counter").is_some() => (
                Pairing::Counter {
                    t: col(t, "t_s")?,
                    counter: col(t, "telegram_counter")?,
                    offset: t.optional_column("offset_bytes"),
                },
                TimeSource::Sidecar,
            ),
            Some(t) => (Pairing::Count { t: col(t, "t_s")? }, TimeSource::Sidecar),
            None if format == RecordingFormat::Raw => (Pairing::None, TimeSource::ScannerClock),
            None => (Pairing::None, TimeSource::Capture),
        };
        Ok(Self {
            path: path.to_path_buf(),
            frames: FrameReader::new(reader),
            table,
            pairing,
            next_row: 0,
            time_source,
            wraps: 0,
            last_clock_us: None,
            telegrams: 0,
            decoded: 0,
            scans: 0,
            other_frames: 0,
            bad_frames: 0,
            damaged: Vec::new(),
            ended: false,
        })
    }

    /// Where the scan times come from.
    pub fn time_source(&self) -> TimeSource {
        self.time_source
    }

    /// The next scan with its time, `None` at the end.
    pub fn next_scan(&mut self) -> Result<Option<LidarScan>, ScanSourceError> {
        loop {
            if self.ended {
                return Ok(None);
            }
            let item = self
                .frames
                .next_frame()
                .map_err(|source| ScanSourceError::Recording {
                    path: self.path.clone(),
                    source,
                })?;
            let f = match item {
                None => {
                    self.end()?;
                    return Ok(None);
                }
                Some(Err(_)) => {
                    self.bad_frames += 1;
                    continue;
                }
                Some(Ok(f)) => f,
            };
            if f.direction == Direction::HostToSensor {
                self.other_frames += 1;
                continue;
            }
            let index = self.telegrams;
            let decoded = match ScanData::new_checked(f.frame()) {
                Err(lidar_driver::ScanError::NotScanData { .. }) => {
                    self.other_frames += 1;
                    continue;
                }
                Err(e) => Err(e.to_string()),
                Ok(s) => lidar_scan(&s)
                    .map(|l| (l, s.header.telegram_counter, s.header.time_since_startup_us)),
            };
            self.telegrams += 1;
            let (mut scan, counter, clock_us) = match decoded {
                Ok(d) => {
                    self.decoded += 1;
                    d
                }
                Err(reason) => {
                    // Paired by counter, the lost telegram is named by the row it misses.
                    if !matches!(self.pairing, Pairing::Counter { .. }) {
                        self.damaged.push(DamagedScan {
                            index,
                            offset_bytes: None,
                            reason,
                        });
                    }
                    continue;
                }
            };
            let time = match self.pairing {
                Pairing::Counter { .. } => self.pair_by_counter(counter, index)?,
                Pairing::Count { t } => {
                    let row = self
                        .table
                        .as_ref()
                        .and_then(|tb| tb.rows().get(self.next_row));
                    let Some(r) = row else {
                        return Err(self.count_mismatch());
                    };
                    self.next_row += 1;
                    Some(cell(r, t))
                }
                Pairing::None if self.time_source == TimeSource::Capture => match f.time_s {
                    Some(t) => Some(t),
                    None => {
                        self.damaged.push(DamagedScan {
                            index,
                            offset_bytes: None,
                            reason: "the capture gives it no time stamp".into(),
                        });
                        None
                    }
                },
                Pairing::None => {
                    // Unwrap the u32 µs counter. The stamp is the scan's first shot; the
                    // scan's time (what its pose refers to) is its last beam, a sweep later.
                    if self.last_clock_us.is_some_and(|p| clock_us < p) {
                        self.wraps += 1;
                    }
                    self.last_clock_us = Some(clock_us);
                    let stamp_s = (self.wraps * (1u64 << 32) + u64::from(clock_us)) as f64 / 1e6;
                    Some(stamp_s + scan.layout.sweep_s())
                }
            };
            let Some(t_s) = time else { continue };
            scan.t_s = t_s;
            self.scans += 1;
            return Ok(Some(scan));
        }
    }

    /// The time of the row whose telegram counter is `counter`, searched from the next
    /// unpaired row on; the rows skipped are lost telegrams. `None` when no row has it.
    fn pair_by_counter(
        &mut self,
        counter: u16,
        index: usize,
    ) -> Result<Option<f64>, ScanSourceError> {
        let Pairing::Counter { t, counter: c, .. } = self.pairing else {
            return Ok(None);
        };
        let rows = self.table.as_ref().map_or(&[][..], CsvTable::rows);
        let found = rows
            .iter()
            .enumerate()
            .skip(self.next_row)
            .take(PAIRING_WINDOW_ROWS)
            .find(|(_, r)| cell(r, c) == f64::from(counter))
            .map(|(row, r)| (row, cell(r, t)));
        match found {
            Some((row, t_s)) => {
                for missing in self.next_row..row {
                    self.lost_row(missing);
                }
                self.next_row = row + 1;
                Ok(Some(t_s))
            }
            None => {
                self.damaged.push(DamagedScan {
                    index,
                    offset_bytes: None,
                    reason: format!(
                        "telegram counter {counter} is in no row of the times file after row {}",
                        self.next_row
                    ),
                });
                Ok(None)
            }
        }
    }

    /// Row `row` of the times file has no telegram.
    fn lost_row(&mut self, row: usize) {
        let offset_bytes = match (&self.pairing, &self.table) {
            (
                Pairing::Counter {
                    offset: Some(c), ..
                },
                Some(t),
            ) => t
                .rows()
                .get(row)
                .map(|r| cell(r, *c))
                .filter(|o| *o >= 0.0)
                .map(|o| o as u64),
            _ => None,
        };
        self.damaged.push(DamagedScan {
            index: row,
            offset_bytes,
            reason: "its telegram is not in the stream (damaged, cut or lost)".into(),
        });
    }

    fn count_mismatch(&self) -> ScanSourceError {
        ScanSourceError::SidecarCount {
            rows: self.table.as_ref().map_or(0, |t| t.rows().len()),
            scans: self.telegrams,
        }
    }

    /// At the end of the stream: the rows no telegram came for, and the counts checked.
    fn end(&mut self) -> Result<(), ScanSourceError> {
        self.ended = true;
        let rows = self.table.as_ref().map_or(0, |t| t.rows().len());
        match self.pairing {
            Pairing::Counter { .. } => {
                if self.scans == 0 && self.decoded > 0 {
                    return Err(ScanSourceError::SidecarUnpaired {
                        rows,
                        scans: self.decoded,
                    });
                }
                for missing in self.next_row..rows {
                    self.lost_row(missing);
                }
            }
            Pairing::Count { .. } if self.next_row != rows => return Err(self.count_mismatch()),
            _ => {}
        }
        if self.scans == 0 {
            return Err(ScanSourceError::NoScans {
                path: self.path.clone(),
            });
        }
        Ok(())
    }

    /// What the stream held, once read to its end (the scans themselves left out).
    pub fn summary(&self) -> RecordedScans {
        let source = self.frames.source();
        RecordedScans {
            scans: Vec::new(),
            format: source.format(),
            time_source: self.time_source,
            other_frames: self.other_frames,
            bad_frames: self.bad_frames,
            garbage_bytes: self.frames.stats().garbage_bytes,
            damaged: self.damaged.clone(),
            file_damage: source.damage().to_vec(),
        }
    }
}

/// Reads all the scans of `path` (see [`ScanStream`]); `sidecar` is the optional times
/// CSV.
pub fn read_scans(path: &Path, sidecar: Option<&Path>) -> Result<RecordedScans, ScanSourceError> {
    let mut stream = ScanStream::open(path, sidecar)?;
    let mut scans = Vec::new();
    while let Some(s) = stream.next_scan()? {
        scans.push(s);
    }
    Ok(RecordedScans {
        scans,
        ..stream.summary()
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
        assert_eq!(raw.scans[0].dist1()[..3], [1305, 1299, 1307]);
        for (a, b) in raw.scans.iter().zip(&json.scans) {
            assert_eq!((a.dist1(), a.layout), (b.dist1(), b.layout));
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

    /// A two-echo scan (a cloud before the wall on some beams) as the recorder writes it.
    fn dusty_scan() -> LidarScan {
        let rate = crate::lidar::ScanRate::Hz25;
        let beams = rate.beam_count();
        let wall: Vec<u16> = (0..beams).map(|i| 3000 + i as u16).collect();
        let cloud: Vec<u16> = (0..beams)
            .map(|i| if i % 7 == 0 { 900 } else { 0 })
            .collect();
        // Where the cloud is, it is the first echo and the wall the second.
        let first = wall
            .iter()
            .zip(&cloud)
            .map(|(&w, &c)| if c > 0 { c } else { w });
        let second = wall
            .iter()
            .zip(&cloud)
            .map(|(&w, &c)| if c > 0 { w } else { 0 });
        LidarScan {
            t_s: 0.04,
            echoes: vec![first.collect(), second.collect()],
            scale_factor: 1.0,
            scale_offset_mm: 0.0,
            layout: rate.layout(),
        }
    }

    fn decoded(repr: &lidar_driver::ScanRepr) -> Result<LidarScan, String> {
        let bytes = repr.to_vec(lidar_driver::Dialect::ColaB).unwrap();
        let frame = lidar_driver::Frame::new_checked(&bytes[..]).unwrap();
        lidar_scan(&ScanData::new_checked(frame).unwrap())
    }

    #[test]
    fn every_echo_channel_comes_back_in_its_place() {
        let scan = dusty_scan();
        let mut t =
            crate::record::scanner_telegram::Lms511Telegrams::new(crate::lidar::ScanRate::Hz25);
        let mut repr = t.next_repr(&scan);
        assert_eq!(repr.channels16.len(), 5);
        // DIST3…DIST5 are empty: left out, the two echoes kept in order.
        let back = decoded(&repr).unwrap();
        assert_eq!(back.echoes, scan.echoes);
        // Channels in another order still land by their number; a missing DIST2 reads as
        // no second echo.
        repr.channels16.swap(0, 1);
        assert_eq!(decoded(&repr).unwrap().echoes, scan.echoes);
        repr.channels16.retain(|c| &c.name != b"DIST2");
        let without = decoded(&repr).unwrap();
        assert_eq!(without.echoes, vec![scan.echoes[0].clone()]);
        // A clear-air scan keeps DIST1 alone.
        let clear = LidarScan {
            echoes: vec![scan.echoes[0].clone()],
            ..scan.clone()
        };
        assert_eq!(decoded(&t.next_repr(&clear)).unwrap().echoes.len(), 1);
    }

    #[test]
    fn an_echo_channel_of_other_beams_is_refused_by_name() {
        let mut t =
            crate::record::scanner_telegram::Lms511Telegrams::new(crate::lidar::ScanRate::Hz25);
        let mut repr = t.next_repr(&dusty_scan());
        repr.channels16[2].values.pop();
        let e = decoded(&repr).unwrap_err();
        assert!(e.contains("DIST3"), "{e}");
        let mut repr = t.next_repr(&dusty_scan());
        repr.channels16[1].scale_factor = 2.0;
        assert!(decoded(&repr).unwrap_err().contains("DIST2"));
        // Without DIST1 nothing is taken from the others.
        repr.channels16.retain(|c| &c.name != b"DIST1");
        assert!(decoded(&repr).unwrap_err().contains("DIST1"));
    }
}
