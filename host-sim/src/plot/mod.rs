//! Plots of a run (or a replay) into its `--out` directory, each as PNG and SVG:
//! - `map.png|svg` ([`map_view`]): walls and landmarks with the true, estimated and odometry
//!   paths;
//! - `error_vs_distance.png|svg` ([`error_plot`]): position error against distance driven,
//!   localiser and odometry alone;
//! - `covariance.png|svg` ([`covariance_plot`]): the localiser's 1σ along the run beside its
//!   actual error.
//!
//! Drawn with `plotters` (bitmap and SVG backends) and an embedded font ([`style`]).

pub mod chart;
pub mod covariance_plot;
pub mod error_plot;
pub mod map_lines;
pub mod map_view;
pub mod style;

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::closed_loop::RunLog;
use map_lines::MapLines;

/// Why a plot could not be written.
pub type PlotError = crate::output::OutputError;

/// Image size of the map, pixels.
pub const MAP_SIZE: (u32, u32) = (1600, 800);
/// Image size of the error and covariance plots, pixels.
pub const CHART_SIZE: (u32, u32) = (1400, 800);

/// [`both`] with one drawing expression for the two backends (a closure cannot be generic
/// over them, so the expression is written into both).
macro_rules! plot_both {
    ($dir:expr, $name:expr, $size:expr, $written:expr, |$r:ident| $draw:expr) => {
        $crate::plot::both($dir, $name, $size, |$r| $draw, |$r| $draw, $written)
    };
}
pub(crate) use plot_both;

/// Draws `f` into `DIR/NAME.png` and `DIR/NAME.svg`.
pub(crate) fn both(
    dir: &Path,
    name: &str,
    size: (u32, u32),
    f: impl Fn(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
    g: impl Fn(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
    written: &mut Vec<PathBuf>,
) -> Result<(), PlotError> {
    let png = dir.join(format!("{name}.png"));
    f(&BitMapBackend::new(&png, size).into_drawing_area())
        .map_err(|reason| PlotError::new(&png, reason))?;
    written.push(png);
    let svg = dir.join(format!("{name}.svg"));
    g(&SVGBackend::new(&svg, size).into_drawing_area())
        .map_err(|reason| PlotError::new(&svg, reason))?;
    written.push(svg);
    Ok(())
}

/// Writes the three plots of `log` (with the stored map's `lines`) into `dir`, which must
/// exist. Returns the files written.
pub fn write_plots(dir: &Path, log: &RunLog, lines: &MapLines) -> Result<Vec<PathBuf>, PlotError> {
    style::register_font();
    let title = format!("{} ({})", log.scenario.name, log.estimator);
    let s = &log.samples;
    let mut written = Vec::new();
    plot_both!(dir, "map", MAP_SIZE, &mut written, |r| map_view::draw(
        r, &title, lines, s
    ))?;
    plot_both!(dir, "error_vs_distance", CHART_SIZE, &mut written, |r| {
        error_plot::draw(r, &title, s)
    })?;
    plot_both!(dir, "covariance", CHART_SIZE, &mut written, |r| {
        covariance_plot::draw(r, &title, s)
    })?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::scenario_map;
    use crate::scenario::named::named;

    #[test]
    fn writes_png_and_svg_of_each_plot_with_text() {
        let mut s = named("paper-10m").unwrap();
        s.drive.end_m = s.drive.start_m + 3.0;
        let log = crate::session::odometry_run(&s);
        let (map, _) = scenario_map(&s).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files = write_plots(dir.path(), &log, &MapLines::of(&map)).unwrap();
        assert_eq!(files.len(), 6);
        for f in &files {
            let bytes = std::fs::read(f).unwrap();
            if f.extension().is_some_and(|e| e == "png") {
                assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", f.display());
                let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
                let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
                let want = if f.ends_with("map.png") {
                    MAP_SIZE
                } else {
                    CHART_SIZE
                };
                assert_eq!((w, h), want);
                // A drawn chart, not a blank canvas: compressed size well above a white image.
                assert!(
                    bytes.len() > 20_000,
                    "{} is {} bytes",
                    f.display(),
                    bytes.len()
                );
            } else {
                let text = String::from_utf8(bytes).unwrap();
                assert!(text.starts_with("<svg"), "{}", f.display());
                assert!(text.contains("<polyline") || text.contains("<path"));
            }
        }
        let svg = std::fs::read_to_string(dir.path().join("error_vs_distance.svg")).unwrap();
        assert!(svg.contains("distance driven (m)") && svg.contains("odometry alone"));
        let svg = std::fs::read_to_string(dir.path().join("map.svg")).unwrap();
        assert!(svg.contains("landmarks") && svg.contains("ground truth"));
    }
}
