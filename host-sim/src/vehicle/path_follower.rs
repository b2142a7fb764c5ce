//! Driving the loader along the tunnel: a speed profile along the chainage and a
//! pure-pursuit steering law towards a point ahead on the path (the centre line shifted by
//! a lateral offset).
//!
//! The follower steers on the TRUE pose: the simulator asks how well the localiser tracks
//! a known trajectory (the paper's §4.4 "known state trajectory"), so control must not
//! depend on the estimate under test.

use crate::world::centerline::CenterLine;

use super::SimPose;

/// Driving parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriveSpec {
    /// Cruising speed, m/s.
    pub cruise_speed_mps: f64,
    /// Acceleration and braking limit, m/s².
    pub accel_mps2: f64,
    /// Lateral acceleration limit on curves, m/s².
    pub lateral_accel_mps2: f64,
    /// Lateral offset of the path from the centre line, metres (+ left).
    pub lateral_offset_m: f64,
    /// Pure-pursuit look-ahead at standstill, metres.
    pub lookahead_min_m: f64,
    /// Look-ahead added per m/s of speed, seconds.
    pub lookahead_time_s: f64,
    /// Chainage where the drive starts, metres.
    pub start_m: f64,
    /// Chainage where the drive stops, metres (clamped to the tunnel length).
    pub end_m: f64,
}

impl Default for DriveSpec {
    fn default() -> Self {
        Self {
            cruise_speed_mps: 3.0,
            accel_mps2: 0.5,
            lateral_accel_mps2: 0.5,
            lateral_offset_m: 0.0,
            lookahead_min_m: 2.0,
            lookahead_time_s: 0.8,
            start_m: 0.0,
            end_m: f64::INFINITY,
        }
    }
}

/// Pure-pursuit path follower with a speed profile.
#[derive(Debug, Clone)]
pub struct PathFollower {
    spec: DriveSpec,
    end_m: f64,
    s_m: f64,
}

/// What the follower asks of the vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveCommand {
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Yaw rate, rad/s.
    pub omega_radps: f64,
    /// True once the vehicle has reached the end of the drive.
    pub finished: bool,
}

impl PathFollower {
    /// A follower for `spec` on a tunnel of `tunnel_length_m`.
    pub fn new(spec: DriveSpec, tunnel_length_m: f64) -> Self {
        let end_m = spec.end_m.min(tunnel_length_m);
        Self {
            spec,
            end_m,
            s_m: spec.start_m,
        }
    }

    /// The start pose on the path.
    pub fn start_pose(&self, line: &CenterLine) -> SimPose {
        let (x, y) = line.offset_point(self.spec.start_m, self.spec.lateral_offset_m);
        let (_, _, h) = line.pose_at(self.spec.start_m);
        SimPose {
            x_m: x,
            y_m: y,
            theta_rad: h,
        }
    }

    /// Moves the follower's idea of where it is by `ds_m` along the line (after the vehicle
    /// was moved without driving: its projection looks only near the last chainage).
    pub fn jump(&mut self, ds_m: f64) {
        self.s_m += ds_m;
    }

    /// Chainage of the drive's end, metres.
    pub fn end_m(&self) -> f64 {
        self.end_m
    }

    /// Length of the drive, metres.
    pub fn length_m(&self) -> f64 {
        (self.end_m - self.spec.start_m).max(0.0)
    }

    /// Speed allowed at chainage `s_m` by the profile: accelerate from rest, cruise, brake
    /// to stop at the end, slow down on curves. `curvature_per_m` is the path's there.
    fn profile_speed(&self, s_m: f64, curvature_per_m: f64) -> f64 {
        let a = self.spec.accel_mps2.max(1e-3);
        // A small creep speed so the vehicle starts and reaches the end point.
        let creep = 0.1;
        let accel = (2.0 * a * (s_m - self.spec.start_m).max(0.0)).sqrt() + creep;
        let brake = (2.0 * a * (self.end_m - s_m).max(0.0)).sqrt() + creep;
        let curve = if curvature_per_m.abs() > 1e-9 {
            (self.spec.lateral_accel_mps2 / curvature_per_m.abs()).sqrt()
        } else {
            f64::INFINITY
        };
        self.spec.cruise_speed_mps.min(accel).min(brake).min(curve)
    }

    /// The command for a vehicle at the true `pose`.
    pub fn command(&mut self, line: &CenterLine, pose: SimPose) -> DriveCommand {
        let proj = line.project(pose.x_m, pose.y_m, self.s_m, 5.0);
        self.s_m = proj.s_m;
        if self.s_m >= self.end_m {
            return DriveCommand {
                v_mps: 0.0,
                omega_radps: 0.0,
                finished: true,
            };
        }
        // Path curvature here, from the heading change over a metre.
        let (_, _, h0) = line.pose_at(self.s_m);
        let (_, _, h1) = line.pose_at(self.s_m + 1.0);
        let curvature = h1 - h0;
        let v = self.profile_speed(self.s_m, curvature);
        let lookahead = self.spec.lookahead_min_m + self.spec.lookahead_time_s * v;
        let (tx, ty) = line.offset_point(self.s_m + lookahead, self.spec.lateral_offset_m);
        // Target in the vehicle frame.
        let (s, c) = pose.theta_rad.sin_cos();
        let (dx, dy) = (tx - pose.x_m, ty - pose.y_m);
        let (lx, ly) = (c * dx + s * dy, -s * dx + c * dy);
        let l2 = (lx * lx + ly * ly).max(1e-6);
        let kappa = 2.0 * ly / l2;
        DriveCommand {
            v_mps: v,
            omega_radps: kappa * v,
            finished: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::skid_steer::{SkidSteer, SkidSteerSpec};
    use crate::world::centerline::CurvePiece;

    #[test]
    fn follows_a_curve_within_centimetres_and_stops_at_the_end() {
        let line = CenterLine::from_pieces(&[
            CurvePiece {
                length_m: 30.0,
                curvature_per_m: 0.0,
            },
            CurvePiece {
                length_m: 60.0,
                curvature_per_m: 1.0 / 60.0,
            },
            CurvePiece {
                length_m: 30.0,
                curvature_per_m: -1.0 / 80.0,
            },
        ])
        .unwrap();
        let spec = DriveSpec {
            lateral_offset_m: 0.3,
            ..DriveSpec::default()
        };
        let mut f = PathFollower::new(spec, line.length_m());
        let veh_spec = SkidSteerSpec::default();
        let mut v = SkidSteer::new(veh_spec, f.start_pose(&line), 4);
        let mut worst: f64 = 0.0;
        let mut steps = 0;
        loop {
            let cmd = f.command(&line, v.pose());
            if cmd.finished || steps > 200_000 {
                break;
            }
            let tracks = v.commands_for(cmd.v_mps, cmd.omega_radps, 1.3);
            v.step(tracks, 0.001);
            let p = line.project(v.pose().x_m, v.pose().y_m, f.s_m, 5.0);
            if p.s_m > 5.0 {
                worst = worst.max((p.lateral_m - 0.3).abs());
            }
            steps += 1;
        }
        assert!(steps < 200_000, "the drive ends");
        assert!(worst < 0.15, "lateral tracking error {worst}");
        let end = line.project(v.pose().x_m, v.pose().y_m, 120.0, 5.0);
        assert!((end.s_m - 120.0).abs() < 0.5, "{}", end.s_m);
    }
}
