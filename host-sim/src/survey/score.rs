//! A stored map's landmarks against the true as-built map's (simulation: the recording's
//! `as_built.postcard`): each landmark paired with the true one nearest it on the same
//! wall, the error split along its wall and across.

use loc_core::map::TunnelMap;
use serde::Serialize;

/// How far a map's landmarks are from the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LandmarkScore {
    /// Landmarks paired with a true one (within 0.5 m, same wall).
    pub paired: usize,
    /// Landmarks of the map without a true one near (in the map, not in the tunnel).
    pub unpaired: usize,
    /// True landmarks the map lacks.
    pub missing: usize,
    /// RMS of the position error, metres.
    pub rms_m: f64,
    /// RMS along the wall, metres.
    pub rms_along_m: f64,
    /// RMS across, metres.
    pub rms_across_m: f64,
    /// RMS after removing the first paired landmark's error (the map relative to its first
    /// landmark), metres.
    pub rms_relative_m: f64,
    /// Largest position error, metres.
    pub max_m: f64,
}

/// A landmark's wall (left?), base centre, tangent and inward normal, world frame.
type Base = (bool, (f64, f64), (f64, f64), (f64, f64));

/// One paired landmark's error: along, across, and the world-frame vector, metres.
type PairError = (f64, f64, (f64, f64));

/// Centre of each landmark's base (stand-off included), its wall and its frame's axes.
fn bases(map: &TunnelMap) -> Vec<Base> {
    map.landmarks()
        .iter()
        .map(|lm| {
            let f = lm.frame;
            let p = f.to_world(
                loc_core::geometry::Point2::new(0.0, 0.0),
                lm.placement.offset_m,
            );
            (
                lm.placement.wall == loc_core::map::WallSide::Left,
                (f64::from(p.x_m), f64::from(p.y_m)),
                (f64::from(f.tangent.x_m), f64::from(f.tangent.y_m)),
                (
                    f64::from(f.inward_normal.x_m),
                    f64::from(f.inward_normal.y_m),
                ),
            )
        })
        .collect()
}

/// Pairing distance, metres: far below the §4.4 spacing, far above a survey's error.
const PAIR_M: f64 = 0.5;

/// Scores `map`'s landmarks against `truth`'s.
pub fn score(map: &TunnelMap, truth: &TunnelMap) -> LandmarkScore {
    let (ours, theirs) = (bases(map), bases(truth));
    let mut used = vec![false; theirs.len()];
    let mut errors: Vec<PairError> = Vec::new();
    let mut unpaired = 0usize;
    for (left, p, _, _) in &ours {
        let best = theirs
            .iter()
            .enumerate()
            .filter(|(i, t)| t.0 == *left && !used[*i])
            .map(|(i, t)| (i, (p.0 - t.1 .0).hypot(p.1 - t.1 .1)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((i, d)) if d <= PAIR_M => {
                used[i] = true;
                let t = &theirs[i];
                let e = (p.0 - t.1 .0, p.1 - t.1 .1);
                errors.push((e.0 * t.2 .0 + e.1 * t.2 .1, e.0 * t.3 .0 + e.1 * t.3 .1, e));
            }
            _ => unpaired += 1,
        }
    }
    let n = errors.len().max(1) as f64;
    let rms = |f: &dyn Fn(&PairError) -> f64| {
        (errors.iter().map(|e| f(e).powi(2)).sum::<f64>() / n).sqrt()
    };
    let first = errors.first().map_or((0.0, 0.0), |e| e.2);
    LandmarkScore {
        paired: errors.len(),
        unpaired,
        missing: used.iter().filter(|u| !**u).count(),
        rms_m: rms(&|e| e.2 .0.hypot(e.2 .1)),
        rms_along_m: rms(&|e| e.0),
        rms_across_m: rms(&|e| e.1),
        rms_relative_m: rms(&|e| (e.2 .0 - first.0).hypot(e.2 .1 - first.1)),
        max_m: errors
            .iter()
            .map(|e| e.2 .0.hypot(e.2 .1))
            .fold(0.0, f64::max),
    }
}
