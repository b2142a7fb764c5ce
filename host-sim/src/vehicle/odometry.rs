//! Wheel odometry of the skid-steer loader: encoder speeds with a scale error and noise,
//! turned into forward speed and yaw rate with a calibrated effective track width.
//!
//! The errors are those of a real loader: encoders that over-read by a scale factor (tyre
//! wear, pressure), unmodelled slip (the odometry cannot see it), a calibrated ICR
//! expansion that is not exactly the true one, and white noise on each reading. The
//! defaults drift about 2 % of the distance travelled along the path.
//!
//! Optionally ([`OdometrySpec::gyro`]) a yaw-rate gyro, as real loaders carry (the paper's
//! CAT 262C had a STIM300 IMU), gives the yaw rate instead of the track difference (the
//! tracks' slip makes theirs drift ≈ 0.36 rad RMS over 300 m of `tunnel-1km`): the true
//! yaw rate plus a constant bias and white noise (angle random walk); the tracks still
//! give the forward speed.

use loc_core::rng::Pcg32;

use super::skid_steer::TrackSpeeds;
use super::SimPose;

/// Odometry error parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OdometrySpec {
    /// Sampling rate, hertz.
    pub rate_hz: f64,
    /// Encoder scale error (0.01: readings 1 % high).
    pub scale_error: f64,
    /// ICR expansion the odometry was calibrated with (the truth is the vehicle's).
    pub calibrated_icr_expansion: f64,
    /// Standard deviation of white noise on each wheel-speed reading, m/s.
    pub speed_noise_mps: f64,
    /// A yaw-rate gyro fused with the tracks (heading from the gyro, distance from the
    /// tracks); `None`: the yaw rate from the track difference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro: Option<GyroSpec>,
}

/// A yaw-rate gyro's errors.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroSpec {
    /// Constant bias left after the standstill calibration, rad/s.
    pub bias_radps: f64,
    /// Angle random walk: white rate noise density, rad/√s.
    pub noise_rad_per_sqrt_s: f64,
}

impl Default for GyroSpec {
    /// A tactical-grade gyro like the STIM300 (angle random walk 0.15°/√h), with 4°/h of
    /// bias left after a standstill calibration.
    fn default() -> Self {
        Self {
            bias_radps: 2.0e-5,
            noise_rad_per_sqrt_s: 4.4e-5,
        }
    }
}

impl Default for OdometrySpec {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            scale_error: 0.01,
            calibrated_icr_expansion: 1.32,
            speed_noise_mps: 0.02,
            gyro: None,
        }
    }
}

/// One odometry reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometrySample {
    /// Time of the reading, seconds since the start of the run.
    pub t_s: f64,
    /// Interval the reading covers, seconds.
    pub dt_s: f64,
    /// Measured forward speed, m/s (vehicle frame).
    pub v_mps: f64,
    /// Measured yaw rate, rad/s.
    pub omega_radps: f64,
    /// The motion over the interval in the vehicle frame at its start:
    /// `(dx_m, dy_m, dtheta_rad)`.
    pub delta: (f64, f64, f64),
}

/// Integrates wheel readings into increments and a dead-reckoned pose.
#[derive(Debug, Clone)]
pub struct Odometry {
    spec: OdometrySpec,
    track_width_m: f64,
    pose: SimPose,
    rng: Pcg32,
}

impl Odometry {
    /// Odometry for a vehicle of `track_width_m`, dead reckoning from `start`.
    pub fn new(spec: OdometrySpec, track_width_m: f64, start: SimPose, seed: u64) -> Self {
        Self {
            spec,
            track_width_m,
            pose: start,
            rng: Pcg32::new(seed, 0x0d0),
        }
    }

    /// Parameters.
    pub fn spec(&self) -> &OdometrySpec {
        &self.spec
    }

    /// The dead-reckoned pose (odometry alone).
    pub fn pose(&self) -> SimPose {
        self.pose
    }

