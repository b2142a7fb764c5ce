//! Closed-loop runs: the vehicle drives, the lidar scans, and the estimator under test gets
//! odometry and every scan exactly as on the vehicle; everything is recorded in a
//! [`RunLog`].
//!
//! Timing: the vehicle is integrated at 1 kHz; odometry readings go to the estimator at the
//! odometry rate (100 Hz by default), each covering the interval since the previous one;
//! a scan is taken every `1 / f` seconds of the LMS511 rate, from the vehicle's true pose
//! at that instant (the sweep's own 21 ms duration is not modelled: loc-core treats a scan
//! as instantaneous), after the odometry up to that instant has been delivered.

use std::time::Instant;

use cpu_time::ThreadTime;

use loc_core::rng::Pcg32;

use crate::lidar::{EchoCounts, LidarScan, Lms511};
use crate::metrics::{self, Metrics, Sample};
use crate::odometry_gaps::dead_reckoned_at;
use crate::scenario::Scenario;
use crate::status::EstimatorStatus;
use crate::traffic::Traffic;
use crate::vehicle::odometry::{Odometry, OdometrySample};
use crate::vehicle::path_follower::PathFollower;
use crate::vehicle::skid_steer::{SkidSteer, TrackSpeeds};
use crate::vehicle::SimPose;
use crate::world::centerline::CenterLine;
use crate::world::layout::Condition;
use crate::world::World;

/// Vehicle integration step, seconds (1 kHz).
pub const VEHICLE_DT_S: f64 = 0.001;

/// What an estimator reports after a scan.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorOutput {
    /// Estimated vehicle pose, world frame (heading may be wrapped).
    pub pose: SimPose,
    /// Standard deviations `(σx m, σy m, σθ rad)` from the estimate's covariance.
    pub sigma: (f64, f64, f64),
    /// What the estimator made of the scan.
    pub status: EstimatorStatus,
    /// The estimate's protection level and availability (`None`: the estimator gives none).
    pub protection: Option<loc_core::localizer::Protection>,
}

/// A pose estimator fed like the one on the vehicle: odometry readings and scans in.
pub trait Estimator {
    /// Name for reports.
    fn name(&self) -> String;
    /// Restarts at an initial pose with the given position and heading uncertainty.
    fn reset(&mut self, pose: SimPose, sigma_m: f64, sigma_rad: f64);
    /// One odometry reading.
    fn odometry(&mut self, sample: &OdometrySample);
    /// One scan; returns the estimate after it.
    fn scan(&mut self, scan: &LidarScan) -> EstimatorOutput;
    /// The estimator's own measure of the time its last scan took, µs, where the caller's
    /// clock would time something else (an external localiser's log); `None`: time the call.
    fn last_update_us(&self) -> Option<f64> {
        None
    }
}

/// Dead reckoning from odometry alone: the baseline every localiser must beat. It ignores
/// scans.
#[derive(Debug, Clone, Default)]
pub struct OdometryOnly {
    pose: SimPose,
    sigma: (f64, f64, f64),
    /// The latest reading (the pose is carried on from it to each scan).
    last: Option<OdometrySample>,
}

impl Estimator for OdometryOnly {
    fn name(&self) -> String {
        "odometry-only".into()
    }

    fn reset(&mut self, pose: SimPose, sigma_m: f64, sigma_rad: f64) {
        self.pose = pose;
        self.sigma = (sigma_m, sigma_m, sigma_rad);
        self.last = None;
    }

    fn odometry(&mut self, s: &OdometrySample) {
        let (dx, dy, dth) = s.delta;
        let (sn, cs) = self.pose.theta_rad.sin_cos();
        self.pose = SimPose {
            x_m: self.pose.x_m + cs * dx - sn * dy,
            y_m: self.pose.y_m + sn * dx + cs * dy,
            theta_rad: self.pose.theta_rad + dth,
        };
        self.last = Some(*s);
    }

    fn scan(&mut self, scan: &LidarScan) -> EstimatorOutput {
        EstimatorOutput {
            pose: dead_reckoned_at(self.pose, self.last.as_ref(), scan.t_s),
            sigma: self.sigma,
            status: EstimatorStatus::Odometry,
            protection: None,
        }
    }
}

