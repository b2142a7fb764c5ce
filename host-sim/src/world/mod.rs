//! The simulated tunnel: centre line, rough walls and landmarks, as two maps.
//!
//! - The **true geometry** is what the lidar sees: walls with roughness, landmarks as
//!   installed (some missing, some damaged, each mounted on the rough wall). It is indexed
//!   for ray casting ([`crate::raycast::SegmentGrid`]).
//! - The **design** is what the localiser is given: ideal walls at ± width / 2 and every
//!   landmark of the layout as designed. [`crate::stored_map`] turns it into loc-core's
//!   stored map.
//!
//! World frame, metres, radians, `f64`.

pub mod centerline;
pub mod centerline_check;
pub mod layout;
pub mod roughness;

use loc_core::rng::Pcg32;

use crate::raycast::{SegmentGrid, Surface, WorldSegment};
use centerline::CenterLine;
use layout::{Condition, LayoutSpec, Placement, WallSide};
use roughness::{RoughnessProfile, ROUGHNESS_STEP_M};

/// Cell size of the ray-casting grid, metres.
const GRID_CELL_M: f64 = 1.0;

/// The tunnel's cross-section and wall texture.
#[derive(Debug, Clone)]
pub struct TunnelSpec {
    /// Centre line.
    pub centerline: CenterLine,
    /// Wall-to-wall width, metres.
    pub width_m: f64,
    /// Standard deviation of the walls' deviation from the design, metres.
    pub roughness_sigma_m: f64,
    /// Correlation length of that deviation along the tunnel, metres.
    pub roughness_correlation_m: f64,
}

/// A landmark's designed shape: `(along_m, height_m)` points in its local frame, `along`
/// from −W/2 to +W/2 along the wall (direction of increasing chainage), `height` from the
/// wall into the tunnel. From loc-core's landmark models ([`crate::landmarks`]).
pub type Profile = Vec<(f64, f64)>;

/// A generated tunnel.
#[derive(Debug, Clone)]
pub struct World {
    centerline: CenterLine,
    width_m: f64,
    placements: Vec<Placement>,
    profile: Profile,
    left: RoughnessProfile,
    right: RoughnessProfile,
    grid: SegmentGrid,
}

impl World {
    /// Builds the tunnel: rough walls, the landmark layouts (placed one after the other,
    /// e.g. one per wall), and the ray-casting index. `profile` is the designed landmark
    /// shape (empty: no landmarks are built, whatever the layouts say). Deterministic for
    /// a given generator state.
    pub fn build(
        tunnel: &TunnelSpec,
        layouts: &[LayoutSpec],
        profile: Profile,
        rng: &mut Pcg32,
    ) -> Self {
        let (left, right) = Self::roughness(tunnel, rng);
        let placements = if profile.is_empty() {
            Vec::new()
        } else {
            layouts
                .iter()
                .flat_map(|l| layout::place_landmarks(l, rng))
                .collect()
        };
        Self::assemble(tunnel, left, right, placements, profile)
    }

    /// Builds the tunnel with landmarks at the given placements (a designed layout, e.g.
    /// `host-sim design`'s) instead of drawing them; the walls' roughness still comes from
    /// `rng`.
    pub fn with_placements(
        tunnel: &TunnelSpec,
        placements: Vec<Placement>,
        profile: Profile,
        rng: &mut Pcg32,
    ) -> Self {
        let (left, right) = Self::roughness(tunnel, rng);
        Self::assemble(tunnel, left, right, placements, profile)
    }

    /// The left and right walls' roughness, drawn in that order.
    fn roughness(tunnel: &TunnelSpec, rng: &mut Pcg32) -> (RoughnessProfile, RoughnessProfile) {
        let len = tunnel.centerline.length_m();
        let mut draw = || {
            RoughnessProfile::generate(
                0.0,
                len,
                tunnel.roughness_sigma_m,
                tunnel.roughness_correlation_m,
                rng,
            )
        };
        let left = draw();
        (left, draw())
    }

