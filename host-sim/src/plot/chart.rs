//! The chart parts the plots share: a log-scale panel of labelled lines against distance
//! driven, and the legend (its swatch and its box).

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::style::{self, msg, FONT};

/// A labelled, coloured line of `(distance m, value)` points.
pub type Series = (&'static str, RGBColor, Vec<(f64, f64)>);

/// The legend swatch of a line drawn in `st`.
pub fn swatch(st: ShapeStyle) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], st)
}

/// Draws the legend box of `chart` at `position`, text `font_px` high.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    font_px: u32,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .label_font((FONT, font_px))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(msg)
}

/// A panel of `series` against `x` (0 … `x1`, described by `x_desc`; distance driven in the
/// run plots) on a log `y` axis spanning their positive values (values below it drawn at
/// its floor), with a legend.
#[allow(clippy::too_many_arguments)]
pub fn log_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: String,
    caption_px: u32,
    x_desc: &str,
    y_desc: &str,
    x1: f64,
    series: Vec<Series>,
    legend_at: SeriesLabelPosition,
) -> Result<(), String> {
    let (y0, y1) = style::log_range(series.iter().flat_map(|s| s.2.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, caption_px))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..x1, (y0..y1).log_scale())
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
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
            .legend(swatch(st));
    }
    legend(&mut chart, legend_at, 14)
}
