//! The scanner's sweep: a scan's beams are not taken at one instant.
//!
//! The LMS5xx's mirror turns once per scan period and the scanner fires one shot per beam,
//! so the 1141 beams of a 25 Hz scan span 190° of 360°: 21 ms, in which a loader at 3 m/s
//! moves 6 cm. Taken as one instant, the scan is smeared by that motion — measured on the
//! simulator (`lidar.sweep`), 200 m of `tunnel-1km` at 3 m/s went from 4.6 to 32 mm with a
//! tracked pose up to 14 σ off. [`ScanTiming`] says when each beam was taken (the telegram's
//! time stamp and shot period), [`SweepMotion`] how the vehicle moved meanwhile, and
//! [`super::Scan::deskew`] moves each point to where it lies in the vehicle frame at the
//! scan's **last beam**: the instant a scan's pose refers to.

use crate::geometry::{Point2, Pose2};
use crate::math;

/// When a scan's beams were taken, on the scanner's own clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanTiming {
    /// The scan's time stamp, µs on the scanner's clock (the `LMDscandata` field "time
    /// since start-up", which wraps after 71.6 min: only differences between scans are
    /// used, wrapping). Any fixed offset from the beams' times cancels in those
    /// differences.
    pub stamp_us: u32,
    /// Time from one beam to the next, seconds (the shot period, `1 / f_shot`: 18.5 µs
    /// for the LMS511 at 25 Hz and 1/6°). Beam `i` of a telegram of `n` beams is taken
    /// `(n − 1 − i) · beam_period_s` before its last beam.
    pub beam_period_s: f32,
}

impl ScanTiming {
    /// Seconds from `earlier`'s stamp to this one (wrapping µs clock).
    pub fn seconds_since(&self, earlier: &ScanTiming) -> f32 {
        self.stamp_us.wrapping_sub(earlier.stamp_us) as f32 * 1e-6
    }
}

/// The vehicle's velocity over a sweep, in the vehicle frame (x forward, y left): the
/// constant twist that moves it as it moved between two scans.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SweepMotion {
    /// Forward speed, m/s.
    pub v_x_mps: f32,
    /// Leftward speed, m/s (side slip).
    pub v_y_mps: f32,
    /// Yaw rate, rad/s (counter-clockwise positive).
    pub omega_radps: f32,
}

/// Longest sweep believed, seconds (the LMS5xx sweeps its 190° in 21 ms at 25 Hz, its
/// slowest; a telegram whose frequencies claim more is not de-skewed).
pub const MAX_SWEEP_S: f32 = 0.1;
/// Fastest a vehicle is believed to move over a sweep, m/s (a loader drives ≤ 8 m/s).
pub const MAX_SWEEP_SPEED_MPS: f32 = 30.0;
/// Largest turn over one sweep that is believed, radians (a loader turns at most
/// ≈ 1 rad/s, 0.02 rad in a 25 Hz sweep).
pub const MAX_SWEEP_TURN_RAD: f32 = 0.2;

/// Below this turn (radians) the series of `sin φ / φ` and `(1 − cos φ) / φ` are used.
const SMALL_TURN_RAD: f32 = 1e-2;

/// `(sin φ / φ, (1 − cos φ) / φ)`: the SE(2) exponential's translation factors.
fn arc_factors(phi_rad: f32) -> (f32, f32) {
    if math::abs(phi_rad) < SMALL_TURN_RAD {
        let p2 = phi_rad * phi_rad;
        (1.0 - p2 / 6.0, phi_rad * (0.5 - p2 / 24.0))
    } else {
        let (s, c) = math::sin_cos(phi_rad);
        (s / phi_rad, (1.0 - c) / phi_rad)
    }
}

impl SweepMotion {
    /// The constant twist that takes the vehicle along `motion` (the pose at the later
    /// scan in the frame of the earlier one) in `dt_s` seconds: SE(2)'s logarithm over the
    /// time. `None` for a non-positive or non-finite time or motion.
    pub fn from_motion(motion: &Pose2, dt_s: f32) -> Option<Self> {
        if !(dt_s.is_finite() && dt_s > 0.0 && motion.is_finite()) {
            return None;
        }
        let (a, b) = arc_factors(motion.theta_rad);
        // (x, y) = [[a, −b], [b, a]] · u · dt: invert the 2×2 rotation-and-scale.
        let det = a * a + b * b;
        let u_x = (a * motion.x_m + b * motion.y_m) / det;
        let u_y = (a * motion.y_m - b * motion.x_m) / det;
        let m = Self {
            v_x_mps: u_x / dt_s,
            v_y_mps: u_y / dt_s,
            omega_radps: motion.theta_rad / dt_s,
        };
        [m.v_x_mps, m.v_y_mps, m.omega_radps]
            .iter()
            .all(|v| v.is_finite())
            .then_some(m)
    }

    /// The vehicle's pose `before_s` seconds before the reference instant, in the vehicle
    /// frame at the reference instant (SE(2)'s exponential of `−before_s` times the twist).
    pub fn pose_before(&self, before_s: f32) -> Pose2 {
        let phi = -self.omega_radps * before_s;
        let (a, b) = arc_factors(phi);
        let (ux, uy) = (-self.v_x_mps * before_s, -self.v_y_mps * before_s);
        Pose2::new(a * ux - b * uy, b * ux + a * uy, phi)
    }

