//! loc-core's `Localizer` as the estimator of a closed-loop run, fed exactly as on the
//! vehicle: each odometry reading becomes an `OdometryIncrement` prediction, each scan's
//! echoes become a `Scan` through the one telegram-to-scan conversion (per beam the echo
//! the scenario's `localizer.echo` chooses, [`scan_input::SelectedEchoes`], then
//! [`scan_input::load_values`], the firmware's too) and go through `update_scan`.
//!
//! The localiser is configured for the simulated sensor: the mounting pose and range limits
//! (the beam layout comes with each scan, as in its telegram), the range noise σ, the
//! scenario's odometry noise, and the chosen matcher. Everything else is loc-core's default
//! tuning. Time the odometry log leaves uncovered is coasted across ([`crate::odometry_gaps`]).

use loc_core::filter::{OdometryIncrement, OdometryNoise};
use loc_core::geometry::Pose2;
use loc_core::localizer::{Localizer, LocalizerConfig};
use loc_core::map::TunnelMap;
use loc_core::matching::{MatcherKind, RoughnessModel};
use loc_core::scan::{Scan, ScanGeometry, SensorSetup, SweepMotion};
use nalgebra::Matrix3;
use scan_input::EchoSelection;

use crate::closed_loop::{Estimator, EstimatorOutput};
use crate::lidar::{LidarScan, LidarSpec};
use crate::odometry_gaps::{Gap, GapTracker};
use crate::scenario::{MatcherChoice, Scenario};
use crate::status::EstimatorStatus;
use crate::vehicle::odometry::OdometrySample;
use crate::vehicle::SimPose;

/// The sensor setup loc-core gets for a simulated LMS511: its nominal layout (scans bring
/// their own), range limits and mounting.
pub fn sensor_setup(lidar: &LidarSpec) -> SensorSetup {
    SensorSetup {
        geometry: lidar
            .rate
            .layout()
            .geometry(ScanGeometry::LMS511_MIN_RANGE_M, lidar.max_range_m as f32),
        mounting: Pose2::new(
            lidar.mount_x_m as f32,
            lidar.mount_y_m as f32,
            lidar.mount_yaw_rad as f32,
        ),
    }
}

/// The odometry noise model a scenario tells the localiser to expect (loc-core's scale
/// state and random walk in distance, see [`OdometryNoise`]).
pub fn odometry_noise(scenario: &Scenario) -> OdometryNoise {
    let c = &scenario.localizer;
    OdometryNoise {
        drift_fraction: c.odometry_drift_fraction as f32,
        drift_length_m: c.odometry_drift_length_m as f32,
        heading_drift_rad_per_m: c.odometry_heading_drift_rad_per_m as f32,
        scale_sd: c.odometry_scale_sd as f32,
        scale_drift_sd: c.odometry_scale_drift_sd as f32,
        scale_drift_length_m: c.odometry_scale_drift_length_m as f32,
        ..OdometryNoise::default()
    }
}

/// The localiser configuration for a scenario.
pub fn localizer_config(scenario: &Scenario) -> LocalizerConfig {
    let mut cfg = LocalizerConfig {
        sensor: sensor_setup(&scenario.lidar),
        odometry: odometry_noise(scenario),
        ..LocalizerConfig::default()
    };
    cfg.matching.matcher = match scenario.localizer.matcher {
        MatcherChoice::Hausdorff => MatcherKind::Hausdorff,
        MatcherChoice::Icp => MatcherKind::Icp,
    };
    // The matcher's covariance is scaled by the sensor's noise (floored: a noiseless
    // simulation must not claim infinite precision).
    cfg.matching.range_noise_sigma_m = (scenario.lidar.range_noise_m as f32).max(0.003);
    // The walls as rough as the scenario makes them (on a vehicle: as the survey measured
    // them): points on one stretch share its offset from the smooth map. With or without
    // landmarks: without, the position along the tunnel comes from the curves seen ahead,
    // fixed by a few stretches of wall, and only the model says how few (without it the
    // 200 m of `tunnel-1km` were 5–8 σ off along; it once made the bare lateral worse, when
    // the stored walls far ahead were matched at a held, metres-wrong position along).
    cfg.matching.roughness = RoughnessModel {
        sigma_m: scenario.tunnel.roughness_sigma_m as f32,
        correlation_m: (scenario.tunnel.roughness_correlation_m as f32).max(0.05),
    };
    // A wall's last metre is as rough as the rest (a wall end seen at grazing incidence
    // moves along with it).
    cfg.wall_end.wall_roughness_m = scenario.tunnel.roughness_sigma_m as f32;
    // The simulated scanner sweeps only when the scenario says so (`lidar.sweep`); scans
    // taken at one instant must not be carried over a sweep that never was.
    cfg.deskew = scenario.lidar.sweep;
    cfg
}