    /// The world of these walls and landmarks (none without a profile) and its index.
    fn assemble(
        tunnel: &TunnelSpec,
        left: RoughnessProfile,
        right: RoughnessProfile,
        mut placements: Vec<Placement>,
        profile: Profile,
    ) -> Self {
        if profile.is_empty() {
            placements.clear();
        }
        let mut world = Self {
            centerline: tunnel.centerline.clone(),
            width_m: tunnel.width_m,
            placements,
            profile,
            left,
            right,
            grid: SegmentGrid::new(Vec::new(), GRID_CELL_M),
        };
        world.grid = SegmentGrid::new(world.true_segments(), GRID_CELL_M);
        world
    }

    /// Mounts every landmark off its design mark ([`layout::draw_installation_errors`]):
    /// the true geometry (and its ray-casting index) moves, the design does not.
    pub fn install_with_errors(&mut self, along_sd_m: f64, standoff_sd_m: f64, rng: &mut Pcg32) {
        layout::draw_installation_errors(&mut self.placements, along_sd_m, standoff_sd_m, rng);
        self.grid = SegmentGrid::new(self.true_segments(), GRID_CELL_M);
    }

    /// Makes every landmark whose centre lies in chainage `[from_m, to_m]` missing from the
    /// true tunnel (the design keeps them).
    pub fn remove_landmarks_between(&mut self, from_m: f64, to_m: f64) {
        for p in &mut self.placements {
            if (from_m..=to_m).contains(&p.s_m) {
                p.condition = Condition::Missing;
            }
        }
        self.grid = SegmentGrid::new(self.true_segments(), GRID_CELL_M);
    }

    /// Moves landmark `index` by `along_m` along its wall in the true tunnel (the design
    /// keeps its mark); false when there is no such landmark.
    pub fn move_landmark(&mut self, index: usize, along_m: f64) -> bool {
        let Some(p) = self.placements.get_mut(index) else {
            return false;
        };
        p.installed_off_m.0 += along_m;
        self.grid = SegmentGrid::new(self.true_segments(), GRID_CELL_M);
        true
    }

    /// The centre line.
    pub fn centerline(&self) -> &CenterLine {
        &self.centerline
    }

    /// Wall-to-wall width, metres.
    pub fn width_m(&self) -> f64 {
        self.width_m
    }

    /// The landmark layout (including missing and damaged ones).
    pub fn placements(&self) -> &[Placement] {
        &self.placements
    }

    /// The designed landmark shape.
    pub fn profile(&self) -> &[(f64, f64)] {
        &self.profile
    }

    /// The ray-casting index over the true geometry.
    pub fn grid(&self) -> &SegmentGrid {
        &self.grid
    }

    /// Signed lateral position of a wall: + left.
    fn wall_lateral_m(&self, side: WallSide, rough: bool, s_m: f64) -> f64 {
        let half = self.width_m / 2.0;
        match side {
            // Roughness is positive into the tunnel.
            WallSide::Left => half - if rough { self.left.at(s_m) } else { 0.0 },
            WallSide::Right => -half + if rough { self.right.at(s_m) } else { 0.0 },
        }
    }

    /// A wall as a polyline (world x, y). `rough = true`: the true wall, a vertex every
    /// [`ROUGHNESS_STEP_M`]; `false`: the design line, simplified so no dropped vertex is
    /// more than `tolerance_m` off it (a straight wall is two points).
    pub fn wall_polyline(&self, side: WallSide, rough: bool, tolerance_m: f64) -> Vec<(f64, f64)> {
        let len = self.centerline.length_m();
        let n = (len / ROUGHNESS_STEP_M).ceil().max(1.0) as usize;
        let pts: Vec<(f64, f64)> = (0..=n)
            .map(|i| {
                let s = (i as f64 * ROUGHNESS_STEP_M).min(len);
                self.centerline
                    .offset_point(s, self.wall_lateral_m(side, rough, s))
            })
            .collect();
        if rough {
            pts
        } else {
            simplify(&pts, tolerance_m)
        }
    }

