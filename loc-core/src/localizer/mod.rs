//! The facade the firmware and the simulator drive: feed odometry and scans, read the pose,
//! its covariance and a status.
//!
//! One scan runs four stages ([`Stage`]); [`Localizer::update_scan_observed`] reports each to
//! a [`StageObserver`] (benchmarks and the firmware time them that way, on this very code):
//! 1. [`crate::strip::strip_walls`]: label points wall / landmark / outlier (vehicle frame);
//! 2. [`crate::matching::select_match_points`]: the points to match;
//! 3. [`crate::matching::match_scan_with_prealign`]: landmark pre-alignment
//!    ([`crate::matching::prealign_along_tunnel`]) and Hausdorff or PL-ICP matching
//!    ([`crate::matching::match_scan`]) against the map; while tracking, each landmark is
//!    judged against the filter's prediction ([`crate::matching::LandmarkGate`]) and one
//!    that disagrees is left out;
//! 4. [`crate::filter::Ekf::update_with_match`]: the EKF update on the observed directions;
//!    after an accepted one, where the scan sees a stored wall end
//!    ([`crate::matching::observe_wall_ends`]), a fix of the position along it
//!    ([`crate::filter::Ekf::update_position_along`]); then [`Integrity`]: does the map
//!    explain the scan's landmarks at the matched pose? A map that has not lately is not
//!    trusted, and the status says so ([`Status::MapUnconfirmed`]).
//!
//! Without a pose — at power-up, or once it has declared itself lost (every scan rejected or
//! the map unconfirmed over [`crate::relocalise::RelocaliseConfig::lost_after_m`], or
//! matches refused by the filter's gate: the innovation test) — the localizer relocalises
//! ([`crate::relocalise`]): it strips each scan, gathers the landmarks seen and searches the
//! map for where their spacings fit, reporting [`Status::Relocalising`] until one placement
//! wins; with a pose it goes on matching on every other scan (its pose may still be right),
//! and re-initialises when the lock disagrees with it. After a lock the status stays [`Status::MapUnconfirmed`] until landmarks not used by
//! the search have fitted over the integrity monitor's confirmation distance.
//!
//! Memory: a `Localizer` holds its scratch buffers (≈ 38 KiB: point labels, selected
//! points, the match workspace); keep it in a `static` or on a large stack. No allocation,
//! no panics, bounded time per call.

mod config;
mod config_record;
mod integrity;
mod protection;
mod stages;
mod start_pose;
mod status;
mod sweep_speed;

pub use config::LocalizerConfig;
pub use config_record::{
    ConfigRecordError, CONFIG_FORMAT_VERSION, CONFIG_MAGIC, CONFIG_RECORD_MAX_BYTES,
};
pub use integrity::{Integrity, IntegrityConfig, IntegrityMonitor};
pub use protection::{Availability, Protection, ProtectionConfig};
pub use stages::{Stage, StageObserver};
pub use start_pose::{
    StartPose, StartPoseError, START_POSE_BYTES, START_POSE_MAGIC, START_POSE_VERSION,
};
pub use status::{RejectReason, Status};
pub use sweep_speed::{SweepSpeed, MAX_SWEEP_BASELINE_S, SWEEP_SPEED_BASELINE_S};

use nalgebra::Matrix3;

use crate::filter::{
    shared_error_scans, CoastRejection, Ekf, FilterInitError, OdometryIncrement, OdometryRejection,
};
use crate::geometry::Pose2;
use crate::map::MapQuery;
use crate::matching::{
    match_scan_with_prealign, observe_wall_ends, select_match_points, LandmarkGate,
    LandmarkOffsets, MatchPoints, MatchResult, MatchWorkspace, PositionPrior, WallEndMemory,
};
use crate::relocalise::{Lock, Relocaliser};
use crate::scan::{Scan, SweepMotion, LMS511_MAX_BEAMS};
use crate::strip::{strip_walls, PointLabel, StripSummary};

