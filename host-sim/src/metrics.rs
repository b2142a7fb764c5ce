//! Accuracy and speed figures of a closed-loop run, against ground truth.
//!
//! - the paper's eq. 2: `E = 1/N Σ (x_g − x̂)² + (y_g − ŷ)² + (θ_g − θ̂)²` (m² and rad²
//!   summed as the paper does), and its root;
//! - position and heading RMS, maximum position error;
//! - the error split along and across the tunnel in tunnel coordinates (chainage and
//!   lateral offset from the centre line), since a smooth tunnel leaves only the
//!   along-tunnel direction unobservable;
//! - position RMS over the first and the last 100 m driven, and binned against distance;
//! - time per scan update (the localiser's, measured around its call);
//! - the same accuracy figures for odometry alone.
//!
//! Samples are taken once per scan, after the localiser has processed it.

use serde::Serialize;

use loc_core::localizer::Availability;

use crate::vehicle::SimPose;
use crate::world::centerline::{wrap_pi, CenterLine};

/// Distance over which the first/last-stretch figures are taken, metres.
pub const STRETCH_M: f64 = 100.0;

/// One per-scan sample of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    /// Time, seconds since the start.
    pub t_s: f64,
    /// Distance driven (true), metres.
    pub distance_m: f64,
    /// Chainage of the true position, metres.
    pub chainage_m: f64,
    /// Ground truth.
    pub truth: SimPose,
    /// The localiser's estimate.
    pub estimate: SimPose,
    /// Dead reckoning from odometry alone.
    pub odometry: SimPose,
    /// The estimate's position standard deviations (square roots of the covariance's
    /// diagonal), metres: `(σx, σy)`; heading σ in radians.
    pub sigma: (f64, f64, f64),
    /// The estimate's protection level and availability (`None`: the estimator gives
    /// none).
    #[serde(skip)]
    pub protection: Option<loc_core::localizer::Protection>,
    /// CPU time the estimator took for this scan, microseconds.
    pub update_us: f64,
}

/// How far the estimate was from the truth in its own standard deviations, per axis
/// (`|error| / σ` in x, y and heading), at the worst sample: a localiser that claims
/// millimetres must be within a few σ of the truth. Above 5 a pose is confidently wrong.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WorstSigmas {
    /// The largest `|error| / σ` of the three axes, at the worst sample.
    pub error_sigmas: f64,
    /// That sample's time, s.
    pub t_s: f64,
}

/// The worst [`WorstSigmas`] over the samples `counted` selects (e.g. those reported
/// tracking); `None` when none is. A zero σ with a non-zero error counts as infinitely
/// many σ, a non-finite estimate as NaN (both worse than any finite figure).
pub fn worst_sigmas<'a>(samples: impl IntoIterator<Item = &'a Sample>) -> Option<WorstSigmas> {
    let mut worst: Option<WorstSigmas> = None;
    for s in samples {
        let e = s.estimate;
        let dth = (e.theta_rad - s.truth.theta_rad + std::f64::consts::PI)
            .rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        let ratios = [
            ((e.x_m - s.truth.x_m).abs(), s.sigma.0),
            ((e.y_m - s.truth.y_m).abs(), s.sigma.1),
            (dth.abs(), s.sigma.2),
        ];
        let r = ratios.iter().fold(0.0, |r, &(err, sd)| {
            // An exact estimate is 0 σ off even at σ = 0.
            max_or_nan(r, if err == 0.0 { 0.0 } else { err / sd })
        });
        let worse = match worst {
            None => true,
            Some(w) => r.is_nan() && !w.error_sigmas.is_nan() || r > w.error_sigmas,
        };
        if worse {
            worst = Some(WorstSigmas {
                error_sigmas: r,
                t_s: s.t_s,
            });
        }
    }
    worst
}