    /// The true wall as a map can hold it: a vertex every `station_m` along the centre line
    /// (and at both ends), each the mean of the rough wall over the `station_m` around it
    /// (what a lidar survey resolves; the roughness below it stays as texture).
    pub fn wall_polyline_smoothed(&self, side: WallSide, station_m: f64) -> Vec<(f64, f64)> {
        let len = self.centerline.length_m();
        let n = (len / station_m).ceil().max(1.0) as usize;
        let per_station = (station_m / ROUGHNESS_STEP_M).round().max(1.0) as usize;
        (0..=n)
            .map(|i| {
                let s = (i as f64 * station_m).min(len);
                let lateral = (0..per_station)
                    .map(|k| {
                        let u = (k as f64 + 0.5) / per_station as f64 - 0.5;
                        let at = (s + u * station_m).clamp(0.0, len);
                        self.wall_lateral_m(side, true, at)
                    })
                    .sum::<f64>()
                    / per_station as f64;
                self.centerline.offset_point(s, lateral)
            })
            .collect()
    }

    /// A landmark's polyline in world coordinates. `as_built = true`: the true landmark
    /// (mounted on the rough wall, damage applied; empty when missing); `false`: as
    /// designed, on the ideal wall.
    pub fn landmark_polyline(&self, index: usize, as_built: bool) -> Vec<(f64, f64)> {
        let Some(p) = self.placements.get(index) else {
            return Vec::new();
        };
        let local: Profile = if as_built {
            match p.condition {
                Condition::Missing => return Vec::new(),
                Condition::Intact => self.profile.clone(),
                Condition::Damaged(kind) => layout::damaged_profile(&self.profile, kind),
            }
        } else {
            self.profile.clone()
        };
        let (along, standoff) = if as_built {
            p.installed_off_m
        } else {
            (0.0, 0.0)
        };
        let s = p.s_m + along;
        let (cx, cy, h) = self.centerline.pose_at(s);
        // Stand-off is into the tunnel: towards the centre line from either wall.
        let lat = self.wall_lateral_m(p.side(), as_built, s);
        let lat = lat - standoff * lat.signum();
        let (ax, ay) = (cx - lat * h.sin(), cy + lat * h.cos());
        let t = (h.cos(), h.sin());
        // Unit vector from the wall into the tunnel.
        let inward = match p.wall {
            WallSide::Left => (h.sin(), -h.cos()),
            WallSide::Right => (-h.sin(), h.cos()),
        };
        local
            .iter()
            .map(|&(u, v)| (ax + u * t.0 + v * inward.0, ay + u * t.1 + v * inward.1))
            .collect()
    }

    /// Every segment of the true geometry: rough walls and as-built landmarks.
    pub fn true_segments(&self) -> Vec<WorldSegment> {
        let mut out = Vec::new();
        for (side, surface) in [
            (WallSide::Left, Surface::LeftWall),
            (WallSide::Right, Surface::RightWall),
        ] {
            let pts = self.wall_polyline(side, true, 0.0);
            out.extend(pts.windows(2).map(|w| WorldSegment {
                a: w[0],
                b: w[1],
                surface,
            }));
        }
        for i in 0..self.placements.len() {
            let pts = self.landmark_polyline(i, true);
            out.extend(pts.windows(2).map(|w| WorldSegment {
                a: w[0],
                b: w[1],
                surface: Surface::Landmark { id: i as u32 },
            }));
        }
        out
    }
}

impl Placement {
    /// The wall this landmark is on.
    pub fn side(&self) -> WallSide {
        self.wall
    }
}

/// Longest chord of a simplified wall, in points (1 km at the 0.1 m wall step).
const MAX_CHORD_POINTS: usize = 10_000;

