//! Ray casting against the true tunnel geometry through a uniform-grid spatial index.
//!
//! The simulated lidar casts about 1141 rays per scan against tens of thousands of wall
//! and landmark segments (a rough kilometre of tunnel). Segments are binned into square
//! cells (compressed-row storage); a ray walks the cells it crosses in order
//! (Amanatides–Woo traversal) and stops in the first cell that holds a hit inside that
//! cell, so its cost grows with the ray's length, not with the map's size. World frame,
//! metres, `f64`. A bounding box mostly empty (a long tunnel far off the axes) indexes only
//! its occupied cells, so memory follows the segments, not the area.

use std::collections::HashMap;

/// What a true-geometry segment belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// The left wall (left of the direction of increasing chainage).
    LeftWall,
    /// The right wall.
    RightWall,
    /// Landmark number `id` (index into the world's landmark list).
    Landmark {
        /// Index of the landmark in the world's list.
        id: u32,
    },
}

/// A segment of the true geometry, world frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldSegment {
    /// Start point `(x, y)`.
    pub a: (f64, f64),
    /// End point `(x, y)`.
    pub b: (f64, f64),
    /// What it belongs to.
    pub surface: Surface,
}

/// A ray's first hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance from the ray origin, metres.
    pub range_m: f64,
    /// What was hit.
    pub surface: Surface,
}

/// Segments binned in a uniform grid.
#[derive(Debug, Clone)]
pub struct SegmentGrid {
    segments: Vec<WorldSegment>,
    origin: (f64, f64),
    cell_m: f64,
    nx: usize,
    ny: usize,
    /// Where each cell's segments lie in `cell_items` (cell `c = iy * nx + ix`).
    cells: CellIndex,
    cell_items: Vec<u32>,
}

/// Grids with more cells than this over their bounding box index only their occupied
/// cells (4 Mi cells: 16 MiB dense).
const MAX_DENSE_CELLS: u64 = 1 << 22;

/// The cells' ranges of `cell_items`.
#[derive(Debug, Clone)]
enum CellIndex {
    /// `start[c]..start[c + 1]` for every cell of the bounding box.
    Dense(Vec<u32>),
    /// `(start, end)` of the occupied cells only.
    Sparse(HashMap<u64, (u32, u32)>),
}

impl CellIndex {
    fn range(&self, c: u64) -> std::ops::Range<usize> {
        match self {
            CellIndex::Dense(start) => {
                let c = c as usize;
                match (start.get(c), start.get(c + 1)) {
                    (Some(&a), Some(&b)) => a as usize..b as usize,
                    _ => 0..0,
                }
            }
            CellIndex::Sparse(map) => map.get(&c).map_or(0..0, |&(a, b)| a as usize..b as usize),
        }
    }
}

