//! How the localiser finds itself: power-up at random places with no pose, and
//! kidnappings (the vehicle moved where its odometry does not see), each a closed-loop run
//! of the scenario's tunnel scored against the truth.
//!
//! A **power-up** run starts the localiser without a pose ([`LocCoreEstimator::without_initial_pose`])
//! at a random chainage and drives `drive_m` on; it reports the metres driven until the first
//! scan reported tracking. A **kidnapping** run starts with the true pose, and after
//! `kidnap_after_m` the vehicle is moved 5–50 m along the tunnel (either way); it reports
//! whether the localiser noticed (declared itself lost: `relocalising`), whether it tracked
//! again, and the metres from the move to that. In both, any scan reported tracking with the
//! position more than [`WRONG_LOCK_M`] off the truth is a **wrong lock** — the outcome that
//! must never happen — and scans reported tracking outside 3σ of their covariance are
//! counted too.

use std::fmt::Write as _;

use loc_core::rng::Pcg32;

use crate::closed_loop::{self, RunLog, RunOptions, Teleport};
use crate::estimator::LocCoreEstimator;
use crate::metrics::ProtectionSummary;
use crate::scenario::Scenario;
use crate::session::SimError;
use crate::stored_map;
use crate::world::World;
use loc_core::map::TunnelMap;

/// A scan reported tracking farther than this from the truth is at a wrong place, metres
/// (a wrong placement is a landmark spacing, ≈ 10 m, off; tracking errors are millimetres).
pub const WRONG_LOCK_M: f64 = 0.5;

/// What a study runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudySpec {
    /// Runs.
    pub runs: u32,
    /// Metres driven per run (after the kidnapping, for kidnapping runs).
    pub drive_m: f64,
    /// Kidnapping runs instead of power-up runs.
    pub kidnap: bool,
    /// Metres driven before the kidnapping.
    pub kidnap_after_m: f64,
    /// Shortest and longest kidnapping, metres.
    pub jump_range_m: (f64, f64),
    /// Seed of the start places and jumps (the scenario's own seed drives the rest).
    pub seed: u64,
}

impl StudySpec {
    /// Metres a run drives before its kidnapping (0 for power-up runs).
    pub fn driven_before_kidnap_m(&self) -> f64 {
        if self.kidnap {
            self.kidnap_after_m
        } else {
            0.0
        }
    }
}

impl Default for StudySpec {
    fn default() -> Self {
        Self {
            runs: 100,
            drive_m: 40.0,
            kidnap: false,
            kidnap_after_m: 10.0,
            jump_range_m: (5.0, 50.0),
            seed: 1,
        }
    }
}

/// One run's outcome.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunOutcome {
    /// Chainage where the run started, metres.
    pub start_m: f64,
    /// The kidnapping's jump along the tunnel, metres (0 for power-up runs).
    pub jump_m: f64,
    /// The localiser declared itself lost after the kidnapping (power-up runs: true).
    pub detected: bool,
    /// Metres driven from the start (power-up) or from the kidnapping until the first
    /// scan reported tracking at the right place; `None`: never within the run.
    pub tracking_after_m: Option<f64>,
    /// Scans reported tracking more than [`WRONG_LOCK_M`] off the truth.
    pub wrong_lock_scans: usize,
    /// Scans reported tracking with the position error beyond 3σ of the covariance.
    pub outside_3sigma_scans: usize,
    /// Scans reported tracking.
    pub tracking_scans: usize,
    /// The largest position error of a scan reported tracking, metres.
    pub worst_tracking_error_m: f64,
    /// Times the localiser went back to relocalising after a lock (a lock the landmarks
    /// did not confirm, dropped before it was ever reported tracking, or a later loss).
    pub relocks: usize,
    /// The status changes: `metres:status` from the start (power-up) or the kidnapping.
    pub timeline: String,
    /// How the protection levels held against the truth over the whole run.
    pub protection: ProtectionSummary,
}

/// A whole study.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StudyResult {
    /// Scenario name.
    pub scenario: String,
    /// `power-up` or `kidnapping`.
    pub kind: &'static str,
    /// Every run.
    pub runs: Vec<RunOutcome>,
}

impl StudyResult {
    /// Runs that reached tracking.
    pub fn tracked(&self) -> usize {
        self.runs
            .iter()
            .filter(|r| r.tracking_after_m.is_some())
            .count()
    }

    /// Runs with any wrong-lock scan.
    pub fn wrong_lock_runs(&self) -> usize {
        self.runs.iter().filter(|r| r.wrong_lock_scans > 0).count()
    }