/// The localisation pipeline over a map `M`.
pub struct Localizer<'m, M: MapQuery> {
    map: &'m M,
    config: LocalizerConfig,
    ekf: Option<Ekf>,
    status: Status,
    labels: [PointLabel; LMS511_MAX_BEAMS],
    match_points: MatchPoints,
    workspace: MatchWorkspace,
    last_strip: Option<StripSummary>,
    last_match: Option<MatchResult>,
    last_integrity: Option<Integrity>,
    /// Wall ends the last scan's update took ([`crate::matching::observe_wall_ends`]).
    last_wall_end_fixes: u8,
    /// When each wall end was last taken.
    wall_end_memory: WallEndMemory,
    integrity_monitor: IntegrityMonitor,
    /// Distance driven by the predictions so far, metres (for the integrity monitor).
    odometer_m: f32,
    /// The odometer at the filter's last accepted match: how far apart successive matches
    /// are, and so how much of their error across the walls they share (`None`: no match
    /// since the pose was set).
    last_match_odometer_m: Option<f32>,
    /// Searching the map for the vehicle (see the module docs).
    relocalising: bool,
    relocaliser: Relocaliser,
    /// Odometer reading since which every scan was rejected or left the map unconfirmed.
    doubtful_since_m: Option<f32>,
    /// Whether the last scan ran the relocalisation's search (with a pose, scans alternate
    /// between it and matching).
    searched_last_scan: bool,
    /// Matches the filter's gate refused since then.
    gate_failures: u8,
    /// The filter's track after recent scans: the vehicle's speed over the next sweep
    /// ([`LocalizerConfig::deskew`]).
    sweep_speed: SweepSpeed,
}

impl<'m, M: MapQuery> Localizer<'m, M> {
    /// A localizer at `initial_pose` (vehicle in world) with covariance `initial_cov` of
    /// `(x_m, y_m, theta_rad)`.
    pub fn new(
        map: &'m M,
        config: LocalizerConfig,
        initial_pose: Pose2,
        initial_cov: Matrix3<f32>,
    ) -> Result<Self, FilterInitError> {
        let mut l = Self::uninitialised(map, config);
        l.initialise(initial_pose, initial_cov)?;
        Ok(l)
    }

    /// A localizer without a pose: scans are ignored ([`Status::NotInitialised`]) until
    /// [`Localizer::initialise`].
    ///
    /// A `const fn`: a controller can build its localizer in a `static` (no 38 KiB
    /// temporary on a small stack).
    pub const fn uninitialised(map: &'m M, config: LocalizerConfig) -> Self {
        Self {
            map,
            config,
            ekf: None,
            status: Status::NotInitialised,
            labels: [PointLabel::Outlier; LMS511_MAX_BEAMS],
            match_points: MatchPoints::new(),
            workspace: MatchWorkspace::new(),
            last_strip: None,
            last_match: None,
            last_integrity: None,
            last_wall_end_fixes: 0,
            wall_end_memory: WallEndMemory::NEW,
            integrity_monitor: IntegrityMonitor::NEW,
            odometer_m: 0.0,
            last_match_odometer_m: None,
            relocalising: false,
            relocaliser: Relocaliser::NEW,
            doubtful_since_m: None,
            searched_last_scan: false,
            gate_failures: 0,
            sweep_speed: SweepSpeed::NEW,
        }
    }

    /// Starts a global relocalisation: the vehicle's position is searched in the whole map
    /// from the landmarks seen while driving ([`crate::relocalise`]). Without a pose (a
    /// localizer built [`Localizer::uninitialised`]) this is how it finds one; with one, the
    /// localizer goes on matching from it meanwhile, and the map must confirm that pose
    /// again. The status is [`Status::Relocalising`] until a placement wins, or until the
    /// landmarks have confirmed the pose kept as they must confirm a placement's
    /// ([`IntegrityConfig::confirm_distance_m`]) and a scan's landmarks lie on two of the
    /// map's: then the search is called off.
    pub fn relocalise(&mut self) {
        self.relocaliser.restart();
        self.relocalising = true;
        self.workspace.forget_landmarks();
        self.integrity_monitor.distrust();
        self.doubtful_since_m = None;
        self.gate_failures = 0;
        self.status = Status::Relocalising {
            progress: self.relocaliser.progress(),
        };
    }

