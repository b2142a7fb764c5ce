//! `host-sim survey`: the stored map as built, from one recorded drive.
//!
//! After the landmarks are installed a vehicle drives the tunnel once; the survey estimates
//! the walls as built and every landmark's pose jointly with the vehicle's trajectory
//! (§4.3 and §6 item 8 of the paper: landmark positions need no topographic survey):
//!
//! 1. [`keyframes`]: the drive localised against the prior map (the design) by loc-core's
//!    localiser, a keyframe every 0.25 m with the scan's points and loc-core's wall fits;
//! 2. [`observations`]: each prior landmark in range fitted in each keyframe
//!    ([`landmark_fit`]); [`steps`]: odometry and walls between consecutive keyframes;
//! 3. [`graph`]: keyframes and landmarks solved together (factrs by default; apex-solver or
//!    the survey's own Levenberg–Marquardt on request, [`graph::Solver`]), each landmark's marginal
//!    covariance; the gauge from the design's marks (installation tolerance), surveyed
//!    anchors, or the first landmark;
//! 4. [`walls`]: the walls from every keyframe's wall points at the solved poses, per metre;
//! 5. the map (loc-core's file, what the firmware loads) and the report ([`report`]).
//!
//! What cannot be surveyed is said, not papered over: landmarks of the design never seen,
//! landmark-like returns no design landmark explains, stretches of wall without points, and
//! stretches without landmarks, where the along-tunnel extent rests on the odometry alone.

pub mod bootstrap;
pub mod graph;
pub mod keyframes;
pub mod landmark_fit;
pub mod observations;
pub mod own_se2;
pub mod plot;
pub mod report;
pub mod scan_steps;
pub mod score;
#[cfg(feature = "solver-apex")]
pub mod solver_apex;
pub mod solver_factrs;
pub mod solver_own;
pub mod steps;
pub mod walls;

use std::fmt;
use std::time::Instant;

use loc_core::geometry::Point2;
use loc_core::map::{LandmarkPlacement, MapError, TunnelMap, WallSide};
use loc_core::strip::PointLabel;
use nalgebra::Matrix3;
use serde::Serialize;

use crate::estimator::{localizer_config, odometry_noise};
use crate::replay::{ReplayError, ReplaySources};
use crate::scenario::Scenario;
use crate::session::EstimatorChoice;
use crate::stored_map::{wall_position, MAP_CELL_M};
use crate::vehicle::SimPose;
use graph::{Prior, Problem, Relative, Solver};
use landmark_fit::FitConfig;
use walls::{Stations, SurveyedWall};

/// A landmark whose position in mine coordinates is known (surveyed by the mine's
/// surveyors): it ties the map to those coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// Index of the landmark in the prior map.
    pub landmark: usize,
    /// Position of the centre of its base on the wall, world (mine) frame, metres.
    pub x_m: f64,
    /// The same, y.
    pub y_m: f64,
    /// 1σ of that position, metres.
    pub sd_m: f64,
}

/// Where the survey's prior map came from: what pairs the scans with landmarks and starts
/// the solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PriorMap {
    /// The design (or an earlier survey).
    Design,
    /// The drive's own map, built without any prior ([`bootstrap`]).
    Drive,
}

impl PriorMap {
    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            PriorMap::Design => "design",
            PriorMap::Drive => "drive's own map",
        }
    }
}

/// How a survey runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveyOptions {
    /// Odometry distance between keyframes, metres.
    pub keyframe_spacing_m: f64,
    /// Landmarks farther than this from a keyframe are not fitted in it, metres.
    pub landmark_range_m: f64,
    /// Tie the landmarks to the design's marks with this installation tolerance (1σ along
    /// the wall, metres; half of it across); `None`: the design only pairs scans with
    /// landmarks.
    pub design_tolerance_m: Option<f64>,
    /// Surveyed anchors.
    pub anchors: Vec<Anchor>,
    /// Fewest fits for a landmark to be in the map.
    pub min_observations: usize,
    /// Levenberg–Marquardt iterations at most.
    pub max_iterations: usize,
    /// The back end of the joint solve.
    pub solver: Solver,
    /// The per-scan landmark fit.
    pub fit: FitConfig,
    /// Drive without a landmark fix longer than this is reported as a stretch whose
    /// along-tunnel extent rests on the odometry, metres.
    pub max_unobserved_m: f64,
    /// Where the prior map came from (for the report's words).
    pub prior: PriorMap,
}