/// Polyline simplification that leaves no bias: greedy, a vertex is kept only when skipping
/// it would move some dropped point more than `tolerance_m` off the chord; then each chord
/// is moved along its normal by the mean of its dropped points' deviation from it, and the
/// vertices are where consecutive moved chords meet.
///
/// Chords between points of a curve all lie on its inner side: on an arc, by two thirds of
/// the sagitta on average. A map of chords through points of the walls is thus 1.3 mm (at
/// a 2 mm tolerance) towards the centre of every curve on both walls, and every localiser
/// matched against it sat that far off, on the bend's inner side (measured on 200 m of
/// `tunnel-1km` with noise-free scans: 1.07 mm mean lateral error, 0.06 mm with the chords
/// moved). Moved, the chords straddle the curve: as many points on each side, none farther
/// than the sagitta.
fn simplify(pts: &[(f64, f64)], tolerance_m: f64) -> Vec<(f64, f64)> {
    let kept = chord_ends(pts, tolerance_m);
    // Each chord as a moved line: a point on it and its direction.
    let lines: Vec<((f64, f64), (f64, f64))> = kept
        .windows(2)
        .map(|w| {
            let (a, b) = (pts[w[0]], pts[w[1]]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len = dx.hypot(dy);
            if len < 1e-12 {
                return (a, (dx, dy));
            }
            let n = (-dy / len, dx / len);
            // Trapezoidal mean over the chord's length (its two ends lie on it).
            let interior = &pts[w[0] + 1..w[1]];
            let sum: f64 = interior
                .iter()
                .map(|p| (p.0 - a.0) * n.0 + (p.1 - a.1) * n.1)
                .sum();
            let mean = sum / (w[1] - w[0]) as f64;
            ((a.0 + mean * n.0, a.1 + mean * n.1), (dx, dy))
        })
        .collect();
    let Some((&first, &last)) = lines.first().zip(lines.last()) else {
        return kept.iter().map(|&i| pts[i]).collect();
    };
    let mut out = Vec::with_capacity(kept.len());
    out.push(first.0);
    for (k, pair) in lines.windows(2).enumerate() {
        let vertex = pts[kept[k + 1]];
        // Nearly parallel chords (a straight): the vertex where both moved chords are.
        let on_both = || {
            let (a, b) = (project(vertex, pair[0]), project(vertex, pair[1]));
            (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1))
        };
        // (Chords meeting at a tiny angle, where a straight runs into a curve, would meet
        // far off: the vertex moves by at most the chords' own shifts.)
        let near = |m: &(f64, f64)| (m.0 - vertex.0).hypot(m.1 - vertex.1) <= 4.0 * tolerance_m;
        out.push(meet(pair[0], pair[1]).filter(near).unwrap_or_else(on_both));
    }
    out.push(project(pts[kept[kept.len() - 1]], last));
    out
}

/// The foot of `v` on line `l` (a point and a direction).
fn project(v: (f64, f64), l: ((f64, f64), (f64, f64))) -> (f64, f64) {
    let (p, d) = l;
    let t = ((v.0 - p.0) * d.0 + (v.1 - p.1) * d.1) / (d.0 * d.0 + d.1 * d.1).max(1e-24);
    (p.0 + t * d.0, p.1 + t * d.1)
}

/// Where lines `l` and `m` (a point and a direction each) meet; `None` when they are within
/// 1e-9 rad of parallel.
fn meet(l: ((f64, f64), (f64, f64)), m: ((f64, f64), (f64, f64))) -> Option<(f64, f64)> {
    let ((p, d), (q, e)) = (l, m);
    let cross = d.0 * e.1 - d.1 * e.0;
    let norms = d.0.hypot(d.1) * e.0.hypot(e.1);
    if cross.abs() <= 1e-9 * norms {
        return None;
    }
    let t = ((q.0 - p.0) * e.1 - (q.1 - p.1) * e.0) / cross;
    Some((p.0 + t * d.0, p.1 + t * d.1))
}

