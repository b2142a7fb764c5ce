//! What a survey tells its user: a text report, `survey.json`, and `landmarks.csv` (one row
//! per landmark of the prior map with its surveyed pose and uncertainty).

use std::fmt::Write as _;

use serde::Serialize;

use super::score::LandmarkScore;
use super::{
    Gauge, LandmarkState, PriorMap, SolveStats, Stretch, Survey, SurveyedLandmark, Timings,
    Unexplained,
};

/// The surveyed map and the prior against the truth (simulated drives).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AgainstTruth {
    /// The prior map's (design's) landmarks against the truth: the installation error.
    pub prior: LandmarkScore,
    /// The surveyed map's.
    pub surveyed: LandmarkScore,
}

/// `survey.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SurveyJson<'a> {
    /// What fixes the map.
    pub gauge: Gauge,
    /// Where the prior map came from: the design, or the drive's own map (`--without-map`).
    pub prior_map: PriorMap,
    /// Scans in the recording.
    pub scans: usize,
    /// Keyframes used.
    pub keyframes: usize,
    /// Landmarks of the prior map.
    pub prior_landmarks: usize,
    /// Landmarks surveyed (in the map).
    pub surveyed_landmarks: usize,
    /// Odometry steps between consecutive keyframes.
    pub odometry_steps: usize,
    /// Scan-to-scan factors (across and heading from the walls).
    pub scan_steps: usize,
    /// Consecutive keyframes whose scans could not be matched.
    pub unmatched_steps: usize,
    /// Median 1σ along the wall of the surveyed landmarks, metres.
    pub median_sd_along_m: f64,
    /// Largest 1σ along the wall, metres.
    pub max_sd_along_m: f64,
    /// Stretches whose along-tunnel extent rests on the odometry.
    pub along_unobserved: &'a [Stretch],
    /// Their 1σ from the odometry's scale uncertainty, metres.
    pub along_unobserved_sd_m: f64,
    /// Keyframe steps across gaps in the odometry log.
    pub odometry_gaps: &'a [Stretch],
    /// Stretches without scans.
    pub scan_gaps: &'a [Stretch],
    /// Keyframe steps the solution contradicts.
    pub inconsistent_steps: &'a [Stretch],
    /// Wall stretches interpolated: `(wall, from s m, to s m)`.
    pub unsurveyed_walls: &'a [(&'static str, f64, f64)],
    /// Landmark-like returns no prior landmark explains.
    pub unexplained: &'a [Unexplained],
    /// Against the truth, when given.
    pub against_truth: Option<AgainstTruth>,
    /// Time per stage, seconds.
    pub timings: Timings,
    /// The joint solve: back end, iterations, cost before and after.
    pub solve: SolveStats,
    /// Warnings.
    pub warnings: &'a [String],
    /// Every landmark of the prior map.
    pub landmarks: &'a [SurveyedLandmark],
}

fn sd_stats(s: &Survey) -> (f64, f64) {
    let mut v: Vec<f64> = s
        .landmarks
        .iter()
        .filter(|l| l.map_index.is_some())
        .map(|l| l.sd_along_m)
        .collect();
    v.sort_unstable_by(f64::total_cmp);
    (
        v.get(v.len() / 2).copied().unwrap_or(0.0),
        v.last().copied().unwrap_or(0.0),
    )
}

/// The JSON view of a survey.
pub fn json<'a>(s: &'a Survey, truth: Option<AgainstTruth>) -> SurveyJson<'a> {
    let (median, max) = sd_stats(s);
    SurveyJson {
        gauge: s.gauge,
        prior_map: s.prior_map,
        scans: s.scans,
        keyframes: s.keyframes,
        prior_landmarks: s.landmarks.len(),
        surveyed_landmarks: s.map.landmarks().len(),
        odometry_steps: s.odometry_steps,
        scan_steps: s.scan_steps,
        unmatched_steps: s.unmatched_steps,
        median_sd_along_m: median,
        max_sd_along_m: max,
        along_unobserved: &s.along_unobserved,
        along_unobserved_sd_m: s.along_unobserved_sd_m,
        odometry_gaps: &s.odometry_gaps,
        scan_gaps: &s.scan_gaps,
        inconsistent_steps: &s.inconsistent_steps,
        unsurveyed_walls: &s.unsurveyed_walls,
        unexplained: &s.unexplained,
        against_truth: truth,
        timings: s.timings,
        solve: s.solve,
        warnings: &s.warnings,
        landmarks: &s.landmarks,
    }
}

/// `landmarks.csv`.
pub fn landmarks_csv(s: &Survey) -> String {
    let mut out = String::from(
        "prior_index,map_index,wall,state,x_m,y_m,s_m,offset_m,sd_along_m,sd_across_m,sd_rotation_rad,fits,failed_fits,from_prior_along_m,from_prior_across_m\n",
    );
    for l in &s.landmarks {
        let state = match l.state {
            LandmarkState::Surveyed => "surveyed",
            LandmarkState::NotSeen => "not-seen",
            LandmarkState::Moved => "moved",
        };
        let _ = writeln!(
            out,
            "{},{},{},{state},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{},{},{:.4},{:.4}",
            l.prior_index,
            l.map_index.map_or(String::new(), |i| i.to_string()),
            l.wall,
            l.x_m,
            l.y_m,
            l.s_m,
            l.offset_m,
            l.sd_along_m,
            l.sd_across_m,
            l.sd_rotation_rad,
            l.fits,
            l.failed_fits,
            l.from_prior_m.0,
            l.from_prior_m.1
        );
    }
    out
}

fn mm(m: f64) -> String {
    format!("{:.1} mm", m * 1e3)
}