impl Default for SurveyOptions {
    /// A keyframe every 0.25 m, landmarks within 20 m, the design as prior with a 0.05 m
    /// tolerance, 10 fits per landmark, 30 iterations of factrs.
    fn default() -> Self {
        Self {
            keyframe_spacing_m: 0.25,
            landmark_range_m: 20.0,
            design_tolerance_m: Some(0.05),
            anchors: Vec::new(),
            min_observations: 10,
            max_iterations: 30,
            solver: Solver::Factrs,
            fit: FitConfig::default(),
            max_unobserved_m: 15.0,
            prior: PriorMap::Design,
        }
    }
}

/// The error every fit of one landmark shares, as fractions of the walls' roughness
/// (`tunnel.roughness_sigma_m`): along, across. The rough wall either side of a landmark
/// fixes its base in every scan alike, so its fits do not average it away, while the solve
/// counts them as independent; its marginal alone claimed 4.6 / 4.8 mm where the landmarks
/// were 6.1 / 7.1 mm off (`tunnel-1km`, 1 cm roughness, design prior: 4–5 % beyond 3σ). The
/// share is added to the reported uncertainty only: weighting the fits by it in the solve
/// made the map worse (9.4 → 10.7 mm).
pub const SHARED_FIT_ERROR: (f64, f64) = (0.4, 0.5);

/// What fixes the map in the world.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Gauge {
    /// The design's marks, with the installation tolerance (and anchors, if any).
    Design,
    /// Surveyed anchors alone.
    Anchors,
    /// The first landmark seen, held where the localiser first saw it: the map is relative
    /// to it.
    FirstLandmark,
    /// No landmark at all: the first keyframe, and the along-tunnel extent from the
    /// odometry alone.
    FirstPose,
}

/// What became of one landmark of the prior map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LandmarkState {
    /// Surveyed, and in the map.
    Surveyed,
    /// Surveyed and in the map, but more than [`MOVED_SIGMAS`] × the prior's tolerance from
    /// where the prior has it: moved since the prior was made (a survey refreshed from a
    /// later drive), or mounted far off its mark.
    Moved,
    /// Passed within range but seen too seldom to survey: left out of the map (fallen
    /// off, hidden, or moved away from its mark).
    NotSeen,
}

/// Consecutive keyframes farther apart than this (metres driven) mark a stretch without
/// scans.
pub const MAX_KEYFRAME_GAP_M: f64 = 2.0;

/// A keyframe step whose squared Mahalanobis distance from the solution exceeds this (a
/// 20σ disagreement) is reported inconsistent. On the clean `tunnel-1km` drive the largest
/// of 13 820 is 103; a scan match across 10 m of dropped scans (without the baseline limit)
/// reached 5·10⁸.
pub const INCONSISTENT_CHI2: f64 = 400.0;

/// A surveyed landmark farther than this many tolerances (`--tolerance`, along; half of it
/// across) from its prior pose is reported [`LandmarkState::Moved`].
pub const MOVED_SIGMAS: f64 = 3.0;

/// One landmark of the prior map in the survey.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SurveyedLandmark {
    /// Index in the prior map.
    pub prior_index: usize,
    /// Index in the surveyed map (surveyed landmarks only).
    pub map_index: Option<usize>,
    /// `left` or `right`.
    pub wall: &'static str,
    /// What became of it.
    pub state: LandmarkState,
    /// Base centre, world frame, metres (the prior's for landmarks not seen).
    pub x_m: f64,
    /// The same, y.
    pub y_m: f64,
    /// Arc length along its surveyed wall, metres.
    pub s_m: f64,
    /// Stand-off from the surveyed wall, metres.
    pub offset_m: f64,
    /// 1σ along its wall, metres (marginal: the trajectory's uncertainty included, and the
    /// error its fits share, [`SHARED_FIT_ERROR`]).
    pub sd_along_m: f64,
    /// 1σ across, metres (the same).
    pub sd_across_m: f64,
    /// 1σ of its rotation, radians.
    pub sd_rotation_rad: f64,
    /// Scans it was fitted in.
    pub fits: usize,
    /// Keyframes in range where it could not be fitted.
    pub failed_fits: usize,
    /// How far it sits from its mark in the prior map, along its wall and across, metres.
    pub from_prior_m: (f64, f64),
}

/// A place where landmark-like returns appeared that no prior landmark explains.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Unexplained {
    /// Where (centre of the returns), world frame, metres.
    pub x_m: f64,
    /// The same, y.
    pub y_m: f64,
    /// Keyframes that saw them.
    pub keyframes: usize,
}

/// A stretch of the drive, by distance driven (odometry), metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stretch {
    /// Start, metres driven.
    pub from_m: f64,
    /// End.
    pub to_m: f64,
    /// Where, world frame (start).
    pub at: (f64, f64),
}

