//! A survey without a design: the drive's own first map, built from the scans and the
//! odometry alone, to stand in for the prior ([`super::survey`] then runs against it).
//!
//! The survey's front end needs a map to localise against and to tell one landmark from
//! another. Without a design, that map is made here, from what the drive shows:
//!
//! 1. keyframes dead-reckoned from the odometry (`host-sim replay --estimator odometry`),
//!    tied keyframe to keyframe by the same scan-to-scan matches as the survey
//!    ([`super::scan_steps`]: across and heading from the walls) and solved as a pose graph
//!    with no landmark, the first keyframe held at the drive's initial pose;
//! 2. in each keyframe, every run of landmark-labelled returns (loc-core's wall stripping)
//!    within [`DETECT_RANGE_M`] is placed on its wall (a line through the wall points beside
//!    it) and the installed shape fitted to it ([`super::landmark_fit`]): one landmark pose
//!    per run that fits;
//! 3. the fits are chained into landmarks across keyframes: a fit within [`TRACK_GATE_M`]
//!    of a landmark seen in the last [`TRACK_MEMORY_M`] driven on the same wall is that
//!    landmark (the §4.4 spacing puts a wall's landmarks metres apart); a landmark needs
//!    `min_observations` keyframes;
//! 4. keyframes and landmarks solved together: a landmark ties the keyframes that saw it,
//!    along the tunnel too, which the walls do not — so the landmarks give the along-tunnel
//!    scale the odometry lacks (the first solve's path is the odometry's length, a few per
//!    cent long with wheels that over-read and slip; on the kilometre the second solve's
//!    path is 0.9801 of the odometry's, the truth 0.9802);
//! 5. the walls from every keyframe's wall points at the solved poses (stations every metre
//!    along lines at each wall's median distance from the trajectory, [`super::walls`]) and
//!    the landmarks on them: loc-core's [`TunnelMap`], in the frame of the drive's initial
//!    pose, landmarks in the order the drive first saw them.
//!
//! The map is only a start: it is in the frame of the drive's initial pose (turned by that
//! pose's heading error, bent by the heading's random walk over the scan matches). The survey
//! against it refits every landmark from the localiser's poses; anchors (`--anchor`, indices
//! as in this map) tie it to mine coordinates.

use loc_core::landmark::{LandmarkShape, Profile};
use loc_core::map::{LandmarkPlacement, TunnelMap, WallSide, MAX_LANDMARK_OFFSET_M};
use loc_core::strip::PointLabel;
use rayon::prelude::*;

use super::graph::{self, Problem, Relative};
use super::keyframes::{self, Keyframe};
use super::landmark_fit::{fit_in_scan, FitModel, LandmarkFix};
use super::walls::{self, Stations};
use super::{median_pose, scan_steps, steps, wall_name, SurveyError, SurveyOptions};
use crate::estimator::{localizer_config, odometry_noise};
use crate::replay::ReplaySources;
use crate::scenario::Scenario;
use crate::session::EstimatorChoice;
use crate::stored_map::{wall_position, AS_BUILT_STATION_M, MAP_CELL_M};
use crate::vehicle::SimPose;

/// Landmark returns farther than this from the vehicle are not used to find landmarks,
/// metres (nearer fits are the sharper ones; the survey fits out to its own range later).
pub const DETECT_RANGE_M: f64 = 12.0;

/// A fit this close to a landmark's last fit on the same wall is that landmark, metres:
/// far below a wall's landmark spacing (9.5 m for the paper's P1), above the dead
/// reckoning's drift over the stretch a landmark is seen from (1 % of 24 m).
pub const TRACK_GATE_M: f64 = 0.6;

/// A landmark not fitted for this far driven is closed: a later fit is another landmark,
/// metres.
pub const TRACK_MEMORY_M: f64 = 25.0;

/// 1σ of the prior that holds the first keyframe at the drive's initial pose, metres and
/// radians: nothing else fixes the map in the world (a loose prior lets the solve turn the
/// whole drive about, decimetres a kilometre on).
pub const FIRST_KEYFRAME_SD: f64 = 1e-3;

/// Landmark-labelled returns farther apart than this (consecutive in beam order) belong to
/// different runs, metres.
const RUN_GAP_M: f64 = 0.25;