/// The vehicle's pose `lag_s` seconds before the newest of `recent` (one pose per
/// [`VEHICLE_DT_S`], newest last), interpolated between steps; the oldest held beyond them.
fn pose_before(recent: &std::collections::VecDeque<SimPose>, lag_s: f64) -> (f64, f64, f64) {
    let Some(newest) = recent.len().checked_sub(1) else {
        return (0.0, 0.0, 0.0);
    };
    let steps = (lag_s / VEHICLE_DT_S).max(0.0);
    let k = (steps.floor() as usize).min(newest);
    let u = (steps - k as f64).clamp(0.0, 1.0);
    let a = recent[newest - k];
    let b = if k < newest {
        recent[newest - k - 1]
    } else {
        a
    };
    let lerp = |p: f64, q: f64| p + (q - p) * u;
    (
        lerp(a.x_m, b.x_m),
        lerp(a.y_m, b.y_m),
        lerp(a.theta_rad, b.theta_rad),
    )
}

/// A summary of the simulated world, for reports.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WorldSummary {
    /// Centre-line length, metres.
    pub tunnel_length_m: f64,
    /// Wall-to-wall width, metres.
    pub width_m: f64,
    /// Landmarks in the design (stored map).
    pub landmarks_designed: usize,
    /// Of those, missing in the true tunnel (`None`: not known, as in a replay).
    pub landmarks_missing: Option<usize>,
    /// Of those, damaged in the true tunnel (`None`: not known).
    pub landmarks_damaged: Option<usize>,
    /// Segments of the true geometry (ray-casting load; `None` without a simulated world).
    pub true_segments: Option<usize>,
}

impl WorldSummary {
    /// Summarises a world.
    pub fn of(world: &World) -> Self {
        let p = world.placements();
        Self {
            tunnel_length_m: world.centerline().length_m(),
            width_m: world.width_m(),
            landmarks_designed: p.len(),
            landmarks_missing: Some(
                p.iter()
                    .filter(|l| l.condition == Condition::Missing)
                    .count(),
            ),
            landmarks_damaged: Some(
                p.iter()
                    .filter(|l| matches!(l.condition, Condition::Damaged(_)))
                    .count(),
            ),
            true_segments: Some(world.grid().segments().len()),
        }
    }

    /// What the design alone tells (a replay: no simulated world, so nothing is known of
    /// missing or damaged landmarks): the centre line's length, the scenario's width and the
    /// stored map's landmarks.
    pub fn of_design(line: &CenterLine, width_m: f64, map: &loc_core::map::TunnelMap) -> Self {
        Self {
            tunnel_length_m: line.length_m(),
            width_m,
            landmarks_designed: map.landmarks().len(),
            landmarks_missing: None,
            landmarks_damaged: None,
            true_segments: None,
        }
    }
}

/// Everything recorded in one run (later consumers: CSV/JSON output, plots, recordings).
#[derive(Debug, Clone)]
pub struct RunLog {
    /// The scenario run.
    pub scenario: Scenario,
    /// The estimator's name.
    pub estimator: String,
    /// World summary.
    pub world: WorldSummary,
    /// The tunnel's centre line (for the along/across error split).
    pub centerline: CenterLine,
    /// One sample per scan.
    pub samples: Vec<Sample>,
    /// The estimator's status per scan.
    pub statuses: Vec<EstimatorStatus>,
    /// The scans themselves, when asked for ([`RunOptions::keep_scans`]).
    pub scans: Vec<LidarScan>,
    /// The odometry readings, when asked for ([`RunOptions::keep_scans`]).
    pub odometry: Vec<OdometrySample>,
    /// The true start pose (where the odometry's dead reckoning starts), world frame.
    pub start: SimPose,
    /// What the estimator was reset with: initial pose (world frame), position σ (m) and
    /// heading σ (rad). A recording keeps it so a replay starts the same way.
    pub initial_estimate: (SimPose, f64, f64),
    /// Wall-clock time of the whole run (simulation + estimator), seconds.
    pub wall_time_s: f64,
    /// CPU time spent ray casting, seconds.
    pub raycast_time_s: f64,
    /// What the scans' first echoes came from (dust, people and vehicles; zero for a
    /// replay).
    pub echo_counts: EchoCounts,
}

impl RunLog {
    /// The run's figures.
    pub fn metrics(&self) -> Metrics {
        metrics::compute(&self.centerline, &self.samples, 10.0)
    }

    /// Simulated time over wall-clock time (how much faster than real time the run was).
    pub fn real_time_factor(&self) -> f64 {
        let sim = self.samples.last().map_or(0.0, |s| s.t_s);
        if self.wall_time_s > 0.0 {
            sim / self.wall_time_s
        } else {
            0.0
        }
    }

