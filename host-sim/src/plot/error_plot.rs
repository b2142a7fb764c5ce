//! Plot (b): position error against distance driven, for the localiser and for odometry
//! alone (the along/across split is in the metrics and `trajectories.csv`). Log scale:
//! odometry drifts to metres while the localiser stays at centimetres, and both must be
//! readable.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::chart::{log_panel, Series};
use super::style::{self, msg};
use crate::metrics::Sample;

fn position_error(s: &Sample, est: crate::vehicle::SimPose) -> f64 {
    (est.x_m - s.truth.x_m).hypot(est.y_m - s.truth.y_m)
}

/// Draws the error plot onto `root`.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    samples: &[Sample],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let series: [Series; 2] = [
        (
            "odometry alone: position error",
            style::ODOMETRY,
            samples
                .iter()
                .map(|s| (s.distance_m, position_error(s, s.odometry)))
                .collect(),
        ),
        (
            "localiser: position error",
            style::ESTIMATE,
            samples
                .iter()
                .map(|s| (s.distance_m, position_error(s, s.estimate)))
                .collect(),
        ),
    ];
    let x1 = samples.last().map_or(1.0, |s| s.distance_m).max(1e-3);
    log_panel(
        root,
        format!("{title}: position error vs distance driven"),
        22,
        "distance driven (m)",
        "error (m, log scale)",
        x1,
        series.into(),
        SeriesLabelPosition::LowerRight,
    )?;
    root.present().map_err(msg)
}