impl SegmentGrid {
    /// Indexes `segments` in cells of `cell_m` metres (a cell size near the wall-vertex
    /// spacing times ten, e.g. 1 m, balances cells walked against segments tested).
    /// Non-finite segments are dropped.
    pub fn new(segments: Vec<WorldSegment>, cell_m: f64) -> Self {
        let segments: Vec<WorldSegment> = segments
            .into_iter()
            .filter(|s| {
                s.a.0.is_finite() && s.a.1.is_finite() && s.b.0.is_finite() && s.b.1.is_finite()
            })
            .collect();
        let cell_m = if cell_m.is_finite() && cell_m > 0.0 {
            cell_m
        } else {
            1.0
        };
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for s in &segments {
            for p in [s.a, s.b] {
                x0 = x0.min(p.0);
                y0 = y0.min(p.1);
                x1 = x1.max(p.0);
                y1 = y1.max(p.1);
            }
        }
        if segments.is_empty() {
            (x0, y0, x1, y1) = (0.0, 0.0, 0.0, 0.0);
        }
        let origin = (x0 - cell_m, y0 - cell_m);
        let nx = (((x1 - origin.0) / cell_m).ceil() as usize + 2).max(1);
        let ny = (((y1 - origin.1) / cell_m).ceil() as usize + 2).max(1);
        let mut grid = Self {
            segments,
            origin,
            cell_m,
            nx,
            ny,
            cells: CellIndex::Dense(Vec::new()),
            cell_items: Vec::new(),
        };
        let cells = nx as u64 * ny as u64;
        if cells <= MAX_DENSE_CELLS {
            // Two passes: count, then fill (compressed rows).
            let n = cells as usize;
            let mut counts = vec![0u32; n + 1];
            for i in 0..grid.segments.len() {
                grid.for_cells_of_segment(i, |c| counts[c as usize] += 1);
            }
            let mut start = vec![0u32; n + 1];
            let mut acc = 0u32;
            for (c, k) in counts.iter().enumerate().take(n) {
                start[c] = acc;
                acc += k;
            }
            start[n] = acc;
            let mut fill = start.clone();
            let mut items = vec![0u32; acc as usize];
            for i in 0..grid.segments.len() {
                grid.for_cells_of_segment(i, |c| {
                    items[fill[c as usize] as usize] = i as u32;
                    fill[c as usize] += 1;
                });
            }
            grid.cells = CellIndex::Dense(start);
            grid.cell_items = items;
        } else {
            // A bounding box mostly empty (a long tunnel far off the axes): only the cells
            // that hold segments, memory in proportion to the segments.
            let mut pairs: Vec<(u64, u32)> = Vec::new();
            for i in 0..grid.segments.len() {
                grid.for_cells_of_segment(i, |c| pairs.push((c, i as u32)));
            }
            pairs.sort_unstable();
            let mut map = HashMap::new();
            let mut k = 0usize;
            while let Some(&(c, _)) = pairs.get(k) {
                let end = k + pairs[k..].partition_point(|p| p.0 == c);
                map.insert(c, (k as u32, end as u32));
                k = end;
            }
            grid.cell_items = pairs.into_iter().map(|(_, i)| i).collect();
            grid.cells = CellIndex::Sparse(map);
        }
        grid
    }

    /// The indexed segments.
    pub fn segments(&self) -> &[WorldSegment] {
        &self.segments
    }

    fn cell_of(&self, x: f64, y: f64) -> (i64, i64) {
        (
            ((x - self.origin.0) / self.cell_m).floor() as i64,
            ((y - self.origin.1) / self.cell_m).floor() as i64,
        )
    }

    /// Calls `f` with every cell the segment's bounding box touches (segments are short
    /// compared with cells, so the box is a tight cover).
    fn for_cells_of_segment(&self, i: usize, mut f: impl FnMut(u64)) {
        let s = self.segments[i];
        let (ax, ay) = self.cell_of(s.a.0.min(s.b.0), s.a.1.min(s.b.1));
        let (bx, by) = self.cell_of(s.a.0.max(s.b.0), s.a.1.max(s.b.1));
        for iy in ay.max(0)..=by.min(self.ny as i64 - 1) {
            for ix in ax.max(0)..=bx.min(self.nx as i64 - 1) {
                f(iy as u64 * self.nx as u64 + ix as u64);
            }
        }
    }

