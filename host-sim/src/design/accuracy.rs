//! The predicted accuracy of a layout along the tunnel: at every step of chainage, a
//! noise-free LMS511 scan from the centre line, its Cramér–Rao bound (the replay's
//! [`ScanBound`]: loc-core's Fisher information with the localiser's own noise and
//! roughness model) split along and across the tunnel; the stretches above the target.
//! The plot shades the curves and the gaps (chainages no landmark in reach fixes).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;

use crate::lidar::{LidarSpec, Lms511};
use crate::plot::style::{self, msg, FONT};
use crate::plot::{plot_both, PlotError, CHART_SIZE};
use crate::replay::bound::ScanBound;
use crate::scenario::Scenario;
use crate::vehicle::SimPose;
use crate::world::centerline::wrap_pi;
use crate::world::World;

/// Curvature above which a chainage counts as in a curve, 1/m (radius below 5 km).
const CURVE_1PM: f64 = 2e-4;

/// The bound at one chainage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AccuracyPoint {
    /// Chainage, metres.
    pub chainage_m: f64,
    /// 1σ bound along the tunnel, metres (+∞: the scan does not fix the chainage).
    pub along_sd_m: f64,
    /// 1σ bound across the tunnel, metres.
    pub across_sd_m: f64,
    /// Curvature of the centre line, 1/m (signed, left positive).
    pub curvature_1pm: f64,
}

/// A stretch of chainage where the along bound exceeds the target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stretch {
    /// First chainage, metres.
    pub from_m: f64,
    /// Last chainage, metres.
    pub to_m: f64,
    /// The largest along bound in it, metres.
    pub worst_along_sd_m: f64,
    /// Whether any of it is in a curve.
    pub in_curve: bool,
}

/// The bound every `step_m` from `start_m` to `end_m`.
pub fn along_tunnel(
    world: &World,
    map: &loc_core::map::TunnelMap,
    scenario: &Scenario,
    start_m: f64,
    end_m: f64,
    step_m: f64,
) -> Vec<AccuracyPoint> {
    let spec = LidarSpec {
        range_noise_m: 0.0,
        systematic_error_m: 0.0,
        ..scenario.lidar
    };
    let mut lidar = Lms511::new(spec, 0);
    let mut bound = ScanBound::new(map, scenario);
    let line = world.centerline();
    let mut out = Vec::new();
    let mut s = start_m;
    while s <= end_m + 1e-9 {
        let (x, y, h) = line.pose_at(s);
        let scan = lidar.scan(world.grid(), (x, y, h), 0.0);
        let truth = SimPose {
            x_m: x,
            y_m: y,
            theta_rad: h,
        };
        let (t, n) = ((h.cos(), h.sin()), (-h.sin(), h.cos()));
        let (along, across) = match bound.at(&scan, truth) {
            Some(b) => {
                let q = |v: (f64, f64)| {
                    b[(0, 0)] * v.0 * v.0 + 2.0 * b[(0, 1)] * v.0 * v.1 + b[(1, 1)] * v.1 * v.1
                };
                (q(t).max(0.0).sqrt(), q(n).max(0.0).sqrt())
            }
            None => (f64::INFINITY, f64::INFINITY),
        };
        let (a, b) = (line.pose_at((s - 1.0).max(0.0)).2, line.pose_at(s + 1.0).2);
        let ds = (s + 1.0).min(line.length_m()) - (s - 1.0).max(0.0);
        out.push(AccuracyPoint {
            chainage_m: s,
            along_sd_m: along,
            across_sd_m: across,
            curvature_1pm: wrap_pi(b - a) / ds.max(1e-9),
        });
        s += step_m;
    }
    out
}