/// The indices of `pts` the greedy simplification keeps: a vertex only where skipping it
/// would move some dropped point more than `tolerance_m` off the chord (first and last
/// always).
fn chord_ends(pts: &[(f64, f64)], tolerance_m: f64) -> Vec<usize> {
    if pts.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0];
    let mut anchor = 0usize;
    let mut i = 1usize;
    while i < pts.len() {
        // Try to extend the chord from `anchor` to `i + 1`.
        let candidate = i + 1;
        if candidate >= pts.len() {
            break;
        }
        let (a, b) = (pts[anchor], pts[candidate]);
        // Each extension re-checks the whole chord: capping its span keeps a 100 km
        // straight linear in its length (a vertex at least every MAX_CHORD_POINTS).
        let ok = candidate - anchor <= MAX_CHORD_POINTS && {
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len = dx.hypot(dy);
            if len < 1e-12 {
                pts[anchor + 1..candidate]
                    .iter()
                    .all(|&p| point_line_distance(p, a, b) <= tolerance_m)
            } else {
                // |cross| / len ≤ tol, without a square root per point.
                let limit = tolerance_m * len;
                pts[anchor + 1..candidate]
                    .iter()
                    .all(|&p| ((p.0 - a.0) * dy - (p.1 - a.1) * dx).abs() <= limit)
            }
        };
        if ok {
            i = candidate;
        } else {
            out.push(i);
            anchor = i;
            i += 1;
        }
    }
    let last = pts.len() - 1;
    if out.last() != Some(&last) {
        out.push(last);
    }
    out
}

fn point_line_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy);
    if len < 1e-12 {
        return (p.0 - a.0).hypot(p.1 - a.1);
    }
    ((p.0 - a.0) * dy - (p.1 - a.1) * dx).abs() / len
}

#[cfg(test)]
mod tests {
    use super::*;
    use centerline::CurvePiece;
    use layout::{Omission, WallChoice};

    fn world(sigma: f64, curvature: f64, omission: Omission) -> World {
        let tunnel = TunnelSpec {
            centerline: CenterLine::from_pieces(&[CurvePiece {
                length_m: 100.0,
                curvature_per_m: curvature,
            }])
            .unwrap(),
            width_m: 5.0,
            roughness_sigma_m: sigma,
            roughness_correlation_m: 0.5,
        };
        let layout = LayoutSpec {
            spacing_m: 9.0,
            first_m: 5.0,
            last_m: 95.0,
            walls: WallChoice::Both,
            omission,
            damage: None,
        };
        let tri = vec![(-0.2, 0.0), (0.0, 0.15), (0.2, 0.0)];
        World::build(&tunnel, &[layout], tri, &mut Pcg32::seeded(3))
    }

    #[test]
    fn straight_design_walls_are_two_points_and_rays_see_the_walls() {
        let w = world(0.0, 0.0, Omission::None);
        let l = w.wall_polyline(WallSide::Left, false, 0.002);
        assert_eq!(l.len(), 2);
        assert!((l[0].1 - 2.5).abs() < 1e-12 && (l[1].0 - 100.0).abs() < 1e-9);
        // Straight up from chainage 7.5 (between landmarks at 5 and ~14): the left wall.
        let hit = w
            .grid()
            .cast((7.5, 0.0), std::f64::consts::FRAC_PI_2, 80.0)
            .unwrap();
        assert!((hit.range_m - 2.5).abs() < 1e-9);
        assert_eq!(hit.surface, Surface::LeftWall);
        // Straight down at chainage 5: the right wall's first landmark tip at 2.5 − 0.15.
        let hit = w
            .grid()
            .cast((5.0, 0.0), -std::f64::consts::FRAC_PI_2, 80.0)
            .unwrap();
        assert!((hit.range_m - 2.35).abs() < 1e-9, "{hit:?}");
    }

