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
}

#[cfg(test)]
mod tests {
    use super::*;

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