/// Wall points within this of a run's centre along the wall place its wall line, metres.
const WALL_LINE_HALF_M: f64 = 1.5;

/// Fewest wall points for a wall line.
const WALL_LINE_POINTS: usize = 8;

/// Wall polyline vertices every this far driven, metres.
const WALL_LINE_STEP_M: f64 = 1.0;

/// The walls are extended this far before the first keyframe and past the last along
/// their headings, metres (the scanner sees them that far: [`walls::WALL_RANGE_M`]).
const WALL_EXTENSION_M: f64 = 20.0;

/// One landmark of the drive's own map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoundLandmark {
    /// Index in the map (the order the drive first saw them): what `--anchor` names.
    pub index: usize,
    /// `left` or `right`.
    pub wall: &'static str,
    /// Base centre, world frame (the drive's initial pose's), metres.
    pub x_m: f64,
    /// The same, y.
    pub y_m: f64,
    /// Odometry distance driven when it was first fitted, metres.
    pub first_seen_m: f64,
    /// Keyframes it was fitted in.
    pub keyframes: usize,
    /// Scan time of the keyframe nearest it, seconds.
    pub nearest_t_s: f64,
    /// Its pose in that keyframe's vehicle frame (x, y metres, θ radians): with the
    /// vehicle's true pose at that time, where it truly is (a simulation's yardstick).
    pub in_nearest: (f64, f64, f64),
}

/// The drive's own map and how it was found.
#[derive(Debug)]
pub struct Bootstrap {
    /// The map (walls and landmarks), world frame of the drive's initial pose.
    pub map: Box<TunnelMap>,
    /// Its landmarks, in map order.
    pub landmarks: Vec<FoundLandmark>,
    /// Runs of landmark returns fitted in fewer than `min_observations` keyframes (a
    /// person, a vehicle, a landmark glimpsed): left out.
    pub rejected: usize,
    /// The odometry's scale the landmarks show: true distance over logged distance, median
    /// over the drive (1 without landmarks).
    pub odometry_scale: f64,
    /// Keyframes used.
    pub keyframes: usize,
}

/// The installed shape as the survey fits it, on either wall.
struct ShapeModels {
    left: FitModel,
    right: FitModel,
    half_width_m: f64,
}

impl ShapeModels {
    fn new(shape: &LandmarkShape, wall_run_m: f64) -> Self {
        let profile: Vec<(f64, f64)> = Profile::new(shape.model, &shape.genome)
            .vertices()
            .iter()
            .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
            .collect();
        let half_width_m = profile.iter().fold(0.0f64, |w, p| w.max(p.0.abs()));
        Self {
            // The tunnel is to the right of the left wall's direction, to the left of the
            // right wall's.
            left: FitModel::new(&profile, false, wall_run_m),
            right: FitModel::new(&profile, true, wall_run_m),
            half_width_m,
        }
    }

    fn on(&self, wall: WallSide) -> &FitModel {
        match wall {
            WallSide::Left => &self.left,
            WallSide::Right => &self.right,
        }
    }
}

/// One landmark fitted in one keyframe.
#[derive(Debug, Clone, Copy)]
struct Detection {
    keyframe: usize,
    wall: WallSide,
    fix: LandmarkFix,
}

