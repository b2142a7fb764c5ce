//! Scan-to-map matching (paper §3, §5): find the vehicle pose `(x, y, θ)` (world frame) that
//! lays the scan onto the stored map.
//!
//! Two matchers share one input, one output and one solver:
//! - [`MatcherKind::Hausdorff`], the paper's choice: minimise the **modified Hausdorff
//!   distance** over the K best points, `K = k_fraction · m` (0.8·m by default, §5). "K best"
//!   has two readings, both supported by [`KBest`]:
//!   - [`KBest::TrimmedMean`] (**default**, the paper's eq. 1): the mean of the K smallest
//!     point-to-map distances. Minimised by iteratively reweighted least squares (weights
//!     `1/max(|r|, σ)`, which turns the squared point-to-line residual into the distance
//!     itself), re-associating and re-selecting the K best every iteration.
//!   - [`KBest::KthRanked`] (Huttenlocher's partial Hausdorff distance): the K-th ranked
//!     distance. The step is the least-squares step on the K best points; steps are accepted
//!     only when the K-th distance does not grow.
//!
//!   Steps that raise the cost are rejected and retried shorter (Levenberg damping). The K
//!   best are found by introselect in the workspace (`O(m)`, no full sort). At the optimum,
//!   a landmark whose points the model mostly leaves unexplained (bent or moved) is left
//!   out and the match converges again without it (`misfit`); so is one whose own
//!   correction disagrees with the filter's prediction, beside one that agrees
//!   ([`LandmarkGate`], `landmark_gate`).
//! - [`MatcherKind::Icp`]: point-to-line ICP after Censi (PL-ICP): every point within an
//!   association gate is paired with the nearest map segment and the sum of squared
//!   point-to-line distances is minimised; the gate shrinks to 3× the RMS residual (never below
//!   `icp_min_gate_m`). Departure from Censi: each iteration takes one Gauss–Newton step on
//!   the linearised rotation instead of his closed-form Lagrange-multiplier solution; near
//!   convergence (where this matcher operates after odometry prediction) the two coincide.
//!
//! Both re-associate every iteration: a full map search ([`MapQuery::nearest`]) on the first
//! iteration and whenever the pose has moved more than 25 cm / 0.0125 rad since the last
//! one; otherwise wall points are re-projected onto the segments found then (searched again
//! one by one when they slide off a segment's end) and landmark points are searched again
//! after 1.25 cm / 0.000625 rad of motion ([`AssociationSchedule`]). Map searches dominate
//! the cost; near convergence the wall segments no longer change.
//!
//! ## What a scan may cost
//! The schedule counts the work ([`AssociationSchedule::work`]) and a scan's matching stops
//! at [`MatchConfig::max_work`] (the guided sequence's matches share it), so no scan exceeds
//! the controller's budget whatever its points and however its iterations go. A match stopped
//! short of its optimum says how far it may still be ([`MatchResult::unconverged_sd_m`]), and
//! the filter trusts it only that far; the next scan, predicted from it, finishes the job.
//! The Hausdorff loop also ends when its steps flip back and forth between two association
//! sets (each pulling the pose to the other's side), taking the middle.
//!
//! ## What to feed it
//! Vehicle-frame points from [`select_match_points`]: **the landmark points** (at most
//! `LocalizerConfig::max_landmark_points`, 64, spread evenly over them when a scan has more)
//! plus a **decimated subset of wall points** (evenly spread along each wall, each the mean
//! of the wall's points over [`WALL_RUN_M`] there, as a voxel filter averages). The walls carry the
//! heading and the across-tunnel position; landmarks carry the along-tunnel position, and
//! without them so do, weakly, the far wall points where the tunnel's curvature changes.
//! Feeding every wall point would drown the landmarks: the K-best trimming would then discard
//! the (initially misaligned) landmark points first. Decimation also bounds the cost: each
//! point costs a map search and a share of every iteration, and F4s on both walls at 50 Hz
//! put a hundred landmark points in a scan (the cap took the S-bend's match under the
//! firmware from 0.77 to 0.43 M instructions a scan, README).
//! Before matching, [`prealign_along_tunnel`] can shift the prediction along the tunnel so that
//! observed landmark clusters sit on their map landmarks (a landmark is narrower than a
//! typical along-tunnel prediction error, beyond which the nearest-segment association fails);
//! [`match_scan_with_prealign`] runs pre-alignment and matching in the order the localizer
//! uses.
//!
//! ## What it returns
//! [`MatchResult`]: pose, 3×3 covariance `σ²·(ΣJᵀJ)⁻¹` from the point-to-line information of
//! the final inliers (σ: range noise; plus the allowance of a match cut short), iterations,
//! work, cost, inliers, and a [`Degeneracy`]: the
//! smallest eigenvalue of the translation information (heading marginalised) and its
//! direction in the world. Directions observed by less than `min_information_points` fully
//! informative points are not moved by the matcher and get a huge variance
//! ([`UNOBSERVED_VARIANCE`]); the filter does not update them. Directions observed by less
//! than `weak_information_points` (the position along a bare tunnel from the curve it runs
//! into, seen from a straight) are weakly observed: the matcher estimates them, the filter
//! takes them only where they improve on what it knows.

