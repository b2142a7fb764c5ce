//! `initial_pose.csv`: the pose the localiser is started from and its uncertainty (on a real
//! vehicle: the operator's or the dispatch system's fix at the start of the shift).
//!
//! One header row `x_m,y_m,theta_rad,sigma_xy_m,sigma_theta_rad` and one row of numbers:
//! world frame, metres and radians; the σ are 1σ of each position coordinate and of the
//! heading.

use std::io::Write;
use std::path::Path;

use super::csv_table::{CsvError, CsvTable};
use crate::closed_loop::RunLog;
use crate::vehicle::SimPose;

/// The header row.
pub const HEADER: &str = "x_m,y_m,theta_rad,sigma_xy_m,sigma_theta_rad";

/// Initial pose and its 1σ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialPose {
    /// The pose, world frame.
    pub pose: SimPose,
    /// 1σ of x and of y, metres.
    pub sigma_xy_m: f64,
    /// 1σ of the heading, radians.
    pub sigma_theta_rad: f64,
}

impl InitialPose {
    /// What a run reset its estimator with.
    pub fn of(log: &RunLog) -> Self {
        let (pose, sigma_xy_m, sigma_theta_rad) = log.initial_estimate;
        Self {
            pose,
            sigma_xy_m,
            sigma_theta_rad,
        }
    }
}

/// Writes the file.
pub fn write(w: &mut dyn Write, p: &InitialPose) -> std::io::Result<()> {
    writeln!(w, "{HEADER}")?;
    writeln!(
        w,
        "{},{},{},{},{}",
        p.pose.x_m, p.pose.y_m, p.pose.theta_rad, p.sigma_xy_m, p.sigma_theta_rad
    )
}

/// Reads the file (its first data row); `None` if it has no data row.
pub fn read(path: &Path) -> Result<Option<InitialPose>, CsvError> {
    let t = CsvTable::read(path)?;
    if t.rows().is_empty() {
        // The columns must still be there: a file of another kind is not "no pose".
        for name in ["x_m", "y_m", "theta_rad", "sigma_xy_m", "sigma_theta_rad"] {
            t.column(name)?;
        }
        return Ok(None);
    }
    // Every value of the pose is required: a NaN start would leave nothing to measure.
    Ok(Some(InitialPose {
        pose: SimPose {
            x_m: t.value(0, "x_m")?,
            y_m: t.value(0, "y_m")?,
            theta_rad: t.value(0, "theta_rad")?,
        },
        sigma_xy_m: t.value(0, "sigma_xy_m")?,
        sigma_theta_rad: t.value(0, "sigma_theta_rad")?,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_that_is_not_a_number_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("initial_pose.csv");
        let header = "x_m,y_m,theta_rad,sigma_xy_m,sigma_theta_rad\n";
        std::fs::write(&p, format!("{header}NaN,0,0,0.05,0.01\n")).unwrap();
        let e = read(&p).unwrap_err().to_string();
        assert!(
            e.contains("line 2") && e.contains("x_m") && e.contains("finite"),
            "{e}"
        );
        std::fs::write(&p, format!("{header}1,,0,0.05,0.01\n")).unwrap();
        let e = read(&p).unwrap_err().to_string();
        assert!(
            e.contains("line 2") && e.contains("y_m") && e.contains("empty"),
            "{e}"
        );
        std::fs::write(&p, header).unwrap();
        assert!(read(&p).unwrap().is_none());
    }

    #[test]
    fn round_trips() {
        let p = InitialPose {
            pose: SimPose {
                x_m: 0.1 + 0.2,
                y_m: -1e-17,
                theta_rad: std::f64::consts::PI,
            },
            sigma_xy_m: 0.05,
            sigma_theta_rad: 0.01,
        };
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("initial_pose.csv");
        let mut buf = Vec::new();
        write(&mut buf, &p).unwrap();
        std::fs::write(&f, &buf).unwrap();
        assert_eq!(read(&f).unwrap(), Some(p));
        std::fs::write(&f, HEADER).unwrap();
        assert_eq!(read(&f).unwrap(), None);
    }
}