    /// Drops the pose (power-up without one): the localizer is as
    /// [`Localizer::uninitialised`] left it, its configuration kept. Scans are ignored
    /// ([`Status::NotInitialised`]) until [`Localizer::initialise`] or
    /// [`Localizer::relocalise`].
    pub fn forget_pose(&mut self) {
        self.ekf = None;
        self.relocalising = false;
        self.workspace.forget_landmarks();
        self.relocaliser.restart();
        self.integrity_monitor = IntegrityMonitor::NEW;
        self.last_strip = None;
        self.last_match = None;
        self.last_integrity = None;
        self.doubtful_since_m = None;
        self.last_match_odometer_m = None;
        self.gate_failures = 0;
        self.sweep_speed.reset();
        self.status = Status::NotInitialised;
    }

    /// Whether a relocalisation is under way.
    pub fn is_relocalising(&self) -> bool {
        self.relocalising
    }

    /// The relocaliser (its local landmark map and progress).
    pub fn relocaliser(&self) -> &Relocaliser {
        &self.relocaliser
    }

    /// Sets (or resets) the pose and its covariance; the odometry's scale error starts at
    /// zero ± the configured [`crate::filter::OdometryNoise::scale_sd`].
    pub fn initialise(
        &mut self,
        pose: Pose2,
        covariance: Matrix3<f32>,
    ) -> Result<(), FilterInitError> {
        self.ekf = Some(Ekf::with_scale(
            pose,
            covariance,
            self.config.odometry.scale_sd,
        )?);
        self.status = Status::DeadReckoning;
        self.last_match_odometer_m = None;
        self.workspace.forget_landmarks();
        self.integrity_monitor = IntegrityMonitor::default();
        self.relocalising = false;
        self.doubtful_since_m = None;
        self.gate_failures = 0;
        self.sweep_speed.reset();
        Ok(())
    }

    /// Predicts with an odometry increment (vehicle frame at the previous pose: metres
    /// forward, metres left, radians counter-clockwise) and the configured noise model.
    /// A rejected increment leaves the state unchanged.
    pub fn predict_odometry(
        &mut self,
        increment: &OdometryIncrement,
    ) -> Result<(), OdometryRejection> {
        let noise = self.config.odometry;
        self.predict_by(increment, |ekf| ekf.predict(increment, &noise))
    }

    /// Predicts with an odometry increment and its own covariance (vehicle frame).
    pub fn predict_odometry_with_covariance(
        &mut self,
        increment: &OdometryIncrement,
        covariance: &Matrix3<f32>,
    ) -> Result<(), OdometryRejection> {
        let noise = self.config.odometry;
        self.predict_by(increment, |ekf| {
            ekf.predict_with_covariance(increment, covariance, &noise)
        })
    }

    /// Predicts with motion that is not odometry's (a constant-velocity guess when the
    /// vehicle sends none; vehicle frame at the previous pose) and its covariance: the
    /// odometry's scale error does not apply to it.
    pub fn predict_motion(
        &mut self,
        increment: &OdometryIncrement,
        covariance: &Matrix3<f32>,
    ) -> Result<(), OdometryRejection> {
        let noise = self.config.odometry;
        self.predict_by(increment, |ekf| {
            ekf.predict_motion(increment, covariance, &noise)
        })
    }

    /// Runs one of the filter's predictions by `increment` (nothing before initialisation)
    /// and counts its distance when applied.
    fn predict_by(
        &mut self,
        increment: &OdometryIncrement,
        predict: impl FnOnce(&mut Ekf) -> Result<(), OdometryRejection>,
    ) -> Result<(), OdometryRejection> {
        let r = self.ekf.as_mut().map_or(Ok(()), predict);
        if self.relocalising && r.is_ok() {
            self.relocaliser.advance(increment);
        }
        self.count_distance(r.is_ok(), increment.distance_m());
        r
    }

