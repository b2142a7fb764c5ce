//! Text reports for people: one run's figures, and runs side by side in a table (the
//! demo). Lengths print in millimetres below a metre and in metres above.

use std::fmt::Write;

use crate::closed_loop::RunLog;
use crate::metrics::{Accuracy, Metrics};

/// A length for people: `12.3 mm` or `4.56 m`.
pub fn length(m: f64) -> String {
    if !m.is_finite() {
        "-".into()
    } else if m.abs() < 1.0 {
        format!("{:.1} mm", m * 1000.0)
    } else {
        format!("{m:.2} m")
    }
}

/// An angle for people, in milliradians.
pub fn angle(rad: f64) -> String {
    format!("{:.2} mrad", rad * 1000.0)
}

/// One column of a comparison: a heading and a run with its figures. `odometry = true`
/// reports the run's odometry-alone figures instead of the estimator's.
pub struct Column<'a> {
    /// Column heading.
    pub heading: String,
    /// The run.
    pub log: &'a RunLog,
    /// Its figures.
    pub metrics: &'a Metrics,
    /// Report odometry alone.
    pub odometry: bool,
}

fn accuracy<'a>(c: &'a Column<'_>) -> &'a Accuracy {
    if c.odometry {
        &c.metrics.odometry
    } else {
        &c.metrics.localizer
    }
}

/// A table with one row per figure and one column per run.
pub fn comparison_table(columns: &[Column<'_>]) -> String {
    type Row<'r> = (&'r str, Box<dyn Fn(&Column<'_>) -> String + 'r>);
    let rows: Vec<Row<'_>> = vec![
        (
            "position RMS",
            Box::new(|c| length(accuracy(c).position_rms_m)),
        ),
        (
            "  along the tunnel",
            Box::new(|c| length(accuracy(c).along_rms_m)),
        ),
        (
            "  across the tunnel",
            Box::new(|c| length(accuracy(c).across_rms_m)),
        ),
        (
            "  odometry distance error",
            Box::new(|c| {
                if c.odometry {
                    length(c.metrics.odometry_distance_error_rms_m)
                } else {
                    "-".into()
                }
            }),
        ),
        (
            "heading RMS",
            Box::new(|c| angle(accuracy(c).heading_rms_rad)),
        ),
        (
            "eq. 2 RMS (x, y, θ)",
            Box::new(|c| format!("{:.4}", accuracy(c).rms_eq2)),
        ),
        (
            "max position error",
            Box::new(|c| length(accuracy(c).max_position_error_m)),
        ),
        (
            "first 100 m position RMS",
            Box::new(|c| length(accuracy(c).first_100m_position_rms_m)),
        ),
        (
            "last 100 m position RMS",
            Box::new(|c| length(accuracy(c).last_100m_position_rms_m)),
        ),
        (
            "position error at the end",
            Box::new(|c| length(accuracy(c).final_position_error_m)),
        ),
        ("scans", Box::new(|c| c.metrics.scans.to_string())),
        (
            "localiser CPU time per scan",
            Box::new(|c| {
                if c.odometry {
                    "-".into()
                } else {
                    format!("{:.0} µs", c.metrics.mean_us_per_scan)
                }
            }),
        ),
        (
            "faster than real time (1 core)",
            Box::new(|c| {
                if c.odometry {
                    "-".into()
                } else {
                    format!("{:.0}×", c.log.scan_cpu_real_time_factor())
                }
            }),
        ),
    ];
    let label_w = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0) + 2;
    let cells: Vec<Vec<String>> = rows
        .iter()
        .map(|(_, f)| columns.iter().map(f).collect())
        .collect();
    let col_w: Vec<usize> = (0..columns.len())
        .map(|i| {
            cells
                .iter()
                .map(|r| r[i].chars().count())
                .chain(std::iter::once(columns[i].heading.chars().count()))
                .max()
                .unwrap_or(0)
                + 3
        })
        .collect();
    let mut out = String::new();
    let _ = write!(out, "{:label_w$}", "");
    for (c, w) in columns.iter().zip(&col_w) {
        let _ = write!(out, "{:>w$}", c.heading, w = *w);
    }
    out.push('\n');
    let total: usize = label_w + col_w.iter().sum::<usize>();
    out.push_str(&"-".repeat(total));
    out.push('\n');
    for ((label, _), row) in rows.iter().zip(&cells) {
        let pad = label_w.saturating_sub(label.chars().count());
        let _ = write!(out, "{label}{}", " ".repeat(pad));
        for (cell, w) in row.iter().zip(&col_w) {
            let pad = w.saturating_sub(cell.chars().count());
            let _ = write!(out, "{}{cell}", " ".repeat(pad));
        }
        out.push('\n');
    }
    out
}