/// How the protection levels of a run's scans held against the truth (loc-core's
/// [`Protection`](loc_core::localizer::Protection): a bound on the horizontal position error, and whether the pose was
/// available). Sums over runs with [`ProtectionSummary::add`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ProtectionSummary {
    /// Scans with a protection level reported (bounded or not).
    pub scans: usize,
    /// Of which with a bound (a level).
    pub bounded: usize,
    /// Of those, the position error within the level.
    pub bounded_within: usize,
    /// Scans flagged available.
    pub available: usize,
    /// Scans flagged available with the position error above the level: misleading
    /// information, the outcome the integrity risk bounds (target 0).
    pub misleading: usize,
    /// Scans unavailable for want of a pose (not initialised, relocalising).
    pub unavailable_no_pose: usize,
    /// Scans unavailable for a detected fault (map unconfirmed, gate refusal).
    pub unavailable_fault: usize,
    /// Scans unavailable with the level above the alert limit.
    pub unavailable_above_limit: usize,
    /// The largest position error over the level among available scans.
    pub worst_available_ratio: f64,
    /// Sum of the levels of available scans, metres (for the mean).
    pub available_level_sum_m: f64,
    /// The largest level of an available scan, metres.
    pub available_level_max_m: f64,
}

impl ProtectionSummary {
    /// Summarises `samples`; `None` when none carries a protection level (an estimator
    /// without one).
    pub fn of(samples: &[Sample]) -> Option<Self> {
        let mut out = Self::default();
        for s in samples {
            let Some(p) = s.protection else { continue };
            out.scans += 1;
            let e = (s.estimate.x_m - s.truth.x_m).hypot(s.estimate.y_m - s.truth.y_m);
            if let Some(level) = p.level_m.map(f64::from) {
                out.bounded += 1;
                // A non-finite error is not within any bound.
                if e <= level {
                    out.bounded_within += 1;
                }
                if p.is_available() {
                    out.available += 1;
                    out.available_level_sum_m += level;
                    out.available_level_max_m = out.available_level_max_m.max(level);
                    if e.is_nan() || e > level {
                        out.misleading += 1;
                    }
                    out.worst_available_ratio = max_or_nan(out.worst_available_ratio, e / level);
                }
            }
            match p.availability {
                Availability::Available => {}
                Availability::NoPose => out.unavailable_no_pose += 1,
                Availability::FaultDetected => out.unavailable_fault += 1,
                _ => out.unavailable_above_limit += 1,
            }
        }
        (out.scans > 0).then_some(out)
    }

    /// Adds another run's summary.
    pub fn add(&mut self, o: &Self) {
        self.scans += o.scans;
        self.bounded += o.bounded;
        self.bounded_within += o.bounded_within;
        self.available += o.available;
        self.misleading += o.misleading;
        self.unavailable_no_pose += o.unavailable_no_pose;
        self.unavailable_fault += o.unavailable_fault;
        self.unavailable_above_limit += o.unavailable_above_limit;
        self.worst_available_ratio =
            max_or_nan(self.worst_available_ratio, o.worst_available_ratio);
        self.available_level_sum_m += o.available_level_sum_m;
        self.available_level_max_m = self.available_level_max_m.max(o.available_level_max_m);
    }

    /// The share of bounded scans whose error was within the level (1 without any).
    pub fn bounded_fraction(&self) -> f64 {
        if self.bounded == 0 {
            1.0
        } else {
            self.bounded_within as f64 / self.bounded as f64
        }
    }

    /// Mean level of the available scans, metres (0 without any).
    pub fn mean_available_level_m(&self) -> f64 {
        if self.available == 0 {
            0.0
        } else {
            self.available_level_sum_m / self.available as f64
        }
    }

