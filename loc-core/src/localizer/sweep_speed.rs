//! The vehicle's speed over a scan's sweep, from the filter's own track.
//!
//! [`crate::scan::Scan::deskew`] needs how fast the vehicle moved and turned while the
//! mirror swept. The two are taken over different baselines:
//! - the **velocity** over the last scan interval: from the pose after the last scan to the
//!   prediction now (the odometry's motion at the filter's scale). A longer baseline lags
//!   the vehicle's accelerations: on the firmware's recorded weave (1.5 m/s sideways,
//!   5.6 m/s² at 10 m/s) a 0.24–0.4 s baseline left 5.8 mm RMS where this leaves 1.7 mm;
//! - the **yaw rate** over 0.2–0.4 s of the track, from the pose after a scan that long
//!   back, corrected by the scans since, to the prediction now. A skid-steer loader's yaw
//!   rate from its tracks is off by ~0.01 rad/s (as much as a tunnel curve's whole rate at
//!   3 m/s); turning each far echo by that error cost the heading 40 % (`tunnel-1km`
//!   0.13 → 0.19 mrad); over the longer baseline the odometry's share is one interval's.

use crate::geometry::Pose2;
use crate::math;
use crate::scan::{ScanTiming, SweepMotion};

/// Shortest baseline the speed is taken over once the track is that long, seconds.
pub const SWEEP_SPEED_BASELINE_S: f32 = 0.2;
/// Longest baseline used, seconds: a scan after a longer gap is not de-skewed.
pub const MAX_SWEEP_BASELINE_S: f32 = 0.5;

/// Poses of the filter's track after scans, with their scans' timing: the last one, and
/// two for the yaw rate's baseline — `newer` moves on once it is [`SWEEP_SPEED_BASELINE_S`]
/// old, handing its place to `older` (they leapfrog: the baseline to a new scan is between
/// one and two of it, plus a scan interval at most; shorter only in the track's first
/// 0.2 s).
#[derive(Debug, Clone, Copy, Default)]
pub struct SweepSpeed {
    last: Option<(ScanTiming, Pose2)>,
    older: Option<(ScanTiming, Pose2)>,
    newer: Option<(ScanTiming, Pose2)>,
    /// The speed the integrator measured for the next scan (its odometry's rate), used
    /// when the track does not reach back to a scan yet.
    hint: Option<SweepMotion>,
}

impl SweepSpeed {
    /// No track yet.
    pub const NEW: Self = Self {
        last: None,
        older: None,
        newer: None,
        hint: None,
    };

    /// Forgets the track (a new pose that the predictions do not link to the old ones);
    /// a hint for the next scan is kept.
    pub fn reset(&mut self) {
        *self = Self {
            hint: self.hint,
            ..Self::NEW
        };
    }

    /// The vehicle's speed for the next scan as measured otherwise (the odometry's rate),
    /// for when the track does not reach back to an earlier scan: the first scan after a
    /// start or a gap, or a scan without a pose. Used for that scan only.
    pub fn hint(&mut self, motion: SweepMotion) {
        self.hint = Some(motion);
    }

    /// After a scan: forgets the hint, and adds the filter's pose after the scan of
    /// `timing` when there is one (the last, and the newer one once a baseline old).
    pub fn scanned(&mut self, track: Option<(ScanTiming, Pose2)>) {
        self.hint = None;
        if let Some((timing, pose)) = track {
            self.record(timing, pose);
        }
    }

    /// Adds the filter's pose after the scan of `timing`: the last, and the newer pose once
    /// the newer one is a baseline old (which becomes the older). Forgets the hint.
    fn record(&mut self, timing: ScanTiming, pose: Pose2) {
        self.hint = None;
        self.last = Some((timing, pose));
        match self.newer {
            Some((t, _)) if timing.seconds_since(&t) < SWEEP_SPEED_BASELINE_S => {}
            newer => {
                self.older = newer;
                self.newer = Some((timing, pose));
            }
        }
    }

