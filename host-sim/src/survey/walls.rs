//! The walls as built: every keyframe's wall points placed in the world by the solved
//! trajectory, gathered per station along the prior wall, and each station's offset from
//! the prior taken as a robust mean — the wall smoothed to the station spacing (1 m: what
//! the lidar resolves through its noise, and what the firmware's map holds for 1 km).

use loc_core::strip::PointLabel;

use super::keyframes::Keyframe;
use crate::vehicle::SimPose;

/// Stations along a prior wall, every `step_m` of its arc length (and at its end).
#[derive(Debug, Clone, PartialEq)]
pub struct Stations {
    /// Station points on the prior wall, world frame.
    pub points: Vec<(f64, f64)>,
    /// Unit tangents there.
    pub tangents: Vec<(f64, f64)>,
    /// Arc length of each station, metres.
    pub s_m: Vec<f64>,
}

impl Stations {
    /// Stations every `step_m` along `poly`.
    pub fn along(poly: &[(f64, f64)], step_m: f64) -> Self {
        let length: f64 = poly
            .windows(2)
            .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
            .sum();
        let n = (length / step_m).ceil().max(1.0) as usize;
        let mut out = Stations {
            points: Vec::with_capacity(n + 1),
            tangents: Vec::with_capacity(n + 1),
            s_m: Vec::with_capacity(n + 1),
        };
        for i in 0..=n {
            let s = (i as f64 * step_m).min(length);
            let (p, t) = crate::stored_map::point_at(poly, s);
            out.points.push(p);
            out.tangents.push(t);
            out.s_m.push(s);
        }
        out
    }

    /// The station nearest `p`, searched from station `hint` (points come in beam order,
    /// so the previous point's station is a close start).
    fn nearest(&self, p: (f64, f64), hint: usize) -> usize {
        let d2 = |i: usize| {
            let q = self.points[i];
            (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)
        };
        let last = self.points.len().saturating_sub(1);
        let mut i = hint.min(last);
        while i < last && d2(i + 1) < d2(i) {
            i += 1;
        }
        while i > 0 && d2(i - 1) < d2(i) {
            i -= 1;
        }
        i
    }

    /// Signed distance of `p` from station `i`'s wall, metres, to the left of the tangent.
    fn offset(&self, i: usize, p: (f64, f64)) -> f64 {
        let (q, t) = (self.points[i], self.tangents[i]);
        t.0 * (p.1 - q.1) - t.1 * (p.0 - q.0)
    }
}

/// A surveyed wall.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveyedWall {
    /// Its vertices, one per station, world frame.
    pub vertices: Vec<(f64, f64)>,
    /// Each station's offset from the prior wall, metres (to the left of its direction).
    pub offset_m: Vec<f64>,
    /// Wall points behind each station's offset.
    pub support: Vec<usize>,
}

/// Fewest points a station needs for its own offset; stations with fewer take their
/// neighbours' (interpolated) and are reported as not surveyed.
pub const MIN_STATION_POINTS: usize = 20;

/// Farthest wall points used, metres from the vehicle (near points are the accurate ones:
/// a pose's heading error moves a point by its range).
pub const WALL_RANGE_M: f64 = 20.0;