mod association;
mod fisher;
mod guided;
mod hausdorff;
mod icp;
mod information;
mod landmark_gate;
mod landmark_offsets;
mod misfit;
mod points;
mod prealign;
mod roughness;
mod wall_end;

pub use association::{
    associate, reproject, select_k_best, Association, AssociationSchedule, DistanceKey, Pairing,
};
pub use fisher::{paired_information, scan_information, ScanInformation};
pub use guided::{
    match_scan_with_prealign, GuidedMatch, PositionPrior, COARSE_CONVERGENCE_FACTOR,
    COARSE_MATCH_POINTS,
};
pub use information::{
    covariance_from_information, degeneracy, observable_subspace, truncated_step, Degeneracy,
    NormalEquations, Observability, ObservableSubspace,
};
pub use landmark_gate::{GateMemory, LandmarkGate, GATE_MEMORY_SLOTS};
pub use landmark_offsets::{
    LandmarkOffset, LandmarkOffsets, CONSISTENT_SIGMAS, EFFECTIVE_READINGS, LANDMARK_OFFSET_SLOTS,
    READ_EVERY_SCANS,
};
pub use points::{select_match_points, MatchPoints, SelectionCounts, WALL_RUN_M};
pub use prealign::{prealign_along_tunnel, PrealignConfig, PrealignShift};
pub use roughness::{OffsetEstimate, RoughWalls, RoughnessModel};
pub use wall_end::{
    observe_wall_ends, WallEndConfig, WallEndFix, WallEndMemory, MAX_WALL_END_FIXES,
};

use core::fmt;
use misfit::FittedMemory;

use nalgebra::{Matrix3, Vector3};

use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;

/// Most points one match uses (landmarks plus decimated walls).
pub const MAX_MATCH_POINTS: usize = 512;

/// Variance reported along directions the scan does not observe, m² (or rad²).
pub const UNOBSERVED_VARIANCE: f32 = 1.0e6;

/// The lengths of a loop's last two steps, metres (rotation counted at `rotation_scale_m`),
/// from which a match stopped mid-descent estimates how far it still is from its optimum.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Steps {
    last_m: f32,
    previous_m: f32,
}

impl Steps {
    /// Before the first step.
    pub(crate) const fn new() -> Self {
        Self {
            last_m: f32::INFINITY,
            previous_m: f32::INFINITY,
        }
    }

    /// Records a step of length `len_m`.
    pub(crate) fn record(&mut self, len_m: f32) {
        self.previous_m = self.last_m;
        self.last_m = len_m;
    }

    /// The distance still to go after the last step: Gauss–Newton on these costs converges
    /// linearly, so with the steps shrinking by `ρ` the rest is `last · ρ / (1 − ρ)`; `ρ`
    /// is the ratio of the last two steps, taken between 0.5 and 0.9 (one to nine more
    /// steps: a loop that stalls or was damped counts as the slowest).
    pub(crate) fn remaining_m(&self) -> f32 {
        let rho = if self.previous_m > 0.0 && self.previous_m.is_finite() {
            (self.last_m / self.previous_m).clamp(0.5, 0.9)
        } else {
            0.9
        };
        self.last_m * rho / (1.0 - rho)
    }
}