    /// One line for reports.
    pub fn line(&self) -> String {
        format!(
            "protection level: bounds the error on {} of {} bounded scans ({:.4} %); available {} of {} scans (level mean {:.3} m, max {:.3} m; worst error {:.2} of the level); misleading (available, error above the level) {}; unavailable: no pose {}, fault detected {}, above the alert limit {}",
            self.bounded_within,
            self.bounded,
            100.0 * self.bounded_fraction(),
            self.available,
            self.scans,
            self.mean_available_level_m(),
            self.available_level_max_m,
            self.worst_available_ratio,
            self.misleading,
            self.unavailable_no_pose,
            self.unavailable_fault,
            self.unavailable_above_limit
        )
    }
}

/// The larger of `a` and `b`, NaN when either is: a maximum over errors one of which cannot
/// be computed is not a number (JSON `null`), never the maximum of the others — `f64::max`
/// would drop the NaN and report a clean 0.
fn max_or_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Accuracy figures of one pose source (the localiser, or odometry alone).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Accuracy {
    /// Mean of eq. 2's summand over the samples (m² + rad²).
    pub mse_eq2: f64,
    /// Square root of `mse_eq2`.
    pub rms_eq2: f64,
    /// RMS of the position error, metres.
    pub position_rms_m: f64,
    /// RMS of the heading error, radians.
    pub heading_rms_rad: f64,
    /// Largest position error, metres.
    pub max_position_error_m: f64,
    /// RMS of the along-tunnel error, metres.
    pub along_rms_m: f64,
    /// RMS of the across-tunnel error, metres.
    pub across_rms_m: f64,
    /// Largest along-tunnel error (absolute), metres.
    pub max_along_error_m: f64,
    /// Position RMS over the first 100 m driven, metres.
    pub first_100m_position_rms_m: f64,
    /// Position RMS over the last 100 m driven, metres.
    pub last_100m_position_rms_m: f64,
    /// Position error at the last sample, metres.
    pub final_position_error_m: f64,
}

/// Serialises an [`Accuracy`] with each key prefixed `odometry_` (the flat JSON of
/// [`Metrics`]).
mod odometry_prefix {
    use serde::ser::{Error, SerializeMap};
    use serde::Serializer;

    pub fn serialize<S: Serializer>(a: &super::Accuracy, s: S) -> Result<S::Ok, S::Error> {
        let serde_json::Value::Object(fields) =
            serde_json::to_value(a).map_err(S::Error::custom)?
        else {
            return Err(S::Error::custom("accuracy is not a JSON object"));
        };
        let mut map = s.serialize_map(Some(fields.len()))?;
        for (k, v) in fields {
            map.serialize_entry(&format!("odometry_{k}"), &v)?;
        }
        map.end()
    }
}

/// Position error RMS in one distance bin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DistanceBin {
    /// Distance driven at the bin's end, metres.
    pub distance_m: f64,
    /// Localiser position RMS in the bin, metres.
    pub position_rms_m: f64,
    /// Localiser along-tunnel error RMS in the bin, metres.
    pub along_rms_m: f64,
    /// Odometry-alone position RMS in the bin, metres.
    pub odometry_position_rms_m: f64,
}

/// All figures of a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metrics {
    /// Localiser accuracy (its keys unprefixed in JSON).
    #[serde(flatten)]
    pub localizer: Accuracy,
    /// Odometry-alone accuracy (its keys prefixed `odometry_` in JSON).
    #[serde(flatten, with = "odometry_prefix")]
    pub odometry: Accuracy,
    /// Number of scans processed.
    pub scans: usize,
    /// Distance driven, metres.
    pub distance_m: f64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// Mean localiser time per scan, microseconds.
    pub mean_us_per_scan: f64,
    /// Largest localiser time for one scan, microseconds.
    pub max_us_per_scan: f64,
    /// RMS of odometry's distance error: the length of the dead-reckoned path minus the
    /// true distance driven, over the samples, metres. The along-tunnel error a localiser
    /// without landmarks inherits (odometry alone's own along-tunnel figure is lower on
    /// curves, where its heading drift bends the path off the tunnel).
    pub odometry_distance_error_rms_m: f64,
    /// Odometry's distance error at the last sample, metres.
    pub odometry_distance_error_final_m: f64,
    /// Error against distance driven.
    pub by_distance: Vec<DistanceBin>,
}