/// Gathers the `label` wall points of every keyframe at its solved pose (`poses[k]`), skips
/// those `excluded` (on a landmark), and fits the wall's offset at each station.
pub fn fuse(
    keyframes: &[Keyframe],
    poses: &[SimPose],
    label: PointLabel,
    stations: &Stations,
    excluded: &dyn Fn(usize, (f64, f64)) -> bool,
) -> SurveyedWall {
    let mut bins: Vec<Vec<f32>> = vec![Vec::new(); stations.points.len()];
    let mut hint = 0usize;
    for (k, (kf, pose)) in keyframes.iter().zip(poses).enumerate() {
        hint = stations.nearest((pose.x_m, pose.y_m), hint);
        let mut h = hint;
        for (p, l) in kf.points.iter().zip(&kf.labels) {
            if *l != label || p.0.hypot(p.1) > WALL_RANGE_M {
                continue;
            }
            let w = pose.apply(*p);
            if excluded(k, w) {
                continue;
            }
            h = stations.nearest(w, h);
            bins[h].push(stations.offset(h, w) as f32);
        }
    }
    let mut offset: Vec<Option<f64>> = bins.iter_mut().map(|b| robust_mean(b)).collect();
    let support: Vec<usize> = bins.iter().map(Vec::len).collect();
    for (o, n) in offset.iter_mut().zip(&support) {
        if *n < MIN_STATION_POINTS {
            *o = None;
        }
    }
    let offset_m = fill_gaps(&offset);
    let vertices = stations
        .points
        .iter()
        .zip(&stations.tangents)
        .zip(&offset_m)
        .map(|((q, t), d)| (q.0 - t.1 * d, q.1 + t.0 * d))
        .collect();
    SurveyedWall {
        vertices,
        offset_m,
        support,
    }
}

/// The mean of the values within 3 cm of their median (a person, a pipe, a mixed pixel
/// left out), or `None` without values.
fn robust_mean(v: &mut [f32]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable_by(f32::total_cmp);
    let med = f64::from(v[v.len() / 2]);
    let (sum, n) = v
        .iter()
        .map(|&x| f64::from(x))
        .filter(|x| (x - med).abs() <= 0.03)
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    Some(if n > 0 { sum / n as f64 } else { med })
}

/// Stations without an offset take the linear interpolation of their nearest surveyed
/// neighbours (the prior's own, 0, when there are none).
fn fill_gaps(offset: &[Option<f64>]) -> Vec<f64> {
    let known: Vec<(usize, f64)> = offset
        .iter()
        .enumerate()
        .filter_map(|(i, o)| o.map(|v| (i, v)))
        .collect();
    (0..offset.len())
        .map(|i| {
            if let Some(v) = offset[i] {
                return v;
            }
            let after = known.partition_point(|(j, _)| *j < i);
            match (after.checked_sub(1).map(|a| known[a]), known.get(after)) {
                (Some((i0, v0)), Some(&(i1, v1))) => {
                    v0 + (v1 - v0) * (i - i0) as f64 / (i1 - i0) as f64
                }
                (Some((_, v)), None) | (None, Some(&(_, v))) => v,
                (None, None) => 0.0,
            }
        })
        .collect()
}

/// The stretches of a wall whose stations were not surveyed (too few points): `(from, to)`
/// arc lengths, metres.
pub fn unsurveyed_stretches(wall: &SurveyedWall, stations: &Stations) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (i, &n) in wall.support.iter().enumerate() {
        if n >= MIN_STATION_POINTS {
            continue;
        }
        let s = stations.s_m[i];
        match out.last_mut() {
            Some(last) if i > 0 && wall.support[i - 1] < MIN_STATION_POINTS => last.1 = s,
            _ => out.push((s, s)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_interpolated_and_reported() {
        let filled = fill_gaps(&[None, Some(0.01), None, None, Some(0.04), None]);
        let want = [0.01, 0.01, 0.02, 0.03, 0.04, 0.04];
        for (a, b) in filled.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{filled:?}");
        }
        assert_eq!(fill_gaps(&[None, None]), vec![0.0, 0.0]);
        let mut v = [0.01f32, 0.011, 0.009, 0.5, 0.0105];
        assert!((robust_mean(&mut v).unwrap() - 0.0101).abs() < 1e-4);
    }

    #[test]
    fn stations_follow_the_wall_and_offsets_are_signed_to_its_left() {
        let st = Stations::along(&[(0.0, 2.0), (10.0, 2.0)], 1.0);
        assert_eq!(st.points.len(), 11);
        let i = st.nearest((6.4, 1.9), 0);
        assert_eq!(i, 6);
        assert!((st.offset(i, (6.4, 1.9)) + 0.1).abs() < 1e-12);
    }
}