    /// The first segment a ray from `origin` in direction `angle_rad` meets within
    /// `max_range_m`, or `None` (no echo).
    pub fn cast(&self, origin: (f64, f64), angle_rad: f64, max_range_m: f64) -> Option<Hit> {
        if !(origin.0.is_finite() && origin.1.is_finite() && angle_rad.is_finite()) {
            return None;
        }
        let (dy, dx) = angle_rad.sin_cos();
        let (mut ix, mut iy) = self.cell_of(origin.0, origin.1);
        let step_x: i64 = if dx >= 0.0 { 1 } else { -1 };
        let step_y: i64 = if dy >= 0.0 { 1 } else { -1 };
        let next_boundary = |i: i64, step: i64, o: f64, org: f64| {
            let edge = org + (i + i64::from(step > 0)) as f64 * self.cell_m;
            edge - o
        };
        let mut t_max_x = if dx.abs() < 1e-15 {
            f64::INFINITY
        } else {
            next_boundary(ix, step_x, origin.0, self.origin.0) / dx
        };
        let mut t_max_y = if dy.abs() < 1e-15 {
            f64::INFINITY
        } else {
            next_boundary(iy, step_y, origin.1, self.origin.1) / dy
        };
        let t_delta_x = if dx.abs() < 1e-15 {
            f64::INFINITY
        } else {
            self.cell_m / dx.abs()
        };
        let t_delta_y = if dy.abs() < 1e-15 {
            f64::INFINITY
        } else {
            self.cell_m / dy.abs()
        };
        let mut t_enter = 0.0f64;
        loop {
            let t_exit = t_max_x.min(t_max_y);
            if ix >= 0 && iy >= 0 && (ix as usize) < self.nx && (iy as usize) < self.ny {
                let c = iy as u64 * self.nx as u64 + ix as u64;
                let items = self.cell_items.get(self.cells.range(c)).unwrap_or_default();
                let mut best: Option<Hit> = None;
                for &k in items {
                    let s = &self.segments[k as usize];
                    if let Some(t) = ray_segment(origin, (dx, dy), s.a, s.b) {
                        // Only hits inside this cell count here: a hit beyond it may be
                        // hidden by a segment in a cell not yet walked.
                        if t >= t_enter - 1e-9
                            && t <= t_exit + 1e-9
                            && t <= max_range_m
                            && best.is_none_or(|h| t < h.range_m)
                        {
                            best = Some(Hit {
                                range_m: t,
                                surface: s.surface,
                            });
                        }
                    }
                }
                if best.is_some() {
                    return best;
                }
            } else {
                // Outside the grid and moving away: nothing more to meet.
                let leaving_x = (ix < 0 && step_x < 0) || (ix >= self.nx as i64 && step_x > 0);
                let leaving_y = (iy < 0 && step_y < 0) || (iy >= self.ny as i64 && step_y > 0);
                if leaving_x || leaving_y {
                    return None;
                }
            }
            if t_exit > max_range_m {
                return None;
            }
            t_enter = t_exit;
            if t_max_x < t_max_y {
                ix += step_x;
                t_max_x += t_delta_x;
            } else {
                iy += step_y;
                t_max_y += t_delta_y;
            }
        }
    }

    /// Reference answer by testing every segment (for tests: O(n) per ray).
    pub fn cast_brute_force(
        &self,
        origin: (f64, f64),
        angle_rad: f64,
        max_range_m: f64,
    ) -> Option<Hit> {
        let (dy, dx) = angle_rad.sin_cos();
        self.segments
            .iter()
            .filter_map(|s| {
                ray_segment(origin, (dx, dy), s.a, s.b).map(|t| Hit {
                    range_m: t,
                    surface: s.surface,
                })
            })
            .filter(|h| h.range_m <= max_range_m)
            .min_by(|a, b| a.range_m.total_cmp(&b.range_m))
    }
}

