//! Another localiser's per-scan poses, scored by the replay like its own estimator
//! (`host-sim replay DIR --estimates FILE`): the peer comparison's localisers (KISS-ICP,
//! small_gicp) write their poses, and the same truth pairing and metrics
//! ([`crate::metrics`]) score them, so no metric is implemented twice.
//!
//! The file is a CSV with a header row: `t_s` (the scan's time, on the recording's clock),
//! `est_x_m`, `est_y_m`, `est_theta_rad` (the vehicle's pose after the scan, world frame), and
//! optionally `sigma_x_m`, `sigma_y_m`, `sigma_theta_rad` (1σ) and `update_us` (the
//! localiser's own time for the scan, µs) — the columns of a replay's own `estimates.csv`, so
//! that file scores too. Rows are in time order; every scan of the recording needs a row
//! within half a millisecond of its time.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::closed_loop::{Estimator, EstimatorOutput};
use crate::lidar::LidarScan;
use crate::record::csv_table::{cell, CsvError, CsvTable};
use crate::status::EstimatorStatus;
use crate::vehicle::odometry::OdometrySample;
use crate::vehicle::SimPose;

/// How far a row's time may be from its scan's, seconds (the recordings' times have
/// microseconds; half a millisecond is far below any scan interval).
pub const TIME_TOLERANCE_S: f64 = 0.5e-3;

/// The columns read (others, such as a replay's `status`, are left alone).
const COLUMNS: [&str; 8] = [
    "t_s",
    "est_x_m",
    "est_y_m",
    "est_theta_rad",
    "sigma_x_m",
    "sigma_y_m",
    "sigma_theta_rad",
    "update_us",
];

/// Why an estimates file cannot be scored.
#[derive(Debug)]
pub enum EstimatesError {
    /// The file is not a readable CSV of the columns.
    Csv(CsvError),
    /// A row's time is not after the previous row's.
    OutOfOrder {
        /// The file.
        path: PathBuf,
        /// Line number, 1-based.
        line: usize,
    },
    /// Scans of the recording have no row.
    NoEstimate {
        /// The file.
        path: PathBuf,
        /// Time of the first scan without a row, s.
        first_t_s: f64,
        /// Scans without a row.
        scans: usize,
    },
}

impl fmt::Display for EstimatesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EstimatesError::Csv(e) => write!(f, "{e}"),
            EstimatesError::OutOfOrder { path, line } => write!(
                f,
                "{} line {line}: t_s is not after the previous row's: the estimates must be in time order, one row per scan",
                path.display()
            ),
            EstimatesError::NoEstimate {
                path,
                first_t_s,
                scans,
            } => write!(
                f,
                "{} has no row for {scans} scans of the recording (the first at t = {first_t_s:.6} s): write one row per scan at the scan's time (within {:.1} ms)",
                path.display(),
                TIME_TOLERANCE_S * 1e3
            ),
        }
    }
}

impl std::error::Error for EstimatesError {}

impl From<CsvError> for EstimatesError {
    fn from(e: CsvError) -> Self {
        EstimatesError::Csv(e)
    }
}

#[derive(Debug, Clone, Copy)]
struct Row {
    t_s: f64,
    pose: SimPose,
    sigma: (f64, f64, f64),
    update_us: Option<f64>,
}

/// An estimator that hands out the poses of an estimates file, scan by scan.
#[derive(Debug, Clone)]
pub struct ExternalEstimates {
    path: PathBuf,
    rows: Vec<Row>,
    next: usize,
    /// The last pose given (what a scan without a row gets, counted as missing).
    last: Option<Row>,
    missing: usize,
    first_missing_t_s: Option<f64>,
}

impl ExternalEstimates {
    /// Reads an estimates file (see the module's documentation for the columns).
    pub fn read(path: &Path) -> Result<Self, EstimatesError> {
        Self::from_table(&CsvTable::read_columns(path, &COLUMNS)?)
    }

    /// The estimates of a parsed table.
    pub fn from_table(t: &CsvTable) -> Result<Self, EstimatesError> {
        // The required columns, checked even when there are no rows.
        for name in ["t_s", "est_x_m", "est_y_m", "est_theta_rad"] {
            t.column(name)?;
        }
        let opt = |n| t.optional_column(n);
        let (csx, csy, csh, cu) = (
            opt("sigma_x_m"),
            opt("sigma_y_m"),
            opt("sigma_theta_rad"),
            opt("update_us"),
        );
        let get = |r: &[f64], c: Option<usize>| c.map_or(f64::NAN, |c| cell(r, c));
        let mut rows: Vec<Row> = Vec::with_capacity(t.rows().len());
        for (i, r) in t.rows().iter().enumerate() {
            // Time and pose are required: a pose that is not a number is refused, not scored
            // as zero error.
            let row = Row {
                t_s: t.value(i, "t_s")?,
                pose: SimPose {
                    x_m: t.value(i, "est_x_m")?,
                    y_m: t.value(i, "est_y_m")?,
                    theta_rad: t.value(i, "est_theta_rad")?,
                },
                sigma: (get(r, csx), get(r, csy), get(r, csh)),
                update_us: Some(get(r, cu)).filter(|u| u.is_finite()),
            };
            if rows.last().is_some_and(|p| row.t_s <= p.t_s) {
                return Err(EstimatesError::OutOfOrder {
                    path: t.path().to_path_buf(),
                    line: t.line(i),
                });
            }
            rows.push(row);
        }
        Ok(Self {
            path: t.path().to_path_buf(),
            rows,
            next: 0,
            last: None,
            missing: 0,
            first_missing_t_s: None,
        })
    }