/// A scan's stamp on the scanner's µs clock from its time on the run's clock, seconds
/// (the telegram's field, wrapping at 2³² µs).
pub fn scan_stamp_us(t_s: f64) -> u32 {
    (t_s * 1e6).round().rem_euclid(4_294_967_296.0) as u32
}

/// loc-core's localiser over a stored map, driven like on the vehicle.
pub struct LocCoreEstimator<'m> {
    localizer: Box<Localizer<'m, TunnelMap>>,
    /// Start without a pose: relocalise (power-up anywhere).
    without_initial_pose: bool,
    scan: Box<Scan>,
    matcher: MatcherChoice,
    /// Which echo of each beam becomes its range.
    echo: EchoSelection,
    last_reset: SimPose,
    gaps: GapTracker,
    /// The last odometry reading: its whole increment is the rate a scan between readings
    /// is predicted at ([`GapTracker::lead`]); its speed and yaw rate the sweep's speed for
    /// a scan the localiser's own track does not cover (as the firmware gives its
    /// odometry's rate).
    last_reading: Option<OdometrySample>,
}

impl<'m> LocCoreEstimator<'m> {
    /// A localiser over `map`, configured for `scenario`'s sensor and matcher.
    pub fn new(map: &'m TunnelMap, scenario: &Scenario) -> Self {
        Self {
            localizer: Box::new(Localizer::uninitialised(map, localizer_config(scenario))),
            without_initial_pose: false,
            scan: Box::new(Scan::new()),
            matcher: scenario.localizer.matcher,
            echo: scenario.localizer.echo.selection(),
            last_reset: SimPose::default(),
            gaps: GapTracker::default(),
            last_reading: None,
        }
    }

    /// The same localiser, started without a pose at each reset: it relocalises from the
    /// landmarks it sees (a vehicle powered up anywhere in the tunnel). Until it locks, the
    /// run's estimate is the reset's pose and its status `relocalising`.
    pub fn without_initial_pose(mut self) -> Self {
        self.without_initial_pose = true;
        self
    }

    /// Predicts with `fraction` of an odometry increment `delta` (`dx_m, dy_m, dtheta_rad`,
    /// vehicle frame); a rejected increment leaves the state unchanged, as on the vehicle.
    fn predict_share(&mut self, delta: (f64, f64, f64), fraction: f64) {
        let inc = OdometryIncrement {
            dx_m: (delta.0 * fraction) as f32,
            dy_m: (delta.1 * fraction) as f32,
            dtheta_rad: (delta.2 * fraction) as f32,
        };
        let _ = self.localizer.predict_odometry(&inc);
    }

    /// Coasts across a gap in the odometry (a rejected coast leaves the state unchanged).
    fn coast(&mut self, gap: Option<Gap>) {
        if let Some(g) = gap {
            let _ =
                self.localizer
                    .coast(g.unobserved_s as f32, g.v_mps as f32, g.omega_radps as f32);
        }
    }

    /// The localiser (for inspection: last strip, last match).
    pub fn localizer(&self) -> &Localizer<'m, TunnelMap> {
        &self.localizer
    }
}