    /// Simulated time over the CPU time of the lidar simulation and the estimator (the
    /// scan-rate work; the 1 kHz vehicle integration is not counted): how much faster than
    /// real time the sensor and localiser run on one core, whatever else loads the machine.
    /// [`crate::session::run_scenario_timed`] measures the whole run.
    pub fn scan_cpu_real_time_factor(&self) -> f64 {
        let sim = self.samples.last().map_or(0.0, |s| s.t_s);
        let cpu =
            self.raycast_time_s + self.samples.iter().map(|s| s.update_us).sum::<f64>() * 1e-6;
        if cpu > 0.0 {
            sim / cpu
        } else {
            0.0
        }
    }

    /// The worst error in σ over the scans reported tracking ([`metrics::worst_sigmas`]):
    /// above 5 the localiser claimed a pose it did not have.
    pub fn worst_tracking_sigmas(&self) -> Option<metrics::WorstSigmas> {
        metrics::worst_sigmas(
            self.samples
                .iter()
                .zip(&self.statuses)
                .filter(|(_, st)| st.is_tracking())
                .map(|(s, _)| s),
        )
    }

    /// Number of scans whose status satisfies `which` (e.g. [`EstimatorStatus::is_tracking`]).
    pub fn status_count(&self, which: impl Fn(&EstimatorStatus) -> bool) -> usize {
        self.statuses.iter().filter(|s| which(s)).count()
    }
}

/// Options of a run.
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Keep every scan and odometry reading in the log (memory: ~2.3 kB per scan and
    /// echo channel in use: clear air uses one, dust two).
    pub keep_scans: bool,
    /// Called now and then with the fraction of the drive done (0–1).
    pub progress: Option<&'a dyn Fn(f64)>,
    /// Kidnappings: the vehicle moved along the tunnel where its odometry does not see it.
    pub teleports: &'a [Teleport],
    /// Stretches without scans (the lidar blanked: a cable, a power dip): no scan reaches
    /// the estimator from `from_m` driven for `seconds`.
    pub blind: &'a [Blind],
}

/// The lidar blanked: no scan reaches the estimator for `seconds` once the vehicle has
/// driven `from_m` (the odometry goes on).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blind {
    /// Distance driven when it starts, metres.
    pub from_m: f64,
    /// How long, seconds.
    pub seconds: f64,
}

/// A kidnapping: once the vehicle has driven `at_distance_m`, it is moved `jump_m` along
/// the centre line (negative: back), keeping its offset from the line and its heading
/// relative to it, with no odometry of the move (a tow, wheels sliding on mud).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Teleport {
    /// Distance driven when it happens, metres.
    pub at_distance_m: f64,
    /// Along the centre line, metres.
    pub jump_m: f64,
}

