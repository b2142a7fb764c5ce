//! `ground_truth.csv`: where the vehicle really was (the simulator's truth; on a real vehicle
//! e.g. RTK-GPS or a total station), in the world frame of the map.
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `t_s` | s | time |
//! | `x_m`, `y_m` | m | vehicle position, world frame |
//! | `theta_rad` | rad | heading, world frame (continuous, not wrapped) |
//! | `distance_m` | m | distance driven since the start (optional on reading) |
//! | `chainage_m` | m | chainage of the position on the tunnel's centre line (optional on reading) |
//!
//! A recording of a run has the start (t = 0) and then one row per scan at the scan's time.

use std::io::Write;
use std::path::Path;

use super::csv_table::{cell, CsvError, CsvTable};
use crate::closed_loop::RunLog;
use crate::vehicle::SimPose;

/// The header row.
pub const HEADER: &str = "t_s,x_m,y_m,theta_rad,distance_m,chainage_m";

/// One ground-truth row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthRow {
    /// Time, seconds.
    pub t_s: f64,
    /// The true pose, world frame.
    pub pose: SimPose,
    /// Distance driven, metres, if logged.
    pub distance_m: Option<f64>,
    /// Centre-line chainage, metres, if logged.
    pub chainage_m: Option<f64>,
}

fn row(w: &mut dyn Write, r: &TruthRow) -> std::io::Result<()> {
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
    writeln!(
        w,
        "{},{},{},{},{},{}",
        r.t_s,
        r.pose.x_m,
        r.pose.y_m,
        r.pose.theta_rad,
        opt(r.distance_m),
        opt(r.chainage_m)
    )
}

/// The rows of a run: its start pose at t = 0, then the truth of every scan.
pub fn rows_of_run(log: &RunLog) -> Vec<TruthRow> {
    let start_chainage = log
        .centerline
        .project(
            log.start.x_m,
            log.start.y_m,
            log.scenario.drive.start_m,
            5.0,
        )
        .s_m;
    std::iter::once(TruthRow {
        t_s: 0.0,
        pose: log.start,
        distance_m: Some(0.0),
        chainage_m: Some(start_chainage),
    })
    .chain(log.samples.iter().map(|s| TruthRow {
        t_s: s.t_s,
        pose: s.truth,
        distance_m: Some(s.distance_m),
        chainage_m: Some(s.chainage_m),
    }))
    .collect()
}

/// Writes rows.
pub fn write(w: &mut dyn Write, rows: &[TruthRow]) -> std::io::Result<()> {
    writeln!(w, "{HEADER}")?;
    rows.iter().try_for_each(|r| row(w, r))
}

/// Writes the ground truth of a run ([`rows_of_run`]).
pub fn write_run(w: &mut dyn Write, log: &RunLog) -> std::io::Result<()> {
    write(w, &rows_of_run(log))
}

/// Reads a ground-truth CSV (columns by name). Rows must be in time order.
pub fn read(path: &Path) -> Result<Vec<TruthRow>, CsvError> {
    let t = CsvTable::read(path)?;
    let (ct, cx, cy, ch) = (
        t.column("t_s")?,
        t.column("x_m")?,
        t.column("y_m")?,
        t.column("theta_rad")?,
    );
    let (cd, cc) = (
        t.optional_column("distance_m"),
        t.optional_column("chainage_m"),
    );
    let opt = |r: &[f64], c: Option<usize>| c.map(|c| cell(r, c)).filter(|v| v.is_finite());
    Ok(t.rows()
        .iter()
        .map(|r| TruthRow {
            t_s: cell(r, ct),
            pose: SimPose {
                x_m: cell(r, cx),
                y_m: cell(r, cy),
                theta_rad: cell(r, ch),
            },
            distance_m: opt(r, cd),
            chainage_m: opt(r, cc),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_optional_columns() {
        let rows = vec![
            TruthRow {
                t_s: 0.0,
                pose: SimPose {
                    x_m: 0.1,
                    y_m: -0.2,
                    theta_rad: 1.0 / 3.0,
                },
                distance_m: Some(0.0),
                chainage_m: Some(0.1),
            },
            TruthRow {
                t_s: 0.04,
                pose: SimPose {
                    x_m: 0.14,
                    y_m: -0.2,
                    theta_rad: 0.333,
                },
                distance_m: None,
                chainage_m: Some(0.14),
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("ground_truth.csv");
        let mut buf = Vec::new();
        write(&mut buf, &rows).unwrap();
        std::fs::write(&p, &buf).unwrap();
        assert_eq!(read(&p).unwrap(), rows);
        std::fs::write(&p, "x_m,t_s,y_m,theta_rad\n1,2,3,4\n").unwrap();
        let r = read(&p).unwrap()[0];
        assert_eq!((r.t_s, r.pose.x_m, r.distance_m), (2.0, 1.0, None));
    }
}