    /// After the replay: an error if any scan had no row.
    pub fn check_complete(&self) -> Result<(), EstimatesError> {
        match self.first_missing_t_s {
            None => Ok(()),
            Some(first_t_s) => Err(EstimatesError::NoEstimate {
                path: self.path.clone(),
                first_t_s,
                scans: self.missing,
            }),
        }
    }
}

impl Estimator for ExternalEstimates {
    fn name(&self) -> String {
        let stem = self.path.file_stem().map_or_else(
            || self.path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        format!("external ({stem})")
    }

    fn reset(&mut self, _pose: SimPose, _sigma_m: f64, _sigma_rad: f64) {
        self.next = 0;
        self.last = None;
    }

    fn odometry(&mut self, _sample: &OdometrySample) {}

    fn scan(&mut self, scan: &LidarScan) -> EstimatorOutput {
        // Rows before this scan belong to no scan of the recording: skipped.
        while self
            .rows
            .get(self.next)
            .is_some_and(|r| r.t_s < scan.t_s - TIME_TOLERANCE_S)
        {
            self.next += 1;
        }
        let found = self
            .rows
            .get(self.next)
            .filter(|r| (r.t_s - scan.t_s).abs() <= TIME_TOLERANCE_S)
            .copied();
        let status = match found {
            Some(r) => {
                self.next += 1;
                self.last = Some(r);
                EstimatorStatus::External
            }
            None => {
                self.missing += 1;
                self.first_missing_t_s.get_or_insert(scan.t_s);
                EstimatorStatus::NoEstimate
            }
        };
        let r = self.last;
        EstimatorOutput {
            pose: r.map_or(SimPose::default(), |r| r.pose),
            sigma: r.map_or((f64::NAN, f64::NAN, f64::NAN), |r| r.sigma),
            status,
            protection: None,
        }
    }

    fn last_update_us(&self) -> Option<f64> {
        self.last.and_then(|r| r.update_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scan_input::BeamLayout;

    fn table(text: &str) -> CsvTable {
        CsvTable::parse(Path::new("est.csv"), text).unwrap()
    }

    fn scan_at(t_s: f64) -> LidarScan {
        LidarScan {
            t_s,
            echoes: Vec::new(),
            scale_factor: 1.0,
            scale_offset_mm: 0.0,
            layout: BeamLayout {
                start_angle_1e4_deg: 0,
                step_1e4_deg: 1667,
                beams: 0,
                scan_frequency_1e2_hz: 0,
                measurement_frequency_100hz: 0,
            },
        }
    }

    #[test]
    fn rows_pair_with_scans_by_time_and_extra_rows_are_skipped() {
        let t = table("t_s,est_x_m,est_y_m,est_theta_rad,update_us\n0.02,9,9,9,1\n0.04,1,2,0.1,7.5\n0.08,3,4,0.2,8\n");
        let mut e = ExternalEstimates::from_table(&t).unwrap();
        let a = e.scan(&scan_at(0.0401));
        assert_eq!((a.pose.x_m, a.pose.y_m, a.pose.theta_rad), (1.0, 2.0, 0.1));
        assert!(a.sigma.0.is_nan(), "no sigma columns: no sigma, not 0");
        assert_eq!(e.last_update_us(), Some(7.5));
        assert_eq!(e.scan(&scan_at(0.08)).pose.x_m, 3.0);
        e.check_complete().unwrap();
    }

    #[test]
    fn a_scan_without_a_row_is_an_error_naming_it() {
        let t = table("t_s,est_x_m,est_y_m,est_theta_rad\n0.04,1,2,0.1\n");
        let mut e = ExternalEstimates::from_table(&t).unwrap();
        e.scan(&scan_at(0.04));
        e.scan(&scan_at(0.08));
        e.scan(&scan_at(0.12));
        let err = e.check_complete().unwrap_err().to_string();
        assert!(
            err.contains("no row for 2 scans") && err.contains("t = 0.080000"),
            "{err}"
        );
    }

    #[test]
    fn rows_out_of_order_or_without_a_pose_are_refused_with_their_line() {
        let t = table("t_s,est_x_m,est_y_m,est_theta_rad\n0.08,1,2,0.1\n0.04,1,2,0.1\n");
        let err = ExternalEstimates::from_table(&t).unwrap_err().to_string();
        assert!(
            err.contains("line 3") && err.contains("time order"),
            "{err}"
        );
        let t = table("t_s,est_x_m,est_y_m,est_theta_rad\n0.04,1,,0.1\n");
        let err = ExternalEstimates::from_table(&t).unwrap_err().to_string();
        assert!(err.contains("line 2") && err.contains("est_y_m"), "{err}");
        let t = table("t_s,x_m,y_m\n0.04,1,2\n");
        let err = ExternalEstimates::from_table(&t).unwrap_err().to_string();
        assert!(err.contains("est_x_m"), "{err}");
    }
}
