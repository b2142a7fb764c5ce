//! Wheel odometry of the skid-steer loader: encoder speeds with a scale error and noise,
//! turned into forward speed and yaw rate with a calibrated effective track width.
//!
//! The errors are those of a real loader: encoders that over-read by a scale factor (tyre
//! wear, pressure), unmodelled slip (the odometry cannot see it), a calibrated ICR
//! expansion that is not exactly the true one, and white noise on each reading. The
//! defaults drift about 2 % of the distance travelled along the path.

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
}

impl Default for OdometrySpec {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            scale_error: 0.01,
            calibrated_icr_expansion: 1.32,
            speed_noise_mps: 0.02,
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

    /// Reads the wheels (their mean speeds over the last `dt_s`) and returns the reading.
    pub fn read(&mut self, wheels: TrackSpeeds, t_s: f64, dt_s: f64) -> OdometrySample {
        let k = 1.0 + self.spec.scale_error;
        let l = k * wheels.left_mps + self.spec.speed_noise_mps * f64::from(self.rng.gaussian());
        let r = k * wheels.right_mps + self.spec.speed_noise_mps * f64::from(self.rng.gaussian());
        let v = 0.5 * (l + r);
        let omega = (r - l) / (self.spec.calibrated_icr_expansion * self.track_width_m);
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
                f64::from(i) * 0.01,
                0.01,
            ));
        }
        // 1 s at 1 m/s heading +y, read 1 % high.
        assert!((odo.pose().y_m - 1.01).abs() < 1e-9 && odo.pose().x_m.abs() < 1e-9);
        let d = last.unwrap().delta;
        assert!((d.0 - 0.0101).abs() < 1e-12 && d.1.abs() < 1e-12 && d.2 == 0.0);
    }
}