    /// The protection levels over every run.
    pub fn protection(&self) -> ProtectionSummary {
        let mut p = ProtectionSummary::default();
        for r in &self.runs {
            p.add(&r.protection);
        }
        p
    }

    /// Metres to tracking: (median, 90th percentile, max) over the runs that tracked.
    pub fn metres_to_tracking(&self) -> Option<(f64, f64, f64)> {
        let mut m: Vec<f64> = self
            .runs
            .iter()
            .filter_map(|r| r.tracking_after_m)
            .collect();
        if m.is_empty() {
            return None;
        }
        m.sort_by(f64::total_cmp);
        let q = |f: f64| m[((f * (m.len() - 1) as f64).round() as usize).min(m.len() - 1)];
        Some((q(0.5), q(0.9), m[m.len() - 1]))
    }

    /// The study as text: counts, the distribution, the runs that failed.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let n = self.runs.len();
        let _ = writeln!(s, "{} study on {}: {n} runs", self.kind, self.scenario);
        if self.kind == "kidnapping" {
            let detected = self.runs.iter().filter(|r| r.detected).count();
            let _ = writeln!(s, "  detected (declared itself lost): {detected} of {n}");
        }
        let _ = writeln!(
            s,
            "  reached tracking at the right place: {} of {n}",
            self.tracked()
        );
        if let Some((median, p90, max)) = self.metres_to_tracking() {
            let _ = writeln!(
                s,
                "  metres to tracking: median {median:.1}, 90 % {p90:.1}, max {max:.1}"
            );
            let _ = writeln!(s, "  histogram (5 m bins):");
            let mut bins = [0usize; 16];
            for m in self.runs.iter().filter_map(|r| r.tracking_after_m) {
                bins[((m / 5.0) as usize).min(bins.len() - 1)] += 1;
            }
            for (i, c) in bins.iter().enumerate().filter(|(_, c)| **c > 0) {
                let _ = writeln!(
                    s,
                    "    {:>3}-{:<3} m {c:>4} {}",
                    5 * i,
                    5 * i + 5,
                    "#".repeat(*c)
                );
            }
        }
        let tracking: usize = self.runs.iter().map(|r| r.tracking_scans).sum();
        let wrong: usize = self.runs.iter().map(|r| r.wrong_lock_scans).sum();
        let outside: usize = self.runs.iter().map(|r| r.outside_3sigma_scans).sum();
        let _ = writeln!(
            s,
            "  wrong locks (tracking > {WRONG_LOCK_M} m off the truth): {wrong} scans in {} runs",
            self.wrong_lock_runs()
        );
        let _ = writeln!(
            s,
            "  tracking scans outside 3σ of their covariance: {outside} of {tracking}"
        );
        let _ = writeln!(s, "  {}", self.protection().line());
        let relocks: usize = self.runs.iter().map(|r| r.relocks).sum();
        let _ = writeln!(
            s,
            "  locks dropped and searched again (the landmarks did not confirm them): {relocks}"
        );
        for r in self
            .runs
            .iter()
            .filter(|r| r.tracking_after_m.is_none() || r.wrong_lock_scans > 0)
        {
            let _ = writeln!(
                s,
                "  run from {:.1} m (jump {:+.1} m): tracking {:?}, {} wrong-lock scans (worst {:.2} m off); {}",
                r.start_m,
                r.jump_m,
                r.tracking_after_m,
                r.wrong_lock_scans,
                r.worst_tracking_error_m,
                r.timeline
            );
        }
        s
    }
}