/// Which matcher to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MatcherKind {
    /// Modified Hausdorff distance over the K best points (the paper's matcher).
    #[default]
    Hausdorff,
    /// Point-to-line ICP (Censi's PL-ICP), the paper's comparison.
    Icp,
}

/// The reading of "the K best points" in the modified Hausdorff distance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum KBest {
    /// Mean of the K smallest distances (the paper's eq. 1). Default.
    #[default]
    TrimmedMean,
    /// The K-th ranked distance (partial Hausdorff distance).
    KthRanked,
}

/// Matcher tuning. Distances in metres, angles in radians.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MatchConfig {
    /// Which matcher.
    pub matcher: MatcherKind,
    /// Reading of "K best" (Hausdorff only).
    pub k_best: KBest,
    /// K as a fraction of the points, `(0, 1]` (Hausdorff only); the paper uses 0.8.
    pub k_fraction: f32,
    /// K is never below the number of points whose distance at the start of the match is
    /// within this many `√(σ_r² + σ_w²)` (range noise and wall roughness): points the
    /// measurement model explains are not trimmed (Hausdorff only; 0: always the paper's
    /// `k_fraction · m`). In a scan that fits the map the fixed fraction throws away a
    /// fifth of good points, the farthest wall points first (their residuals grow most
    /// with a heading error); where landmarks are bent or missing, the fraction still
    /// trims them.
    pub keep_within_sigmas: f32,
    /// Iteration limit.
    pub max_iterations: u16,
    /// Work limit of one scan's matching (dimensionless units): a match stops after the
    /// iteration that reaches it, and the guided sequence's matches share it
    /// ([`match_scan_with_prealign`]). A unit is one point in one iteration (its
    /// re-projection, K-best selection and normal equations: about 370 instructions on a
    /// Cortex-M4F); a map search adds [`AssociationSchedule::SEARCH_WORK`]. It bounds a
    /// scan's cost whatever its points and however the iterations go. On `tunnel-1km` a
    /// tracking match (a full association of 100–200 points, 3–5 iterations) does about 770
    /// (median), 1 % of them over 1600; the default 1500 caps the match at roughly
    /// 0.55–0.7 M instructions, the rest of a scan costing about 0.6 M. A match stopped by
    /// it is judged like one that ran out of iterations (its last step must be small) and
    /// reports how far it may still be ([`MatchResult::unconverged_sd_m`]); `u32::MAX` for
    /// no limit.
    pub max_work: u32,
    /// Points farther than this from any map geometry are unassociated, metres.
    pub association_gate_m: f32,
    /// ICP's association gate never shrinks below this, metres (≈ 5σ).
    pub icp_min_gate_m: f32,
    /// 1σ range noise of the lidar, metres: scales the covariance.
    pub range_noise_sigma_m: f32,
    /// How far the real walls deviate from the smooth stored map, and over what length
    /// along them the deviation stays alike (see [`RoughnessModel`]).
    pub roughness: RoughnessModel,
    /// Fewest points (and fewest associated inliers) for a match.
    pub min_points: u16,
    /// A direction is observed when its information is at least this many fully
    /// informative points' worth (eigenvalue of `ΣJᵀJ`, dimensionless). Low: a curve seen
    /// ahead at the end of a straight fixes the position along the tunnel to 0.1–0.5 m per
    /// scan from a few hundredths of a point's worth (points tens of metres past the
    /// curve's start, where the wall has turned a few hundredths of a radian); below
    /// [`MatchConfig::weak_information_points`] such a direction is weakly observed. The
    /// default, 2.5e-4 (σ 0.63 m at 10 mm range noise), lets the coarser beams of the
    /// LMS511's faster rates see a curve too: at 5e-4, 200 m of `tunnel-1km` without
    /// landmarks at 100 Hz (2/3° beams, a quarter of the points of 25 Hz) never saw its
    /// first curve (along 2.54 m RMS, worse than odometry's 2.29); now 0.65 m, and every
    /// rate and recording without landmarks is better along (2026-12-04, README).
    pub min_information_points: f32,
    /// An observed direction with less information than this many points' worth is weakly
    /// observed ([`Observability::weak_below_per_m2`]): the filter takes it only where the
    /// match knows it better than the filter does.
    pub weak_information_points: f32,
    /// Converged when a step moves less than this, metres.
    pub convergence_translation_m: f32,
    /// Converged when a step turns less than this, radians.
    pub convergence_rotation_rad: f32,
    /// Characteristic point distance scaling θ against metres in eigen-decompositions, m.
    pub rotation_scale_m: f32,
}