    /// Signed distance of `p` from the nearest segment of `poly` (positive to the left of
    /// its direction).
    fn signed_distance(poly: &[(f64, f64)], p: (f64, f64)) -> f64 {
        poly.windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let len2 = dx * dx + dy * dy;
                let t = (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0);
                let (fx, fy) = (a.0 + t * dx, a.1 + t * dy);
                let side = (dx * (p.1 - a.1) - dy * (p.0 - a.0)).signum();
                side * (p.0 - fx).hypot(p.1 - fy)
            })
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
            .unwrap()
    }

    #[test]
    fn a_curved_design_wall_is_simplified_within_tolerance_and_without_bias() {
        // 100 m of a 200 m radius: each 2 mm chord spans about 1.8 m of wall.
        let w = world(0.0, 1.0 / 200.0, Omission::None);
        for side in [WallSide::Left, WallSide::Right] {
            let simple = w.wall_polyline(side, false, 0.002);
            assert!(simple.len() > 40 && simple.len() < 70, "{}", simple.len());
            // The wall itself, densely: the design line (σ 0), a point every 0.1 m.
            let dense = w.wall_polyline(side, true, 0.0);
            let d: Vec<f64> = dense.iter().map(|&p| signed_distance(&simple, p)).collect();
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            let worst = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // Chords through points of the arc were 1.3 mm inside it on average.
            assert!(mean.abs() < 0.05e-3, "{side:?}: mean {mean}");
            assert!(worst <= 0.002, "{side:?}: worst {worst}");
        }
    }

    #[test]
    fn missing_landmarks_are_absent_from_the_truth_only() {
        let w = world(0.01, 0.0, Omission::EveryNth(2));
        let missing = w
            .placements()
            .iter()
            .position(|p| p.condition == Condition::Missing)
            .unwrap();
        assert!(w.landmark_polyline(missing, true).is_empty());
        assert_eq!(w.landmark_polyline(missing, false).len(), 3);
        assert!(w
            .true_segments()
            .iter()
            .all(|s| s.surface != Surface::Landmark { id: missing as u32 }));
    }

    #[test]
    fn installation_errors_move_the_true_landmarks_only() {
        let mut w = world(0.0, 0.0, Omission::None);
        let designed: Vec<_> = (0..w.placements().len())
            .map(|i| w.landmark_polyline(i, false))
            .collect();
        w.install_with_errors(0.03, 0.01, &mut Pcg32::seeded(9));
        let mut moved = 0;
        for (i, d) in designed.iter().enumerate() {
            assert_eq!(&w.landmark_polyline(i, false), d, "design of {i} moved");
            let (along, standoff) = w.placements()[i].installed_off_m;
            assert!(standoff >= 0.0 && along.abs() < 0.2);
            let built = w.landmark_polyline(i, true);
            // Straight smooth tunnel: the base moves along x by `along`, the tip inwards.
            assert!((built[0].0 - d[0].0 - along).abs() < 1e-9, "{i}");
            assert!(((built[1].1 - d[1].1).abs() - standoff).abs() < 1e-9, "{i}");
            moved += usize::from(along.abs() > 1e-4);
        }
        assert!(moved > designed.len() / 2);
        // The ray-casting index follows: straight up to the first (left) landmark's tip.
        let p = w.landmark_polyline(0, true);
        let hit = w
            .grid()
            .cast((p[1].0, 0.0), std::f64::consts::FRAC_PI_2, 80.0)
            .unwrap();
        assert!((hit.range_m - p[1].1).abs() < 1e-6, "{hit:?} {p:?}");
    }

    #[test]
    fn rough_walls_deviate_by_about_sigma() {
        let w = world(0.01, 0.0, Omission::None);
        let rough = w.wall_polyline(WallSide::Left, true, 0.0);
        let rms =
            (rough.iter().map(|p| (p.1 - 2.5).powi(2)).sum::<f64>() / rough.len() as f64).sqrt();
        assert!(rms > 0.004 && rms < 0.02, "{rms}");
    }
}