/// Runs the study on `scenario`'s tunnel; `progress` gets the fraction done.
pub fn run_study(
    scenario: &Scenario,
    spec: &StudySpec,
    progress: Option<&dyn Fn(f64)>,
) -> Result<StudyResult, SimError> {
    scenario.validate()?;
    let world = scenario.build_world()?;
    let choice = scenario.landmark_choice()?;
    let map = stored_map::build(&world, &choice).map_err(SimError::Map)?;
    let length = world.centerline().length_m();
    let before = spec.driven_before_kidnap_m();
    // Room for the drive, and for the longest jump either way.
    let margin = if spec.kidnap {
        spec.jump_range_m.1
    } else {
        0.0
    } + 5.0;
    let span = (length - spec.drive_m - before - 2.0 * margin).max(0.0);
    let mut rng = Pcg32::new(spec.seed, 0x2e10);
    let mut runs = Vec::new();
    for i in 0..spec.runs {
        let start_m = margin + f64::from(rng.uniform01()) * span;
        let jump_m = if spec.kidnap {
            let (lo, hi) = spec.jump_range_m;
            let magnitude = lo + f64::from(rng.uniform01()) * (hi - lo);
            if rng.uniform01() < 0.5 {
                -magnitude
            } else {
                magnitude
            }
        } else {
            0.0
        };
        let mut s = scenario.clone();
        s.seed = scenario.seed.wrapping_add(u64::from(i));
        runs.push(run_one(&s, &world, &map, spec, start_m, jump_m));
        if let Some(p) = progress {
            p(f64::from(i + 1) / f64::from(spec.runs.max(1)));
        }
    }
    Ok(StudyResult {
        scenario: scenario.name.clone(),
        kind: if spec.kidnap {
            "kidnapping"
        } else {
            "power-up"
        },
        runs,
    })
}

/// One run of a study: `scenario` (its seed the run's own) driven from chainage `start_m`
/// in `world` against `map`, kidnapped by `jump_m` after [`StudySpec::kidnap_after_m`] when
/// `spec` says so.
pub fn run_one(
    scenario: &Scenario,
    world: &World,
    map: &TunnelMap,
    spec: &StudySpec,
    start_m: f64,
    jump_m: f64,
) -> RunOutcome {
    let before = spec.driven_before_kidnap_m();
    let mut s = scenario.clone();
    s.drive.start_m = start_m;
    s.drive.end_m = start_m + before + spec.drive_m + jump_m.max(0.0);
    let mut est = LocCoreEstimator::new(map, &s);
    if !spec.kidnap {
        est = est.without_initial_pose();
    }
    let teleports = [Teleport {
        at_distance_m: before,
        jump_m,
    }];
    let options = RunOptions {
        teleports: if spec.kidnap { &teleports } else { &[] },
        ..RunOptions::default()
    };
    let log = closed_loop::run(&s, world, &mut est, &options);
    outcome(&log, start_m, jump_m, spec.kidnap.then_some(before))
}

/// Scores one run (`kidnapped_at_m`: the distance of the kidnapping, for those runs).
fn outcome(log: &RunLog, start_m: f64, jump_m: f64, kidnapped_at_m: Option<f64>) -> RunOutcome {
    let from_m = kidnapped_at_m.unwrap_or(0.0);
    let mut r = RunOutcome {
        start_m,
        jump_m,
        detected: kidnapped_at_m.is_none(),
        tracking_after_m: None,
        wrong_lock_scans: 0,
        outside_3sigma_scans: 0,
        tracking_scans: 0,
        worst_tracking_error_m: 0.0,
        relocks: 0,
        timeline: String::new(),
        protection: ProtectionSummary::of(&log.samples).unwrap_or_default(),
    };
    let mut last_label = "";
    // Power-up runs start relocalising; a kidnapping's first entry is its detection.
    let mut was_relocalising = kidnapped_at_m.is_none();
    let mut entries = 0usize;
    for (sample, status) in log.samples.iter().zip(&log.statuses) {
        let after = sample.distance_m >= from_m;
        if after && status.is_relocalising() {
            r.detected = true;
        }
        if status.label() != last_label {
            last_label = status.label();
            let _ = write!(
                r.timeline,
                "{}{:.1}:{last_label}",
                if r.timeline.is_empty() { "" } else { " " },
                sample.distance_m - from_m
            );
        }
        let relocalising = status.is_relocalising();
        if relocalising && !was_relocalising {
            entries += 1;
        }
        was_relocalising = relocalising;
        if !status.is_tracking() {
            continue;
        }
        r.tracking_scans += 1;
        let (dx, dy) = (
            sample.estimate.x_m - sample.truth.x_m,
            sample.estimate.y_m - sample.truth.y_m,
        );
        let e = dx.hypot(dy);
        r.worst_tracking_error_m = r.worst_tracking_error_m.max(e);
        let (sx, sy, _) = sample.sigma;
        if e > 3.0 * sx.hypot(sy) {
            r.outside_3sigma_scans += 1;
        }
        if e > WRONG_LOCK_M {
            r.wrong_lock_scans += 1;
        } else if after && r.detected && r.tracking_after_m.is_none() {
            r.tracking_after_m = Some(sample.distance_m - from_m);
        }
    }
    r.relocks = if kidnapped_at_m.is_some() {
        entries.saturating_sub(1)
    } else {
        entries
    };
    r
}