/// A few lines describing the scenario of a run.
pub fn scenario_line(log: &RunLog) -> String {
    let s = &log.scenario;
    let w = &log.world;
    let choice = s.landmark_choice().map(|c| c.code()).unwrap_or("?");
    let mut text = format!(
        "{}: {:.0} m tunnel, {:.1} m wide, wall roughness {} (σ); LMS511 {:.0} Hz, range noise {}; \
         drive {:.0} m at up to {:.1} m/s; seed {}",
        s.name,
        w.tunnel_length_m,
        w.width_m,
        length(s.tunnel.roughness_sigma_m),
        s.lidar.rate.frequency_hz(),
        length(s.lidar.range_noise_m),
        log.samples.last().map_or(0.0, |x| x.distance_m),
        s.drive.cruise_speed_mps,
        s.seed
    );
    if choice != "none" {
        let _ = write!(
            text,
            "\nlandmarks {choice} (genes {:?}) on {}: {} designed{}; matcher {}",
            s.landmark_choice().map(|c| c.genes()).unwrap_or_default(),
            match s.landmarks.walls {
                crate::world::layout::WallChoice::Both => "both walls",
                crate::world::layout::WallChoice::Left => "the left wall",
                crate::world::layout::WallChoice::Right => "the right wall",
            },
            w.landmarks_designed,
            match (w.landmarks_missing, w.landmarks_damaged) {
                (Some(m), Some(d)) => format!(", {m} missing, {d} damaged"),
                _ => String::new(),
            },
            s.localizer.matcher.name()
        );
    } else {
        let _ = write!(
            text,
            "\nno landmarks; matcher {}",
            s.localizer.matcher.name()
        );
    }
    text
}

/// How many scans ended in each estimator status, e.g. `scans: 8384 tracking, 19
/// degenerate (along-tunnel unobserved)`.
pub fn status_line(log: &RunLog) -> String {
    let mut counts: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for s in &log.statuses {
        *counts.entry(s.label()).or_insert(0) += 1;
    }
    let parts: Vec<String> = counts
        .iter()
        .map(|(k, n)| match *k {
            "degenerate" => format!("{n} degenerate (along-tunnel unobserved)"),
            other => format!("{n} {other}"),
        })
        .collect();
    format!("scans: {}", parts.join(", "))
}