    /// Predicts across `unobserved_s` seconds in which no odometry arrived, at the last
    /// reported speed `v_mps` and yaw rate `omega_radps` (vehicle frame), with the
    /// configured [`crate::filter::CoastNoise`]: the covariance grows with the time. Call it
    /// for every gap in the odometry; a rejected coast leaves the state unchanged.
    pub fn coast(
        &mut self,
        unobserved_s: f32,
        v_mps: f32,
        omega_radps: f32,
    ) -> Result<(), CoastRejection> {
        let r = match self.ekf.as_mut() {
            Some(ekf) => ekf.coast(unobserved_s, v_mps, omega_radps, &self.config.coast),
            None => Ok(()),
        };
        if self.relocalising && r.is_ok() {
            self.relocaliser.advance(&OdometryIncrement {
                dx_m: v_mps * unobserved_s,
                dy_m: 0.0,
                dtheta_rad: omega_radps * unobserved_s,
            });
        }
        self.count_distance(r.is_ok(), crate::math::abs(v_mps * unobserved_s));
        r
    }

    /// The vehicle's speed for the next scan's sweep as the integrator measures it (its
    /// odometry's rate, vehicle frame), for a scan the filter's own track does not reach
    /// back from: the first after [`Localizer::initialise`] (a start or a resume while
    /// moving), and every scan without a pose (relocalising). Used by the next scan only;
    /// with a track, scans take the filter's. Without it those scans are not de-skewed.
    pub fn hint_sweep_speed(&mut self, motion: SweepMotion) {
        self.sweep_speed.hint(motion);
    }

    /// Adds an applied prediction's distance to the odometer.
    fn count_distance(&mut self, applied: bool, distance_m: f32) {
        if applied && distance_m.is_finite() {
            self.odometer_m += distance_m;
        }
    }

    /// Runs strip → select → pre-align → match → update on one scan (vehicle-frame points
    /// in beam order, as [`Scan`] holds them) and returns the new status. The filter must
    /// have been predicted to the scan's **last beam**, the instant its pose refers to.
    ///
    /// With [`LocalizerConfig::deskew`] and a scan that says when its beams were taken
    /// ([`Scan::timing`]), the scan's points are first carried to where they lie at that
    /// last beam ([`Scan::deskew`]), at the speed the filter moved at over its recent track
    /// ([`SweepSpeed`]: the velocity from its pose after the last scan to its prediction
    /// now, the yaw rate from its pose after a scan 0.2–0.4 s back, over the time between
    /// the scans' stamps). A scan the track does not reach (the first after
    /// [`Localizer::initialise`], one after a gap over 0.5 s, any without a pose) takes the
    /// integrator's [`Localizer::hint_sweep_speed`], or is not de-skewed without one.
    pub fn update_scan(&mut self, scan: &mut Scan) -> Status {
        self.update_scan_observed(scan, &mut ())
    }

    /// [`Localizer::update_scan`], reporting each [`Stage`] to `observer` as it runs (the
    /// de-skew is part of [`Stage::Strip`]).
    pub fn update_scan_observed<O: StageObserver>(
        &mut self,
        scan: &mut Scan,
        observer: &mut O,
    ) -> Status {
        let status = self.localise(scan, observer);
        self.sweep_speed
            .scanned(scan.timing().zip(self.ekf.as_ref().map(|ekf| ekf.pose())));
        status
    }

    /// Carries `scan`'s points to its last beam at the filter's speed over its recent
    /// track (see [`Localizer::update_scan`]); without a pose (relocalising) only the
    /// integrator's hint can say.
    fn deskew(&self, scan: &mut Scan) {
        let (Some(timing), true) = (scan.timing(), self.config.deskew) else {
            return;
        };
        let predicted = self.ekf.as_ref().map(|ekf| ekf.pose());
        if let Some(m) = self.sweep_speed.motion(&timing, predicted.as_ref()) {
            // An implausible speed is refused by the scan (left as taken).
            scan.deskew(&m);
        }
    }

