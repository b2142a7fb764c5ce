//! Plot (b): position error against distance driven, for the localiser and for odometry
//! alone (the along/across split is in the metrics and `trajectories.csv`). Log scale:
//! odometry drifts to metres while the localiser stays at centimetres, and both must be
//! readable.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{self, msg, FONT};
use crate::metrics::Sample;

/// A labelled, coloured line of `(distance m, error m)` points.
type Series = (&'static str, RGBColor, Vec<(f64, f64)>);

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
    let (y0, y1) = style::log_range(series.iter().flat_map(|s| s.2.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("{title}: position error vs distance driven"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..x1, (y0..y1).log_scale())
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("distance driven (m)")
        .y_desc("error (m, log scale)")
        .label_style((FONT, 14))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(msg)?;
    for (label, colour, pts) in series {
        let st = ShapeStyle::from(&colour).stroke_width(style::DATA_LINE_PX);
        chart
            .draw_series(LineSeries::new(
                pts.into_iter().map(|(d, e)| (d, e.max(y0))),
                st,
            ))
            .map_err(msg)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], st));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(msg)?;
    root.present().map_err(msg)
}