/// Time spent per stage, seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Timings {
    /// Localising against the prior map and re-reading the scans.
    pub front_end_s: f64,
    /// Landmark fits.
    pub observations_s: f64,
    /// The joint solve and the marginals.
    pub solve_s: f64,
    /// Walls and map.
    pub map_s: f64,
}

/// How the joint solve went.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolveStats {
    /// The back end.
    pub solver: Solver,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Keyframes and landmarks solved for.
    pub variables: usize,
    /// Factors (the loose prior, steps, landmark fits, landmark priors).
    pub factors: usize,
    /// The cost `Σ ρ(d²)` (squared Mahalanobis lengths, Huber on the scans' factors) at the
    /// start, dimensionless.
    pub error_before: f64,
    /// The same at the solution.
    pub error_after: f64,
    /// Wall time of the solve and the marginals alone (part of the stage's `solve_s`, which
    /// also matches the scans), seconds.
    pub seconds: f64,
}

/// The survey's result.
#[derive(Debug)]
pub struct Survey {
    /// The surveyed map (loc-core's stored map, the firmware's capacity).
    pub map: Box<TunnelMap>,
    /// The prior map it started from.
    pub prior: Box<TunnelMap>,
    /// Where that came from.
    pub prior_map: PriorMap,
    /// Every landmark of the prior map.
    pub landmarks: Vec<SurveyedLandmark>,
    /// What fixes the map in the world.
    pub gauge: Gauge,
    /// Scans in the recording and keyframes used.
    pub scans: usize,
    /// Keyframes used.
    pub keyframes: usize,
    /// The solved trajectory (one pose per keyframe) with each keyframe's scan time.
    pub trajectory: Vec<(f64, SimPose)>,
    /// Odometry steps (one per pair of consecutive keyframes).
    pub odometry_steps: usize,
    /// Scan-to-scan factors (across and heading from the walls), over every baseline of
    /// [`scan_steps::BASELINES`].
    pub scan_steps: usize,
    /// Consecutive keyframes whose scans could not be matched (no wall in common, a
    /// changed scene): across and heading there rest on the odometry and the landmarks.
    pub unmatched_steps: usize,
    /// Keyframe steps across a gap in the odometry log (from the localiser's poses,
    /// loosely; placed by the landmarks and scan matches).
    pub odometry_gaps: Vec<Stretch>,
    /// Stretches without scans (dropped or undecodable telegrams), longer than
    /// [`MAX_KEYFRAME_GAP_M`]: their walls are interpolated, their landmarks seen from afar.
    pub scan_gaps: Vec<Stretch>,
    /// Keyframe steps the solution contradicts by more than [`INCONSISTENT_CHI2`] (a scan
    /// match locked wrong, odometry that slipped): held off by the Huber kernel, named here.
    pub inconsistent_steps: Vec<Stretch>,
    /// Stretches without any landmark fix longer than `max_unobserved_m`: their
    /// along-tunnel extent is the odometry's.
    pub along_unobserved: Vec<Stretch>,
    /// 1σ of the along-tunnel extent of those stretches from the odometry's scale
    /// uncertainty, metres (summed over them).
    pub along_unobserved_sd_m: f64,
    /// Wall stretches without enough points (interpolated), per wall: `(wall, from s, to s)`.
    pub unsurveyed_walls: Vec<(&'static str, f64, f64)>,
    /// Landmark-like returns no prior landmark explains.
    pub unexplained: Vec<Unexplained>,
    /// Each surveyed wall (for plots).
    pub walls: [SurveyedWall; 2],
    /// Things to read (from the replay of the drive, and the survey's own).
    pub warnings: Vec<String>,
    /// Time per stage.
    pub timings: Timings,
    /// The joint solve's back end, iterations and cost.
    pub solve: SolveStats,
}

/// Why a survey could not run.
#[derive(Debug)]
pub enum SurveyError {
    /// The recording cannot be replayed (files, formats, clocks).
    Replay(ReplayError),
    /// The scanner recording read differently the second time (changed while surveying).
    ScansChanged,
    /// The joint estimate failed.
    Graph(graph::GraphError),
    /// The surveyed map does not fit loc-core's stored map.
    Map(MapError),
    /// An anchor names a landmark the prior map does not have.
    BadAnchor {
        /// The landmark index given.
        landmark: usize,
        /// Landmarks in the prior map.
        landmarks: usize,
    },
    /// Nothing to survey: the recording has fewer than two usable scans.
    TooShort,
}

impl fmt::Display for SurveyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SurveyError::Replay(e) => write!(f, "{e}"),
            SurveyError::ScansChanged => write!(
                f,
                "the scanner recording read differently the second time: was it written to while the survey ran?"
            ),
            SurveyError::Graph(e) => write!(f, "{e}"),
            SurveyError::Map(e) => write!(f, "the surveyed map cannot be stored: {e}"),
            SurveyError::BadAnchor { landmark, landmarks } => write!(
                f,
                "anchor on landmark {landmark}: the prior map has landmarks 0…{} (see `host-sim export-map --format json` for their indices)",
                landmarks.saturating_sub(1)
            ),
            SurveyError::TooShort => write!(
                f,
                "the recording has fewer than two usable scans: nothing to survey"
            ),
        }
    }
}

