//! Keyframe to keyframe from the scans themselves: the later keyframe's wall points matched
//! by loc-core's point-to-line ICP against the earlier keyframe's walls.
//!
//! Both scans see the same stretch of rough wall, so its roughness is shared structure, not
//! noise: the match gives the across-tunnel offset and the heading change to a fraction of
//! a millimetre and a tenth of a milliradian, where one wall model fitted per scan (the
//! stripper's cubic) moves by millimetres from scan to scan as its window slides over the
//! roughness. Along the tunnel the walls say little and the matcher claims more than it
//! knows (the texture seen twice), so the factor keeps the odometry's along-tunnel position
//! and no information there: a survey without landmarks stays honest about its extent.
//!
//! The earlier keyframe's walls become a loc-core [`TunnelMap`] in its own vehicle frame
//! (wall points averaged in runs of a few centimetres, so that the polyline is not the
//! scanner's zig-zag); the landmark points of both scans are left out (the landmark fits
//! carry them).

use loc_core::geometry::{Point2, Pose2};
use loc_core::map::TunnelMap;
use loc_core::matching::{
    match_scan, MatchConfig, MatchWorkspace, MatcherKind, RoughnessModel, MAX_MATCH_POINTS,
};
use loc_core::strip::PointLabel;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::graph::Relative;
use super::keyframes::Keyframe;
use crate::vehicle::SimPose;

/// Keyframe distances (in keyframes) over which scans are matched: 0.25 m to 4 m at the
/// default spacing. Errors against the truth on `tunnel-1km` (across, heading): 0.9 mm and
/// 0.13 mrad at 1 and 4, 1.0 mm and 0.16 mrad at 8, 1.7 mm and 0.4 mrad at 16; at 32 the
/// scans overlap too little (64 mm, 27 mrad) and it is not used. The longer baselines keep
/// the heading from drifting as a random walk of the short ones.
pub const BASELINES: [usize; 4] = [1, 4, 8, 16];

/// Keyframes farther apart than this are not matched (after dropped scans), metres: the
/// longest baseline at the keyframes' real spacing (0.25 m and up to one scan's motion more,
/// 0.36 m at 3 m/s and 25 Hz) with some slack.
pub const MAX_BASELINE_M: f64 = 7.0;

/// Wall points closer than this along the wall are averaged into one vertex of the
/// earlier keyframe's walls, metres.
pub const VERTEX_RUN_M: f64 = 0.06;

/// Most points averaged into one vertex.
const VERTEX_RUN_POINTS: usize = 4;

/// Polyline gaps longer than this split a wall (an occlusion, a cross-cut), metres; the
/// part nearer the scanner is kept.
const MAX_VERTEX_GAP_M: f64 = 1.5;

/// Variance along the tunnel of a scan-to-scan factor, m² (10 m: nothing).
const UNOBSERVED_ALONG_VARIANCE_M2: f64 = 100.0;

/// Index cell of the per-keyframe wall map, metres.
const CELL_M: f32 = 1.0;

/// A scan-to-scan match is refused when its RMS residual exceeds this, metres (the walls
/// changed between the scans: a vehicle passing, a door).
const MAX_RMS_M: f32 = 0.05;

/// The match configuration for scan-to-scan: loc-core's ICP with the localiser's gates and
/// noise, and smooth walls (the roughness is in both scans, not between them).
pub fn scan_match_config(localizer: &MatchConfig) -> MatchConfig {
    MatchConfig {
        matcher: MatcherKind::Icp,
        roughness: RoughnessModel::SMOOTH,
        // Offline: every match runs to its optimum (the work budget is the controller's
        // real-time bound, and a step cut short would be a factor's error).
        max_work: u32::MAX,
        ..*localizer
    }
}