    /// The constant twist to `predicted`, the filter's pose at the scan of `timing`: the
    /// velocity from the last scan's pose, the yaw rate from the oldest pose of the track
    /// within [`MAX_SWEEP_BASELINE_S`]; without a prediction (no pose: relocalising) or a
    /// last pose that recent, the hint if any.
    pub fn motion(&self, timing: &ScanTiming, predicted: Option<&Pose2>) -> Option<SweepMotion> {
        let since = |(t, pose): (ScanTiming, Pose2)| {
            let dt_s = timing.seconds_since(&t);
            (dt_s > 0.0 && dt_s <= MAX_SWEEP_BASELINE_S).then_some((dt_s, pose))
        };
        let (Some(predicted), Some((dt_s, last))) = (predicted, self.last.and_then(since)) else {
            return self.hint;
        };
        let mut motion = SweepMotion::from_motion(&last.between(predicted), dt_s)?;
        if let Some((dt_s, base)) = [self.older, self.newer]
            .into_iter()
            .flatten()
            .find_map(since)
        {
            motion.omega_radps = math::wrap_angle(predicted.theta_rad - base.theta_rad) / dt_s;
        }
        Some(motion)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timing(t_s: f32) -> ScanTiming {
        ScanTiming {
            stamp_us: (t_s * 1e6).round() as u32,
            beam_period_s: 1.0 / 54_000.0,
        }
    }

    /// The track of a vehicle at 2 m/s turning at 0.1 rad/s, at time `t_s`.
    fn on_arc(t_s: f32) -> Pose2 {
        SweepMotion {
            v_x_mps: -2.0,
            v_y_mps: 0.0,
            omega_radps: -0.1,
        }
        .pose_before(t_s)
    }

    #[test]
    fn the_speed_is_taken_over_a_baseline_of_the_track() {
        let mut speed = SweepSpeed::NEW;
        assert!(speed.motion(&timing(0.0), Some(&on_arc(0.0))).is_none());
        let mut baselines = heapless::Vec::<f32, 40>::new();
        for k in 0..40 {
            let t = 0.04 * k as f32;
            if let Some(m) = speed.motion(&timing(t), Some(&on_arc(t))) {
                assert!((m.v_x_mps - 2.0).abs() < 2e-3, "{t}: {m:?}");
                assert!((m.omega_radps - 0.1).abs() < 2e-3, "{t}: {m:?}");
                let base = [speed.older, speed.newer]
                    .into_iter()
                    .flatten()
                    .map(|(s, _)| timing(t).seconds_since(&s))
                    .find(|d| *d <= MAX_SWEEP_BASELINE_S)
                    .unwrap();
                baselines.push(base).unwrap();
            }
            speed.record(timing(t), on_arc(t));
        }
        // After the first 0.2 s, every baseline is 0.24–0.4 s at 25 Hz.
        assert!(
            baselines[6..].iter().all(|b| (0.239..=0.401).contains(b)),
            "{baselines:?}"
        );
    }

    #[test]
    fn after_a_long_gap_the_old_track_is_not_used() {
        let mut speed = SweepSpeed::NEW;
        speed.record(timing(0.0), on_arc(0.0));
        speed.record(timing(0.3), on_arc(0.3));
        assert!(speed.motion(&timing(1.5), Some(&on_arc(1.5))).is_none());
        speed.record(timing(1.5), on_arc(1.5));
        let m = speed.motion(&timing(1.54), Some(&on_arc(1.54))).unwrap();
        assert!((m.v_x_mps - 2.0).abs() < 2e-3, "{m:?}");
        speed.reset();
        assert!(speed.motion(&timing(1.58), Some(&on_arc(1.58))).is_none());
    }

    #[test]
    fn a_hint_serves_the_scan_the_track_does_not_reach() {
        let mut speed = SweepSpeed::NEW;
        let hint = SweepMotion {
            v_x_mps: 10.0,
            ..SweepMotion::default()
        };
        speed.hint(hint);
        assert_eq!(speed.motion(&timing(0.0), Some(&on_arc(0.0))), Some(hint));
        speed.record(timing(0.0), on_arc(0.0));
        // One scan on, the track's own speed; the hint is gone.
        let m = speed.motion(&timing(0.04), Some(&on_arc(0.04))).unwrap();
        assert!((m.v_x_mps - 2.0).abs() < 2e-3, "{m:?}");
        speed.reset();
        assert!(speed.motion(&timing(0.08), Some(&on_arc(0.08))).is_none());
    }
}
