//! Plot (a): the stored map (walls, landmarks) with the true, estimated and odometry paths,
//! world frame. The axes span everything drawn; for a long tunnel they cannot be to scale
//! (a 1 km × 5 m tunnel would be a line), and the caption says so.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::chart::{legend, swatch};
use super::map_lines::MapLines;
use super::style::{self, msg, FONT};
use crate::metrics::Sample;

/// How far beyond the driven paths the map is shown, metres (a tunnel's half width and more).
pub const TUNNEL_MARGIN_M: f64 = 8.0;

/// Bounding box `(x0, x1, y0, y1)` of the finite points, if any.
fn bbox(pts: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64, f64, f64)> {
    let mut b = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in pts.filter(|p| p.0.is_finite() && p.1.is_finite()) {
        b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
    }
    (b.0 <= b.1).then_some(b)
}

/// A path: label, colour, and which pose of a sample it follows.
type PathSeries = (&'static str, RGBColor, fn(&Sample) -> (f64, f64));

/// Draws the map view onto `root`.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    lines: &MapLines,
    samples: &[Sample],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    // The view spans the drive (plus the tunnel around it), not the whole map: a 200 m
    // drive in a 1 km tunnel would be a speck. Lines leaving the view are clipped.
    let paths: Vec<(f64, f64)> = samples
        .iter()
        .flat_map(|s| [s.truth, s.estimate, s.odometry])
        .map(|p| (p.x_m, p.y_m))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = match bbox(paths.iter().copied()) {
        Some((a, b, c, d)) => {
            let m = TUNNEL_MARGIN_M;
            let near = |p: &(f64, f64)| p.0 > a - m && p.0 < b + m && p.1 > c - m && p.1 < d + m;
            bbox(lines.points().filter(near).chain(paths.iter().copied())).unwrap_or((a, b, c, d))
        }
        None => bbox(lines.points()).unwrap_or((0.0, 1.0, 0.0, 1.0)),
    };
    if x1 - x0 < 1.0 {
        (x0, x1) = (x0 - 0.5, x1 + 0.5);
    }
    if y1 - y0 < 1.0 {
        (y0, y1) = (y0 - 0.5, y1 + 0.5);
    }
    let (px, py) = (0.03 * (x1 - x0), 0.06 * (y1 - y0));
    let (x0, x1, y0, y1) = (x0 - px, x1 + px, y0 - py, y1 + py);
    let (w, h) = root.dim_in_pixel();
    // Metres per pixel along each axis (plot area about 85 % of the image).
    let sx = (x1 - x0) / (0.85 * f64::from(w));
    let sy = (y1 - y0) / (0.85 * f64::from(h));
    let to_scale = (sx / sy - 1.0).abs() < 0.25;
    let caption = if to_scale {
        format!("{title}: map and paths")
    } else {
        format!("{title}: map and paths (axes not to scale)")
    };
    let mut chart = ChartBuilder::on(root)
        .caption(caption, (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("world x (m)")
        .y_desc("world y (m)")
        .label_style((FONT, 14))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(msg)?;
    let wall = ShapeStyle::from(&style::WALL).stroke_width(2);
    chart
        .draw_series(LineSeries::new(lines.left_wall.iter().copied(), wall))
        .map_err(msg)?
        .label("walls")
        .legend(swatch(wall));
    chart
        .draw_series(LineSeries::new(lines.right_wall.iter().copied(), wall))
        .map_err(msg)?;
    let lm = ShapeStyle::from(&style::LANDMARK).stroke_width(2);
    for (i, l) in lines.landmarks.iter().enumerate() {
        let s = chart
            .draw_series(LineSeries::new(l.iter().copied(), lm))
            .map_err(msg)?;
        if i == 0 {
            s.label("landmarks").legend(swatch(lm));
        }
    }
    let series: [PathSeries; 3] = [
        ("odometry alone", style::ODOMETRY, |s| {
            (s.odometry.x_m, s.odometry.y_m)
        }),
        ("ground truth", style::TRUTH, |s| (s.truth.x_m, s.truth.y_m)),
        ("localiser", style::ESTIMATE, |s| {
            (s.estimate.x_m, s.estimate.y_m)
        }),
    ];
    for (label, colour, pick) in series {
        let st = ShapeStyle::from(&colour).stroke_width(style::DATA_LINE_PX);
        chart
            .draw_series(LineSeries::new(samples.iter().map(pick), st))
            .map_err(msg)?
            .label(label)
            .legend(swatch(st));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 15)?;
    root.present().map_err(msg)
}
