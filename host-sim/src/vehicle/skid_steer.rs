//! Skid-steer kinematics with instantaneous centres of rotation (ICR) and track slip.
//!
//! A skid-steer loader turns by driving its left and right tracks (or wheel sets) at
//! different speeds; the tracks skid sideways, so the vehicle turns less than a
//! differential drive of the same track width would. The ICR model (Mandow et al., 2007;
//! the loader model of the paper's ref. \[2\] is of this family) captures that: the ground
//! contact of the left track is at rest at lateral coordinate `y_l`, the right one at
//! `y_r`, both further out than the tracks (`y_l = χ·B/2`, `y_r = −χ·B/2`, expansion
//! `χ > 1`), and the vehicle's own ICR lies `x_icr` ahead of its reference point:
//!
//! ```text
//! ω   = (v_r − v_l) / (y_l − y_r)
//! v_x = (v_r·y_l − v_l·y_r) / (y_l − y_r)
//! v_y = −x_icr · ω
//! ```
//!
//! `v_l`, `v_r` are the tracks' speeds over the ground: the wheel (encoder) speeds reduced
//! by a longitudinal slip that wanders around its mean (first-order Gauss–Markov). Track
//! speeds follow their commands with a first-order lag. Vehicle frame: x forward, y left.

use loc_core::rng::Pcg32;

use super::SimPose;

/// Physical parameters of the loader.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SkidSteerSpec {
    /// Distance between the track centre lines, metres.
    pub track_width_m: f64,
    /// ICR expansion factor χ (≥ 1; 1 is a slip-free differential drive).
    pub icr_expansion: f64,
    /// Longitudinal position of the vehicle's ICR ahead of the reference point, metres.
    pub icr_x_m: f64,
    /// Mean longitudinal slip (fraction of wheel speed lost, e.g. 0.01).
    pub slip_mean: f64,
    /// Standard deviation of the slip's wander around its mean.
    pub slip_std: f64,
    /// Correlation time of the slip's wander, seconds.
    pub slip_correlation_s: f64,
    /// Time constant of the track speed response to a command, seconds.
    pub track_time_constant_s: f64,
}

impl Default for SkidSteerSpec {
    fn default() -> Self {
        // Figures of a compact loader of the CAT 262C class.
        Self {
            track_width_m: 1.5,
            icr_expansion: 1.3,
            icr_x_m: 0.05,
            slip_mean: 0.01,
            slip_std: 0.005,
            slip_correlation_s: 2.0,
            track_time_constant_s: 0.1,
        }
    }
}

/// Wheel (encoder) speeds of both sides, m/s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackSpeeds {
    /// Left side, m/s.
    pub left_mps: f64,
    /// Right side, m/s.
    pub right_mps: f64,
}

/// The simulated vehicle: true pose and track state.
#[derive(Debug, Clone)]
pub struct SkidSteer {
    spec: SkidSteerSpec,
    pose: SimPose,
    wheels: TrackSpeeds,
    slip_left: f64,
    slip_right: f64,
    rng: Pcg32,
}

impl SkidSteer {
    /// A vehicle at rest at `pose`, with its own random stream for slip.
    pub fn new(spec: SkidSteerSpec, pose: SimPose, seed: u64) -> Self {
        Self {
            spec,
            pose,
            wheels: TrackSpeeds::default(),
            slip_left: spec.slip_mean,
            slip_right: spec.slip_mean,
            rng: Pcg32::new(seed, 0x5c1d),
        }
    }

    /// Parameters.
    pub fn spec(&self) -> &SkidSteerSpec {
        &self.spec
    }

    /// True pose (ground truth).
    pub fn pose(&self) -> SimPose {
        self.pose
    }

    /// Puts the vehicle at `pose` without its tracks turning (a tow, a slide on mud): the
    /// kidnapping the odometry does not see. Speeds are kept.
    pub fn teleport(&mut self, pose: SimPose) {
        self.pose = pose;
    }

    /// Current wheel (encoder) speeds.
    pub fn wheel_speeds(&self) -> TrackSpeeds {
        self.wheels
    }