    /// Strip, then relocalise or match and update, on a scan ready to localise on.
    fn localise<O: StageObserver>(&mut self, scan: &mut Scan, observer: &mut O) -> Status {
        if self.ekf.is_none() && !self.relocalising {
            self.status = Status::NotInitialised;
            return self.status;
        }
        observer.begin(Stage::Strip);
        self.deskew(scan);
        let points = scan.points();
        let n = points.len().min(self.labels.len());
        let labels = self.labels.get_mut(..n).unwrap_or_default();
        let strip = strip_walls(points, &self.config.strip, labels);
        self.last_strip = Some(strip);
        observer.end(Stage::Strip);

        // The search runs in the match stage's place: on every scan without a pose, on every
        // other one with a pose (the others match from it), so that no scan pays for both.
        let search = self.relocalising && (self.ekf.is_none() || !self.searched_last_scan);
        self.searched_last_scan = search;
        if search {
            observer.begin(Stage::Match);
            let labels = self.labels.get(..n).unwrap_or_default();
            let lock =
                self.relocaliser
                    .update(self.map, points, labels, &strip, &self.config.relocalise);
            observer.end(Stage::Match);
            self.last_match = None;
            self.last_integrity = None;
            self.status = match lock {
                // Matched from the next scan on: the lock's scan has had its budget.
                Some(lock) => {
                    self.take_lock(&lock);
                    Status::MapUnconfirmed {
                        integrity: Integrity::default(),
                    }
                }
                None => Status::Relocalising {
                    progress: self.relocaliser.progress(),
                },
            };
            return self.status;
        }
        let status = self.match_and_update(points, n, &strip, observer);
        self.status = self.judge(status);
        self.status
    }

    /// Select → pre-align → match → update on a stripped scan (the first `n` labels).
    fn match_and_update<O: StageObserver>(
        &mut self,
        points: &[crate::scan::ScanPoint],
        n: usize,
        strip: &StripSummary,
        observer: &mut O,
    ) -> Status {
        let Some(ekf) = self.ekf.as_mut() else {
            return Status::NotInitialised;
        };
        let cfg = &self.config;
        let labels = self.labels.get(..n).unwrap_or_default();

        observer.begin(Stage::Select);
        select_match_points(
            points,
            labels,
            cfg.max_wall_points,
            cfg.max_landmark_points,
            &mut self.match_points,
        );
        observer.end(Stage::Select);

        observer.begin(Stage::Match);
        let prior = PositionPrior::from_covariance(&ekf.covariance());
        // Each landmark's own correction is judged against the prediction; not while
        // relocalising (the pose kept meanwhile may be the wrong one).
        self.workspace
            .set_landmark_gate((!self.relocalising).then(|| LandmarkGate::new(ekf.pose(), &prior)));
        let matched = match_scan_with_prealign(
            self.map,
            points,
            labels,
            strip,
            &self.match_points,
            ekf.pose(),
            &prior,
            &cfg.prealign,
            &cfg.matching,
            &mut self.workspace,
        );
        observer.end(Stage::Match);
        let (result, match_work) = match matched {
            Ok(r) => (r.result, r.work),
            Err(e) => {
                self.last_match = None;
                self.last_integrity = None;
                return Status::MatchRejected { reason: e.into() };
            }
        };
        self.last_match = Some(result);

        observer.begin(Stage::Update);
        // Matches a short way apart see the same stretch of rough wall: their errors across
        // it are shared over the roughness's correlation length (smooth walls: none).
        let shared_scans = match self.last_match_odometer_m {
            Some(at_m) if cfg.matching.roughness.sigma_m > 0.0 => shared_error_scans(
                self.odometer_m - at_m,
                cfg.matching.roughness.correlation_m,
                cfg.update.max_shared_scans,
            ),
            _ => 1.0,
        };
        let updated = ekf.update_with_match(&result, &cfg.update, shared_scans);
        if updated.is_ok() {
            self.last_match_odometer_m = Some(self.odometer_m);
        }
        self.last_wall_end_fixes = 0;
        // Not while relocalising: the pose kept meanwhile may be the wrong one. Nor on a scan
        // whose matching spent its whole work budget: a match at the cap and a reading
        // (≈ 45 k instructions) on one scan are the controller's worst case, ≈ 1.5 M; the
        // reading waits for the next scan.
        let budget_spent = match_work >= cfg.matching.max_work;
        if updated.is_ok() && !self.relocalising && !budget_spent {
            // What this scan says of its landmarks' offsets, for the matches to come.
            self.workspace.learn_landmark_offsets(
                self.map,
                &self.match_points,
                ekf.pose(),
                &ekf.covariance(),
                &cfg.matching,
            );
        }
        if updated.is_ok() {
            // Where the walls end fixes what the walls alone leave open: the position along
            // them (after the match, so the footprints sit on walls placed by it).
            let prior = PositionPrior::from_covariance(&ekf.covariance());
            let (fixes, memory, odometer_m) = (
                &mut self.last_wall_end_fixes,
                &mut self.wall_end_memory,
                self.odometer_m,
            );
            observe_wall_ends(
                self.map,
                points,
                &cfg.sensor,
                ekf.pose(),
                &prior,
                &cfg.wall_end,
                &mut |fix| {
                    if !memory.is_due(&fix, odometer_m, cfg.wall_end.refix_gaps) {
                        return;
                    }
                    let innovation_m = fix.innovation_m();
                    if ekf
                        .update_position_along(
                            fix.direction,
                            innovation_m,
                            fix.variance_m2,
                            cfg.update.gate,
                        )
                        .is_ok()
                    {
                        memory.take(&fix, odometer_m);
                        *fixes = fixes.saturating_add(1);
                    }
                },
            );
        }
        // Whether the map explains the landmarks decides whether the pose may be called
        // tracked (part of the update stage).
        let integrity = Integrity {
            match_stopped_short: result.unconverged_sd_m > cfg.update.min_measurement_sd_m,
            landmarks_stopped_fitting: result.landmarks_stopped_fitting,
            ..Integrity::check(self.map, points, labels, result.pose, &cfg.integrity)
        };
        self.last_integrity = Some(integrity);
        let trusted = self
            .integrity_monitor
            .observe(&integrity, self.odometer_m, &cfg.integrity);
        let status = match updated {
            Err(e) => Status::MatchRejected { reason: e.into() },
            Ok(_) if !trusted => Status::MapUnconfirmed { integrity },
            Ok(_) if result.degeneracy.degenerate => Status::Degenerate {
                direction_world: result.degeneracy.direction_world,
                eigenvalue_per_m2: result.degeneracy.min_eigenvalue_per_m2,
            },
            Ok(_) => Status::Tracking,
        };
        observer.end(Stage::Update);
        status
    }