/// The text report.
pub fn text(s: &Survey, truth: Option<&AgainstTruth>) -> String {
    let mut o = String::new();
    let (median, max) = sd_stats(s);
    let prior = s.prior_map.name();
    let gauge = match s.gauge {
        Gauge::Design => "the design's marks (installation tolerance) and any anchors",
        Gauge::Anchors => "the surveyed anchors",
        Gauge::FirstLandmark => "the first landmark (the map is relative to it)",
        Gauge::FirstPose => "the first pose (no landmark surveyed)",
    };
    let _ = writeln!(
        o,
        "survey of {} scans ({} keyframes): {} of {} landmarks surveyed; map tied to {gauge}",
        s.scans,
        s.keyframes,
        s.map.landmarks().len(),
        s.landmarks.len()
    );
    let _ = writeln!(
        o,
        "landmark uncertainty along the wall (1σ, marginal): median {}, worst {}",
        mm(median),
        mm(max)
    );
    let _ = writeln!(
        o,
        "keyframe steps: {} from the odometry, {} scan-to-scan matches (across and heading), {} consecutive keyframes unmatched",
        s.odometry_steps, s.scan_steps, s.unmatched_steps
    );
    if let Some(t) = truth.filter(|t| t.prior.paired + t.surveyed.paired > 0) {
        let _ = writeln!(o, "\nlandmarks against the true as-built map:");
        let _ = writeln!(
            o,
            "  {:<16} {:>8} {:>10} {:>10} {:>10} {:>12} {:>10}",
            "map", "paired", "RMS", "along", "across", "rel. first", "max"
        );
        for (name, sc) in [(prior, &t.prior), ("surveyed", &t.surveyed)] {
            let _ = writeln!(
                o,
                "  {:<16} {:>8} {:>10} {:>10} {:>10} {:>12} {:>10}",
                name,
                sc.paired,
                mm(sc.rms_m),
                mm(sc.rms_along_m),
                mm(sc.rms_across_m),
                mm(sc.rms_relative_m),
                mm(sc.max_m)
            );
        }
        if s.prior_map == PriorMap::Drive && s.gauge == Gauge::FirstLandmark {
            let _ = writeln!(
                o,
                "  (no map and no anchors: the map is in the frame of the drive's initial pose, turned by that pose's heading error against the truth; landmarks pair within 0.5 m only near the start. Tie it with --anchor to score it.)"
            );
        }
    }
    let not_seen: Vec<&SurveyedLandmark> = s
        .landmarks
        .iter()
        .filter(|l| l.state == LandmarkState::NotSeen)
        .collect();
    if !not_seen.is_empty() {
        let _ = writeln!(
            o,
            "\nlandmarks of the {prior} not surveyed (left out of the map):"
        );
        for l in not_seen {
            let _ = writeln!(
                o,
                "  #{:<4} {:<5} wall, s {:8.2} m: fitted in {} scans, not fitted in {}",
                l.prior_index, l.wall, l.s_m, l.fits, l.failed_fits
            );
        }
    }
    let moved: Vec<&SurveyedLandmark> = s
        .landmarks
        .iter()
        .filter(|l| l.state == LandmarkState::Moved)
        .collect();
    if !moved.is_empty() {
        let _ = writeln!(
            o,
            "\nlandmarks moved from where the prior map has them (surveyed where they are now):"
        );
        for l in moved {
            let _ = writeln!(
                o,
                "  #{:<4} {:<5} wall, s {:8.2} m: {:+.1} mm along, {:+.1} mm across ({} fits)",
                l.prior_index,
                l.wall,
                l.s_m,
                1e3 * l.from_prior_m.0,
                1e3 * l.from_prior_m.1,
                l.fits
            );
        }
    }
    if !s.unexplained.is_empty() {
        let _ = writeln!(
            o,
            "\nlandmark-like returns no landmark of the {prior} explains:"
        );
        for u in &s.unexplained {
            let _ = writeln!(
                o,
                "  at ({:.2}, {:.2}) m, seen from {} keyframes",
                u.x_m, u.y_m, u.keyframes
            );
        }
    }
    let without_landmark = format!(
        "stretches without a landmark (along-tunnel extent from the odometry alone, ±{:.2} m in all)",
        s.along_unobserved_sd_m
    );
    for (title, list) in [
        (without_landmark.as_str(), &s.along_unobserved),
        ("steps across gaps in the odometry log", &s.odometry_gaps),
        ("stretches without scans", &s.scan_gaps),
        (
            "keyframe steps the solution contradicts",
            &s.inconsistent_steps,
        ),
    ] {
        if !list.is_empty() {
            let _ = writeln!(o, "\n{title}:");
            for st in list.iter() {
                let _ = writeln!(
                    o,
                    "  {:8.1} – {:8.1} m driven, from ({:.1}, {:.1})",
                    st.from_m, st.to_m, st.at.0, st.at.1
                );
            }
        }
    }
    for w in &s.warnings {
        let _ = writeln!(o, "\nwarning: {w}");
    }
    let t = &s.timings;
    let _ = writeln!(
        o,
        "\ntime: front end {:.1} s, landmark fits {:.1} s, joint solve {:.1} s, walls and map {:.1} s",
        t.front_end_s, t.observations_s, t.solve_s, t.map_s
    );
    let v = &s.solve;
    let _ = writeln!(
        o,
        "joint solve: {}, {} keyframes and landmarks, {} factors, {} iterations, cost {:.6e} → {:.6e}, {:.2} s with the marginals",
        v.solver, v.variables, v.factors, v.iterations, v.error_before, v.error_after, v.seconds
    );
    o
}