/// Distance along a unit-direction ray `o + t·d` (t ≥ 0) to segment `a`–`b`, if they meet.
pub(crate) fn ray_segment(
    o: (f64, f64),
    d: (f64, f64),
    a: (f64, f64),
    b: (f64, f64),
) -> Option<f64> {
    let e = (b.0 - a.0, b.1 - a.1);
    let denom = d.0 * e.1 - d.1 * e.0;
    if denom.abs() < 1e-15 {
        return None;
    }
    let w = (a.0 - o.0, a.1 - o.1);
    let t = (w.0 * e.1 - w.1 * e.0) / denom;
    let u = (w.0 * d.1 - w.1 * d.0) / denom;
    (t >= 0.0 && (-1e-12..=1.0 + 1e-12).contains(&u)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::rng::Pcg32;

    fn random_segments(n: usize, rng: &mut Pcg32) -> Vec<WorldSegment> {
        (0..n)
            .map(|i| {
                let x = f64::from(rng.uniform(-50.0, 50.0));
                let y = f64::from(rng.uniform(-20.0, 20.0));
                let a = f64::from(rng.uniform(0.0, 6.3));
                let l = f64::from(rng.uniform(0.05, 2.0));
                WorldSegment {
                    a: (x, y),
                    b: (x + l * a.cos(), y + l * a.sin()),
                    surface: Surface::Landmark { id: i as u32 },
                }
            })
            .collect()
    }

    #[test]
    fn grid_agrees_with_brute_force() {
        let mut rng = Pcg32::seeded(11);
        let grid = SegmentGrid::new(random_segments(3000, &mut rng), 1.0);
        for _ in 0..3000 {
            let o = (
                f64::from(rng.uniform(-60.0, 60.0)),
                f64::from(rng.uniform(-25.0, 25.0)),
            );
            let ang = f64::from(rng.uniform(-4.0, 4.0));
            let fast = grid.cast(o, ang, 80.0);
            let slow = grid.cast_brute_force(o, ang, 80.0);
            match (fast, slow) {
                (None, None) => {}
                (Some(f), Some(s)) => assert!((f.range_m - s.range_m).abs() < 1e-9),
                other => panic!("mismatch from {o:?} at {ang}: {other:?}"),
            }
        }
    }

    #[test]
    fn axis_aligned_rays_and_range_limit() {
        let wall = WorldSegment {
            a: (10.0, -5.0),
            b: (10.0, 5.0),
            surface: Surface::RightWall,
        };
        let grid = SegmentGrid::new(vec![wall], 0.7);
        let h = grid.cast((0.0, 0.0), 0.0, 80.0).unwrap();
        assert!((h.range_m - 10.0).abs() < 1e-12);
        assert_eq!(h.surface, Surface::RightWall);
        assert!(grid.cast((0.0, 0.0), 0.0, 9.0).is_none());
        assert!(grid.cast((0.0, 0.0), std::f64::consts::PI, 80.0).is_none());
        assert!(grid
            .cast((0.0, 0.0), std::f64::consts::FRAC_PI_2, 80.0)
            .is_none());
        assert!(grid.cast((f64::NAN, 0.0), 0.0, 80.0).is_none());
        assert!(SegmentGrid::new(Vec::new(), 1.0)
            .cast((0.0, 0.0), 0.3, 80.0)
            .is_none());
    }

    /// Segments spread over a 10 000 km box (10¹⁶ cells of 1 m, dense) are indexed sparsely
    /// and give the brute force's answers.
    #[test]
    fn a_huge_empty_box_is_indexed_sparsely() {
        let mut rng = Pcg32::seeded(5);
        let mut segments = random_segments(500, &mut rng);
        for s in random_segments(500, &mut rng) {
            let far = |p: (f64, f64)| (p.0 + 1.0e7, p.1 + 1.0e7);
            segments.push(WorldSegment {
                a: far(s.a),
                b: far(s.b),
                ..s
            });
        }
        let grid = SegmentGrid::new(segments, 1.0);
        assert!(matches!(grid.cells, CellIndex::Sparse(_)));
        for base in [(0.0, 0.0), (1.0e7, 1.0e7)] {
            for _ in 0..500 {
                let o = (
                    base.0 + f64::from(rng.uniform(-60.0, 60.0)),
                    base.1 + f64::from(rng.uniform(-25.0, 25.0)),
                );
                let ang = f64::from(rng.uniform(-4.0, 4.0));
                match (grid.cast(o, ang, 80.0), grid.cast_brute_force(o, ang, 80.0)) {
                    (None, None) => {}
                    (Some(f), Some(s)) => assert!((f.range_m - s.range_m).abs() < 1e-6),
                    other => panic!("mismatch from {o:?} at {ang}: {other:?}"),
                }
            }
        }
    }
}
