//! Where the odometry log leaves time uncovered: each reading covers `[t_s − dt_s, t_s]`,
//! and time that no reading covers (a gap in the log, readings lost on the bus) is motion
//! nobody measured. [`GapTracker`] says how long each gap is, so the estimator coasts
//! across it ([`loc_core::localizer::Localizer::coast`]) with an uncertainty that grows with
//! the time, instead of keeping a covariance the pose no longer deserves.

use crate::vehicle::odometry::OdometrySample;
use crate::vehicle::SimPose;

/// Uncovered time before a reading longer than this fraction of its `dt_s` is a gap (shorter
/// ones are clock jitter between logger and wheel counter).
pub const GAP_BEFORE_READING_DT: f64 = 0.5;

/// At a scan, time since the last reading longer than this many `dt_s` is a gap (up to one
/// interval is the normal wait for the next reading).
pub const GAP_BEFORE_SCAN_DT: f64 = 1.5;

/// Whether a scan `since_s` seconds after the end of a reading of interval `dt_s` is within
/// the normal wait for the next reading (up to [`GAP_BEFORE_SCAN_DT`] intervals), rather than
/// in a gap.
fn awaited(since_s: f64, dt_s: f64) -> bool {
    since_s <= GAP_BEFORE_SCAN_DT * dt_s
}

/// A dead-reckoned `pose` (odometry alone, up to the end of `last`, the latest reading)
/// carried on to a scan taken at `t_s` at that reading's speed and yaw rate, while the next
/// reading is normally awaited (up to [`GAP_BEFORE_SCAN_DT`] intervals after it); as it is
/// otherwise. What the odometry says of the vehicle at the scan's own time — the keyframes
/// of a survey and the odometry-alone baseline are taken at the scans.
pub fn dead_reckoned_at(pose: SimPose, last: Option<&OdometrySample>, t_s: f64) -> SimPose {
    match last {
        Some(r) if t_s > r.t_s && awaited(t_s - r.t_s, r.dt_s) => {
            pose.integrate(r.v_mps, 0.0, r.omega_radps, t_s - r.t_s)
        }
        _ => pose,
    }
}

/// A gap to coast across, at the speed of the reading before it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// The time uncovered, s.
    pub unobserved_s: f64,
    /// Forward speed of the last reading before the gap, m/s.
    pub v_mps: f64,
    /// Yaw rate of that reading, rad/s.
    pub omega_radps: f64,
}

/// The part of the time line the odometry has covered so far.
#[derive(Debug, Clone, Copy, Default)]
pub struct GapTracker {
    /// End of the covered time (by readings, leads to scans and coasts), s; `None` before
    /// the first reading.
    covered_until_s: Option<f64>,
    /// End of the latest reading's interval, s: a scan long after it is in a gap, however
    /// far leads to earlier scans went.
    reading_until_s: Option<f64>,
    /// The last reading's speed, yaw rate and interval.
    last: Option<(f64, f64, f64)>,
}

impl GapTracker {
    /// Forgets the time line (a new initial pose).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Takes `reading`: returns the gap before it (to coast first) and the fraction of its
    /// increment to apply — less than 1 when part of its interval was already coasted at a
    /// scan.
    pub fn reading(&mut self, reading: &OdometrySample) -> (Option<Gap>, f64) {
        let start = reading.t_s - reading.dt_s;
        let mut gap = None;
        let mut fraction = 1.0;
        if let (Some(until), Some((v, w, _))) = (self.covered_until_s, self.last) {
            let uncovered = start - until;
            if uncovered > GAP_BEFORE_READING_DT * reading.dt_s {
                gap = Some(Gap {
                    unobserved_s: uncovered,
                    v_mps: v,
                    omega_radps: w,
                });
            } else if until > start + 1e-6 && reading.dt_s > 0.0 {
                fraction = ((reading.t_s - until) / reading.dt_s).clamp(0.0, 1.0);
            }
        }
        self.covered_until_s = Some(
            self.covered_until_s
                .map_or(reading.t_s, |u| u.max(reading.t_s)),
        );
        self.reading_until_s = Some(
            self.reading_until_s
                .map_or(reading.t_s, |u| u.max(reading.t_s)),
        );
        self.last = Some((reading.v_mps, reading.omega_radps, reading.dt_s));
        (gap, fraction)
    }

    /// At a scan taken at `t_s` within the normal wait for the next reading (after
    /// [`GapTracker::scan`] found no gap): the share of the last reading's interval between
    /// the end of the covered time and the scan, to predict at that reading's rate so that
    /// the scan is matched at its own time, not at the last reading's; the time up to the
    /// scan is then covered (the next reading applies only the rest of its own interval).
    /// `None` when the scan is not after the covered time.
    ///
    /// Without it, scans and readings at rates that are not multiples (35 or 75 Hz scans,
    /// 100 Hz odometry) were matched up to one reading's motion from where the filter had
    /// predicted them, and the next reading added that motion again: on 200 m of
    /// `tunnel-1km` the position along jumped by ±1 cm from scan to scan.
    pub fn lead(&mut self, t_s: f64) -> Option<f64> {
        let (until, (_, _, dt)) = (self.covered_until_s?, self.last?);
        let since_reading_s = t_s - self.reading_until_s?;
        let ahead_s = t_s - until;
        (ahead_s > 0.0 && dt > 0.0 && awaited(since_reading_s, dt)).then(|| {
            self.covered_until_s = Some(t_s);
            ahead_s / dt
        })
    }