/// The installed shape fitted to each run of landmark returns of keyframe `k` within
/// [`DETECT_RANGE_M`] (vehicle frame).
fn detect(
    kf: &Keyframe,
    k: usize,
    models: &ShapeModels,
    options: &SurveyOptions,
) -> Vec<Detection> {
    let config = &options.fit;
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut last: Option<(f64, f64)> = None;
    for (p, l) in kf.points.iter().zip(&kf.labels) {
        if *l != PointLabel::Landmark || p.0.hypot(p.1) > DETECT_RANGE_M {
            continue;
        }
        match (last, runs.last_mut()) {
            (Some(q), Some(run)) if (p.0 - q.0).hypot(p.1 - q.1) <= RUN_GAP_M => run.push(*p),
            _ => runs.push(vec![*p]),
        }
        last = Some(*p);
    }
    let mut out = Vec::new();
    for run in runs
        .iter()
        .filter(|r| r.len() >= config.min_landmark_points)
    {
        let n = run.len() as f64;
        let c = run
            .iter()
            .fold((0.0, 0.0), |s, p| (s.0 + p.0 / n, s.1 + p.1 / n));
        let (wall, label) = if c.1 > 0.0 {
            (WallSide::Left, PointLabel::LeftWall)
        } else {
            (WallSide::Right, PointLabel::RightWall)
        };
        // The wall beside the run: a line y = a + b (x − cx) through its wall points.
        let beside: Vec<(f64, f64)> = kf
            .points
            .iter()
            .zip(&kf.labels)
            .filter(|(p, l)| **l == label && (p.0 - c.0).abs() <= WALL_LINE_HALF_M)
            .map(|(p, _)| *p)
            .collect();
        if beside.len() < WALL_LINE_POINTS {
            continue;
        }
        let Some((a, b)) = line_fit(&beside, c.0) else {
            continue;
        };
        // The run's centre dropped onto that line: the base's centre, to within the bias of
        // a landmark seen from one side (tried either way below).
        let norm = b.hypot(1.0);
        let t = (1.0 / norm, b / norm);
        let along = (c.1 - a) * t.1;
        let base = (c.0 + along * t.0, a + along * t.1);
        let theta = b.atan();
        let model = models.on(wall);
        let shift = models.half_width_m / 2.0;
        let best = [0.0, -shift, shift]
            .iter()
            .filter_map(|&s| {
                let t0 = SimPose::new(base.0 + s * t.0, base.1 + s * t.1, theta);
                fit_in_scan(model, &kf.points, t0, config)
            })
            .min_by(|x, y| x.rms_m.total_cmp(&y.rms_m));
        if let Some(fix) = best {
            out.push(Detection {
                keyframe: k,
                wall,
                fix,
            });
        }
    }
    out
}

/// Least-squares line `y = a + b (x − x0)` through `pts`, or `None` if they are not spread
/// along x.
fn line_fit(pts: &[(f64, f64)], x0: f64) -> Option<(f64, f64)> {
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0 - x0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - x0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - x0 - mx) * (p.1 - my)).sum();
    (sxx > 0.05).then(|| {
        let b = sxy / sxx;
        (my - b * mx, b)
    })
}

/// The detections chained into landmarks (indices into `detections`), in the order they
/// were first seen. `driven` is the odometry distance at each keyframe.
fn chain(detections: &[Detection], poses: &[SimPose], driven: &[f64]) -> Vec<Vec<usize>> {
    // Per landmark: its wall, its last fit in the world and the distance driven then.
    let mut open: Vec<(WallSide, (f64, f64), f64, usize)> = Vec::new();
    let mut tracks: Vec<Vec<usize>> = Vec::new();
    for (i, d) in detections.iter().enumerate() {
        let w = poses[d.keyframe].compose(d.fix.pose);
        let here = driven[d.keyframe];
        let best = open
            .iter()
            .enumerate()
            .filter(|(_, o)| o.0 == d.wall && here - o.2 <= TRACK_MEMORY_M)
            .map(|(j, o)| (j, (o.1 .0 - w.x_m).hypot(o.1 .1 - w.y_m)))
            .filter(|(_, dist)| *dist <= TRACK_GATE_M)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((j, _)) => {
                open[j].1 = (w.x_m, w.y_m);
                open[j].2 = here;
                tracks[open[j].3].push(i);
            }
            None => {
                open.push((d.wall, (w.x_m, w.y_m), here, tracks.len()));
                tracks.push(vec![i]);
            }
        }
        open.retain(|o| here - o.2 <= TRACK_MEMORY_M);
    }
    tracks
}

