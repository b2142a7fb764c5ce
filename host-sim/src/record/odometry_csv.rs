//! `odometry.csv`: the wheel odometry as the vehicle's computer logs it, one row per reading.
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `t_s` | s | time of the reading (end of the interval it covers) |
//! | `dt_s` | s | interval the reading covers |
//! | `v_mps` | m/s | forward speed over the interval, from the track encoders (mean of left and right) |
//! | `omega_radps` | rad/s | yaw rate over the interval, (right − left) / effective track width |
//! | `dx_m`, `dy_m`, `dtheta_rad` | m, m, rad | the motion over the interval in the vehicle frame at its start (x forward, y left) |
//!
//! The increment columns are optional on reading: a log with only speeds gets them by exact
//! arc integration of `v_mps` and `omega_radps` over `dt_s` (what the simulator's odometry
//! does too). Numbers are written in Rust's shortest round-trip form, so a replay reads back
//! exactly the `f64` the run had.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::csv_table::{cell, CsvError, CsvTable};
use crate::vehicle::odometry::OdometrySample;
use crate::vehicle::SimPose;

/// The header row.
pub const HEADER: &str = "t_s,dt_s,v_mps,omega_radps,dx_m,dy_m,dtheta_rad";

/// Writes the readings.
pub fn write(w: &mut dyn Write, readings: &[OdometrySample]) -> std::io::Result<()> {
    writeln!(w, "{HEADER}")?;
    for r in readings {
        writeln!(
            w,
            "{},{},{},{},{},{},{}",
            r.t_s, r.dt_s, r.v_mps, r.omega_radps, r.delta.0, r.delta.1, r.delta.2
        )?;
    }
    Ok(())
}

/// The increment of `v_mps`, `omega_radps` over `dt_s` in the vehicle frame at its start.
pub fn increment(v_mps: f64, omega_radps: f64, dt_s: f64) -> (f64, f64, f64) {
    let p = SimPose::default().integrate(v_mps, 0.0, omega_radps, dt_s);
    (p.x_m, p.y_m, p.theta_rad)
}

/// An odometry CSV as read: the readings and where each came from.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryLog {
    /// The file.
    pub path: PathBuf,
    /// The readings in file order.
    pub readings: Vec<OdometrySample>,
    /// The file's line number (1-based) of each reading.
    pub lines: Vec<usize>,
    /// Whether the file gave the increment columns (else they came from the speeds).
    pub increments_given: bool,
}

/// Reads an odometry CSV (columns by name; see the module docs); what the values mean
/// together (time order, units, gaps) is `replay::odometry_check`'s job.
pub fn read(path: &Path) -> Result<OdometryLog, CsvError> {
    let t = CsvTable::read(path)?;
    let (ct, cdt, cv, cw) = (
        t.column("t_s")?,
        t.column("dt_s")?,
        t.column("v_mps")?,
        t.column("omega_radps")?,
    );
    let inc = match (
        t.optional_column("dx_m"),
        t.optional_column("dy_m"),
        t.optional_column("dtheta_rad"),
    ) {
        (Some(a), Some(b), Some(c)) => Some((a, b, c)),
        _ => None,
    };
    let readings = t
        .rows()
        .iter()
        .map(|r| {
            let (t_s, dt_s, v, w) = (cell(r, ct), cell(r, cdt), cell(r, cv), cell(r, cw));
            let delta = match inc {
                Some((a, b, c)) if cell(r, a).is_finite() => (cell(r, a), cell(r, b), cell(r, c)),
                _ => increment(v, w, dt_s),
            };
            OdometrySample {
                t_s,
                dt_s,
                v_mps: v,
                omega_radps: w,
                delta,
            }
        })
        .collect();
    Ok(OdometryLog {
        path: t.path().to_path_buf(),
        readings,
        lines: (0..t.rows().len()).map(|k| t.line(k)).collect(),
        increments_given: inc.is_some(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_exactly_and_fills_missing_increments() {
        let rows = vec![
            OdometrySample {
                t_s: 0.01,
                dt_s: 0.01,
                v_mps: 1.0 / 3.0,
                omega_radps: -0.123_456_789_012_345_6,
                delta: (0.003_333_3, -1e-9, -0.001_234_567_890_123_456),
            },
            OdometrySample {
                t_s: 0.02,
                dt_s: 0.01,
                v_mps: 2.0,
                omega_radps: 0.5,
                delta: increment(2.0, 0.5, 0.01),
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("odometry.csv");
        let mut buf = Vec::new();
        write(&mut buf, &rows).unwrap();
        std::fs::write(&p, &buf).unwrap();
        let log = read(&p).unwrap();
        assert_eq!(log.readings, rows);
        assert_eq!(
            (log.lines.as_slice(), log.increments_given),
            ([2, 3].as_slice(), true)
        );
        // Speeds only: the increment comes from arc integration.
        std::fs::write(&p, "t_s,dt_s,v_mps,omega_radps\n0.02,0.01,2,0.5\n").unwrap();
        let back = read(&p).unwrap();
        assert!(!back.increments_given);
        let back = back.readings;
        assert_eq!(back[0].delta, rows[1].delta);
        let (dx, dy, dth) = back[0].delta;
        assert!((dx - 0.02).abs() < 1e-6 && dy > 0.0 && (dth - 0.005).abs() < 1e-15);
    }
}
