//! What the plots share: the embedded font, colours per pose source, and the error type.
//!
//! Text is drawn with plotters' `ab_glyph` feature and DejaVu Sans from the `dejavu` crate,
//! registered once as `sans-serif`: no system font library (fontconfig, freetype) is needed.

use std::sync::Once;

use plotters::style::{FontStyle, RGBColor};

/// Font family name the plots use.
pub const FONT: &str = "sans-serif";

/// Ground truth.
pub const TRUTH: RGBColor = RGBColor(0, 0, 0);
/// The localiser's estimate.
pub const ESTIMATE: RGBColor = RGBColor(31, 119, 180);
/// Odometry alone.
pub const ODOMETRY: RGBColor = RGBColor(214, 39, 40);
/// Tunnel walls.
pub const WALL: RGBColor = RGBColor(120, 120, 120);
/// Landmarks.
pub const LANDMARK: RGBColor = RGBColor(44, 160, 44);
/// A second quantity of the same source (e.g. σy beside σx).
pub const SECOND: RGBColor = RGBColor(255, 127, 14);

/// Width of data lines, pixels. One: plotters joins wider polylines with mitres, and the
/// sharp zig-zags of noisy per-scan data then grow spikes far beyond the data.
pub const DATA_LINE_PX: u32 = 1;

static FONT_REGISTERED: Once = Once::new();

/// Registers the embedded font (once per process).
pub fn register_font() {
    FONT_REGISTERED.call_once(|| {
        // DejaVu Sans is a valid TrueType font: registration cannot fail on it; if it ever
        // did, text would be missing from the plots, not the plots themselves.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Turns any drawing error into its message.
pub fn msg<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// The range of a log axis for `values`: from a little under the smallest positive value
/// (never below 1e-6) to a little over the largest, at least one decade wide.
pub fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (1e-4, 1.0);
    }
    let lo = (lo / 1.5).max(1e-6);
    (lo, (hi * 1.5).max(lo * 10.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_range_spans_the_data_and_a_decade() {
        assert_eq!(log_range([0.0, f64::NAN].into_iter()), (1e-4, 1.0));
        let (lo, hi) = log_range([0.003, 0.3, 0.0].into_iter());
        assert!((lo - 0.002).abs() < 1e-12 && (hi - 0.45).abs() < 1e-12);
        let (lo, hi) = log_range([1e-9].into_iter());
        assert!(lo == 1e-6 && (hi - 1e-5).abs() < 1e-18);
    }
}
