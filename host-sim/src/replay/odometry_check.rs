//! What an odometry log's values mean together: a log that cannot be right is refused
//! ([`OdometryError`]: time going back, rows out of order, an interval that is not positive,
//! times or increments in the wrong unit), and readings that look wrong are flagged
//! ([`OdometryFinding`]) and left out of the replay — a gap, a speed spike, an increment that
//! disagrees with its own speed columns. A reading left out becomes a gap, and the estimator
//! coasts across every gap with an uncertainty that grows with the time
//! ([`crate::odometry_gaps`]): the pose after it is never as sure as before.

use std::fmt;
use std::path::PathBuf;

use crate::odometry_gaps::GAP_BEFORE_READING_DT;
use crate::record::odometry_csv::OdometryLog;
use crate::vehicle::odometry::OdometrySample;

/// Fastest plausible forward speed of a loader, m/s (40 km/h is 11 m/s).
pub const MAX_SPEED_MPS: f64 = 15.0;

/// Fastest plausible yaw rate, rad/s (a skid-steer loader turning on the spot ≈ 1 rad/s).
pub const MAX_YAW_RATE_RADPS: f64 = 3.0;

/// Longest plausible median interval between readings, s (odometry runs at 10–100 Hz).
pub const MAX_MEDIAN_INTERVAL_S: f64 = 1.0;

/// An increment disagrees with its speeds when they differ by more than this fraction...
pub const INCREMENT_TOLERANCE_FRACTION: f64 = 0.1;

/// ...plus this much, m (and rad for the heading): rounding of the logged columns.
pub const INCREMENT_TOLERANCE_ABS: f64 = 1e-3;

/// More than this fraction of the rows wrong in the same way is a systematic fault (a unit,
/// a column mix-up), not a glitch: the log is refused.
pub const SYSTEMATIC_FRACTION: f64 = 0.5;

/// Why an odometry log cannot be used.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum OdometryError {
    /// The log has no readings.
    NoReadings {
        /// The file.
        path: PathBuf,
    },
    /// `t_s` does not increase from one row to the next.
    TimeNotIncreasing {
        /// The file.
        path: PathBuf,
        /// Its line.
        line: usize,
        /// Its time, s.
        t_s: f64,
        /// The previous row's time, s.
        previous_t_s: f64,
    },
    /// `dt_s` is zero or negative.
    BadInterval {
        /// The file.
        path: PathBuf,
        /// Its line.
        line: usize,
        /// The interval, s.
        dt_s: f64,
    },
    /// The rows' spacing in `t_s` and their `dt_s` differ by orders of magnitude.
    UnitMismatch {
        /// The file.
        path: PathBuf,
        /// Median `t_s` step between rows.
        median_step: f64,
        /// Median `dt_s`.
        median_dt: f64,
    },
    /// Readings are further apart than [`MAX_MEDIAN_INTERVAL_S`].
    TooSparse {
        /// The file.
        path: PathBuf,
        /// Median `dt_s`.
        median_dt: f64,
    },
    /// Most rows are wrong the same way.
    Systematic {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: FindingKind,
        /// Rows affected.
        rows: usize,
        /// Rows in the log.
        of: usize,
    },
}

impl fmt::Display for OdometryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OdometryError::NoReadings { path } => write!(
                f,
                "{} has no readings: a replay needs the wheel odometry of the drive",
                path.display()
            ),
            OdometryError::TimeNotIncreasing {
                path,
                line,
                t_s,
                previous_t_s,
            } => write!(
                f,
                "{} line {line}: t_s {t_s} s is not after the previous row's {previous_t_s} s: rows are out of order or the clock went back; sort the log by t_s or fix the logger's clock",
                path.display()
            ),
            OdometryError::BadInterval { path, line, dt_s } => write!(
                f,
                "{} line {line}: dt_s {dt_s} s is not positive: each reading covers the interval before its t_s",
                path.display()
            ),
            OdometryError::UnitMismatch {
                path,
                median_step,
                median_dt,
            } => write!(
                f,
                "{}: t_s advances by {median_step} per row but dt_s is {median_dt}: one of them is not in seconds (milliseconds?); both must be seconds",
                path.display()
            ),
            OdometryError::TooSparse { path, median_dt } => write!(
                f,
                "{}: readings are {median_dt} s apart (median dt_s): odometry runs at 10-100 Hz; are the times in milliseconds? They must be seconds",
                path.display()
            ),
            OdometryError::Systematic {
                path,
                what,
                rows,
                of,
            } => write!(
                f,
                "{}: {rows} of {of} rows {what}: a unit or a column is wrong (dx_m in mm? v_mps in km/h?); fix the log",
                path.display()
            ),
        }
    }
}