impl MatchConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        matcher: MatcherKind::Hausdorff,
        k_best: KBest::TrimmedMean,
        k_fraction: 0.8,
        keep_within_sigmas: 2.0,
        max_iterations: 30,
        max_work: 1500,
        association_gate_m: 1.0,
        icp_min_gate_m: 0.05,
        range_noise_sigma_m: 0.01,
        roughness: RoughnessModel::SMOOTH,
        min_points: 12,
        min_information_points: 2.5e-4,
        weak_information_points: 2.0,
        convergence_translation_m: 2.0e-4,
        convergence_rotation_rad: 2.0e-5,
        rotation_scale_m: 10.0,
    };
}

impl Default for MatchConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl MatchConfig {
    /// The information threshold in m⁻² (translation units): `min_information_points / σ²`.
    pub fn min_information_per_m2(&self) -> f32 {
        self.min_information_points / self.sigma_sq_m2()
    }

    /// When a direction counts as observed by this matcher's results.
    pub fn observability(&self) -> Observability {
        Observability {
            min_information_per_m2: self.min_information_per_m2(),
            weak_below_per_m2: self.weak_information_points / self.sigma_sq_m2(),
            rotation_scale_m: self.rotation_scale_m,
        }
    }

    /// The distance below which a point counts as explained by the measurement model
    /// ([`MatchConfig::keep_within_sigmas`] × `√(σ_r² + σ_w²)`), metres; 0 when disabled.
    pub fn explained_distance_m(&self) -> f32 {
        let k = self.keep_within_sigmas;
        if !(k.is_finite() && k > 0.0) {
            return 0.0;
        }
        let w = self.roughness.sigma_m;
        let w_sq = if w.is_finite() { w * w } else { 0.0 };
        k * crate::math::sqrt(self.sigma_sq_m2() + w_sq)
    }

    fn sigma_sq_m2(&self) -> f32 {
        let s = self.range_noise_sigma_m;
        if s.is_finite() && s > 0.0 {
            s * s
        } else {
            1.0e-4
        }
    }
}

/// A successful match.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchResult {
    /// The vehicle pose (vehicle frame in the world frame).
    pub pose: Pose2,
    /// Covariance of `(x_m, y_m, theta_rad)`, m², m·rad, rad²; [`UNOBSERVED_VARIANCE`] along
    /// unobserved directions.
    pub covariance: Matrix3<f32>,
    /// Point-to-line information `ΣJᵀJ / σ²` of the final inliers, world frame.
    pub information: Matrix3<f32>,
    /// Iterations run.
    pub iterations: u16,
    /// Work done, in the units of [`MatchConfig::max_work`].
    pub work: u32,
    /// 0 for a match that converged; for one stopped by the work budget or the iteration
    /// limit while still stepping, an allowance for the distance still to go, metres (its
    /// last step times one to nine, by how fast its steps were shrinking; rotation counted
    /// at `rotation_scale_m`). A Hausdorff match that stopped with a landmark not as
    /// mapped still in it (found with no work left to converge without it, or never
    /// judged: see `misfit`) adds how far it moved from its start. It is in `covariance`,
    /// and the filter adds it to the measurement noise of every observed direction, so a
    /// match cut short is trusted only as far as it got.
    pub unconverged_sd_m: f32,
    /// Map landmarks the match found not as mapped and left out (or, with no work left to
    /// converge without them, would have): their points misfit at the optimum (`misfit`) or
    /// their own correction disagreed with the prediction (`landmark_gate`). 0 for the ICP
    /// matcher, which judges no landmark.
    pub landmarks_left_out: u8,
    /// Of those, the landmarks the last scan's match found plainly fitting (≥ 12 paired
    /// points, ≤ 5 % of them beyond 2 σ; see `misfit::FittedMemory`): a landmark that fitted
    /// one scan and misfits the next is the sign of a jump, where a damaged one misfits from
    /// its first good sighting. Counted by matches run through [`match_scan_with_prealign`],
    /// which marks where a scan begins ([`MatchWorkspace::begin_scan`]); 0 for the ICP
    /// matcher.
    pub landmarks_stopped_fitting: u8,
    /// Final cost, metres: the trimmed mean or K-th distance (Hausdorff), RMS residual (ICP).
    pub cost_m: f32,
    /// Points used in the final estimate.
    pub inliers: u16,
    /// Translation degeneracy of the information.
    pub degeneracy: Degeneracy,
    /// The observability criterion the degeneracy was judged by (the filter uses the same).
    pub observability: Observability,
}

