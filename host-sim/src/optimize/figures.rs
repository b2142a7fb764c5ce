//! The search's figures, as the paper draws them, each PNG and SVG in the search directory:
//! - `convergence` (Figure 6): best and median RMS of eq. 2 per generation;
//! - `shapes` (Figure 7): the best profile of successive generations overlaid, light to dark;
//! - `spacing_histogram` (Figure 8): the D gene over the first and the last generation.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::genes::{GeneSpace, Genes};
use super::store::GenerationRow;
use crate::plot::chart::{legend, log_panel, swatch, Series};
use crate::plot::style::{self, msg, FONT};
use crate::plot::{plot_both, PlotError, CHART_SIZE};

/// Draws Figure 6.
fn convergence<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    rows: &[GenerationRow],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let series: Vec<Series> = vec![
        (
            "median of the generation",
            style::ODOMETRY,
            rows.iter()
                .map(|r| (r.index as f64 + 1.0, r.median_fitness.sqrt()))
                .collect(),
        ),
        (
            "best of the generation",
            style::ESTIMATE,
            rows.iter()
                .map(|r| (r.index as f64 + 1.0, r.best_fitness.sqrt()))
                .collect(),
        ),
    ];
    log_panel(
        root,
        format!("{title}: convergence"),
        22,
        "generation",
        "RMS of eq. 2 (m, log scale)",
        (rows.len() as f64 + 1.0).max(2.0),
        series,
        SeriesLabelPosition::UpperRight,
    )?;
    root.present().map_err(msg)
}

/// The best profile of each generation to draw: at most `max` of them, evenly spread,
/// the last always included.
fn shown_generations(rows: &[GenerationRow], max: usize) -> Vec<&GenerationRow> {
    let n = rows.len();
    if n <= max {
        return rows.iter().collect();
    }
    let mut picked: Vec<usize> = (0..max).map(|k| k * (n - 1) / (max - 1)).collect();
    picked.dedup();
    picked.into_iter().map(|i| &rows[i]).collect()
}

/// Draws Figure 7.
fn shapes<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    space: &GeneSpace,
    rows: &[GenerationRow],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let shown = shown_generations(rows, 12);
    let profiles: Vec<(usize, Vec<(f64, f64)>)> = shown
        .iter()
        .filter_map(|r| Some((r.index, space.choice(&r.best).ok()?.profile())))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (-0.05f64, 0.05f64, 0.0f64, 0.05f64);
    for (_, p) in &profiles {
        for &(x, y) in p {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    let pad = 0.05 * (x1 - x0).max(y1 - y0);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("{title}: best shape of successive generations"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(x0 - pad..x1 + pad, y0 - pad..y1 + pad)
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("along the wall (m)")
        .y_desc("out of the wall (m)")
        .label_style((FONT, 14))
        .draw()
        .map_err(msg)?;
    let n = profiles.len().max(2) - 1;
    for (k, (gen, p)) in profiles.iter().enumerate() {
        // Light grey-blue for the first generation shown to full colour for the last.
        let t = k as f64 / n as f64;
        let mix = |a: u8, b: u8| (f64::from(a) + t * (f64::from(b) - f64::from(a))) as u8;
        let c = RGBColor(
            mix(200, style::ESTIMATE.0),
            mix(210, style::ESTIMATE.1),
            mix(225, style::ESTIMATE.2),
        );
        let st = ShapeStyle::from(&c).stroke_width(if k == n { 3 } else { 1 });
        let s = chart
            .draw_series(LineSeries::new(p.iter().copied(), st))
            .map_err(msg)?;
        if k == 0 || k == n {
            s.label(format!("generation {}", gen + 1))
                .legend(swatch(st));
        }
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
    root.present().map_err(msg)
}

/// Histogram counts of `values` in `bins` equal bins over `[lo, hi]`.
pub fn histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut counts = vec![0; bins];
    if bins == 0 || hi <= lo {
        return counts;
    }
    for &v in values.iter().filter(|v| v.is_finite()) {
        let k = (((v - lo) / (hi - lo)) * bins as f64).floor();
        counts[(k.max(0.0) as usize).min(bins - 1)] += 1;
    }
    counts
}

/// Draws Figure 8.
fn spacing_histogram<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    space: &GeneSpace,
    first: (usize, &[f64]),
    last: (usize, &[f64]),
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let (lo, hi) = space.bounds[GeneSpace::SPACING];
    let bins = 40;
    let a = histogram(first.1, lo, hi, bins);
    let b = histogram(last.1, lo, hi, bins);
    let top = a.iter().chain(&b).copied().max().unwrap_or(1).max(1) as f64 * 1.1;
    let w = (hi - lo) / bins as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(format!("{title}: spacing gene D"), (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(lo..hi, 0.0..top)
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("D (m)")
        .y_desc("individuals")
        .label_style((FONT, 14))
        .draw()
        .map_err(msg)?;
    for (counts, colour, label, offset) in [
        (
            &a,
            style::ODOMETRY,
            format!("generation {}", first.0 + 1),
            0.0,
        ),
        (
            &b,
            style::ESTIMATE,
            format!("generation {}", last.0 + 1),
            0.5,
        ),
    ] {
        let fill = colour.mix(0.7).filled();
        chart
            .draw_series(
                counts
                    .iter()
                    .enumerate()
                    .filter(|(_, &c)| c > 0)
                    .map(|(k, &c)| {
                        let x = lo + k as f64 * w + offset * w;
                        Rectangle::new([(x, 0.0), (x + 0.5 * w, c as f64)], fill)
                    }),
            )
            .map_err(msg)?
            .label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], fill));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
    root.present().map_err(msg)
}

/// Writes the three figures of a search into `dir`. `first` and `last` are the first and
/// last generations' populations (index, individuals). Returns the files written.
pub fn write_figures(
    dir: &Path,
    title: &str,
    space: &GeneSpace,
    rows: &[GenerationRow],
    first: (usize, &[Genes]),
    last: (usize, &[Genes]),
) -> Result<Vec<PathBuf>, PlotError> {
    style::register_font();
    let mut written = Vec::new();
    plot_both!(dir, "convergence", CHART_SIZE, &mut written, |r| {
        convergence(r, title, rows)
    })?;
    plot_both!(dir, "shapes", CHART_SIZE, &mut written, |r| shapes(
        r, title, space, rows
    ))?;
    let d = |p: &[Genes]| -> Vec<f64> { p.iter().map(|g| g[GeneSpace::SPACING]).collect() };
    let (d_first, d_last) = (d(first.1), d(last.1));
    plot_both!(dir, "spacing_histogram", CHART_SIZE, &mut written, |r| {
        spacing_histogram(r, title, space, (first.0, &d_first), (last.0, &d_last))
    })?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_bins_and_edges() {
        assert_eq!(
            histogram(&[0.0, 0.49, 0.5, 1.0, 2.0, -1.0, f64::NAN], 0.0, 1.0, 2),
            vec![3, 3]
        );
        let rows: Vec<GenerationRow> = (0..30)
            .map(|i| GenerationRow {
                index: i,
                new_evaluations: 1,
                best_fitness: 1.0,
                best: vec![],
                median_fitness: 1.0,
            })
            .collect();
        let s = shown_generations(&rows, 12);
        assert_eq!(s.len(), 12);
        assert_eq!(s[0].index, 0);
        assert_eq!(s[11].index, 29);
    }
}