impl std::error::Error for OdometryError {}

/// What is wrong with a flagged reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum FindingKind {
    /// Time before it that no reading covers.
    Gap,
    /// Speed or yaw rate beyond [`MAX_SPEED_MPS`] / [`MAX_YAW_RATE_RADPS`].
    Spike,
    /// Its increment columns disagree with its speed columns.
    IncrementDisagrees,
}

impl fmt::Display for FindingKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FindingKind::Gap => "follow a gap no reading covers",
            FindingKind::Spike => "have a speed or yaw rate no loader reaches",
            FindingKind::IncrementDisagrees => "have increments that disagree with their speeds",
        })
    }
}

/// A flagged reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryFinding {
    /// What.
    pub kind: FindingKind,
    /// Index of the reading.
    pub row: usize,
    /// Its line in the file.
    pub line: usize,
    /// Its time, s.
    pub t_s: f64,
    /// The gap's length (s), the speed (m/s) or the increment's distance (m).
    pub value: f64,
    /// For a disagreeing increment, the distance its speed gives, m.
    pub expected: f64,
}

impl fmt::Display for OdometryFinding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (line, t) = (self.line, self.t_s);
        match self.kind {
            FindingKind::Gap => write!(
                f,
                "line {line} (t = {t:.3} s): {:.3} s without odometry before it; the estimate coasts across with growing uncertainty",
                self.value
            ),
            FindingKind::Spike => write!(
                f,
                "line {line} (t = {t:.3} s): {:.3} m/s or {:.3} rad/s is beyond what a loader does; the reading is left out",
                self.value, self.expected
            ),
            FindingKind::IncrementDisagrees => write!(
                f,
                "line {line} (t = {t:.3} s): increment of {:.4} m / rad where its speeds give {:.4}; the reading is left out",
                self.value, self.expected
            ),
        }
    }
}

/// The log checked: the readings to replay (flagged ones left out) and what was flagged.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedOdometry {
    /// Readings to feed, in time order.
    pub readings: Vec<OdometrySample>,
    /// Flagged readings, in file order.
    pub findings: Vec<OdometryFinding>,
}

impl CheckedOdometry {
    /// One warning per kind of finding: how many, the worst and the first.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        for kind in [
            FindingKind::Gap,
            FindingKind::Spike,
            FindingKind::IncrementDisagrees,
        ] {
            let of: Vec<&OdometryFinding> =
                self.findings.iter().filter(|f| f.kind == kind).collect();
            let Some(first) = of.first() else { continue };
            let worst = of
                .iter()
                .max_by(|a, b| a.value.abs().total_cmp(&b.value.abs()))
                .unwrap_or(first);
            out.push(format!(
                "odometry: {} readings {kind}; first at {first}; worst at {worst}",
                of.len()
            ));
        }
        out
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}