    /// Reads the wheels (their mean speeds over the last `dt_s`) and, with a gyro, the
    /// vehicle's true mean yaw rate over it (`true_yaw_rate_radps`, what the gyro senses);
    /// returns the reading.
    pub fn read(
        &mut self,
        wheels: TrackSpeeds,
        true_yaw_rate_radps: f64,
        t_s: f64,
        dt_s: f64,
    ) -> OdometrySample {
        let k = 1.0 + self.spec.scale_error;
        let l = k * wheels.left_mps + self.spec.speed_noise_mps * f64::from(self.rng.gaussian());
        let r = k * wheels.right_mps + self.spec.speed_noise_mps * f64::from(self.rng.gaussian());
        let v = 0.5 * (l + r);
        let omega = match self.spec.gyro {
            Some(g) => {
                true_yaw_rate_radps
                    + g.bias_radps
                    + g.noise_rad_per_sqrt_s / dt_s.max(1e-6).sqrt()
                        * f64::from(self.rng.gaussian())
            }
            None => (r - l) / (self.spec.calibrated_icr_expansion * self.track_width_m),
        };
        let before = self.pose;
        let after = before.integrate(v, 0.0, omega, dt_s);
        // The increment in the vehicle frame at the start of the interval.
        let (s, c) = before.theta_rad.sin_cos();
        let (dxw, dyw) = (after.x_m - before.x_m, after.y_m - before.y_m);
        self.pose = after;
        OdometrySample {
            t_s,
            dt_s,
            v_mps: v,
            omega_radps: omega,
            delta: (
                c * dxw + s * dyw,
                -s * dxw + c * dyw,
                after.theta_rad - before.theta_rad,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_error_shows_in_distance_and_increment_is_in_vehicle_frame() {
        let spec = OdometrySpec {
            speed_noise_mps: 0.0,
            ..OdometrySpec::default()
        };
        let start = SimPose {
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: std::f64::consts::FRAC_PI_2,
        };
        let mut odo = Odometry::new(spec, 1.5, start, 1);
        let mut last = None;
        for i in 0..100 {
            last = Some(odo.read(
                TrackSpeeds {
                    left_mps: 1.0,
                    right_mps: 1.0,
                },
                0.0,
                f64::from(i) * 0.01,
                0.01,
            ));
        }
        // 1 s at 1 m/s heading +y, read 1 % high.
        assert!((odo.pose().y_m - 1.01).abs() < 1e-9 && odo.pose().x_m.abs() < 1e-9);
        let d = last.unwrap().delta;
        assert!((d.0 - 0.0101).abs() < 1e-12 && d.1.abs() < 1e-12 && d.2 == 0.0);
    }

    #[test]
    fn a_gyro_gives_the_heading_through_track_slip_with_its_bias_and_noise() {
        let gyro = GyroSpec::default();
        let spec = OdometrySpec {
            gyro: Some(gyro),
            ..OdometrySpec::default()
        };
        let start = SimPose::default();
        let mut with_gyro = Odometry::new(spec, 1.5, start, 3);
        let mut tracks = Odometry::new(OdometrySpec::default(), 1.5, start, 3);
        // 100 s driving straight while the left track slips 5 % (the tracks see a turn
        // that is not there; the vehicle's true yaw rate is zero).
        let wheels = TrackSpeeds {
            left_mps: 1.05,
            right_mps: 1.0,
        };
        for i in 0..10_000 {
            let t = f64::from(i) * 0.01;
            with_gyro.read(wheels, 0.0, t, 0.01);
            tracks.read(wheels, 0.0, t, 0.01);
        }
        // Gyro: bias × 100 s = 2 mrad, plus a random walk of 0.44 mrad (1σ).
        let h = with_gyro.pose().theta_rad;
        assert!((h - 2.0e-3).abs() < 2.5e-3, "gyro heading {h}");
        // Tracks: the slip turns the dead reckoning by a whole radian and more.
        assert!(
            tracks.pose().theta_rad.abs() > 1.0,
            "{}",
            tracks.pose().theta_rad
        );
        // Distance still from the tracks (mean 1.025 m/s, 1 % scale error): ≈ 103.5 m.
        assert!((with_gyro.pose().x_m.hypot(with_gyro.pose().y_m) - 103.5).abs() < 1.5);
    }
}