impl std::error::Error for SurveyError {}

impl From<ReplayError> for SurveyError {
    fn from(e: ReplayError) -> Self {
        SurveyError::Replay(e)
    }
}

/// Stages reported to the progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Without a prior: the drive's own map ([`bootstrap`]).
    Bootstrap,
    /// Localising against the prior and reading the keyframes.
    FrontEnd,
    /// Fitting landmarks.
    Observations,
    /// The joint solve.
    Solve,
    /// Walls and the map.
    Map,
}

impl Stage {
    /// Name for progress lines.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Bootstrap => "the drive's own map (odometry, scan matches, landmarks found)",
            Stage::FrontEnd => "localising against the prior map",
            Stage::Observations => "fitting landmarks",
            Stage::Solve => "solving keyframes and landmarks",
            Stage::Map => "walls and map",
        }
    }
}

pub(crate) fn wall_name(w: WallSide) -> &'static str {
    match w {
        WallSide::Left => "left",
        WallSide::Right => "right",
    }
}

/// Surveys the drive of `sources` (its map is the prior). `progress(stage, fraction)`.
pub fn survey(
    sources: &ReplaySources,
    options: &SurveyOptions,
    progress: &dyn Fn(Stage, f64),
) -> Result<Survey, SurveyError> {
    let scenario = Scenario::from_file(&sources.scenario).map_err(ReplayError::from)?;
    let mut timings = Timings::default();
    let t = Instant::now();
    let front = keyframes::run(
        sources,
        &scenario,
        options.keyframe_spacing_m,
        EstimatorChoice::Localizer,
        &|f| progress(Stage::FrontEnd, f),
    )?;
    timings.front_end_s = t.elapsed().as_secs_f64();
    let kfs = &front.keyframes;
    if kfs.len() < 2 {
        return Err(SurveyError::TooShort);
    }
    let prior = &front.replay.map;
    for a in &options.anchors {
        if a.landmark >= prior.landmarks().len() {
            return Err(SurveyError::BadAnchor {
                landmark: a.landmark,
                landmarks: prior.landmarks().len(),
            });
        }
    }

    // Landmark fits, keyframe by keyframe (in parallel: each is independent).
    let t = Instant::now();
    progress(Stage::Observations, 0.0);
    let priors = observations::prior_landmarks(prior, &options.fit);
    let seen: Vec<observations::Seen> = {
        use rayon::prelude::*;
        kfs.par_iter()
            .enumerate()
            .map(|(k, kf)| {
                observations::observe(kf, k, &priors, options.landmark_range_m, &options.fit)
            })
            .collect()
    };
    progress(Stage::Observations, 1.0);
    timings.observations_s = t.elapsed().as_secs_f64();

    let t = Instant::now();
    progress(Stage::Solve, 0.0);
    let mut fits = vec![0usize; priors.len()];
    let mut failed = vec![0usize; priors.len()];
    for s in &seen {
        for f in &s.fixes {
            fits[f.to] += 1;
        }
        for &j in &s.failed {
            failed[j] += 1;
        }
    }
    // Landmarks in the graph: those fitted often enough, renumbered densely.
    let in_graph: Vec<usize> = (0..priors.len())
        .filter(|&j| fits[j] >= options.min_observations)
        .collect();
    let mut graph_index = vec![None; priors.len()];
    for (g, &j) in in_graph.iter().enumerate() {
        graph_index[j] = Some(g);
    }
    let odometry = odometry_noise(&scenario);
    let mut problem = Problem {
        keyframes: kfs.iter().map(|k| k.guess).collect(),
        ..Problem::default()
    };
    // Steps across time the odometry log does not cover: its dead reckoning misses that
    // motion.
    let gaps = &front.replay.odometry_gaps;
    let gap_steps = steps::gap_steps(kfs, gaps);
    let scales = steps::local_scales(kfs, &gap_steps);
    // The gyro's bias is estimated against the localiser's heading, which is only
    // independent of the drive against a map made without it: against the drive's own map
    // it would take in that map's bend and hold it there (no map, two anchors at the ends:
    // 41.7 mm with the gyro's heading, 22.0 mm with the tracks' noise model).
    let gyro = scenario
        .odometry
        .gyro
        .filter(|_| options.prior == PriorMap::Design)
        .and_then(|spec| steps::GyroHeading::estimate(kfs, &gap_steps, &spec));
    problem.steps = steps::odometry_steps(kfs, &gap_steps, &scales, &odometry, gyro.as_ref());
    let driven = driven_m(kfs);
    let stretches_where = |flags: &dyn Fn(usize) -> bool| -> Vec<Stretch> {
        (0..kfs.len() - 1)
            .filter(|&k| flags(k))
            .map(|k| Stretch {
                from_m: driven[k],
                to_m: driven[k + 1],
                at: (kfs[k].guess.x_m, kfs[k].guess.y_m),
            })
            .collect()
    };
    let odometry_gaps = stretches_where(&|k| gap_steps[k]);
    // Scans missing (dropped, undecodable): keyframes farther apart than this.
    let scan_gaps = stretches_where(&|k| driven[k + 1] - driven[k] > MAX_KEYFRAME_GAP_M);
    let odometry_steps = problem.steps.len();
    let match_config = scan_steps::scan_match_config(&localizer_config(&scenario).matching);
    let scan = scan_steps::scan_factors(kfs, &problem.steps, &match_config);
    let scan_steps = scan.factors.len();
    let unmatched_steps = scan.unmatched_steps;
    problem.steps.extend(scan.factors);
    let mut implied: Vec<Vec<SimPose>> = vec![Vec::new(); in_graph.len()];
    for s in &seen {
        for f in &s.fixes {
            if let Some(g) = graph_index[f.to] {
                implied[g].push(kfs[f.from].guess.compose(f.z));
                problem.observations.push(Relative { to: g, ..*f });
            }
        }
    }
    problem.landmarks = implied.iter().map(|v| median_pose(v)).collect();
    let gauge = if in_graph.is_empty() {
        // Nothing else ties the map down: its first keyframe stays where the drive began.
        problem.first_keyframe_sd = Some(bootstrap::FIRST_KEYFRAME_SD);
        Gauge::FirstPose
    } else if let Some(tol) = options.design_tolerance_m {
        for (g, &j) in in_graph.iter().enumerate() {
            problem.priors.push(Prior {
                landmark: g,
                pose: priors[j].frame,
                covariance: diag(0.05, tol, tol / 2.0),
            });
        }
        Gauge::Design
    } else if options.anchors.is_empty() {
        // The map relative to the first landmark: held where the drive first placed it.
        problem.priors.push(Prior {
            landmark: 0,
            pose: problem.landmarks[0],
            covariance: diag(1e-4, 1e-4, 1e-4),
        });
        Gauge::FirstLandmark
    } else {
        Gauge::Anchors
    };
    for a in &options.anchors {
        if let Some(g) = graph_index[a.landmark] {
            let mut pose = problem.landmarks[g];
            pose.x_m = a.x_m;
            pose.y_m = a.y_m;
            // Position only: the rotation stays free (1 rad).
            problem.priors.push(Prior {
                landmark: g,
                pose,
                covariance: diag(1.0, a.sd_m, a.sd_m),
            });
        }
    }
    let solve_start = Instant::now();
    let solution = graph::solve(&problem, options.solver, options.max_iterations)
        .map_err(SurveyError::Graph)?;
    let solve_seconds = solve_start.elapsed().as_secs_f64();
    let solve = SolveStats {
        solver: options.solver,
        iterations: solution.iterations,
        variables: problem.keyframes.len() + problem.landmarks.len(),
        factors: usize::from(!problem.keyframes.is_empty())
            + problem.steps.len()
            + problem.observations.len()
            + problem.priors.len(),
        error_before: solution.error_before,
        error_after: solution.error_after,
        seconds: solve_seconds,
    };
    // Steps the solution contradicts (a scan match that locked wrong, odometry that
    // slipped): the Huber kernel kept them from bending the map, the report names them.
    let mut inconsistent_steps: Vec<Stretch> = Vec::new();
    for s in &problem.steps {
        let (Some(&a), Some(&b)) = (solution.keyframes.get(s.from), solution.keyframes.get(s.to))
        else {
            continue;
        };
        if s.chi2(a, b) > INCONSISTENT_CHI2 {
            inconsistent_steps.push(Stretch {
                from_m: driven[s.from],
                to_m: driven[s.to],
                at: (a.x_m, a.y_m),
            });
        }
    }
    progress(Stage::Solve, 1.0);
    timings.solve_s = t.elapsed().as_secs_f64();

    // Walls at the solved poses, landmark footprints left out.
    let t = Instant::now();
    progress(Stage::Map, 0.0);
    let footprint = |k: usize, w: (f64, f64)| {
        seen[k].fixes.iter().any(|f| {
            graph_index[f.to].is_some_and(|g| {
                priors[f.to]
                    .model
                    .covers_landmark(solution.landmarks[g].apply_inverse(w))
            })
        })
    };
    let wall_poly = |side: WallSide| -> Vec<(f64, f64)> {
        prior
            .wall_vertices(side)
            .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
            .collect()
    };
    let mut unsurveyed_walls = Vec::new();
    let mut fuse_wall = |side: WallSide, label: PointLabel| {
        let stations = Stations::along(&wall_poly(side), crate::stored_map::AS_BUILT_STATION_M);
        let wall = walls::fuse(kfs, &solution.keyframes, label, &stations, &footprint);
        unsurveyed_walls.extend(
            walls::unsurveyed_stretches(&wall, &stations)
                .into_iter()
                .map(|(a, b)| (wall_name(side), a, b)),
        );
        wall
    };
    let left = fuse_wall(WallSide::Left, PointLabel::LeftWall);
    let right = fuse_wall(WallSide::Right, PointLabel::RightWall);

    // The landmarks on the surveyed walls.
    let mut landmarks = Vec::with_capacity(priors.len());
    let mut placements = Vec::new();
    // (θ, along, across), as the marginals.
    let roughness_m = scenario.tunnel.roughness_sigma_m;
    let shared_fit = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        0.0,
        (SHARED_FIT_ERROR.0 * roughness_m).powi(2),
        (SHARED_FIT_ERROR.1 * roughness_m).powi(2),
    ));
    for (j, p) in priors.iter().enumerate() {
        let wall = match p.wall {
            WallSide::Left => &left.vertices,
            WallSide::Right => &right.vertices,
        };
        let (pose, cov) = match graph_index[j] {
            Some(g) => (
                solution.landmarks[g],
                solution.landmark_covariance[g] + shared_fit,
            ),
            None => (p.frame, Matrix3::zeros()),
        };
        let (s, standoff) = wall_position(wall, p.wall, (pose.x_m, pose.y_m));
        let from_prior = p.frame.between(pose);
        let map_index = graph_index[j].map(|_| {
            let shape = prior.landmarks()[j].placement.shape;
            placements.push(LandmarkPlacement {
                wall: p.wall,
                s_m: s as f32,
                offset_m: standoff as f32,
                shape,
            });
            placements.len() - 1
        });
        landmarks.push(SurveyedLandmark {
            prior_index: j,
            map_index,
            wall: wall_name(p.wall),
            state: match (map_index, options.design_tolerance_m) {
                (None, _) => LandmarkState::NotSeen,
                (Some(_), Some(tol))
                    if (from_prior.x_m / tol).hypot(2.0 * from_prior.y_m / tol) > MOVED_SIGMAS =>
                {
                    LandmarkState::Moved
                }
                (Some(_), _) => LandmarkState::Surveyed,
            },
            x_m: pose.x_m,
            y_m: pose.y_m,
            s_m: s,
            offset_m: standoff,
            sd_along_m: cov[(1, 1)].max(0.0).sqrt(),
            sd_across_m: cov[(2, 2)].max(0.0).sqrt(),
            sd_rotation_rad: cov[(0, 0)].max(0.0).sqrt(),
            fits: fits[j],
            failed_fits: failed[j],
            from_prior_m: (from_prior.x_m, from_prior.y_m),
        });
    }
    let to_points = |v: &[(f64, f64)]| -> Vec<Point2> {
        v.iter()
            .map(|&(x, y)| Point2::new(x as f32, y as f32))
            .collect()
    };
    let mut map = Box::<TunnelMap>::default();
    map.rebuild(
        &to_points(&left.vertices),
        &to_points(&right.vertices),
        &placements,
        MAP_CELL_M,
    )
    .map_err(SurveyError::Map)?;

    // Stretches without a landmark fix: their along-tunnel extent is the odometry's.
    let mut along_unobserved = Vec::new();
    let mut start: Option<usize> = None;
    let fixed_at: Vec<bool> = seen
        .iter()
        .map(|s| s.fixes.iter().any(|f| graph_index[f.to].is_some()))
        .chain(std::iter::once(true))
        .collect();
    for (k, &fixed) in fixed_at.iter().enumerate() {
        match (start, fixed) {
            (None, false) => start = Some(k),
            (Some(k0), true) => {
                let k1 = k.min(kfs.len() - 1);
                if driven[k1] - driven[k0] > options.max_unobserved_m {
                    along_unobserved.push(Stretch {
                        from_m: driven[k0],
                        to_m: driven[k1],
                        at: (solution.keyframes[k0].x_m, solution.keyframes[k0].y_m),
                    });
                }
                start = None;
            }
            _ => {}
        }
    }
    let unobserved_m: f64 = along_unobserved.iter().map(|s| s.to_m - s.from_m).sum();
    let along_unobserved_sd_m = f64::from(odometry.scale_sd) * unobserved_m;
    let unexplained = cluster_unexplained(&seen);
    let mut warnings = front.replay.warnings.clone();
    let not_seen = landmarks
        .iter()
        .filter(|l| l.state == LandmarkState::NotSeen && l.failed_fits > 0)
        .count();
    if not_seen > 0 {
        warnings.push(format!(
            "{not_seen} landmarks of the {} passed within {:.0} m but were fitted in fewer than {} scans: left out of the map (fallen off, hidden, or moved from their marks; see the landmark table)",
            options.prior.name(), options.landmark_range_m, options.min_observations
        ));
    }
    if !odometry_gaps.is_empty() {
        warnings.push(format!(
            "{} keyframe steps cross gaps in the odometry log (first at {:.1} m driven): there the keyframes rest on the landmarks and the scans, not on the odometry (see `odometry_gaps`)",
            odometry_gaps.len(),
            odometry_gaps[0].from_m
        ));
    }
    if !inconsistent_steps.is_empty() {
        warnings.push(format!(
            "{} keyframe steps disagree with the solved map by more than 20σ (first at {:.1} m driven): a scan match or odometry step there is wrong and was outvoted; check that stretch (see `inconsistent_steps`)",
            inconsistent_steps.len(),
            inconsistent_steps[0].from_m
        ));
    }
    if !scan_gaps.is_empty() {
        let m: f64 = scan_gaps.iter().map(|s| s.to_m - s.from_m).sum();
        warnings.push(format!(
            "{} stretches without scans ({m:.1} m; first at {:.1} m driven): walls there interpolated, landmarks there seen only from afar (see `scan_gaps`)",
            scan_gaps.len(),
            scan_gaps[0].from_m
        ));
    }
    let moved = landmarks
        .iter()
        .filter(|l| l.state == LandmarkState::Moved)
        .count();
    if moved > 0 {
        warnings.push(format!(
            "{moved} landmarks were surveyed more than {MOVED_SIGMAS}× the tolerance from where the prior map has them: moved since it was made, or mounted far off their marks (in the map where surveyed; see the landmark table)"
        ));
    }
    if !unexplained.is_empty() {
        warnings.push(format!(
            "{} places show landmark-like returns no landmark of the {} explains (a landmark not in it, or one moved off its mark; see `unexplained`)",
            unexplained.len(),
            options.prior.name()
        ));
    }
    if gauge == Gauge::FirstPose {
        warnings.push(format!(
            "no landmark was surveyed: the map's along-tunnel extent is unobservable from the scans and rests on the odometry alone (±{:.2} m over {:.0} m driven at the odometry's {:.1} % scale uncertainty)",
            along_unobserved_sd_m,
            unobserved_m,
            100.0 * odometry.scale_sd
        ));
    } else if !along_unobserved.is_empty() {
        warnings.push(format!(
            "{} stretches ({unobserved_m:.0} m in all) without a landmark fix: their along-tunnel extent rests on the odometry (±{along_unobserved_sd_m:.2} m)",
            along_unobserved.len()
        ));
    }
    if !unsurveyed_walls.is_empty() {
        let m: f64 = unsurveyed_walls.iter().map(|w| w.2 - w.1 + 1.0).sum();
        warnings.push(format!(
            "{} wall stretches ({m:.0} m) had too few points and were interpolated (see `unsurveyed_walls`)",
            unsurveyed_walls.len()
        ));
    }
    progress(Stage::Map, 1.0);
    timings.map_s = t.elapsed().as_secs_f64();
    Ok(Survey {
        map,
        prior: front.replay.map.clone(),
        prior_map: options.prior,
        landmarks,
        gauge,
        scans: front.scans,
        keyframes: kfs.len(),
        trajectory: kfs
            .iter()
            .zip(&solution.keyframes)
            .map(|(k, p)| (k.t_s, *p))
            .collect(),
        odometry_steps,
        scan_steps,
        unmatched_steps,
        along_unobserved,
        odometry_gaps,
        scan_gaps,
        inconsistent_steps,
        along_unobserved_sd_m,
        unsurveyed_walls,
        unexplained,
        walls: [left, right],
        warnings,
        timings,
        solve,
    })
}

