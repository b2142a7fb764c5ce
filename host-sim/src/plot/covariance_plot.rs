//! Plot (c): the localiser's covariance along the run: 1σ of x and y and the position 1σ
//! radius `sqrt(σx² + σy²)` (the square root of the position block's trace) against distance
//! driven, with the actual position error beside them (a consistent filter keeps the error
//! mostly under about 2σ), and in a second panel the heading 1σ with the heading error.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::chart::log_panel;
use super::style::{self, msg};
use crate::metrics::Sample;
use crate::world::centerline::wrap_pi;

/// Draws the two covariance panels onto `root`.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    samples: &[Sample],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let x1 = samples.last().map_or(1.0, |s| s.distance_m).max(1e-3);
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 * 3 / 5);
    let pts = |f: fn(&Sample) -> f64| samples.iter().map(|s| (s.distance_m, f(s))).collect();
    log_panel(
        &top,
        format!("{title}: localiser position 1σ along the run"),
        20,
        "distance driven (m)",
        "metres (log scale)",
        x1,
        vec![
            ("σx", style::ESTIMATE, pts(|s| s.sigma.0)),
            ("σy", style::SECOND, pts(|s| s.sigma.1)),
            (
                "sqrt(σx² + σy²)",
                style::TRUTH,
                pts(|s| s.sigma.0.hypot(s.sigma.1)),
            ),
            (
                "actual position error",
                style::ODOMETRY,
                pts(|s| (s.estimate.x_m - s.truth.x_m).hypot(s.estimate.y_m - s.truth.y_m)),
            ),
        ],
        SeriesLabelPosition::UpperRight,
    )?;
    log_panel(
        &bottom,
        "heading 1σ".to_string(),
        20,
        "distance driven (m)",
        "degrees (log scale)",
        x1,
        vec![
            ("σθ", style::ESTIMATE, pts(|s| s.sigma.2.to_degrees())),
            (
                "actual heading error",
                style::ODOMETRY,
                pts(|s| {
                    wrap_pi(s.estimate.theta_rad - s.truth.theta_rad)
                        .abs()
                        .to_degrees()
                }),
            ),
        ],
        SeriesLabelPosition::UpperRight,
    )?;
    root.present().map_err(msg)
}