/// Position error against distance driven, in 100 m stretches (from the 10 m bins of the
/// metrics): `to 100 m: 7.5 mm (odometry 1.43 m)`, one line per stretch. Empty for runs
/// shorter than 150 m.
pub fn distance_lines(m: &Metrics) -> String {
    if m.distance_m < 150.0 {
        return String::new();
    }
    let mut out =
        String::from("position RMS against distance driven (localiser / odometry alone):\n");
    let mut stretch = 100.0;
    while stretch < m.distance_m + 100.0 {
        let bins: Vec<_> = m
            .by_distance
            .iter()
            .filter(|b| b.distance_m > stretch - 100.0 && b.distance_m <= stretch)
            .collect();
        if !bins.is_empty() {
            let n = bins.len() as f64;
            let loc = (bins.iter().map(|b| b.position_rms_m.powi(2)).sum::<f64>() / n).sqrt();
            let odo = (bins
                .iter()
                .map(|b| b.odometry_position_rms_m.powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            let _ = writeln!(
                out,
                "  {:>5.0}–{:<5.0} m  {:>10} / {}",
                stretch - 100.0,
                stretch.min(m.distance_m),
                length(loc),
                length(odo)
            );
        }
        stretch += 100.0;
    }
    out
}

/// The report of one run: scenario, then the run beside odometry alone.
pub fn run_report(log: &RunLog, m: &Metrics) -> String {
    let cols = [
        Column {
            heading: log.estimator.clone(),
            log,
            metrics: m,
            odometry: false,
        },
        Column {
            heading: "odometry alone".into(),
            log,
            metrics: m,
            odometry: true,
        },
    ];
    let by_distance = distance_lines(m);
    let mut text = format!(
        "{}\n\n{}\n{}",
        scenario_line(log),
        comparison_table(&cols),
        status_line(log)
    );
    if let Some(p) = crate::metrics::ProtectionSummary::of(&log.samples) {
        text.push('\n');
        text.push_str(&p.line());
    }
    if !by_distance.is_empty() {
        text.push_str("\n\n");
        text.push_str(by_distance.trim_end());
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;

    #[test]
    fn table_has_every_row_and_aligned_columns() {
        let s = named("paper-10m").unwrap();
        let log = crate::session::odometry_run(&s);
        let m = log.metrics();
        let text = run_report(&log, &m);
        assert!(text.contains("paper-10m") && text.contains("landmarks P1"));
        let table: Vec<&str> = text
            .lines()
            .skip_while(|l| !l.starts_with("   "))
            .take_while(|l| !l.is_empty())
            .collect();
        let status = format!("scans: {} odometry", log.samples.len());
        assert!(text.ends_with(&status), "{text}");
        assert!(table.len() >= 14, "{text}");
        let widths: Vec<usize> = table
            .iter()
            .filter(|l| !l.starts_with('-'))
            .map(|l| l.chars().count())
            .collect();
        assert!(widths.windows(2).all(|w| w[0] == w[1]), "{text}");
        assert!(distance_lines(&m).is_empty(), "a 10 m run has no stretches");
        assert_eq!(length(0.0123), "12.3 mm");
        assert_eq!(length(4.561), "4.56 m");
    }

    #[test]
    fn distance_lines_per_100_m() {
        use crate::metrics::{compute, Sample};
        use crate::vehicle::SimPose;
        use crate::world::centerline::{CenterLine, CurvePiece};
        let line = CenterLine::from_pieces(&[CurvePiece {
            length_m: 300.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        let p = |x: f64, y: f64| SimPose {
            x_m: x,
            y_m: y,
            theta_rad: 0.0,
        };
        // 250 m: the estimate 1 cm off before 100 m and 2 cm after; odometry 1 m off.
        let samples: Vec<Sample> = (1..=250)
            .map(|i| {
                let d = f64::from(i);
                Sample {
                    t_s: d,
                    distance_m: d,
                    chainage_m: d,
                    truth: p(d, 0.0),
                    estimate: p(d, if d <= 100.0 { 0.01 } else { 0.02 }),
                    odometry: p(d, 1.0),
                    sigma: (0.0, 0.0, 0.0),
                    protection: None,
                    update_us: 1.0,
                }
            })
            .collect();
        let text = distance_lines(&compute(&line, &samples, 10.0));
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4, "{text}");
        assert!(
            lines[1].contains("10.0 mm") && lines[1].contains("1.00 m"),
            "{text}"
        );
        // The 100–110 m bin still holds the sample at 100 m (1 cm): 19.9 mm.
        assert!(
            lines[2].contains("19.9 mm") && lines[3].contains("–250"),
            "{text}"
        );
    }
}