/// Drives the scenario's route through `world`, feeding `estimator`.
pub fn run(
    scenario: &Scenario,
    world: &World,
    estimator: &mut dyn Estimator,
    options: &RunOptions<'_>,
) -> RunLog {
    let wall = Instant::now();
    let line = world.centerline();
    let mut follower = PathFollower::new(scenario.drive, line.length_m());
    let start = follower.start_pose(line);
    let seed = scenario.seed;
    let mut vehicle = SkidSteer::new(scenario.vehicle, start, seed ^ 0x7e41);
    let mut odometry = Odometry::new(
        scenario.odometry,
        scenario.vehicle.track_width_m,
        start,
        seed ^ 0x0d0,
    );
    let mut lidar = Lms511::new(scenario.lidar, seed ^ 0x11d);
    let traffic = Traffic::new(
        scenario.traffic,
        line,
        (scenario.drive.start_m, scenario.drive.end_m),
        scenario.tunnel.width_m,
        seed ^ 0x7a,
    );
    let mut obstacles = Vec::new();
    let mut init_rng = Pcg32::new(seed, 0x1417);
    let c = &scenario.localizer;
    let initial = SimPose {
        x_m: start.x_m + c.initial_sigma_m * f64::from(init_rng.gaussian()),
        y_m: start.y_m + c.initial_sigma_m * f64::from(init_rng.gaussian()),
        theta_rad: start.theta_rad + c.initial_sigma_rad * f64::from(init_rng.gaussian()),
    };
    let initial_estimate = (
        initial,
        c.initial_sigma_m.max(0.01),
        c.initial_sigma_rad.max(0.002),
    );
    estimator.reset(initial_estimate.0, initial_estimate.1, initial_estimate.2);

    let steps_per_odometry = ((1.0 / scenario.odometry.rate_hz) / VEHICLE_DT_S)
        .round()
        .max(1.0) as u64;
    let scan_period_s = 1.0 / scenario.lidar.rate.frequency_hz();
    let drive_len = follower.length_m().max(1e-9);
    // Generous time limit: the drive at a tenth of its cruise speed.
    let max_steps =
        ((10.0 * drive_len / scenario.drive.cruise_speed_mps + 60.0) / VEHICLE_DT_S) as u64;

    let mut samples = Vec::new();
    let mut statuses = Vec::new();
    let mut scans = Vec::new();
    let mut odo_log = Vec::new();
    let mut wheel_sum = TrackSpeeds::default();
    let mut wheel_n = 0u32;
    let mut distance = 0.0f64;
    let mut chainage_hint = scenario.drive.start_m;
    let mut next_scan_index = 1u64;
    // The latest odometry reading (the dead reckoning is carried on from it to each scan).
    let mut last_reading: Option<OdometrySample> = None;
    // The vehicle's recent poses, one per step, newest last: where it was when the
    // scanner's mirror passed each beam (`lidar.sweep`).
    let sweep_steps = if scenario.lidar.sweep {
        (scan_period_s / VEHICLE_DT_S).ceil() as usize + 2
    } else {
        1
    };
    let mut recent: std::collections::VecDeque<SimPose> =
        std::collections::VecDeque::with_capacity(sweep_steps + 1);
    let mut raycast_time = 0.0f64;
    let mut finished_at: Option<u64> = None;
    let mut last_progress = -1.0f64;
    let mut teleports_done = 0usize;
    let mut yaw_sum = 0.0f64;
    // Start time of each blind stretch once the vehicle reached it.
    let mut blind_since: Vec<Option<f64>> = vec![None; options.blind.len()];

    for step in 1..=max_steps {
        let before = vehicle.pose();
        let cmd = follower.command(line, before);
        let tracks = if cmd.finished {
            finished_at.get_or_insert(step);
            TrackSpeeds::default()
        } else {
            vehicle.commands_for(
                cmd.v_mps,
                cmd.omega_radps,
                scenario.odometry.calibrated_icr_expansion,
            )
        };
        vehicle.step(tracks, VEHICLE_DT_S);
        let mut after = vehicle.pose();
        distance += (after.x_m - before.x_m).hypot(after.y_m - before.y_m);
        // What a gyro senses: the vehicle's own turning (not a kidnapping's).
        yaw_sum += (after.theta_rad - before.theta_rad + std::f64::consts::PI)
            .rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        if let Some(k) = options.teleports.get(teleports_done) {
            if distance >= k.at_distance_m {
                teleports_done += 1;
                after = teleported(line, after, chainage_hint, k.jump_m);
                vehicle.teleport(after);
                follower.jump(k.jump_m);
                chainage_hint += k.jump_m;
            }
        }
        if recent.len() == sweep_steps {
            recent.pop_front();
        }
        recent.push_back(after);
        let w = vehicle.wheel_speeds();
        wheel_sum.left_mps += w.left_mps;
        wheel_sum.right_mps += w.right_mps;
        wheel_n += 1;
        let t = step as f64 * VEHICLE_DT_S;

        if step % steps_per_odometry == 0 {
            let mean = TrackSpeeds {
                left_mps: wheel_sum.left_mps / f64::from(wheel_n),
                right_mps: wheel_sum.right_mps / f64::from(wheel_n),
            };
            let dt = f64::from(wheel_n) * VEHICLE_DT_S;
            let reading = odometry.read(mean, yaw_sum / dt, t, dt);
            yaw_sum = 0.0;
            estimator.odometry(&reading);
            last_reading = Some(reading);
            if options.keep_scans {
                odo_log.push(reading);
            }
            wheel_sum = TrackSpeeds::default();
            wheel_n = 0;
        }

        for (b, since) in options.blind.iter().zip(blind_since.iter_mut()) {
            if since.is_none() && distance >= b.from_m {
                *since = Some(t);
            }
        }
        let blind = options
            .blind
            .iter()
            .zip(&blind_since)
            .any(|(b, since)| since.is_some_and(|s| t < s + b.seconds));
        if t + 1e-9 >= next_scan_index as f64 * scan_period_s {
            next_scan_index += 1;
            if blind {
                continue;
            }
            // CPU time of this thread: other processes on the machine do not count.
            let r0 = ThreadTime::now();
            traffic.obstacles_at(line, t, &mut obstacles);
            let scan = lidar.scan_swept(
                world.grid(),
                &obstacles,
                |lag_s| pose_before(&recent, lag_s),
                t,
            );
            raycast_time += r0.elapsed().as_secs_f64();
            let e0 = ThreadTime::now();
            let out = estimator.scan(&scan);
            let update_us = e0.elapsed().as_secs_f64() * 1e6;
            let proj = line.project(after.x_m, after.y_m, chainage_hint, 5.0);
            chainage_hint = proj.s_m;
            samples.push(Sample {
                t_s: t,
                distance_m: distance,
                chainage_m: proj.s_m,
                truth: after,
                estimate: out.pose,
                odometry: dead_reckoned_at(odometry.pose(), last_reading.as_ref(), t),
                sigma: out.sigma,
                protection: out.protection,
                update_us,
            });
            statuses.push(out.status);
            if options.keep_scans {
                scans.push(scan);
            }
            if let Some(p) = options.progress {
                let frac = (distance / drive_len).min(1.0);
                if frac - last_progress >= 0.005 {
                    p(frac);
                    last_progress = frac;
                }
            }
        }
        // Stop half a second after the follower finished (the vehicle has come to rest).
        if finished_at.is_some_and(|f| step >= f + 500) {
            break;
        }
    }
    if let Some(p) = options.progress {
        p(1.0);
    }
    RunLog {
        scenario: scenario.clone(),
        estimator: estimator.name(),
        world: WorldSummary::of(world),
        centerline: line.clone(),
        samples,
        statuses,
        scans,
        odometry: odo_log,
        start,
        initial_estimate,
        wall_time_s: wall.elapsed().as_secs_f64(),
        raycast_time_s: raycast_time,
        echo_counts: lidar.counts(),
    }
}