    /// Moves `p`, an echo in the vehicle frame taken `before_s` seconds before the
    /// reference instant, into the vehicle frame at the reference instant. The turn over a
    /// sweep is small (≤ 0.1 rad even at 5 rad/s): its sine and cosine by their series.
    #[inline]
    pub(super) fn carry(&self, p: Point2, before_s: f32) -> Point2 {
        let phi = -self.omega_radps * before_s;
        let p2 = phi * phi;
        let (sin, cos) = (phi * (1.0 - p2 / 6.0), 1.0 - p2 * (0.5 - p2 / 24.0));
        let (a, b) = (1.0 - p2 / 6.0, phi * (0.5 - p2 / 24.0));
        let (ux, uy) = (-self.v_x_mps * before_s, -self.v_y_mps * before_s);
        Point2::new(
            cos * p.x_m - sin * p.y_m + a * ux - b * uy,
            sin * p.x_m + cos * p.y_m + b * ux + a * uy,
        )
    }

    /// The largest turn over `sweep_s` seconds, radians.
    pub fn turn_over_rad(&self, sweep_s: f32) -> f32 {
        math::abs(self.omega_radps * sweep_s)
    }

    /// Whether a vehicle can move so over a sweep of `sweep_s` seconds: every component
    /// finite, the speed at most [`MAX_SWEEP_SPEED_MPS`], the turn at most
    /// [`MAX_SWEEP_TURN_RAD`], and the sweep itself between 0 and [`MAX_SWEEP_S`] (anything
    /// else is a broken prediction, hint or telegram, and carrying echoes by it would place
    /// them confidently wrong).
    pub fn is_plausible(&self, sweep_s: f32) -> bool {
        (0.0..=MAX_SWEEP_S).contains(&sweep_s)
            && math::hypot(self.v_x_mps, self.v_y_mps) <= MAX_SWEEP_SPEED_MPS
            && self.turn_over_rad(sweep_s) <= MAX_SWEEP_TURN_RAD
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arc_driven_in_a_time_gives_its_speed_and_yaw_rate() {
        // 2 m/s, 0.5 rad/s for 0.04 s and for 0.4 s (series and exact branches).
        for dt in [0.04f32, 0.4] {
            let truth = SweepMotion {
                v_x_mps: 2.0,
                v_y_mps: 0.1,
                omega_radps: 0.5,
            };
            // The pose after dt is the pose "−dt before" a reference at the start.
            let motion = SweepMotion {
                v_x_mps: -truth.v_x_mps,
                v_y_mps: -truth.v_y_mps,
                omega_radps: -truth.omega_radps,
            }
            .pose_before(dt);
            let m = SweepMotion::from_motion(&motion, dt).unwrap();
            assert!((m.v_x_mps - 2.0).abs() < 1e-4, "{dt}: {m:?}");
            assert!((m.v_y_mps - 0.1).abs() < 1e-4, "{dt}: {m:?}");
            assert!((m.omega_radps - 0.5).abs() < 1e-4, "{dt}: {m:?}");
        }
    }

    #[test]
    fn carrying_a_point_is_the_pose_before_applied_to_it() {
        let m = SweepMotion {
            v_x_mps: 3.0,
            v_y_mps: -0.2,
            omega_radps: 1.5,
        };
        let p = Point2::new(12.0, -4.0);
        for before in [0.0f32, 0.005, 0.021] {
            let exact = m.pose_before(before).transform_point(p);
            let fast = m.carry(p, before);
            assert!((exact.x_m - fast.x_m).abs() < 2e-6, "{before}");
            assert!((exact.y_m - fast.y_m).abs() < 2e-6, "{before}");
        }
        // Driving straight ahead, an echo taken earlier lies farther back now.
        let straight = SweepMotion {
            v_x_mps: 3.0,
            ..SweepMotion::default()
        };
        let q = straight.carry(Point2::new(10.0, 2.0), 0.02);
        assert!((q.x_m - 9.94).abs() < 1e-5 && (q.y_m - 2.0).abs() < 1e-6);
    }

    #[test]
    fn no_time_or_a_broken_motion_gives_no_speed() {
        let m = Pose2::new(0.1, 0.0, 0.0);
        assert!(SweepMotion::from_motion(&m, 0.0).is_none());
        assert!(SweepMotion::from_motion(&m, -0.04).is_none());
        assert!(SweepMotion::from_motion(&m, f32::NAN).is_none());
        assert!(SweepMotion::from_motion(&Pose2::new(f32::INFINITY, 0.0, 0.0), 0.04).is_none());
    }

    #[test]
    fn no_vehicle_moves_at_an_implausible_speed() {
        let ok = SweepMotion {
            v_x_mps: 8.0,
            v_y_mps: 0.5,
            omega_radps: 1.0,
        };
        assert!(ok.is_plausible(0.021));
        for bad in [
            SweepMotion {
                v_x_mps: f32::NAN,
                ..ok
            },
            SweepMotion {
                v_y_mps: f32::INFINITY,
                ..ok
            },
            SweepMotion {
                omega_radps: f32::NAN,
                ..ok
            },
            SweepMotion {
                v_x_mps: 31.0,
                ..ok
            },
            SweepMotion {
                omega_radps: 20.0,
                ..ok
            },
        ] {
            assert!(!bad.is_plausible(0.021), "{bad:?}");
        }
        for sweep_s in [-0.01, 0.2, f32::NAN, f32::INFINITY] {
            assert!(!ok.is_plausible(sweep_s), "{sweep_s}");
        }
    }

    #[test]
    fn seconds_between_stamps_wrap_with_the_clock() {
        let a = ScanTiming {
            stamp_us: u32::MAX - 10_000,
            beam_period_s: 1.0 / 54_000.0,
        };
        let b = ScanTiming {
            stamp_us: 29_999,
            ..a
        };
        assert!((b.seconds_since(&a) - 0.04).abs() < 1e-6);
    }
}