/// A diagonal `(θ, x, y)` covariance from 1σ values.
fn diag(theta_rad: f64, x_m: f64, y_m: f64) -> Matrix3<f64> {
    Matrix3::from_diagonal(&nalgebra::Vector3::new(
        theta_rad * theta_rad,
        x_m * x_m,
        y_m * y_m,
    ))
}

/// Component-wise median of poses (robust start for a landmark seen many times).
pub(crate) fn median_pose(v: &[SimPose]) -> SimPose {
    let med = |f: &dyn Fn(&SimPose) -> f64| {
        let mut x: Vec<f64> = v.iter().map(f).collect();
        x.sort_unstable_by(f64::total_cmp);
        x.get(x.len() / 2).copied().unwrap_or(0.0)
    };
    SimPose::new(med(&|p| p.x_m), med(&|p| p.y_m), med(&|p| p.theta_rad))
}

/// Odometry distance driven at each keyframe, metres.
pub(crate) fn driven_m(kfs: &[keyframes::Keyframe]) -> Vec<f64> {
    let mut d = 0.0;
    let mut out = Vec::with_capacity(kfs.len());
    for (i, k) in kfs.iter().enumerate() {
        if i > 0 {
            let m = kfs[i - 1].odometry.between(k.odometry);
            d += m.x_m.hypot(m.y_m);
        }
        out.push(d);
    }
    out
}