/// `pose` moved `jump_m` along `line` (chainage near `s_hint_m`), keeping its lateral
/// offset and its heading relative to the line (clamped to the line's ends).
fn teleported(line: &CenterLine, pose: SimPose, s_hint_m: f64, jump_m: f64) -> SimPose {
    let proj = line.project(pose.x_m, pose.y_m, s_hint_m, 5.0);
    let (_, _, h0) = line.pose_at(proj.s_m);
    let s1 = (proj.s_m + jump_m).clamp(0.0, line.length_m());
    let (x, y) = line.offset_point(s1, proj.lateral_m);
    let (_, _, h1) = line.pose_at(s1);
    SimPose {
        x_m: x,
        y_m: y,
        theta_rad: pose.theta_rad + (h1 - h0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;

    #[test]
    fn odometry_only_run_drifts_like_odometry_and_reaches_the_end() {
        let mut s = named("paper-10m").unwrap();
        s.localizer.initial_sigma_m = 0.0;
        s.localizer.initial_sigma_rad = 0.0;
        let world = s.build_world().unwrap();
        let mut est = OdometryOnly::default();
        let log = run(&s, &world, &mut est, &RunOptions::default());
        let m = log.metrics();
        // About 10 m at 1 m/s with start-up and braking: 12–20 s of 25 Hz scans.
        assert!(m.scans > 250 && m.scans < 600, "{}", m.scans);
        assert!((m.distance_m - 10.0).abs() < 0.5, "{}", m.distance_m);
        // With a zero initial error the estimator is exactly the odometry.
        assert!((m.localizer.position_rms_m - m.odometry.position_rms_m).abs() < 1e-9);
        // Roughly 2 % of distance along the tunnel at the end (scale error + slip).
        let end = m.odometry.final_position_error_m;
        assert!(end > 0.05 && end < 0.5, "final odometry error {end}");
        assert_eq!(
            log.status_count(|s| *s == EstimatorStatus::Odometry),
            m.scans
        );
    }

    #[test]
    fn the_pose_before_the_scan_is_interpolated_between_steps() {
        let recent: std::collections::VecDeque<SimPose> = (0..3)
            .map(|k| SimPose::new(f64::from(k), 0.0, 0.01 * f64::from(k)))
            .collect();
        assert_eq!(pose_before(&recent, 0.0), (2.0, 0.0, 0.02));
        let (x, _, th) = pose_before(&recent, 1.5 * VEHICLE_DT_S);
        assert!((x - 0.5).abs() < 1e-9 && (th - 0.005).abs() < 1e-12);
        // Past the oldest kept pose: held there.
        assert_eq!(pose_before(&recent, 1.0), (0.0, 0.0, 0.0));
    }

    #[test]
    fn runs_are_deterministic_for_a_seed() {
        let s = named("paper-10m").unwrap();
        let a = crate::session::odometry_run(&s);
        let b = crate::session::odometry_run(&s);
        assert_eq!(a.samples.len(), b.samples.len());
        for (x, y) in a.samples.iter().zip(&b.samples) {
            assert_eq!((x.truth, x.estimate), (y.truth, y.estimate));
        }
    }
}
