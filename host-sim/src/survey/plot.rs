//! The survey's plots, each PNG and SVG (1 km of tunnel drawn to scale would hide the
//! millimetres that matter, so both are against arc length along the wall):
//! - `survey_walls`: each surveyed wall's offset from the design, and each landmark's
//!   displacement from its mark (along and across), millimetres;
//! - `survey_uncertainty`: each landmark's marginal 1σ along and across its wall.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::Survey;
use crate::plot::chart::{legend, swatch};
use crate::plot::style::{self, msg, FONT};
use crate::plot::{plot_both, CHART_SIZE};

fn surveyed(s: &Survey) -> impl Iterator<Item = &super::SurveyedLandmark> {
    s.landmarks.iter().filter(|l| l.map_index.is_some())
}

fn draw_walls<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, s: &Survey) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let x1 = s
        .walls
        .iter()
        .map(|w| w.offset_m.len() as f64)
        .fold(1.0, f64::max);
    let mm = |v: f64| v * 1e3;
    let mut lo: f64 = -10.0;
    let mut hi: f64 = 10.0;
    for w in &s.walls {
        for &o in &w.offset_m {
            lo = lo.min(mm(o));
            hi = hi.max(mm(o));
        }
    }
    for l in surveyed(s) {
        for v in [l.from_prior_m.0, l.from_prior_m.1] {
            lo = lo.min(mm(v));
            hi = hi.max(mm(v));
        }
    }
    let pad = 0.05 * (hi - lo);
    let mut chart = ChartBuilder::on(root)
        .caption(
            "surveyed walls and landmarks against the design",
            (FONT, 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..x1, (lo - pad)..(hi + pad))
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("arc length along the wall (m)")
        .y_desc("offset from the design (mm)")
        .label_style((FONT, 14))
        .draw()
        .map_err(msg)?;
    for (w, name, colour) in [
        (&s.walls[0], "left wall", style::WALL),
        (&s.walls[1], "right wall", style::TRUTH),
    ] {
        let st = ShapeStyle::from(&colour).stroke_width(style::DATA_LINE_PX);
        chart
            .draw_series(LineSeries::new(
                w.offset_m
                    .iter()
                    .enumerate()
                    .map(|(i, o)| (i as f64, mm(*o))),
                st,
            ))
            .map_err(msg)?
            .label(name)
            .legend(swatch(st));
    }
    for (name, colour, pick) in [
        (
            "landmark along its wall",
            style::ESTIMATE,
            (|l: &super::SurveyedLandmark| l.from_prior_m.0) as fn(&super::SurveyedLandmark) -> f64,
        ),
        ("landmark across", style::SECOND, |l| l.from_prior_m.1),
    ] {
        let st = ShapeStyle::from(&colour).filled();
        chart
            .draw_series(surveyed(s).map(|l| Circle::new((l.s_m, mm(pick(l))), 3, st)))
            .map_err(msg)?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 6, y), 4, st));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
    root.present().map_err(msg)
}

fn draw_uncertainty<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Survey,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let x1 = surveyed(s).map(|l| l.s_m).fold(1.0, f64::max);
    let (y0, y1) =
        style::log_range(surveyed(s).flat_map(|l| [l.sd_along_m * 1e3, l.sd_across_m * 1e3]));
    let mut chart = ChartBuilder::on(root)
        .caption("each landmark's surveyed 1σ (marginal)", (FONT, 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..x1, (y0..y1).log_scale())
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("arc length along the wall (m)")
        .y_desc("1σ (mm, log scale)")
        .label_style((FONT, 14))
        .draw()
        .map_err(msg)?;
    for (name, colour, pick) in [
        (
            "along the wall",
            style::ESTIMATE,
            (|l: &super::SurveyedLandmark| l.sd_along_m) as fn(&super::SurveyedLandmark) -> f64,
        ),
        ("across", style::SECOND, |l| l.sd_across_m),
    ] {
        let st = ShapeStyle::from(&colour).filled();
        chart
            .draw_series(surveyed(s).map(|l| Circle::new((l.s_m, pick(l) * 1e3), 3, st)))
            .map_err(msg)?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 6, y), 4, st));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
    root.present().map_err(msg)
}

/// Writes both plots into `dir`; returns the files written.
pub fn write_plots(dir: &Path, s: &Survey) -> Result<Vec<PathBuf>, String> {
    style::register_font();
    let mut written = Vec::new();
    plot_both!(dir, "survey_walls", CHART_SIZE, &mut written, |r| {
        draw_walls(r, s)
    })
    .map_err(|e| e.to_string())?;
    plot_both!(dir, "survey_uncertainty", CHART_SIZE, &mut written, |r| {
        draw_uncertainty(r, s)
    })
    .map_err(|e| e.to_string())?;
    Ok(written)
}
