//! Plot (c): the localiser's covariance along the run: 1σ of x and y and the position 1σ
//! radius `sqrt(σx² + σy²)` (the square root of the position block's trace) against distance
//! driven, with the actual position error beside them (a consistent filter keeps the error
//! mostly under about 2σ), and in a second panel the heading 1σ with the heading error.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{self, msg, FONT};
use crate::metrics::Sample;
use crate::world::centerline::wrap_pi;

type Series = (&'static str, RGBColor, Vec<(f64, f64)>);

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: String,
    y_desc: &str,
    x1: f64,
    series: Vec<Series>,
) -> Result<(), String> {
    let (y0, y1) = style::log_range(series.iter().flat_map(|s| s.2.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..x1, (y0..y1).log_scale())
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("distance driven (m)")
        .y_desc(y_desc)
        .label_style((FONT, 14))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(msg)?;
    for (label, colour, pts) in series {
        let st = ShapeStyle::from(&colour).stroke_width(style::DATA_LINE_PX);
        chart
            .draw_series(LineSeries::new(
                pts.into_iter().map(|(d, v)| (d, v.max(y0))),
                st,
            ))
            .map_err(msg)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], st));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(msg)
}

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
    panel(
        &top,
        format!("{title}: localiser position 1σ along the run"),
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
    )?;
    panel(
        &bottom,
        "heading 1σ".to_string(),
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
    )?;
    root.present().map_err(msg)
}