/// One wall of a keyframe (points with `label`, vehicle frame) as averaged vertices in the
/// order of increasing x, cut at the first long gap on either side of the scanner.
fn wall_vertices(kf: &Keyframe, label: PointLabel) -> Vec<Point2> {
    let mut pts: Vec<(f64, f64)> = kf
        .points
        .iter()
        .zip(&kf.labels)
        .filter(|(_, l)| **l == label)
        .map(|(p, _)| *p)
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut vertices: Vec<(f64, f64)> = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    let flush = |run: &mut Vec<(f64, f64)>, out: &mut Vec<(f64, f64)>| {
        if !run.is_empty() {
            let n = run.len() as f64;
            let s = run.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
            out.push((s.0 / n, s.1 / n));
            run.clear();
        }
    };
    for p in pts {
        if run
            .first()
            .is_some_and(|f| p.0 - f.0 > VERTEX_RUN_M || run.len() >= VERTEX_RUN_POINTS)
        {
            flush(&mut run, &mut vertices);
        }
        run.push(p);
    }
    flush(&mut run, &mut vertices);
    // Keep the stretch around the scanner unbroken by long gaps.
    let centre = vertices.partition_point(|v| v.0 < 0.0);
    let gap = |i: usize| {
        let (a, b) = (vertices[i], vertices[i + 1]);
        (b.0 - a.0).hypot(b.1 - a.1) > MAX_VERTEX_GAP_M
    };
    let mut lo = centre.min(vertices.len().saturating_sub(1));
    while lo > 0 && !gap(lo - 1) {
        lo -= 1;
    }
    let mut hi = lo;
    while hi + 1 < vertices.len() && !gap(hi) {
        hi += 1;
    }
    vertices
        .get(lo..=hi.min(vertices.len().saturating_sub(1)))
        .unwrap_or_default()
        .iter()
        .map(|&(x, y)| Point2::new(x as f32, y as f32))
        .collect()
}

/// Rebuilds `map` as keyframe `kf`'s walls in its vehicle frame; false when neither wall
/// has two vertices.
pub fn wall_map(kf: &Keyframe, map: &mut TunnelMap) -> bool {
    let left = wall_vertices(kf, PointLabel::LeftWall);
    let right = wall_vertices(kf, PointLabel::RightWall);
    let usable = |w: &[Point2]| w.len() >= 2;
    if !usable(&left) && !usable(&right) {
        return false;
    }
    let empty: &[Point2] = &[];
    let pick = |w: &[Point2]| {
        if usable(w) {
            w.to_vec()
        } else {
            empty.to_vec()
        }
    };
    map.rebuild(&pick(&left), &pick(&right), &[], CELL_M)
        .is_ok()
}

/// The wall points of `kf` (vehicle frame), spread evenly, at most [`MAX_MATCH_POINTS`].
fn match_points(kf: &Keyframe) -> Vec<Point2> {
    let walls: Vec<Point2> = kf
        .points
        .iter()
        .zip(&kf.labels)
        .filter(|(_, l)| matches!(l, PointLabel::LeftWall | PointLabel::RightWall))
        .map(|(p, _)| Point2::new(p.0 as f32, p.1 as f32))
        .collect();
    let every = walls.len().div_ceil(MAX_MATCH_POINTS).max(1);
    walls.into_iter().step_by(every).collect()
}