/// Checks `log`: refuses what cannot be right, flags and leaves out what looks wrong.
pub fn check(log: &OdometryLog) -> Result<CheckedOdometry, OdometryError> {
    let path = || log.path.clone();
    let r = &log.readings;
    let line = |k: usize| log.lines.get(k).copied().unwrap_or(0);
    if r.is_empty() {
        return Err(OdometryError::NoReadings { path: path() });
    }
    for (k, x) in r.iter().enumerate() {
        if x.dt_s <= 0.0 {
            return Err(OdometryError::BadInterval {
                path: path(),
                line: line(k),
                dt_s: x.dt_s,
            });
        }
        if let Some(prev) = k.checked_sub(1).and_then(|p| r.get(p)) {
            if x.t_s <= prev.t_s {
                return Err(OdometryError::TimeNotIncreasing {
                    path: path(),
                    line: line(k),
                    t_s: x.t_s,
                    previous_t_s: prev.t_s,
                });
            }
        }
    }
    if r.len() >= 3 {
        let steps = median(r.windows(2).map(|w| w[1].t_s - w[0].t_s).collect());
        let dts = median(r.iter().map(|x| x.dt_s).collect());
        if let (Some(median_step), Some(median_dt)) = (steps, dts) {
            let ratio = median_step / median_dt;
            if !(0.01..=100.0).contains(&ratio) {
                return Err(OdometryError::UnitMismatch {
                    path: path(),
                    median_step,
                    median_dt,
                });
            }
            if median_dt > MAX_MEDIAN_INTERVAL_S {
                return Err(OdometryError::TooSparse {
                    path: path(),
                    median_dt,
                });
            }
        }
    }
    let mut findings = Vec::new();
    for (k, x) in r.iter().enumerate() {
        let flag = |kind, value, expected| OdometryFinding {
            kind,
            row: k,
            line: line(k),
            t_s: x.t_s,
            value,
            expected,
        };
        if let Some(prev) = k.checked_sub(1).and_then(|p| r.get(p)) {
            let gap = x.t_s - x.dt_s - prev.t_s;
            if gap > GAP_BEFORE_READING_DT * x.dt_s {
                findings.push(flag(FindingKind::Gap, gap, 0.0));
            }
        }
        if x.v_mps.abs() > MAX_SPEED_MPS || x.omega_radps.abs() > MAX_YAW_RATE_RADPS {
            findings.push(flag(FindingKind::Spike, x.v_mps, x.omega_radps));
        } else if log.increments_given {
            let (dx, dy, dth) = x.delta;
            let distance = dx.hypot(dy);
            let from_speed = (x.v_mps * x.dt_s).abs();
            let turn_from_speed = x.omega_radps * x.dt_s;
            let off = |a: f64, b: f64| {
                (a - b).abs()
                    > INCREMENT_TOLERANCE_FRACTION * a.abs().max(b.abs()) + INCREMENT_TOLERANCE_ABS
            };
            if off(distance, from_speed) {
                findings.push(flag(FindingKind::IncrementDisagrees, distance, from_speed));
            } else if off(dth, turn_from_speed) {
                findings.push(flag(FindingKind::IncrementDisagrees, dth, turn_from_speed));
            }
        }
    }
    for kind in [FindingKind::Spike, FindingKind::IncrementDisagrees] {
        let rows = findings.iter().filter(|f| f.kind == kind).count();
        if r.len() >= 10 && rows as f64 > SYSTEMATIC_FRACTION * r.len() as f64 {
            return Err(OdometryError::Systematic {
                path: path(),
                what: kind,
                rows,
                of: r.len(),
            });
        }
    }
    let left_out: Vec<usize> = findings
        .iter()
        .filter(|f| f.kind != FindingKind::Gap)
        .map(|f| f.row)
        .collect();
    let readings = r
        .iter()
        .enumerate()
        .filter(|(k, _)| !left_out.contains(k))
        .map(|(_, x)| *x)
        .collect();
    Ok(CheckedOdometry { readings, findings })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::odometry_csv::increment;

    fn log(readings: Vec<OdometrySample>) -> OdometryLog {
        OdometryLog {
            path: PathBuf::from("odometry.csv"),
            lines: (0..readings.len()).map(|k| k + 2).collect(),
            readings,
            increments_given: true,
        }
    }

    fn drive(n: usize) -> Vec<OdometrySample> {
        (1..=n)
            .map(|k| {
                let (v, w, dt) = (2.0, 0.05, 0.01);
                OdometrySample {
                    t_s: k as f64 * dt,
                    dt_s: dt,
                    v_mps: v,
                    omega_radps: w,
                    delta: increment(v, w, dt),
                }
            })
            .collect()
    }

    #[test]
    fn a_clean_log_passes_whole() {
        let c = check(&log(drive(100))).unwrap();
        assert_eq!((c.readings.len(), c.findings.len()), (100, 0));
        assert!(c.warnings().is_empty());
    }

    #[test]
    fn what_cannot_be_right_is_refused_with_its_line() {
        let mut r = drive(100);
        r.swap(40, 41);
        let e = check(&log(r)).unwrap_err();
        assert!(
            matches!(e, OdometryError::TimeNotIncreasing { line: 43, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("line 43"), "{e}");

        let e = check(&log(Vec::new())).unwrap_err();
        assert!(matches!(e, OdometryError::NoReadings { .. }), "{e}");

        let mut r = drive(100);
        r[10].dt_s = 0.0;
        let e = check(&log(r)).unwrap_err();
        assert!(
            matches!(e, OdometryError::BadInterval { line: 12, .. }),
            "{e}"
        );

        // t_s in ms, dt_s in s.
        let mut r = drive(100);
        for x in &mut r {
            x.t_s *= 1000.0;
        }
        let e = check(&log(r)).unwrap_err();
        assert!(matches!(e, OdometryError::UnitMismatch { .. }), "{e}");
        // Both in ms.
        let mut r = drive(100);
        for x in &mut r {
            x.t_s *= 1000.0;
            x.dt_s *= 1000.0;
        }
        let e = check(&log(r)).unwrap_err();
        assert!(matches!(e, OdometryError::TooSparse { .. }), "{e}");
        // Increments in mm.
        let mut r = drive(100);
        for x in &mut r {
            x.delta.0 *= 1000.0;
        }
        let e = check(&log(r)).unwrap_err();
        assert!(
            matches!(
                e,
                OdometryError::Systematic {
                    what: FindingKind::IncrementDisagrees,
                    rows: 100,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn glitches_are_flagged_and_left_out_and_gaps_kept_for_coasting() {
        let mut r = drive(200);
        r[50].v_mps = 80.0; // a spike
        r[90].delta.0 = 0.5; // an increment of 0.5 m where 2 m/s gives 0.02 m
        r.drain(120..170); // half a second lost
        let c = check(&log(r)).unwrap();
        let kinds: Vec<(FindingKind, usize)> = c.findings.iter().map(|f| (f.kind, f.row)).collect();
        assert_eq!(
            kinds,
            [
                (FindingKind::Spike, 50),
                (FindingKind::IncrementDisagrees, 90),
                (FindingKind::Gap, 120)
            ]
        );
        assert!((c.findings[2].value - 0.5).abs() < 1e-9);
        assert_eq!(c.readings.len(), 150 - 2);
        assert!(c.readings.iter().all(|x| x.v_mps < 10.0 && x.delta.0 < 0.1));
        let w = c.warnings();
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(
            w[0].contains("1 readings follow a gap") && w[0].contains("line 122"),
            "{w:?}"
        );
    }

    proptest::proptest! {
        /// Any log is refused or checked, never a panic; what is kept is in time order with
        /// positive intervals and plausible speeds, and every reading left out is flagged.
        #[test]
        fn any_log_is_refused_or_kept_in_order(
            rows in proptest::collection::vec(
                (-0.0001f64..0.05, -0.00005f64..0.03, -30.0f64..30.0, -5.0f64..5.0, -0.5f64..0.5),
                0..60,
            ),
            with_increments in proptest::bool::ANY,
        ) {
            // Times mostly increasing (a step may go back), so most logs reach the checks.
            let mut t_s = 0.0;
            let readings: Vec<OdometrySample> = rows
                .iter()
                .map(|&(step_s, dt_s, v_mps, omega_radps, dx)| OdometrySample {
                    t_s: {
                        t_s += step_s;
                        t_s
                    },
                    dt_s,
                    v_mps,
                    omega_radps,
                    delta: (dx, 0.0, omega_radps * dt_s),
                })
                .collect();
            let mut l = log(readings);
            l.increments_given = with_increments;
            if let Ok(c) = check(&l) {
                proptest::prop_assert!(c.readings.windows(2).all(|w| w[0].t_s < w[1].t_s));
                proptest::prop_assert!(c.readings.iter().all(|r| r.dt_s > 0.0
                    && r.v_mps.abs() <= MAX_SPEED_MPS
                    && r.omega_radps.abs() <= MAX_YAW_RATE_RADPS));
                let left_out = l.readings.len() - c.readings.len();
                let flagged = c.findings.iter().filter(|f| f.kind != FindingKind::Gap).count();
                proptest::prop_assert_eq!(left_out, flagged);
            }
        }
    }
}