/// Why a match failed.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MatchError {
    /// Fewer input points than `min_points`: the scan saw too little (blocked, or the
    /// stripper found no walls); check the scan and the stripping tolerances.
    TooFewPoints {
        /// Points given.
        available: u16,
        /// Points required.
        required: u16,
    },
    /// Too few points lie within the association gate of the map: the prediction is far off
    /// or the vehicle left the mapped area; re-initialise the pose.
    TooFewAssociations {
        /// Points associated.
        associated: u16,
        /// Points required.
        required: u16,
    },
    /// The iteration limit was reached while steps were still large: the scan fits the map
    /// ambiguously; rely on odometry for this scan.
    DidNotConverge {
        /// Iterations run.
        iterations: u16,
        /// Length of the last step, metres (rotation counted at `rotation_scale_m`).
        last_step_m: f32,
    },
    /// The initial pose or the points are not finite: fix the caller's input.
    NonFiniteInput,
}

impl fmt::Display for MatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MatchError::TooFewPoints { available, required } => write!(
                f,
                "only {available} scan points to match, {required} needed: check the scan and the wall stripping"
            ),
            MatchError::TooFewAssociations { associated, required } => write!(
                f,
                "only {associated} points lie near the map, {required} needed: the pose prediction is far off or outside the map; re-initialise"
            ),
            MatchError::DidNotConverge { iterations, last_step_m } => write!(
                f,
                "no convergence after {iterations} iterations (last step {last_step_m} m): ambiguous fit, keep odometry for this scan"
            ),
            MatchError::NonFiniteInput => {
                write!(f, "non-finite pose or scan points given to the matcher")
            }
        }
    }
}

/// Scratch memory of one match (32 KiB: 512 associations of 56 bytes, 512 selection keys
/// and the work count): keep one, in the [`crate::localizer`] or a static, rather than on a small stack.
/// It also counts the work of the matches run with it (units of [`MatchConfig::max_work`],
/// failed matches included) since [`MatchWorkspace::reset_work`], and holds what its
/// owner has learnt of the landmarks' offsets ([`LandmarkOffsets`]: every match run with it
/// takes them; empty unless [`MatchWorkspace::learn_landmark_offsets`] is called).
#[derive(Debug, Clone)]
pub struct MatchWorkspace {
    assoc: [Association; MAX_MATCH_POINTS],
    keys: [DistanceKey; MAX_MATCH_POINTS],
    work: u32,
    landmark_offsets: LandmarkOffsets,
    /// The prediction the next match judges its landmarks against, if any
    /// ([`MatchWorkspace::set_landmark_gate`]).
    landmark_gate: Option<LandmarkGate>,
    /// The landmarks the gate has left out since the pose was last set.
    gate_memory: GateMemory,
    /// The landmarks the last scan's and this scan's Hausdorff matches found plainly fitting.
    fitted_landmarks: FittedMemory,
}

impl Default for MatchWorkspace {
    fn default() -> Self {
        Self::new()
    }
}

impl MatchWorkspace {
    /// Zeroed scratch memory.
    pub const fn new() -> Self {
        Self {
            assoc: [Association {
                distance_m: 0.0,
                world: Point2::ORIGIN,
                closest: Point2::ORIGIN,
                normal: Point2::ORIGIN,
                segment: crate::geometry::Segment::new(Point2::ORIGIN, Point2::ORIGIN),
                line_normal: Point2::ORIGIN,
                pairing: Pairing::NONE,
                point: 0,
            }; MAX_MATCH_POINTS],
            keys: [(0.0, 0); MAX_MATCH_POINTS],
            work: 0,
            landmark_offsets: LandmarkOffsets::NEW,
            landmark_gate: None,
            gate_memory: GateMemory::NEW,
            fitted_landmarks: FittedMemory::NEW,
        }
    }