/// Half-width of the chainage window searched when projecting an estimate onto the centre
/// line, metres (odometry alone can be tens of metres off).
const PROJECTION_WINDOW_M: f64 = 80.0;

/// Position error in tunnel coordinates `(along, across)`: the estimate's chainage minus the
/// truth's, and the estimate's lateral offset from the centre line minus the truth's. On a
/// curve this keeps an along-tunnel error from showing up as a lateral one (a pose 10 m
/// too far along a 250 m radius is 0.2 m off the truth's tangent line, yet exactly where
/// it should be across the tunnel).
fn split_error(line: &CenterLine, s: &Sample, est: SimPose) -> (f64, f64) {
    // A projection of a non-finite point would land somewhere: it has no split.
    if !(est.x_m.is_finite() && est.y_m.is_finite()) {
        return (f64::NAN, f64::NAN);
    }
    let t = line.project(s.truth.x_m, s.truth.y_m, s.chainage_m, 1.0);
    let e = line.project(est.x_m, est.y_m, s.chainage_m, PROJECTION_WINDOW_M);
    (e.s_m - t.s_m, e.lateral_m - t.lateral_m)
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for x in v {
        sum += x;
        n += 1;
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

fn accuracy(line: &CenterLine, samples: &[Sample], pick: impl Fn(&Sample) -> SimPose) -> Accuracy {
    if samples.is_empty() {
        return Accuracy::default();
    }
    let total = samples.last().map_or(0.0, |s| s.distance_m);
    let pos2 = |s: &Sample| {
        let e = pick(s);
        (e.x_m - s.truth.x_m).powi(2) + (e.y_m - s.truth.y_m).powi(2)
    };
    let th2 = |s: &Sample| wrap_pi(pick(s).theta_rad - s.truth.theta_rad).powi(2);
    let n = samples.len() as f64;
    let mse = samples.iter().map(|s| pos2(s) + th2(s)).sum::<f64>() / n;
    let splits: Vec<(f64, f64)> = samples
        .iter()
        .map(|s| split_error(line, s, pick(s)))
        .collect();
    Accuracy {
        mse_eq2: mse,
        rms_eq2: mse.sqrt(),
        position_rms_m: rms(samples.iter().map(pos2)),
        heading_rms_rad: rms(samples.iter().map(th2)),
        max_position_error_m: samples.iter().map(|s| pos2(s).sqrt()).fold(0.0, max_or_nan),
        along_rms_m: rms(splits.iter().map(|e| e.0 * e.0)),
        across_rms_m: rms(splits.iter().map(|e| e.1 * e.1)),
        max_along_error_m: splits.iter().map(|e| e.0.abs()).fold(0.0, max_or_nan),
        first_100m_position_rms_m: rms(samples
            .iter()
            .filter(|s| s.distance_m <= STRETCH_M)
            .map(pos2)),
        last_100m_position_rms_m: rms(samples
            .iter()
            .filter(|s| s.distance_m >= total - STRETCH_M)
            .map(pos2)),
        final_position_error_m: samples.last().map_or(0.0, |s| pos2(s).sqrt()),
    }
}

/// Computes every figure of a run from its per-scan samples. `bin_m` is the width of the
/// error-against-distance bins, metres.
pub fn compute(line: &CenterLine, samples: &[Sample], bin_m: f64) -> Metrics {
    let scans = samples.len();
    let distance_m = samples.last().map_or(0.0, |s| s.distance_m);
    let mut by_distance = Vec::new();
    let bin_m = if bin_m > 0.0 { bin_m } else { 10.0 };
    let mut start = 0usize;
    while start < samples.len() {
        let bin = ((samples[start].distance_m / bin_m).floor() + 1.0) * bin_m;
        let end = samples[start..]
            .iter()
            .position(|s| s.distance_m >= bin)
            .map_or(samples.len(), |k| start + k);
        let chunk = &samples[start..end.max(start + 1)];
        let est = accuracy(line, chunk, |s| s.estimate);
        let odo = accuracy(line, chunk, |s| s.odometry);
        by_distance.push(DistanceBin {
            distance_m: bin.min(distance_m),
            position_rms_m: est.position_rms_m,
            along_rms_m: est.along_rms_m,
            odometry_position_rms_m: odo.position_rms_m,
        });
        start = end.max(start + 1);
    }
    // Odometry path length from consecutive samples (chords at the scan rate).
    let mut odo_len = 0.0;
    let mut dist_err_sq = 0.0;
    let mut dist_err_final = 0.0;
    for (i, s) in samples.iter().enumerate() {
        if i > 0 {
            let p = samples[i - 1].odometry;
            odo_len += (s.odometry.x_m - p.x_m).hypot(s.odometry.y_m - p.y_m);
        }
        let first = samples[0].distance_m;
        dist_err_final = odo_len - (s.distance_m - first);
        dist_err_sq += dist_err_final * dist_err_final;
    }
    let odometry_distance_error_rms_m = if scans > 0 {
        (dist_err_sq / scans as f64).sqrt()
    } else {
        0.0
    };
    Metrics {
        odometry_distance_error_rms_m,
        odometry_distance_error_final_m: dist_err_final,
        localizer: accuracy(line, samples, |s| s.estimate),
        odometry: accuracy(line, samples, |s| s.odometry),
        scans,
        distance_m,
        sim_time_s: samples.last().map_or(0.0, |s| s.t_s),
        mean_us_per_scan: if scans == 0 {
            0.0
        } else {
            samples.iter().map(|s| s.update_us).sum::<f64>() / scans as f64
        },
        max_us_per_scan: samples.iter().map(|s| s.update_us).fold(0.0, max_or_nan),
        by_distance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::centerline::CurvePiece;

    fn pose(x: f64, y: f64, t: f64) -> SimPose {
        SimPose {
            x_m: x,
            y_m: y,
            theta_rad: t,
        }
    }

    /// An estimate that is not a number (a NaN start the localiser refused) gives figures
    /// that are not numbers either, never a clean 0.
    #[test]
    fn a_nan_estimate_is_no_figure() {
        let line = CenterLine::from_pieces(&[CurvePiece {
            length_m: 30.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        let samples: Vec<Sample> = (0..10)
            .map(|i| {
                let d = f64::from(i);
                Sample {
                    t_s: d,
                    distance_m: d,
                    chainage_m: d,
                    truth: pose(d, 0.0, 0.0),
                    estimate: pose(f64::NAN, f64::NAN, f64::NAN),
                    odometry: pose(d, 0.0, 0.0),
                    sigma: (0.0, 0.0, 0.0),
                    protection: None,
                    update_us: 1.0,
                }
            })
            .collect();
        let a = compute(&line, &samples, 10.0).localizer;
        assert!(
            a.max_position_error_m.is_nan(),
            "{}",
            a.max_position_error_m
        );
        assert!(a.position_rms_m.is_nan() && a.max_along_error_m.is_nan());
        let json = serde_json::to_value(a).unwrap();
        assert!(json["max_position_error_m"].is_null(), "{json}");
    }

    #[test]
    fn worst_sigmas_finds_the_confidently_wrong_sample() {
        let at = |t: f64, ex: f64, sigma: (f64, f64, f64)| Sample {
            t_s: t,
            distance_m: t,
            chainage_m: t,
            truth: pose(t, 0.0, 3.1),
            estimate: pose(t + ex, 0.0, -3.1),
            odometry: pose(t, 0.0, 0.0),
            sigma,
            protection: None,
            update_us: 1.0,
        };
        // Heading 3.1 vs -3.1 is 0.083 rad apart across ±π: 0.83 σ at σθ = 0.1.
        let ok = at(0.0, 0.01, (0.005, 0.005, 0.1));
        let wrong = at(1.0, 0.07, (0.005, 0.005, 0.1));
        let w = worst_sigmas([&ok, &wrong]).unwrap();
        assert!(
            (w.error_sigmas - 14.0).abs() < 1e-6 && w.t_s == 1.0,
            "{w:?}"
        );
        let w = worst_sigmas([&ok]).unwrap();
        assert!((w.error_sigmas - 2.0).abs() < 1e-6, "{w:?}");
        // σ = 0 with an error is infinitely confident; a NaN estimate is worse still.
        let zero = at(2.0, 0.001, (0.0, 0.0, 0.1));
        assert_eq!(
            worst_sigmas([&ok, &zero]).unwrap().error_sigmas,
            f64::INFINITY
        );
        let nan = at(3.0, f64::NAN, (0.005, 0.005, 0.1));
        assert!(worst_sigmas([&zero, &nan, &ok])
            .unwrap()
            .error_sigmas
            .is_nan());
        assert_eq!(worst_sigmas(std::iter::empty()), None);
    }

    #[test]
    fn figures_from_known_errors() {
        let line = CenterLine::from_pieces(&[CurvePiece {
            length_m: 300.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        // 250 samples 1 m apart; estimate 3 cm ahead and 4 cm left, heading 0.01 rad off,
        // except the last 100 m where it is exact. Odometry 1 m behind.
        let samples: Vec<Sample> = (0..250)
            .map(|i| {
                let d = f64::from(i);
                let late = d > 150.0;
                Sample {
                    t_s: d,
                    distance_m: d,
                    chainage_m: d,
                    truth: pose(d, 0.0, 0.0),
                    estimate: if late {
                        pose(d, 0.0, 0.0)
                    } else {
                        pose(d + 0.03, 0.04, 0.01)
                    },
                    odometry: pose(d - 1.0, 0.0, 0.0),
                    sigma: (0.0, 0.0, 0.0),
                    protection: None,
                    update_us: 100.0 + d,
                }
            })
            .collect();
        let m = compute(&line, &samples, 50.0);
        let a = m.localizer;
        assert!((a.first_100m_position_rms_m - 0.05).abs() < 1e-12);
        assert!((a.last_100m_position_rms_m - 0.05 * (2.0f64 / 101.0).sqrt()).abs() < 1e-12);
        assert!((a.max_position_error_m - 0.05).abs() < 1e-12);
        let frac: f64 = 151.0 / 250.0;
        assert!((a.position_rms_m - (0.0025 * frac).sqrt()).abs() < 1e-12);
        assert!((a.mse_eq2 - (0.0025 + 0.0001) * frac).abs() < 1e-12);
        assert!((a.along_rms_m - (0.0009 * frac).sqrt()).abs() < 1e-12);
        assert!((a.across_rms_m - (0.0016 * frac).sqrt()).abs() < 1e-12);
        assert!((m.odometry.along_rms_m - 1.0).abs() < 1e-12);
        assert_eq!(m.scans, 250);
        // Odometry 1 m behind all along: same path length, no distance error.
        assert!(m.odometry_distance_error_rms_m < 1e-9);
        assert!((m.mean_us_per_scan - 224.5).abs() < 1e-9);
        assert_eq!(m.by_distance.len(), 5);
        assert!((m.by_distance[0].odometry_position_rms_m - 1.0).abs() < 1e-12);
        assert_eq!(m.by_distance[4].position_rms_m, 0.0);
        let empty = compute(&line, &[], 10.0);
        assert_eq!(empty.scans, 0);
        assert_eq!(empty.localizer, Accuracy::default());
    }
}
