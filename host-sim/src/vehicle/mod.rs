//! The simulated skid-steer loader: its kinematics with track slip, the path follower that
//! drives it along the tunnel, and its wheel odometry.

pub mod odometry;
pub mod path_follower;
pub mod skid_steer;

/// A planar pose in the world frame: `x_m`, `y_m`, `theta_rad` (heading, not wrapped:
/// continuous over the run). `f64`: the simulator's own state.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct SimPose {
    /// World x, metres.
    pub x_m: f64,
    /// World y, metres.
    pub y_m: f64,
    /// Heading, radians (continuous, not wrapped).
    pub theta_rad: f64,
}

impl SimPose {
    /// Advances the pose by body-frame velocities `(vx, vy)` m/s and yaw rate `omega`
    /// rad/s over `dt_s` (exact for constant velocities: integration along the arc).
    pub fn integrate(self, vx: f64, vy: f64, omega: f64, dt_s: f64) -> SimPose {
        let dth = omega * dt_s;
        // Body displacement over the step, by the exact arc integral.
        let (sx, sy) = if dth.abs() < 1e-9 {
            (vx * dt_s, vy * dt_s)
        } else {
            let a = dth.sin() / omega;
            let b = (1.0 - dth.cos()) / omega;
            (vx * a - vy * b, vx * b + vy * a)
        };
        let (s, c) = self.theta_rad.sin_cos();
        SimPose {
            x_m: self.x_m + c * sx - s * sy,
            y_m: self.y_m + s * sx + c * sy,
            theta_rad: self.theta_rad + dth,
        }
    }

    /// A pose from its parts.
    pub const fn new(x_m: f64, y_m: f64, theta_rad: f64) -> Self {
        Self {
            x_m,
            y_m,
            theta_rad,
        }
    }

    /// `self ∘ other`: `other` (a pose in this pose's frame) in this pose's parent frame.
    pub fn compose(self, other: SimPose) -> SimPose {
        let (x_m, y_m) = self.apply((other.x_m, other.y_m));
        SimPose::new(x_m, y_m, self.theta_rad + other.theta_rad)
    }

    /// The inverse transform.
    pub fn inverse(self) -> SimPose {
        let (s, c) = self.theta_rad.sin_cos();
        SimPose::new(
            -(c * self.x_m + s * self.y_m),
            s * self.x_m - c * self.y_m,
            -self.theta_rad,
        )
    }

    /// `other` in this pose's frame: `self⁻¹ ∘ other`.
    pub fn between(self, other: SimPose) -> SimPose {
        self.inverse().compose(other)
    }

    /// A point of this pose's frame in its parent frame.
    pub fn apply(self, p: (f64, f64)) -> (f64, f64) {
        let (s, c) = self.theta_rad.sin_cos();
        (self.x_m + c * p.0 - s * p.1, self.y_m + s * p.0 + c * p.1)
    }

    /// A point of the parent frame in this pose's frame.
    pub fn apply_inverse(self, p: (f64, f64)) -> (f64, f64) {
        let (s, c) = self.theta_rad.sin_cos();
        let (dx, dy) = (p.0 - self.x_m, p.1 - self.y_m);
        (c * dx + s * dy, -s * dx + c * dy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_inverse_and_between_agree() {
        let a = SimPose::new(3.0, -1.0, 0.7);
        let b = SimPose::new(-2.0, 5.0, -2.1);
        let ab = a.between(b);
        let back = a.compose(ab);
        assert!((back.x_m - b.x_m).abs() < 1e-12 && (back.y_m - b.y_m).abs() < 1e-12);
        assert!((back.theta_rad - b.theta_rad).abs() < 1e-12);
        let p = (0.3, 0.9);
        let q = a.apply_inverse(a.apply(p));
        assert!((q.0 - p.0).abs() < 1e-12 && (q.1 - p.1).abs() < 1e-12);
        let id = a.compose(a.inverse());
        assert!(id.x_m.abs() < 1e-12 && id.y_m.abs() < 1e-12 && id.theta_rad.abs() < 1e-12);
    }

    #[test]
    fn integration_along_a_circle_closes() {
        let mut p = SimPose::default();
        // 1 m/s at 0.1 rad/s: circle of radius 10 m, period 2π/0.1 s.
        let steps = 62_832;
        let dt = (2.0 * std::f64::consts::PI / 0.1) / steps as f64;
        for _ in 0..steps {
            p = p.integrate(1.0, 0.0, 0.1, dt);
        }
        assert!(p.x_m.abs() < 1e-6 && p.y_m.abs() < 1e-6, "{p:?}");
    }
}