    /// The work of the matches run since the last [`MatchWorkspace::reset_work`].
    pub const fn work(&self) -> u32 {
        self.work
    }

    /// Starts counting the work again from zero.
    pub fn reset_work(&mut self) {
        self.work = 0;
    }

    /// A new scan: the work counted from zero, and the landmarks the last scan's match
    /// found plainly fitting kept for this scan's matches to compare their misfits with
    /// ([`MatchResult::landmarks_stopped_fitting`]). [`match_scan_with_prealign`] calls it.
    pub fn begin_scan(&mut self) {
        self.reset_work();
        self.fitted_landmarks.begin_scan();
    }

    /// What has been learnt of the landmarks' offsets.
    pub fn landmark_offsets(&self) -> &LandmarkOffsets {
        &self.landmark_offsets
    }

    /// Reads the landmarks' offsets from the last match run with this workspace, on
    /// `points` (the points it matched, vehicle frame), at the updated `pose` and its
    /// `covariance` (world frame): see [`LandmarkOffsets::observe`].
    pub fn learn_landmark_offsets<M: MapQuery>(
        &mut self,
        map: &M,
        points: &[Point2],
        pose: Pose2,
        covariance: &Matrix3<f32>,
        config: &MatchConfig,
    ) {
        let assoc = self.assoc.get(..points.len()).unwrap_or_default();
        self.landmark_offsets
            .observe(map, assoc, points, pose, covariance, config);
    }

    /// Forgets what was learnt of the landmarks — their offsets and those the gate left
    /// out (a new pose: what was judged at a wrong one would mislead).
    pub fn forget_landmarks(&mut self) {
        self.landmark_offsets.clear();
        self.gate_memory.clear();
        self.fitted_landmarks.clear();
    }

    /// Judges the landmarks of the matches to come against a prediction (`None`: not):
    /// a landmark whose own correction disagrees with it is left out
    /// ([`LandmarkGate`]). [`match_scan_with_prealign`] takes it for its match when the
    /// prediction is good enough to skip the pre-alignment, and leaves the workspace
    /// without one; set it before each call.
    pub fn set_landmark_gate(&mut self, gate: Option<LandmarkGate>) {
        self.landmark_gate = gate;
    }

    /// The prediction the next match judges its landmarks against, if any.
    pub fn landmark_gate(&self) -> Option<&LandmarkGate> {
        self.landmark_gate.as_ref()
    }

    /// The landmarks the gate has left out since the pose was last set (map ids): the
    /// gated matches leave them out ([`GateMemory`]).
    pub fn gate_memory(&self) -> &GateMemory {
        &self.gate_memory
    }
}

/// Matches `points` (vehicle frame, at most [`MAX_MATCH_POINTS`] are used) against `map`
/// starting from `initial` (the predicted vehicle pose in the world).
pub fn match_scan<M: MapQuery>(
    map: &M,
    points: &[Point2],
    initial: Pose2,
    config: &MatchConfig,
    workspace: &mut MatchWorkspace,
) -> Result<MatchResult, MatchError> {
    let points = points
        .get(..points.len().min(MAX_MATCH_POINTS))
        .unwrap_or_default();
    if !initial.is_finite() {
        return Err(MatchError::NonFiniteInput);
    }
    let required = config.min_points.max(3);
    let available = crate::math::saturating_u16(points.len());
    if available < required {
        return Err(MatchError::TooFewPoints {
            available,
            required,
        });
    }
    if !points.iter().all(|p| p.is_finite()) {
        return Err(MatchError::NonFiniteInput);
    }
    let mut schedule = AssociationSchedule::new();
    let outcome = match config.matcher {
        MatcherKind::Hausdorff => {
            hausdorff::run(map, points, initial, config, &mut schedule, workspace)
        }
        MatcherKind::Icp => icp::run(
            map,
            points,
            initial,
            config,
            &mut schedule,
            &mut workspace.assoc,
            &workspace.landmark_offsets,
        ),
    };
    workspace.work = workspace.work.saturating_add(schedule.work());
    Ok(finish(outcome?, config))
}