impl Estimator for LocCoreEstimator<'_> {
    fn name(&self) -> String {
        format!("loc-core {}", self.matcher.name())
    }

    fn reset(&mut self, pose: SimPose, sigma_m: f64, sigma_rad: f64) {
        self.last_reset = pose;
        self.gaps.reset();
        self.last_reading = None;
        let (v, w) = ((sigma_m * sigma_m) as f32, (sigma_rad * sigma_rad) as f32);
        let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(v, v, w));
        let p = Pose2::new(pose.x_m as f32, pose.y_m as f32, pose.theta_rad as f32);
        if self.without_initial_pose {
            self.localizer.forget_pose();
            self.localizer.relocalise();
            return;
        }
        // Only a non-finite pose is refused; the run then reports "not-initialised".
        let _ = self.localizer.initialise(p, cov);
    }

    fn odometry(&mut self, s: &OdometrySample) {
        let (gap, fraction) = self.gaps.reading(s);
        self.coast(gap);
        self.last_reading = Some(*s);
        self.predict_share(s.delta, fraction);
    }

    fn scan(&mut self, scan: &LidarScan) -> EstimatorOutput {
        let gap = self.gaps.scan(scan.t_s);
        self.coast(gap);
        // Up to the scan's own time at the last reading's rate (the next reading keeps the
        // rest of its interval).
        if let (Some(fraction), Some(r)) = (self.gaps.lead(scan.t_s), self.last_reading) {
            self.predict_share(r.delta, fraction);
        }
        let loaded = scan_input::load_values(
            &scan.layout,
            scan.selected(self.echo),
            scan.scale_factor,
            scan.scale_offset_mm,
            &self.localizer.config().sensor,
            &mut self.scan,
        );
        self.scan
            .set_timing(scan.layout.timing(scan_stamp_us(scan.t_s)));
        if let Some(r) = self.last_reading {
            self.localizer.hint_sweep_speed(SweepMotion {
                v_x_mps: r.v_mps as f32,
                v_y_mps: 0.0,
                omega_radps: r.omega_radps as f32,
            });
        }
        let status = match loaded {
            Ok(()) => EstimatorStatus::Localizer(self.localizer.update_scan(&mut self.scan)),
            Err(e) => EstimatorStatus::ScanUnusable(e),
        };
        let pose = self.localizer.pose().map_or(self.last_reset, |p| SimPose {
            x_m: f64::from(p.x_m),
            y_m: f64::from(p.y_m),
            theta_rad: f64::from(p.theta_rad),
        });
        let sigma = self.localizer.covariance().map_or((0.0, 0.0, 0.0), |c| {
            (
                f64::from(c[0][0]).max(0.0).sqrt(),
                f64::from(c[1][1]).max(0.0).sqrt(),
                f64::from(c[2][2]).max(0.0).sqrt(),
            )
        });
        EstimatorOutput {
            pose,
            sigma,
            status,
            protection: Some(self.localizer.protection()),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::closed_loop::RunOptions;
    use crate::lidar::ScanRate;
    use crate::scenario::named::named;
    use crate::session::{run_scenario, EstimatorChoice};

    /// RMS of the change, from one scan to the next, of the localiser's error along
    /// `paper-10m`'s straight tunnel (world x) over its first 4 m at `rate`, metres.
    fn along_jumps_m(rate: ScanRate) -> f64 {
        let mut s = named("paper-10m").unwrap();
        s.lidar.rate = rate;
        s.drive.end_m = s.drive.start_m + 4.0;
        let log = run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).unwrap();
        let err: Vec<f64> = log
            .samples
            .iter()
            .map(|x| x.estimate.x_m - x.truth.x_m)
            .collect();
        let jumps: Vec<f64> = err.windows(2).map(|w| w[1] - w[0]).collect();
        (jumps.iter().map(|j| j * j).sum::<f64>() / jumps.len() as f64).sqrt()
    }

    /// Position RMS of `paper-10m` (P1, seed 1) with the scanner's sweep modelled or not,
    /// metres.
    fn paper_rms_m(sweep: bool) -> f64 {
        let mut s = named("paper-10m").unwrap();
        s.lidar.sweep = sweep;
        let log = run_scenario(&s, EstimatorChoice::Localizer, &RunOptions::default()).unwrap();
        let sq: Vec<f64> = log
            .samples
            .iter()
            .map(|x| {
                (x.estimate.x_m - x.truth.x_m).powi(2) + (x.estimate.y_m - x.truth.y_m).powi(2)
            })
            .collect();
        (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
    }

    #[test]
    fn a_sweeping_scanner_is_de_skewed_in_the_closed_loop() {
        // Each beam from where the vehicle was when the mirror passed it: taken as one
        // instant the scan gave 10.5 mm; de-skewed 2.39 mm, against 2.51 mm without the
        // sweep.
        let (swept, at_once) = (paper_rms_m(true), paper_rms_m(false));
        assert!(
            swept < 1.15 * at_once,
            "swept {swept} m, at once {at_once} m"
        );
    }

    #[test]
    fn scans_between_odometry_readings_are_predicted_to_their_own_time() {
        // 75 Hz scans fall 0, 3.3 or 6.7 ms after a 100 Hz reading. Predicted only to the
        // last reading, each was matched up to 7 mm (at 1 m/s) from the filter's prediction
        // and the next reading added that motion again: the error along jumped from scan to
        // scan by 3.6 mm RMS (0.6 mm at 25 Hz, whose scans fall on readings); now 0.45 mm.
        let at_25 = along_jumps_m(ScanRate::Hz25);
        let at_75 = along_jumps_m(ScanRate::Hz75);
        assert!(at_25 < 1e-3, "{at_25}");
        assert!(
            at_75 < 2.0 * at_25,
            "75 Hz {at_75} m against 25 Hz {at_25} m"
        );
    }
}