    /// Starts from a relocalisation's lock: a pose without one, or one the lock contradicts
    /// (beyond 3σ of its position), is replaced by the lock's; either way the map must be
    /// confirmed again before the pose is called tracked.
    fn take_lock(&mut self, lock: &Lock) {
        self.relocalising = false;
        self.doubtful_since_m = None;
        self.gate_failures = 0;
        let agrees = self.ekf.as_ref().is_some_and(|ekf| {
            let p = ekf.pose();
            let c = ekf.covariance();
            let (dx, dy) = (lock.pose.x_m - p.x_m, lock.pose.y_m - p.y_m);
            let det = c.m11 * c.m22 - c.m12 * c.m21;
            det > 0.0 && (c.m22 * dx * dx - 2.0 * c.m12 * dx * dy + c.m11 * dy * dy) / det <= 9.0
        });
        if !agrees {
            let [sp, st] = self.config.relocalise.lock_sigma;
            let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(sp * sp, sp * sp, st * st));
            if let Ok(ekf) = Ekf::with_scale(lock.pose, cov, self.config.odometry.scale_sd) {
                self.ekf = Some(ekf);
                self.last_match_odometer_m = None;
                self.sweep_speed.reset();
                self.workspace.forget_landmarks();
            }
        }
        self.integrity_monitor = IntegrityMonitor::UNCONFIRMED;
    }

    /// The status to report for a scan's `status`: relocalising while a search is under
    /// way; and the localizer declares itself lost (starting a search) when every scan over
    /// `lost_after_m` was rejected or left the map unconfirmed.
    fn judge(&mut self, status: Status) -> Status {
        let gate_failed = matches!(
            status,
            Status::MatchRejected {
                reason: RejectReason::Update(crate::filter::UpdateRejection::FailedGate { .. })
            }
        );
        // The innovation test: a match refused by the gate says the pose may have jumped (a
        // kidnapping, wheels sliding): nothing is called tracking until the landmarks have
        // confirmed the map again. (Two in a row were once awaited; after a kidnapping of
        // 28.9 m on `tunnel-1km` the scan between them had slid onto a look-alike stretch of
        // landmarks and fitted there, reported tracking. No drive of the comparison, the
        // robustness runs or the S-bend refuses a single match.)
        if gate_failed {
            self.integrity_monitor.distrust();
        }
        let mut status = status;
        if matches!(status, Status::Tracking | Status::Degenerate { .. })
            && !self.integrity_monitor.is_trusted()
        {
            status = Status::MapUnconfirmed {
                integrity: self.last_integrity.unwrap_or_default(),
            };
        }
        match status {
            Status::Tracking | Status::Degenerate { .. } => {
                self.doubtful_since_m = None;
                self.gate_failures = 0;
            }
            Status::MatchRejected { .. } | Status::MapUnconfirmed { .. } => {
                let since = *self.doubtful_since_m.get_or_insert(self.odometer_m);
                if gate_failed {
                    self.gate_failures = self.gate_failures.saturating_add(1);
                }
                let cfg = &self.config.relocalise;
                let lost = self.odometer_m - since >= cfg.lost_after_m
                    || self.gate_failures >= cfg.lost_after_gate_failures;
                if cfg.enabled && !self.relocalising && lost {
                    self.relocalise();
                }
            }
            _ => {}
        }
        // The pose kept while searching has been confirmed by the landmarks again (over the
        // same distance a placement must be) and this scan's landmarks lie on two of the
        // map's: the search has nothing left to find. Without this, a search that cannot
        // lock left a confirmed pose reported as relocalising, and matched only every other
        // scan, for as long as it ran (250 m of the S-bend's seed 3). Wall bumps confirm the
        // map too, but not a position along a bare tunnel: there the search goes on.
        let on_landmarks = self
            .last_integrity
            .is_some_and(|i| i.clusters_on_landmarks >= 2);
        if self.relocalising
            && matches!(status, Status::Tracking | Status::Degenerate { .. })
            && self.integrity_monitor.is_trusted()
            && on_landmarks
        {
            self.relocalising = false;
            self.relocaliser.restart();
        }
        if self.relocalising {
            Status::Relocalising {
                progress: self.relocaliser.progress(),
            }
        } else {
            status
        }
    }

    /// How well the map explained the last matched scan's landmarks (`None` before the
    /// first match).
    pub fn last_integrity(&self) -> Option<&Integrity> {
        self.last_integrity.as_ref()
    }

    /// The share of landmark points the map explained over the recent scans.
    pub fn integrity_monitor(&self) -> &IntegrityMonitor {
        &self.integrity_monitor
    }

    /// The pose estimate (vehicle frame in the world frame); `None` before initialisation.
    pub fn pose(&self) -> Option<Pose2> {
        self.ekf.as_ref().map(Ekf::pose)
    }

    /// The covariance of `(x_m, y_m, theta_rad)` as rows (m², m·rad, rad²); `None` before
    /// initialisation.
    pub fn covariance(&self) -> Option<[[f32; 3]; 3]> {
        self.ekf.as_ref().map(|e| {
            let c = e.covariance();
            [
                [c.m11, c.m12, c.m13],
                [c.m21, c.m22, c.m23],
                [c.m31, c.m32, c.m33],
            ]
        })
    }

    /// The protection level of the pose after the last call: a bound on the horizontal
    /// position error holding except with `config.protection`'s integrity risk, and whether
    /// the pose may be used (the `protection` module docs: how it is
    /// derived and what it assumes).
    pub fn protection(&self) -> Protection {
        Protection::of(
            &self.status,
            self.covariance_matrix().as_ref(),
            &self.config.protection,
        )
    }

    /// The covariance as a matrix; `None` before initialisation.
    pub fn covariance_matrix(&self) -> Option<Matrix3<f32>> {
        self.ekf.as_ref().map(Ekf::covariance)
    }

    /// The status after the last call.
    pub fn status(&self) -> Status {
        self.status
    }

    /// The filter itself (for inspection).
    pub fn filter(&self) -> Option<&Ekf> {
        self.ekf.as_ref()
    }

    /// The stripping summary of the last scan.
    pub fn last_strip(&self) -> Option<&StripSummary> {
        self.last_strip.as_ref()
    }

    /// How many wall ends the last scan's update took (0–4; see
    /// [`crate::matching::observe_wall_ends`]).
    pub fn last_wall_end_fixes(&self) -> u8 {
        self.last_wall_end_fixes
    }

    /// What the localizer has learnt of its landmarks' offsets across their walls (see
    /// [`crate::matching::LandmarkOffsets`]; empty with smooth walls, and emptied by a
    /// start).
    pub fn landmark_offsets(&self) -> &LandmarkOffsets {
        self.workspace.landmark_offsets()
    }

    /// The match of the last scan, if it succeeded (even if the filter then rejected it).
    pub fn last_match(&self) -> Option<&MatchResult> {
        self.last_match.as_ref()
    }

    /// The point labels of the last scan (one per point of the scan).
    pub fn last_labels(&self) -> &[PointLabel] {
        let n = self.last_strip.map_or(0, |s| {
            let c = s.counts;
            usize::from(c.left_wall)
                + usize::from(c.right_wall)
                + usize::from(c.landmark)
                + usize::from(c.outlier)
                + usize::from(c.out_of_range)
        });
        self.labels.get(..n).unwrap_or_default()
    }

    /// The configuration.
    pub fn config(&self) -> &LocalizerConfig {
        &self.config
    }

    /// Replaces the configuration (a controller built at compile time with the defaults
    /// takes the vehicle's from flash before it starts; changing it while tracking is
    /// allowed but the filter keeps its state).
    pub fn set_config(&mut self, config: LocalizerConfig) {
        self.config = config;
    }
}