/// Landmark-labelled returns no prior landmark explains, clustered on a 0.5 m grid; a
/// cluster seen from at least 10 keyframes is reported (a person walking past, or a single
/// mixed pixel, is not).
fn cluster_unexplained(seen: &[observations::Seen]) -> Vec<Unexplained> {
    use std::collections::HashMap;
    /// Sum of x, sum of y, returns, keyframes, last keyframe counted.
    type Cell = (f64, f64, usize, usize, usize);
    let mut cells: HashMap<(i64, i64), Cell> = HashMap::new();
    for (k, s) in seen.iter().enumerate() {
        for &(x, y) in &s.unexplained {
            let key = ((x / 0.5).floor() as i64, (y / 0.5).floor() as i64);
            let e = cells.entry(key).or_insert((0.0, 0.0, 0, 0, usize::MAX));
            e.0 += x;
            e.1 += y;
            e.2 += 1;
            if e.4 != k {
                e.3 += 1;
                e.4 = k;
            }
        }
    }
    // Neighbouring cells are one place (a landmark straddles a cell boundary): joined
    // across their 8-neighbourhood; a place counts the most keyframes any of its cells saw.
    let mut out: Vec<Unexplained> = Vec::new();
    let mut done: std::collections::HashSet<(i64, i64)> = std::collections::HashSet::new();
    for &start in cells.keys() {
        if !done.insert(start) {
            continue;
        }
        let (mut sx, mut sy, mut n, mut keyframes) = (0.0, 0.0, 0usize, 0usize);
        let mut stack = vec![start];
        while let Some((i, j)) = stack.pop() {
            if let Some(c) = cells.get(&(i, j)) {
                (sx, sy, n, keyframes) = (sx + c.0, sy + c.1, n + c.2, keyframes.max(c.3));
            }
            for (di, dj) in [
                (-1, -1),
                (-1, 0),
                (-1, 1),
                (0, -1),
                (0, 1),
                (1, -1),
                (1, 0),
                (1, 1),
            ] {
                let q = (i + di, j + dj);
                if cells.contains_key(&q) && done.insert(q) {
                    stack.push(q);
                }
            }
        }
        if keyframes >= 10 {
            out.push(Unexplained {
                x_m: sx / n as f64,
                y_m: sy / n as f64,
                keyframes,
            });
        }
    }
    out.sort_by(|a, b| a.x_m.total_cmp(&b.x_m).then(a.y_m.total_cmp(&b.y_m)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn returns_straddling_a_cell_boundary_are_one_place_and_rare_ones_none() {
        let seen: Vec<observations::Seen> = (0..12)
            .map(|k| observations::Seen {
                // One landmark across the 0.5 m cell boundary; a stray return seen once.
                unexplained: if k == 0 {
                    vec![(0.45, 2.2), (0.55, 2.2), (30.0, -2.2)]
                } else {
                    vec![(0.45, 2.2), (0.55, 2.2)]
                },
                ..Default::default()
            })
            .collect();
        let places = cluster_unexplained(&seen);
        assert_eq!(places.len(), 1, "{places:?}");
        assert!((places[0].x_m - 0.5).abs() < 1e-9 && places[0].keyframes == 12);
    }
}