/// Builds the drive's own map from `sources` without any prior: the landmarks are of
/// `shape` (what was installed; `None`: a bare tunnel, walls only). `progress(fraction)` as
/// the scans are read.
pub fn bootstrap(
    sources: &ReplaySources,
    shape: Option<&LandmarkShape>,
    options: &SurveyOptions,
    progress: &dyn Fn(f64),
) -> Result<Bootstrap, SurveyError> {
    let scenario =
        Scenario::from_file(&sources.scenario).map_err(crate::replay::ReplayError::from)?;
    let front = keyframes::run(
        sources,
        &scenario,
        options.keyframe_spacing_m,
        EstimatorChoice::OdometryOnly,
        progress,
    )?;
    let kfs = &front.keyframes;
    if kfs.len() < 2 {
        return Err(SurveyError::TooShort);
    }
    let driven = super::driven_m(kfs);
    let gaps = &front.replay.odometry_gaps;
    let gap_steps = steps::gap_steps(kfs, gaps);
    // The odometry as logged: nothing calibrates its scale before the landmarks are solved.
    let unit_scales = vec![1.0; kfs.len()];
    let odometry_steps = steps::odometry_steps(
        kfs,
        &gap_steps,
        &unit_scales,
        &odometry_noise(&scenario),
        None,
    );
    let match_config = scan_steps::scan_match_config(&localizer_config(&scenario).matching);
    let scan = scan_steps::scan_factors(kfs, &odometry_steps, &match_config).factors;
    let mut problem = Problem {
        keyframes: kfs.iter().map(|k| k.guess).collect(),
        steps: odometry_steps,
        // The map's frame: the drive's initial pose.
        first_keyframe_sd: Some(FIRST_KEYFRAME_SD),
        ..Problem::default()
    };
    problem.steps.extend(scan);
    let first = graph::solve(&problem, options.solver, options.max_iterations)
        .map_err(SurveyError::Graph)?;

    let models = shape.map(|s| ShapeModels::new(s, options.fit.wall_run_m));
    let detections: Vec<Detection> = match &models {
        Some(models) => kfs
            .par_iter()
            .enumerate()
            .flat_map_iter(|(k, kf)| detect(kf, k, models, options))
            .collect(),
        None => Vec::new(),
    };
    let mut tracks = chain(&detections, &first.keyframes, &driven);
    let all_tracks = tracks.len();
    tracks.retain(|t| {
        let mut ks: Vec<usize> = t.iter().map(|&i| detections[i].keyframe).collect();
        ks.dedup();
        ks.len() >= options.min_observations
    });
    // Solved again with the landmarks: each ties the keyframes that saw it, along the
    // tunnel too, where the odometry's scale error and the scan matches leave the first
    // solve centimetres per metre off.
    let world =
        |poses: &[SimPose], i: usize| poses[detections[i].keyframe].compose(detections[i].fix.pose);
    problem.keyframes = first.keyframes;
    problem.landmarks = tracks
        .iter()
        .map(|t| {
            median_pose(
                &t.iter()
                    .map(|&i| world(&problem.keyframes, i))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    problem.observations = tracks
        .iter()
        .enumerate()
        .flat_map(|(j, t)| {
            let detections = &detections;
            t.iter().map(move |&i| Relative {
                from: detections[i].keyframe,
                to: j,
                z: detections[i].fix.pose,
                covariance: detections[i].fix.covariance,
            })
        })
        .collect();
    let solution = if tracks.is_empty() {
        None
    } else {
        Some(
            graph::solve(&problem, options.solver, options.max_iterations)
                .map_err(SurveyError::Graph)?,
        )
    };
    let (poses, landmark_poses) = match solution {
        Some(s) => (s.keyframes, s.landmarks),
        None => (problem.keyframes, Vec::new()),
    };
    let path_m: f64 = poses
        .windows(2)
        .map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m))
        .sum();
    let logged_m = driven.last().copied().unwrap_or(0.0);
    let odometry_scale = if logged_m > 0.0 {
        path_m / logged_m
    } else {
        1.0
    };

    let found: Vec<(WallSide, SimPose, Vec<usize>)> = tracks
        .iter()
        .zip(&landmark_poses)
        .map(|(t, pose)| {
            let ks: Vec<usize> = t.iter().map(|&i| detections[i].keyframe).collect();
            (detections[t[0]].wall, *pose, ks)
        })
        .collect();

    // The walls: stations along lines at each wall's median distance from the trajectory.
    let near: Vec<Vec<usize>> = poses
        .iter()
        .map(|p| {
            found
                .iter()
                .enumerate()
                .filter(|(_, f)| {
                    (f.1.x_m - p.x_m).hypot(f.1.y_m - p.y_m) <= walls::WALL_RANGE_M + 2.0
                })
                .map(|(j, _)| j)
                .collect()
        })
        .collect();
    let footprint = |k: usize, w: (f64, f64)| {
        models.as_ref().is_some_and(|models| {
            near[k].iter().any(|&j| {
                models
                    .on(found[j].0)
                    .covers_landmark(found[j].1.apply_inverse(w))
            })
        })
    };
    let fuse = |label: PointLabel| {
        let line = reference_line(kfs, &poses, &driven, label);
        let stations = Stations::along(&line, AS_BUILT_STATION_M);
        walls::fuse(kfs, &poses, label, &stations, &footprint).vertices
    };
    let left = fuse(PointLabel::LeftWall);
    let right = fuse(PointLabel::RightWall);

    let mut placements = Vec::with_capacity(found.len());
    let mut landmarks = Vec::with_capacity(found.len());
    for ((wall, pose, ks), shape) in found.iter().zip(std::iter::repeat(shape).flatten()) {
        let vertices = match wall {
            WallSide::Left => &left,
            WallSide::Right => &right,
        };
        let (s, standoff) = wall_position(vertices, *wall, (pose.x_m, pose.y_m));
        placements.push(LandmarkPlacement {
            wall: *wall,
            s_m: s as f32,
            offset_m: (standoff as f32).clamp(-MAX_LANDMARK_OFFSET_M, MAX_LANDMARK_OFFSET_M),
            shape: *shape,
        });
        let nearest = *ks
            .iter()
            .min_by(|a, b| {
                let d = |k: usize| (poses[k].x_m - pose.x_m).hypot(poses[k].y_m - pose.y_m);
                d(**a).total_cmp(&d(**b))
            })
            .unwrap_or(&0);
        let rel = poses[nearest].between(*pose);
        let mut unique = ks.clone();
        unique.dedup();
        landmarks.push(FoundLandmark {
            index: landmarks.len(),
            wall: wall_name(*wall),
            x_m: pose.x_m,
            y_m: pose.y_m,
            first_seen_m: driven[ks[0]],
            keyframes: unique.len(),
            nearest_t_s: kfs[nearest].t_s,
            in_nearest: (rel.x_m, rel.y_m, rel.theta_rad),
        });
    }
    let to_points = |v: &[(f64, f64)]| -> Vec<loc_core::geometry::Point2> {
        v.iter()
            .map(|&(x, y)| loc_core::geometry::Point2::new(x as f32, y as f32))
            .collect()
    };
    let mut map = Box::<TunnelMap>::default();
    map.rebuild(
        &to_points(&left),
        &to_points(&right),
        &placements,
        MAP_CELL_M,
    )
    .map_err(SurveyError::Map)?;
    Ok(Bootstrap {
        map,
        landmarks,
        rejected: all_tracks - tracks.len(),
        odometry_scale,
        keyframes: kfs.len(),
    })
}

impl Bootstrap {
    /// One line for progress output.
    pub fn summary(&self) -> String {
        format!(
            "the drive's own map: {} landmarks found in {} keyframes ({} glimpsed ones left out), the odometry's scale from them {:.4}",
            self.landmarks.len(),
            self.keyframes,
            self.rejected,
            self.odometry_scale
        )
    }
}

/// The drive's own landmarks as CSV (one row each, in map order: what `--anchor` names).
pub fn landmarks_csv(b: &Bootstrap) -> String {
    let mut out = String::from(
        "index,wall,x_m,y_m,first_seen_m,keyframes,nearest_t_s,in_nearest_x_m,in_nearest_y_m,in_nearest_theta_rad\n",
    );
    for l in &b.landmarks {
        out.push_str(&format!(
            "{},{},{:.4},{:.4},{:.2},{},{:.6},{:.4},{:.4},{:.6}\n",
            l.index,
            l.wall,
            l.x_m,
            l.y_m,
            l.first_seen_m,
            l.keyframes,
            l.nearest_t_s,
            l.in_nearest.0,
            l.in_nearest.1,
            l.in_nearest.2
        ));
    }
    out
}

/// A line along one wall to hang the survey's stations on: a vertex every
/// [`WALL_LINE_STEP_M`] driven at the wall's median distance from the vehicle beside it,
/// extended [`WALL_EXTENSION_M`] past both ends of the drive.
fn reference_line(
    kfs: &[Keyframe],
    poses: &[SimPose],
    driven: &[f64],
    label: PointLabel,
) -> Vec<(f64, f64)> {
    let beside = |kf: &Keyframe| -> Option<f64> {
        let mut y: Vec<f64> = kf
            .points
            .iter()
            .zip(&kf.labels)
            .filter(|(p, l)| **l == label && p.0.abs() <= 2.0)
            .map(|(p, _)| p.1)
            .collect();
        (y.len() >= 5).then(|| {
            y.sort_by(f64::total_cmp);
            y[y.len() / 2]
        })
    };
    let fallback = if label == PointLabel::LeftWall {
        2.0
    } else {
        -2.0
    };
    let mut offset = fallback;
    let mut line: Vec<(f64, f64)> = Vec::new();
    let mut next_m = 0.0;
    for (k, kf) in kfs.iter().enumerate() {
        if let Some(y) = beside(kf) {
            offset = y;
        }
        if driven[k] >= next_m || k + 1 == kfs.len() {
            line.push(poses[k].apply((0.0, offset)));
            next_m = driven[k] + WALL_LINE_STEP_M;
        }
    }
    let (first, last) = (poses[0], poses[poses.len() - 1]);
    let ahead = |p: SimPose, d: f64| {
        let q = p.apply((d, 0.0));
        let o = p.apply((0.0, 0.0));
        (q.0 - o.0, q.1 - o.1)
    };
    if let (Some(&a), Some(&z)) = (line.first(), line.last()) {
        let back = ahead(first, -WALL_EXTENSION_M);
        let fore = ahead(last, WALL_EXTENSION_M);
        line.insert(0, (a.0 + back.0, a.1 + back.1));
        line.push((z.0 + fore.0, z.1 + fore.1));
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    fn detection(keyframe: usize, wall: WallSide, x_m: f64, y_m: f64) -> Detection {
        Detection {
            keyframe,
            wall,
            fix: LandmarkFix {
                pose: SimPose::new(x_m, y_m, 0.0),
                covariance: Matrix3::identity() * 1e-4,
                points: 20,
                landmark_points: 8,
                rms_m: 0.01,
            },
        }
    }

    #[test]
    fn fits_of_one_landmark_chain_across_keyframes_and_neighbours_stay_apart() {
        // Keyframes every 0.25 m along x; one landmark on the left at 10 m, seen drifting
        // 1 cm per metre (an odometry that over-reads), one on the right 4.75 m on, one on
        // the left 9.5 m on; and the first landmark's place again after 30 m unseen.
        let poses: Vec<SimPose> = (0..200)
            .map(|k| SimPose::new(0.25 * k as f64, 0.0, 0.0))
            .collect();
        let driven: Vec<f64> = poses.iter().map(|p| p.x_m).collect();
        let mut d = Vec::new();
        for k in 0..40 {
            let x = 10.0 + 0.01 * driven[k] - poses[k].x_m;
            d.push(detection(k, WallSide::Left, x, 2.5));
            d.push(detection(k, WallSide::Right, 14.75 - poses[k].x_m, -2.5));
            d.push(detection(k, WallSide::Left, 19.5 - poses[k].x_m, 2.5));
        }
        d.push(detection(199, WallSide::Left, 10.0 - poses[199].x_m, 2.5));
        let tracks = chain(&d, &poses, &driven);
        let sizes: Vec<usize> = tracks.iter().map(Vec::len).collect();
        assert_eq!(sizes, vec![40, 40, 40, 1], "{tracks:?}");
    }

    #[test]
    fn a_wall_line_is_fitted_through_its_points_and_not_through_a_point() {
        let pts: Vec<(f64, f64)> = (0..20)
            .map(|i| (i as f64 * 0.1, 2.0 + 0.01 * i as f64))
            .collect();
        let (a, b) = line_fit(&pts, 1.0).unwrap();
        assert!((b - 0.1).abs() < 1e-9 && (a - 2.1).abs() < 1e-9, "{a} {b}");
        assert!(line_fit(&[(1.0, 2.0); 10], 1.0).is_none());
    }
}