/// The stretches where the along bound exceeds `target_m`.
pub fn stretches_above(points: &[AccuracyPoint], target_m: f64) -> Vec<Stretch> {
    let mut out: Vec<Stretch> = Vec::new();
    let mut open: Option<Stretch> = None;
    for p in points {
        let curve = p.curvature_1pm.abs() > CURVE_1PM;
        if p.along_sd_m > target_m {
            let st = open.get_or_insert(Stretch {
                from_m: p.chainage_m,
                to_m: p.chainage_m,
                worst_along_sd_m: 0.0,
                in_curve: false,
            });
            st.to_m = p.chainage_m;
            st.worst_along_sd_m = st.worst_along_sd_m.max(p.along_sd_m);
            st.in_curve |= curve;
        } else if let Some(st) = open.take() {
            out.push(st);
        }
    }
    out.extend(open);
    out
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    points: &[AccuracyPoint],
    target_m: f64,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    let shown = |v: f64| (v * 1e3).clamp(0.01, 1e4);
    let (y0, y1) = style::log_range(
        points
            .iter()
            .flat_map(|p| [shown(p.along_sd_m), shown(p.across_sd_m)])
            .chain([target_m * 1e3]),
    );
    let (x0, x1) = (
        points.first().map_or(0.0, |p| p.chainage_m),
        points.last().map_or(1.0, |p| p.chainage_m).max(1.0),
    );
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("{title}: predicted accuracy (per-scan Cramér–Rao bound)"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("chainage (m)")
        .y_desc("1σ bound (mm, log scale)")
        .label_style((FONT, 14))
        .draw()
        .map_err(msg)?;
    // Curves shaded.
    let curve = RGBColor(230, 230, 230).filled();
    chart
        .draw_series(
            points
                .windows(2)
                .filter(|w| w[0].curvature_1pm.abs() > CURVE_1PM)
                .map(|w| Rectangle::new([(w[0].chainage_m, y0), (w[1].chainage_m, y1)], curve)),
        )
        .map_err(msg)?
        .label("in a curve")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], curve));
    // Gaps: no landmark in reach, the chainage not fixed at all.
    let gap = RGBColor(250, 200, 200).filled();
    chart
        .draw_series(
            points
                .windows(2)
                .filter(|w| !w[0].along_sd_m.is_finite())
                .map(|w| Rectangle::new([(w[0].chainage_m, y0), (w[1].chainage_m, y1)], gap)),
        )
        .map_err(msg)?
        .label("gap: no landmark in reach")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], gap));
    for (label, colour, f) in [
        (
            "across",
            style::SECOND,
            (|p: &AccuracyPoint| p.across_sd_m) as fn(&AccuracyPoint) -> f64,
        ),
        ("along", style::ESTIMATE, |p: &AccuracyPoint| p.along_sd_m),
    ] {
        let st = ShapeStyle::from(&colour).stroke_width(style::DATA_LINE_PX);
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|p| (p.chainage_m, shown(f(p)))),
                st,
            ))
            .map_err(msg)?
            .label(label)
            .legend(crate::plot::chart::swatch(st));
    }
    let st = ShapeStyle::from(&style::ODOMETRY).stroke_width(2);
    chart
        .draw_series(LineSeries::new(
            [(x0, target_m * 1e3), (x1, target_m * 1e3)],
            st,
        ))
        .map_err(msg)?
        .label("target (along)")
        .legend(crate::plot::chart::swatch(st));
    crate::plot::chart::legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
    root.present().map_err(msg)
}

/// Writes `accuracy.png` and `accuracy.svg` into `dir`.
pub fn write_plot(
    dir: &Path,
    title: &str,
    points: &[AccuracyPoint],
    target_m: f64,
) -> Result<Vec<PathBuf>, PlotError> {
    style::register_font();
    let mut written = Vec::new();
    plot_both!(dir, "accuracy", CHART_SIZE, &mut written, |r| draw(
        r, title, points, target_m
    ))?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stretches_join_consecutive_misses() {
        let p = |s: f64, a: f64, k: f64| AccuracyPoint {
            chainage_m: s,
            along_sd_m: a,
            across_sd_m: 0.001,
            curvature_1pm: k,
        };
        let pts = [
            p(0.0, 0.001, 0.0),
            p(1.0, 0.02, 0.0),
            p(2.0, 0.03, 0.003),
            p(3.0, 0.001, 0.0),
            p(4.0, f64::INFINITY, 0.0),
        ];
        let s = stretches_above(&pts, 0.01);
        assert_eq!(s.len(), 2);
        assert_eq!((s[0].from_m, s[0].to_m, s[0].in_curve), (1.0, 2.0, true));
        assert_eq!(s[0].worst_along_sd_m, 0.03);
        assert_eq!((s[1].from_m, s[1].to_m), (4.0, 4.0));
    }
}