/// Keyframe `b` (index `to`) matched against `a`'s walls (`a_map`, from [`wall_map`]),
/// starting from `initial` (`b` in `a`'s frame, the odometry's). The factor carries `b` in
/// `a`'s frame with the matcher's covariance, reordered to `(θ, x, y)` in `b`'s frame; the
/// along-tunnel direction of a smooth tunnel stays at `initial`, with no information. `None` when the
/// match fails or fits badly.
#[allow(clippy::too_many_arguments)]
pub fn match_keyframes(
    a_map: &TunnelMap,
    from: usize,
    b: &Keyframe,
    to: usize,
    initial: SimPose,
    config: &MatchConfig,
    workspace: &mut MatchWorkspace,
) -> Option<Relative> {
    let points = match_points(b);
    let start = Pose2::new(
        initial.x_m as f32,
        initial.y_m as f32,
        initial.theta_rad as f32,
    );
    let m = match_scan(a_map, &points, start, config, workspace).ok()?;
    if m.cost_m.is_nan() || m.cost_m > MAX_RMS_M {
        return None;
    }
    // Across and heading only: along the tunnel the wall texture seen twice moves the match
    // by centimetres with millimetres claimed (measured on `tunnel-1km`: 15 mm error
    // against 3.7 mm claimed per 0.25 m). So the match slides back along its least-observed
    // direction `u` (the tunnel's axis, with the heading change that goes with it in a
    // curve) to the odometry's along-tunnel position, and its information along `u` is
    // dropped.
    let u = Vector3::from(m.degeneracy.state_direction.map(f64::from));
    let d = Vector3::new(u[0], u[1], 0.0);
    let matched = Vector3::new(
        f64::from(m.pose.x_m),
        f64::from(m.pose.y_m),
        f64::from(m.pose.theta_rad),
    );
    let guess = Vector3::new(initial.x_m, initial.y_m, initial.theta_rad);
    let along = d.dot(&d);
    if along.is_nan() || along <= 0.5 {
        return None;
    }
    let state = matched + u * ((guess - matched).dot(&d) / along);
    let z = SimPose::new(state[0], state[1], state[2]);
    // The residuals say how well the walls really agree: never claim better than that.
    let inflate = (f64::from(m.cost_m) / f64::from(config.range_noise_sigma_m))
        .max(1.0)
        .powi(2);
    let info = Matrix3::from_fn(|r, q| f64::from(m.information[(r, q)])) / inflate;
    let iu = info * u;
    let uiu = u.dot(&iu);
    let across = if uiu > 0.0 {
        info - iu * iu.transpose() / uiu
    } else {
        info
    };
    let unit = u / u.norm();
    let info = across + unit * unit.transpose() / UNOBSERVED_ALONG_VARIANCE_M2;
    // loc-core's order is (x, y, θ) with (x, y) in a's frame; the factor's (θ, x, y) in
    // b's frame (the frames differ by the small heading change).
    let (s, c) = z.theta_rad.sin_cos();
    let rot = Matrix3::new(0.0, 0.0, 1.0, c, s, 0.0, -s, c, 0.0);
    let covariance = rot * info.try_inverse()? * rot.transpose();
    covariance
        .iter()
        .all(|v| v.is_finite())
        .then_some(Relative {
            from,
            to,
            z,
            covariance,
        })
}

/// What [`scan_factors`] found.
#[derive(Debug, Clone, Default)]
pub struct ScanFactors {
    /// The factors, keyframe `from` → keyframe `to`.
    pub factors: Vec<Relative>,
    /// Consecutive keyframes without a scan-to-scan factor.
    pub unmatched_steps: usize,
}