    /// Wheel-speed commands that give forward speed `v_mps` and yaw rate `omega_radps`
    /// for a vehicle whose ICR expansion is believed to be `assumed_expansion`.
    pub fn commands_for(
        &self,
        v_mps: f64,
        omega_radps: f64,
        assumed_expansion: f64,
    ) -> TrackSpeeds {
        let half = assumed_expansion * self.spec.track_width_m / 2.0;
        TrackSpeeds {
            left_mps: v_mps - omega_radps * half,
            right_mps: v_mps + omega_radps * half,
        }
    }

    /// Advances the vehicle by `dt_s` under wheel-speed commands.
    pub fn step(&mut self, command: TrackSpeeds, dt_s: f64) {
        let s = &self.spec;
        // Track response: first-order lag.
        let k = if s.track_time_constant_s > 0.0 {
            1.0 - (-dt_s / s.track_time_constant_s).exp()
        } else {
            1.0
        };
        self.wheels.left_mps += k * (command.left_mps - self.wheels.left_mps);
        self.wheels.right_mps += k * (command.right_mps - self.wheels.right_mps);
        // Slip wander: stationary AR(1) around the mean.
        let rho = if s.slip_correlation_s > 0.0 {
            (-dt_s / s.slip_correlation_s).exp()
        } else {
            0.0
        };
        let innov = s.slip_std * (1.0 - rho * rho).sqrt();
        self.slip_left = s.slip_mean
            + rho * (self.slip_left - s.slip_mean)
            + innov * f64::from(self.rng.gaussian());
        self.slip_right = s.slip_mean
            + rho * (self.slip_right - s.slip_mean)
            + innov * f64::from(self.rng.gaussian());
        let vl = self.wheels.left_mps * (1.0 - self.slip_left);
        let vr = self.wheels.right_mps * (1.0 - self.slip_right);
        let (vx, vy, omega) = icr_velocities(s, vl, vr);
        self.pose = self.pose.integrate(vx, vy, omega, dt_s);
    }
}

/// Body velocities `(v_x m/s, v_y m/s, ω rad/s)` from ground track speeds by the ICR model.
pub fn icr_velocities(spec: &SkidSteerSpec, left_mps: f64, right_mps: f64) -> (f64, f64, f64) {
    let y_l = spec.icr_expansion * spec.track_width_m / 2.0;
    let y_r = -y_l;
    let omega = (right_mps - left_mps) / (y_l - y_r);
    let vx = (right_mps * y_l - left_mps * y_r) / (y_l - y_r);
    (vx, -spec.icr_x_m * omega, omega)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icr_expansion_reduces_turn_rate() {
        let diff = SkidSteerSpec {
            icr_expansion: 1.0,
            icr_x_m: 0.0,
            ..SkidSteerSpec::default()
        };
        let (vx, vy, w) = icr_velocities(&diff, 1.0, 2.0);
        assert!((vx - 1.5).abs() < 1e-12 && vy == 0.0 && (w - 1.0 / 1.5).abs() < 1e-12);
        let skid = SkidSteerSpec::default();
        let (vx2, vy2, w2) = icr_velocities(&skid, 1.0, 2.0);
        assert!((vx2 - 1.5).abs() < 1e-12);
        assert!((w2 - w / 1.3).abs() < 1e-12);
        assert!(
            vy2 < 0.0,
            "ICR ahead of the reference point: the rear swings out"
        );
    }

    #[test]
    fn straight_drive_loses_the_slip_fraction() {
        let spec = SkidSteerSpec {
            slip_std: 0.0,
            ..SkidSteerSpec::default()
        };
        let mut v = SkidSteer::new(spec, SimPose::default(), 1);
        let cmd = v.commands_for(2.0, 0.0, spec.icr_expansion);
        for _ in 0..10_000 {
            v.step(cmd, 0.001);
        }
        // 10 s at 2 m/s less 1 % slip, less the start-up lag (≈ τ · v = 0.2 m).
        let x = v.pose().x_m;
        assert!((x - (20.0 * 0.99 - 0.2 * 0.99)).abs() < 0.01, "{x}");
        assert!(v.pose().y_m.abs() < 1e-9);
        // Commands for a turn with the true expansion give the asked yaw rate.
        let turn = v.commands_for(1.0, 0.2, spec.icr_expansion);
        let (_, _, w) = icr_velocities(&spec, turn.left_mps, turn.right_mps);
        assert!((w - 0.2).abs() < 1e-12);
    }
}