/// The largest standard deviation of the position, metres: the square root of the larger
/// eigenvalue of the covariance's `(x, y)` block (`p` as the filter keeps it, world frame).
pub fn largest_position_sd_m(p: &Matrix3<f32>) -> f32 {
    let (a, b, c) = (p.m11, p.m12, p.m22);
    let half_diff = 0.5 * (a - c);
    let lambda = 0.5 * (a + c) + crate::math::sqrt(half_diff * half_diff + b * b);
    crate::math::sqrt(crate::math::max(lambda, 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matching::{GATE_MEMORY_SLOTS, LANDMARK_OFFSET_SLOTS};

    #[test]
    fn memory_is_what_the_docs_say() {
        use crate::map::TunnelMap;
        let localizer = core::mem::size_of::<Localizer<'static, TunnelMap>>();
        let scan = core::mem::size_of::<Scan>();
        let workspace = core::mem::size_of::<MatchWorkspace>();
        // Module docs: ≈ 38 KiB; Scan ≈ 32 KiB; MatchWorkspace 32 KiB, the landmark
        // offsets (24 slots of 20 bytes and two counts), the landmark gate (32 bytes), its
        // memory (8 ids and a count) and the landmarks fitted in the last scan and this one
        // (16 ids and a count each).
        assert!((37 * 1024..40 * 1024).contains(&localizer), "{localizer}");
        assert!((31 * 1024..34 * 1024).contains(&scan), "{scan}");
        let offsets = LANDMARK_OFFSET_SLOTS * 20 + 8;
        assert_eq!(core::mem::size_of::<LandmarkOffsets>(), offsets);
        let gate = core::mem::size_of::<Option<LandmarkGate>>();
        assert_eq!(gate, 32);
        let memory = core::mem::size_of::<crate::matching::GateMemory>();
        assert_eq!(
            memory,
            GATE_MEMORY_SLOTS * 2 + core::mem::size_of::<usize>()
        );
        // The landmarks the last scan's and this scan's matches found plainly fitting: 16
        // ids and a count each.
        let fitted = 2 * (16 * 2 + core::mem::size_of::<usize>());
        // (and the padding that aligns them)
        let parts = 512 * 56 + 512 * 8 + 4 + offsets + gate + memory + fitted;
        assert!(
            (parts..parts + 8).contains(&workspace),
            "{workspace} for {parts}"
        );
    }
}