/// Every keyframe matched against the keyframes [`BASELINES`] before it, starting from the
/// composed odometry steps (`odometry[k]`: keyframe `k` → `k + 1`). Keyframes in parallel.
pub fn scan_factors(kfs: &[Keyframe], odometry: &[Relative], config: &MatchConfig) -> ScanFactors {
    let longest = BASELINES.iter().copied().max().unwrap_or(1);
    let per_keyframe: Vec<Vec<Relative>> = (0..kfs.len())
        .into_par_iter()
        .map_init(
            || (Box::<TunnelMap>::default(), Box::new(MatchWorkspace::new())),
            |(map, workspace), a| {
                let mut out = Vec::new();
                if !wall_map(&kfs[a], map) {
                    return out;
                }
                let mut odo = SimPose::new(0.0, 0.0, 0.0);
                for (d, step) in odometry.iter().skip(a).take(longest).enumerate() {
                    odo = odo.compose(step.z);
                    let b = a + d + 1;
                    // Past a stretch without scans the keyframes are too far apart to match.
                    if odo.x_m.hypot(odo.y_m) > MAX_BASELINE_M {
                        break;
                    }
                    if let (true, Some(kb)) = (BASELINES.contains(&(d + 1)), kfs.get(b)) {
                        // Along: the odometry's (the factor keeps it); across and heading:
                        // the localiser's (over metres the odometry's drift by centimetres
                        // and tens of milliradians, too far for the match to start from).
                        let guess = kfs[a].guess.between(kb.guess);
                        let initial = SimPose::new(odo.x_m, guess.y_m, guess.theta_rad);
                        out.extend(match_keyframes(map, a, kb, b, initial, config, workspace));
                    }
                }
                out
            },
        )
        .collect();
    let unmatched_steps = per_keyframe
        .iter()
        .take(kfs.len().saturating_sub(1))
        .filter(|f| !f.iter().any(|r| r.to == r.from + 1))
        .count();
    ScanFactors {
        factors: per_keyframe.into_iter().flatten().collect(),
        unmatched_steps,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::rng::Pcg32;

    /// A keyframe at `pose` (world frame) in a straight corridor with walls at ±2.5 m
    /// roughened by a few millimetres, scanned every 0.5° out to 15 m ahead, with range
    /// noise.
    fn keyframe(pose: SimPose, rng: &mut Pcg32) -> Keyframe {
        let wall = |x: f64| 0.004 * (x * 3.1).sin() + 0.003 * (x * 7.7).cos();
        let (mut points, mut labels) = (Vec::new(), Vec::new());
        for i in 0..380 {
            let a = -1.65 + i as f64 * 0.5f64.to_radians() + pose.theta_rad;
            let (s, c) = a.sin_cos();
            if s.abs() < 1e-3 {
                continue;
            }
            // March to the wall the ray meets (the walls bend by millimetres only).
            let side = if s > 0.0 { 1.0 } else { -1.0 };
            let mut t = (side * 2.5 - pose.y_m) / s;
            for _ in 0..3 {
                let x = pose.x_m + t * c;
                t = (side * (2.5 + wall(x)) - pose.y_m) / s;
            }
            if !(0.5..15.0).contains(&t) {
                continue;
            }
            let r = t + 0.005 * f64::from(rng.gaussian());
            let local = a - pose.theta_rad;
            points.push((r * local.cos(), r * local.sin()));
            labels.push(if s > 0.0 {
                PointLabel::LeftWall
            } else {
                PointLabel::RightWall
            });
        }
        Keyframe {
            scan_index: 0,
            t_s: 0.0,
            guess: pose,
            tracking: true,
            odometry: pose,
            points,
            labels,
        }
    }

    #[test]
    fn a_scan_matched_to_the_last_gives_across_and_heading_and_keeps_along() {
        let mut rng = Pcg32::seeded(3);
        let a = SimPose::new(10.0, 0.1, 0.01);
        let b = SimPose::new(10.25, 0.108, 0.013);
        let (ka, kb) = (keyframe(a, &mut rng), keyframe(b, &mut rng));
        let mut map = Box::<TunnelMap>::default();
        assert!(wall_map(&ka, &mut map));
        let truth = a.between(b);
        // The odometry's guess: 2 cm short, 1 cm and 5 mrad off.
        let initial = SimPose::new(truth.x_m - 0.02, truth.y_m + 0.01, truth.theta_rad - 0.005);
        let config = scan_match_config(&MatchConfig::default());
        let mut ws = Box::new(MatchWorkspace::new());
        let r = match_keyframes(&map, 0, &kb, 1, initial, &config, &mut ws).unwrap();
        assert_eq!((r.from, r.to), (0, 1));
        assert!(
            (r.z.y_m - truth.y_m).abs() < 0.002,
            "{:?} vs {truth:?}",
            r.z
        );
        assert!(
            (r.z.theta_rad - truth.theta_rad).abs() < 0.0005,
            "{:?}",
            r.z
        );
        // Along the corridor the match says nothing: the odometry's along stays, with no
        // information.
        assert!((r.z.x_m - initial.x_m).abs() < 1e-3, "{:?}", r.z);
        assert!(r.covariance[(1, 1)] >= 50.0);
        // Across and heading to a millimetre and a milliradian: two small eigenvalues (the
        // third is the along-tunnel line, oblique to the frame's axes by the heading).
        let mut e: Vec<f64> = r
            .covariance
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .collect();
        e.sort_by(f64::total_cmp);
        assert!(e[0].sqrt() < 0.001 && e[1].sqrt() < 0.002, "{e:?}");
    }

    #[test]
    fn a_scan_without_walls_gives_no_map() {
        let kf = Keyframe {
            scan_index: 0,
            t_s: 0.0,
            guess: SimPose::new(0.0, 0.0, 0.0),
            tracking: false,
            odometry: SimPose::new(0.0, 0.0, 0.0),
            points: vec![(1.0, 0.0), (2.0, 0.0)],
            labels: vec![PointLabel::Outlier; 2],
        };
        let mut map = Box::<TunnelMap>::default();
        assert!(!wall_map(&kf, &mut map));
    }
}
