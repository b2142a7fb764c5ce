//! Ground truth at the scan times of a replay, and the per-scan [`Sample`]s the metrics take.
//!
//! A recording of a run has a truth row at every scan's exact time; other logs (e.g. RTK-GPS
//! at its own rate) are interpolated linearly between the rows around a scan. Scans before
//! the first or after the last truth row are not scored. Distance driven and chainage come
//! from the log's columns when present; otherwise the distance is the length of the truth
//! path and the chainage the projection onto the scenario's centre line.

use crate::metrics::Sample;
use crate::record::truth_csv::TruthRow;
use crate::vehicle::SimPose;
use crate::world::centerline::CenterLine;

use super::ReplayStep;

fn lerp(a: f64, b: f64, u: f64) -> f64 {
    a + (b - a) * u
}

/// The truth at `t_s`: `(pose, distance_m, chainage_m if logged)`; `None` outside the log.
/// `path_m[i]` is the truth path's length up to row `i`; `cursor` speeds up time-ordered
/// queries.
fn truth_at(
    rows: &[TruthRow],
    path_m: &[f64],
    t_s: f64,
    cursor: &mut usize,
) -> Option<(SimPose, f64, Option<f64>)> {
    while *cursor + 1 < rows.len() && rows.get(*cursor + 1)?.t_s <= t_s {
        *cursor += 1;
    }
    let i = *cursor;
    let a = rows.get(i)?;
    let dist = |r: &TruthRow, k: usize| {
        r.distance_m
            .unwrap_or(path_m.get(k).copied().unwrap_or(0.0))
    };
    if a.t_s == t_s {
        return Some((a.pose, dist(a, i), a.chainage_m));
    }
    let b = rows.get(i + 1)?;
    if !(a.t_s < t_s && t_s < b.t_s) {
        return None;
    }
    let u = (t_s - a.t_s) / (b.t_s - a.t_s);
    let pose = SimPose {
        x_m: lerp(a.pose.x_m, b.pose.x_m, u),
        y_m: lerp(a.pose.y_m, b.pose.y_m, u),
        theta_rad: lerp(a.pose.theta_rad, b.pose.theta_rad, u),
    };
    let chainage = match (a.chainage_m, b.chainage_m) {
        (Some(x), Some(y)) => Some(lerp(x, y, u)),
        _ => None,
    };
    Some((pose, lerp(dist(a, i), dist(b, i + 1), u), chainage))
}

/// The true pose at `t_s` (interpolated between the rows around it); `None` outside the
/// log. `cursor` speeds up time-ordered queries (start at 0).
pub fn pose_at(rows: &[TruthRow], t_s: f64, cursor: &mut usize) -> Option<SimPose> {
    truth_at(rows, &[], t_s, cursor).map(|(pose, _, _)| pose)
}

/// The scored samples of a replay: `(index of the step, sample)` for every step inside the
/// truth log. `start_chainage_m` seeds the centre-line projection (the drive's start).
pub fn samples(
    steps: &[ReplayStep],
    rows: &[TruthRow],
    line: &CenterLine,
    start_chainage_m: f64,
) -> Vec<(usize, Sample)> {
    let mut path_m = Vec::with_capacity(rows.len());
    let mut acc = 0.0;
    let mut prev: Option<SimPose> = None;
    for r in rows {
        if let Some(p) = prev {
            acc += (r.pose.x_m - p.x_m).hypot(r.pose.y_m - p.y_m);
        }
        prev = Some(r.pose);
        path_m.push(acc);
    }
    let mut cursor = 0usize;
    let mut hint = start_chainage_m;
    let mut out = Vec::with_capacity(steps.len());
    for (i, s) in steps.iter().enumerate() {
        let Some((truth, distance_m, chainage)) = truth_at(rows, &path_m, s.t_s, &mut cursor)
        else {
            continue;
        };
        // The live run projects with the previous scan's chainage as the hint: so does this.
        let chainage_m =
            chainage.unwrap_or_else(|| line.project(truth.x_m, truth.y_m, hint, 5.0).s_m);
        hint = chainage_m;
        out.push((
            i,
            Sample {
                t_s: s.t_s,
                distance_m,
                chainage_m,
                truth,
                estimate: s.estimate,
                odometry: s.odometry,
                sigma: s.sigma,
                protection: s.protection,
                update_us: s.update_us,
            },
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::centerline::CurvePiece;

    fn row(t: f64, x: f64) -> TruthRow {
        TruthRow {
            t_s: t,
            pose: SimPose {
                x_m: x,
                y_m: 0.0,
                theta_rad: 0.0,
            },
            distance_m: None,
            chainage_m: None,
        }
    }

    fn step(t: f64) -> ReplayStep {
        ReplayStep {
            t_s: t,
            estimate: SimPose::default(),
            sigma: (0.0, 0.0, 0.0),
            status: crate::status::EstimatorStatus::Odometry,
            protection: None,
            odometry: SimPose::default(),
            update_us: 0.0,
            bound: None,
        }
    }

    #[test]
    fn exact_rows_interpolation_and_outside_the_log() {
        let line = CenterLine::from_pieces(&[CurvePiece {
            length_m: 100.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        let rows = [row(0.0, 0.0), row(1.0, 2.0), row(2.0, 3.0)];
        let steps = [step(-0.5), step(0.5), step(1.0), step(1.5), step(2.5)];
        let s = samples(&steps, &rows, &line, 0.0);
        let idx: Vec<usize> = s.iter().map(|x| x.0).collect();
        assert_eq!(idx, [1, 2, 3]);
        assert_eq!(s[0].1.truth.x_m, 1.0);
        assert_eq!(s[1].1.truth.x_m, 2.0);
        assert!((s[2].1.distance_m - 2.5).abs() < 1e-12);
        assert!((s[2].1.chainage_m - 2.5).abs() < 1e-9);
    }
}