/// What a matcher loop hands back before covariance and degeneracy are derived.
pub(crate) struct Outcome {
    pose: Pose2,
    equations: NormalEquations,
    iterations: u16,
    work: u32,
    unconverged_sd_m: f32,
    cost_m: f32,
    landmarks_left_out: u8,
    landmarks_stopped_fitting: u8,
}

/// How a matcher loop ends: its last accepted `(pose, cost, equations)` becomes the
/// [`Outcome`]; none at all means nothing was associated; a last step above 100× the
/// convergence tolerance when the iterations ran out means a fit that wanders (ambiguous).
/// A loop stopped by the work budget is still descending: it is kept, with the allowance
/// for the distance still to go, so the filter moves as far as it is sure of and the next
/// scan, predicted from there, finishes the pull-in (a first scan 5 cm and 1.3° off on
/// `paper-10m` was rejected outright otherwise).
pub(crate) fn conclude(
    last: Option<(Pose2, f32, NormalEquations)>,
    iterations: u16,
    work: u32,
    steps: &Steps,
    converged: bool,
    required: usize,
    config: &MatchConfig,
) -> Result<Outcome, MatchError> {
    let Some((pose, cost_m, equations)) = last else {
        return Err(MatchError::TooFewAssociations {
            associated: 0,
            required: crate::math::saturating_u16(required),
        });
    };
    let last_step_m = steps.last_m;
    let budget_spent = out_of_work(work, config);
    if !converged
        && !budget_spent
        && last_step_m > 100.0 * crate::math::max(config.convergence_translation_m, 1.0e-6)
    {
        return Err(MatchError::DidNotConverge {
            iterations,
            last_step_m,
        });
    }
    Ok(Outcome {
        pose,
        equations,
        iterations,
        work,
        unconverged_sd_m: if converged { 0.0 } else { steps.remaining_m() },
        cost_m,
        landmarks_left_out: 0,
        landmarks_stopped_fitting: 0,
    })
}

/// Whether a loop has used up its budget ([`MatchConfig::max_work`]) with `work` done.
pub(crate) fn out_of_work(work: u32, config: &MatchConfig) -> bool {
    work >= config.max_work
}

/// Adds the pose increment `step` `(dx_m, dy_m, dtheta_rad)` (world frame) to `pose`.
pub(crate) fn apply_step(pose: Pose2, step: &Vector3<f32>) -> Pose2 {
    Pose2::new(
        pose.x_m + step[0],
        pose.y_m + step[1],
        pose.theta_rad + step[2],
    )
}

/// Whether a step is below the convergence thresholds; also its length in metres with the
/// rotation counted at `rotation_scale_m`.
pub(crate) fn step_size(step: &Vector3<f32>, config: &MatchConfig) -> (bool, f32) {
    let t = crate::math::hypot(step[0], step[1]);
    let r = crate::math::abs(step[2]);
    let small = t < config.convergence_translation_m && r < config.convergence_rotation_rad;
    (
        small || !(t.is_finite() && r.is_finite()),
        t + r * config.rotation_scale_m,
    )
}

fn finish(o: Outcome, config: &MatchConfig) -> MatchResult {
    let inv_sigma_sq = 1.0 / config.sigma_sq_m2();
    let information = o.equations.information_points * inv_sigma_sq;
    let threshold = config.min_information_per_m2();
    let mut covariance = covariance_from_information(
        &information,
        threshold,
        config.rotation_scale_m,
        UNOBSERVED_VARIANCE,
    );
    let extra_m2 = o.unconverged_sd_m * o.unconverged_sd_m;
    let l = config.rotation_scale_m;
    covariance.m11 += extra_m2;
    covariance.m22 += extra_m2;
    covariance.m33 += extra_m2 / (l * l);
    MatchResult {
        pose: o.pose,
        covariance,
        information,
        iterations: o.iterations,
        work: o.work,
        unconverged_sd_m: o.unconverged_sd_m,
        cost_m: o.cost_m,
        landmarks_left_out: o.landmarks_left_out,
        landmarks_stopped_fitting: o.landmarks_stopped_fitting,
        inliers: crate::math::saturating_u16(o.equations.count),
        degeneracy: degeneracy(&information, threshold, config.rotation_scale_m),
        observability: config.observability(),
    }
}

#[cfg(test)]
mod tests;