    /// At a scan taken at `t_s`: when the last reading ended more than
    /// [`GAP_BEFORE_SCAN_DT`] intervals before it, the gap — the time not covered yet, up to
    /// the scan (which is then covered).
    pub fn scan(&mut self, t_s: f64) -> Option<Gap> {
        let (until, (v, w, dt)) = (self.covered_until_s?, self.last?);
        let since_reading_s = t_s - self.reading_until_s?;
        let uncovered = t_s - until;
        (since_reading_s > GAP_BEFORE_SCAN_DT * dt && uncovered > 0.0).then(|| {
            self.covered_until_s = Some(t_s);
            Gap {
                unobserved_s: uncovered,
                v_mps: v,
                omega_radps: w,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(t_s: f64) -> OdometrySample {
        OdometrySample {
            t_s,
            dt_s: 0.01,
            v_mps: 2.0,
            omega_radps: 0.1,
            delta: (0.02, 0.0, 0.001),
        }
    }

    #[test]
    fn contiguous_readings_have_no_gap_and_a_missing_second_is_one() {
        let mut g = GapTracker::default();
        for k in 1..=100 {
            assert_eq!(g.reading(&reading(f64::from(k) * 0.01)), (None, 1.0));
            // A scan between readings waits for the next one: no gap.
            assert_eq!(g.scan(f64::from(k) * 0.01 + 0.004), None);
        }
        // The next reading comes 1 s late.
        let (gap, f) = g.reading(&reading(2.01));
        let gap = gap.unwrap();
        assert!((gap.unobserved_s - 1.0).abs() < 1e-9);
        assert_eq!((gap.v_mps, gap.omega_radps, f), (2.0, 0.1, 1.0));
    }

    #[test]
    fn a_scan_between_readings_leads_to_its_time_and_the_next_reading_keeps_the_rest() {
        let mut g = GapTracker::default();
        assert_eq!(g.lead(0.005), None, "no reading yet: nothing to lead with");
        g.reading(&reading(1.0));
        // A 75 Hz scan 4 ms after the reading: 0.4 of the last reading's interval ahead.
        assert_eq!(g.scan(1.004), None);
        let f = g.lead(1.004).unwrap();
        assert!((f - 0.4).abs() < 1e-9, "{f}");
        // A second scan before the next reading leads only from the first.
        let f = g.lead(1.008).unwrap();
        assert!((f - 0.4).abs() < 1e-9, "{f}");
        assert_eq!(g.lead(1.008), None, "nothing left to lead");
        // The next reading (0.01 s interval ending at 1.01 s) keeps the 2 ms after the scan.
        let (gap, f) = g.reading(&reading(1.01));
        assert_eq!(gap, None);
        assert!((f - 0.2).abs() < 1e-9, "{f}");
        // A scan at a reading's time needs no lead.
        assert_eq!(g.lead(1.01), None);
        assert_eq!(g.reading(&reading(1.02)), (None, 1.0));
        // The readings stop: leads go on for the normal wait only, then the scans coast
        // from where the last lead ended (the dropout is not taken for steady motion).
        assert_eq!(g.scan(1.033), None);
        assert!(g.lead(1.033).is_some());
        let gap = g.scan(1.047).unwrap();
        assert!((gap.unobserved_s - 0.014).abs() < 1e-9, "{gap:?}");
        assert_eq!(g.lead(1.047), None);
        let gap = g.scan(1.06).unwrap();
        assert!((gap.unobserved_s - 0.013).abs() < 1e-9, "{gap:?}");
    }

    #[test]
    fn dead_reckoning_is_carried_to_the_scan_within_the_wait_only() {
        let r = reading(1.0); // 2 m/s, 0.1 rad/s
        let p = SimPose::new(5.0, 0.0, 0.0);
        let at = dead_reckoned_at(p, Some(&r), 1.004);
        assert!((at.x_m - 5.008).abs() < 1e-6 && (at.theta_rad - 0.0004).abs() < 1e-12);
        // No reading yet, a scan before the reading's end, a scan in a gap: as it is.
        assert_eq!(dead_reckoned_at(p, None, 1.004), p);
        assert_eq!(dead_reckoned_at(p, Some(&r), 0.999), p);
        assert_eq!(dead_reckoned_at(p, Some(&r), 1.02), p);
    }

    #[test]
    fn a_scan_inside_a_gap_coasts_up_to_itself_and_the_late_reading_keeps_its_rest() {
        let mut g = GapTracker::default();
        g.reading(&reading(1.0));
        let gap = g.scan(1.5).unwrap();
        assert!((gap.unobserved_s - 0.5).abs() < 1e-12);
        // The next reading ends after the scan: from 1.5 s to 2.0 s is a gap (coasted at the
        // reading), then all of its own interval.
        let (gap, f) = g.reading(&reading(2.0));
        assert!((gap.unwrap().unobserved_s - 0.49).abs() < 1e-9);
        assert_eq!(f, 1.0);
        // A reading whose interval straddles a coasted scan applies only its uncovered part.
        let mut g = GapTracker::default();
        g.reading(&reading(1.0));
        g.scan(1.5);
        let late = OdometrySample {
            dt_s: 0.6,
            ..reading(1.6)
        };
        let (gap, f) = g.reading(&late);
        assert_eq!(gap, None);
        assert!((f - 0.1 / 0.6).abs() < 1e-9, "{f}");
    }
}
