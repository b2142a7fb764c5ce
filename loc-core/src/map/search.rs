//! The queries of [`MapQuery`](super::MapQuery) answered from a sparse grid index: nearest
//! segment (ring search), ray cast (grid DDA) and landmark segments near a point.
//!
//! One implementation serves every map layout: the queries are written against
//! [`CellIndex`], which the RAM map ([`StoredMap`](super::StoredMap): segments and grid in
//! arrays) and the flash image ([`MapImage`](super::MapImage): the same segments and grid
//! read in place from bytes) both provide.
//!
//! Every query is clipped to the index's bounding rectangle of cells, so its cost is bounded
//! by the map's extent however large the radius or range asked for.

use crate::geometry::{Point2, Segment};
use crate::math;

use super::grid::{Cell, CellRect, CellSpec};
use super::{MapHit, MapSegment, RayHit};

/// A spatial index over map segments as the queries see it: the cell arithmetic, the
/// bounding rectangle of the non-empty cells, each cell's segment indices and the segments.
/// Implementations never panic: an index or cell out of range yields nothing.
pub(crate) trait CellIndex {
    /// Cell size and cell arithmetic.
    fn spec(&self) -> CellSpec;
    /// Bounding rectangle of the non-empty cells; `None` for an empty index.
    fn bounds(&self) -> Option<CellRect>;
    /// Calls `f` with the index of every segment registered in cell `c` (none when the
    /// cell is empty).
    fn for_each_ref(&self, c: Cell, f: impl FnMut(u16));
    /// Segment `i`, `None` past the end.
    fn segment(&self, i: u16) -> Option<MapSegment>;
}

/// Cross products below this (m²) count as a ray parallel to a segment.
const PARALLEL_EPS: f32 = 1e-12;

/// Squared distance from `p` to segment `s`, m² (no square root: the search compares
/// squares).
#[inline]
pub(crate) fn dist_sq_to_segment(p: Point2, s: &Segment) -> f32 {
    let d = s.b.sub(s.a);
    let w = p.sub(s.a);
    let len2 = d.norm_sq();
    let t = if len2 > f32::EPSILON {
        (w.dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    w.sub(d.scale(t)).norm_sq()
}

/// Where a ray meets a segment: `(t, u)` with hit `o + t·d = a + u·(b − a)`, if it does
/// (`t ≥ 0`, `u ∈ [0, 1]`).
#[inline]
pub(crate) fn ray_segment(o: Point2, d: Point2, s: &Segment) -> Option<f32> {
    let e = s.b.sub(s.a);
    let denom = d.cross(e);
    if denom.abs() <= PARALLEL_EPS {
        return None;
    }
    let w = s.a.sub(o);
    let t = w.cross(e) / denom;
    let u = w.cross(d) / denom;
    (t >= 0.0 && (-1e-6..=1.0 + 1e-6).contains(&u)).then_some(t)
}

/// Calls `f` for each cell of ring `k` (Chebyshev distance `k` from `c`) inside `b`.
#[inline]
fn for_each_ring_cell(c: Cell, k: i32, b: &CellRect, mut f: impl FnMut(Cell)) {
    let ix_lo = (c.ix - k).max(b.min.ix);
    let ix_hi = (c.ix + k).min(b.max.ix);
    let rows: [i32; 2] = [c.iy - k, c.iy + k];
    for (n, &iy) in rows.iter().enumerate() {
        if (n == 1 && k == 0) || iy < b.min.iy || iy > b.max.iy {
            continue;
        }
        for ix in ix_lo..=ix_hi {
            f(Cell { ix, iy });
        }
    }
    if k == 0 {
        return;
    }
    let iy_lo = (c.iy - k + 1).max(b.min.iy);
    let iy_hi = (c.iy + k - 1).min(b.max.iy);
    for ix in [c.ix - k, c.ix + k] {
        if ix < b.min.ix || ix > b.max.ix {
            continue;
        }
        for iy in iy_lo..=iy_hi {
            f(Cell { ix, iy });
        }
    }
}

/// The segment nearest to `p` within `max_distance_m`.
pub(crate) fn nearest<I: CellIndex>(index: &I, p: Point2, max_distance_m: f32) -> Option<MapHit> {
    if !p.is_finite() || max_distance_m.is_nan() || max_distance_m < 0.0 {
        return None;
    }
    let b = index.bounds()?;
    let spec = index.spec();
    let c = spec.cell_of(p)?;
    let cs = spec.cell_size_m;
    let k_first = 0
        .max(b.min.ix - c.ix)
        .max(c.ix - b.max.ix)
        .max(b.min.iy - c.iy)
        .max(c.iy - b.max.iy);
    let k_box = (c.ix - b.min.ix)
        .abs()
        .max((c.ix - b.max.ix).abs())
        .max((c.iy - b.min.iy).abs())
        .max((c.iy - b.max.iy).abs());
    let k_dist = if max_distance_m.is_finite() {
        let k = math::floor(max_distance_m * spec.inv_cell_m) + 1.0;
        if k < k_box as f32 {
            k as i32
        } else {
            k_box
        }
    } else {
        k_box
    };
    let k_last = k_box.min(k_dist);
    // How far p lies inside its own cell (0 when the cell is outside the index box and
    // the search starts further out): every cell of ring k ≥ 1 is at least
    // (k − 1)·cs + margin away. With this bound a point a few centimetres from a wall
    // found in its own cell stops after ring 0 instead of visiting the eight
    // neighbours (most queries of a matcher are such points).
    let margin_m = if k_first == 0 {
        let (x0, y0) = (c.ix as f32 * cs, c.iy as f32 * cs);
        math::max(
            0.0,
            math::min(
                math::min(p.x_m - x0, x0 + cs - p.x_m),
                math::min(p.y_m - y0, y0 + cs - p.y_m),
            ),
        )
    } else {
        0.0
    };
    // Squared distances in the search; one full projection for the winner.
    let mut best: Option<u16> = None;
    let mut best_d2 = max_distance_m * max_distance_m;
    for k in k_first..=k_last {
        let ring_gap = if k == 0 {
            0.0
        } else {
            (k - 1) as f32 * cs + margin_m
        };
        if ring_gap * ring_gap > best_d2 {
            break;
        }
        for_each_ring_cell(c, k, &b, |cell| {
            // Skip cells whose box is farther than the best so far.
            let x0 = cell.ix as f32 * cs;
            let y0 = cell.iy as f32 * cs;
            let dx = math::max(math::max(x0 - p.x_m, p.x_m - (x0 + cs)), 0.0);
            let dy = math::max(math::max(y0 - p.y_m, p.y_m - (y0 + cs)), 0.0);
            if dx * dx + dy * dy > best_d2 {
                return;
            }
            index.for_each_ref(cell, |i| {
                let Some(ms) = index.segment(i) else {
                    return;
                };
                let d2 = dist_sq_to_segment(p, &ms.segment);
                let better = match best {
                    None => d2 <= best_d2,
                    Some(_) => d2 < best_d2,
                };
                if better {
                    best_d2 = d2;
                    best = Some(i);
                }
            });
        });
    }
    let ms = index.segment(best?)?;
    Some(MapHit {
        segment: ms.segment,
        kind: ms.kind,
        projection: ms.segment.project(p),
    })
}

/// The first segment a ray meets within `max_range_m`.
pub(crate) fn raycast<I: CellIndex>(
    index: &I,
    origin: Point2,
    angle_rad: f32,
    max_range_m: f32,
) -> Option<RayHit> {
    if !origin.is_finite() || !angle_rad.is_finite() || max_range_m.is_nan() || max_range_m < 0.0 {
        return None;
    }
    let b = index.bounds()?;
    let spec = index.spec();
    let cs = spec.cell_size_m;
    let (sin, cos) = math::sin_cos(angle_rad);
    let d = Point2::new(cos, sin);
    // Clip the ray to the index's bounding box.
    let lo = Point2::new(b.min.ix as f32 * cs, b.min.iy as f32 * cs);
    let hi = Point2::new((b.max.ix + 1) as f32 * cs, (b.max.iy + 1) as f32 * cs);
    let mut t0: f32 = 0.0;
    let mut t1: f32 = max_range_m;
    for (o, dv, l, h) in [
        (origin.x_m, d.x_m, lo.x_m, hi.x_m),
        (origin.y_m, d.y_m, lo.y_m, hi.y_m),
    ] {
        if dv.abs() < 1e-12 {
            if o < l || o > h {
                return None;
            }
        } else {
            let ta = (l - o) / dv;
            let tb = (h - o) / dv;
            t0 = math::max(t0, math::min(ta, tb));
            t1 = math::min(t1, math::max(ta, tb));
        }
    }
    if t0.is_nan() || t1.is_nan() || t0 > t1 {
        return None;
    }
    let start = origin.add(d.scale(t0));
    let mut cell = spec.cell_of(start)?;
    cell.ix = cell.ix.clamp(b.min.ix, b.max.ix);
    cell.iy = cell.iy.clamp(b.min.iy, b.max.iy);
    let axis = |o: f32, dv: f32, i: i32| -> (i32, f32, f32) {
        if dv > 0.0 {
            (1, ((i + 1) as f32 * cs - o) / dv, cs / dv)
        } else if dv < 0.0 {
            (-1, (i as f32 * cs - o) / dv, -cs / dv)
        } else {
            (0, f32::INFINITY, f32::INFINITY)
        }
    };
    let (step_x, mut t_max_x, dt_x) = axis(origin.x_m, d.x_m, cell.ix);
    let (step_y, mut t_max_y, dt_y) = axis(origin.y_m, d.y_m, cell.iy);
    let max_steps = (b.max.ix - b.min.ix) + (b.max.iy - b.min.iy) + 3;
    let mut best: Option<(f32, MapSegment)> = None;
    let mut best_t = max_range_m;
    for _ in 0..max_steps {
        index.for_each_ref(cell, |i| {
            let Some(ms) = index.segment(i) else {
                return;
            };
            if let Some(t) = ray_segment(origin, d, &ms.segment) {
                if t <= best_t && best.is_none_or(|(bt, _)| t < bt) {
                    best_t = t;
                    best = Some((t, ms));
                }
            }
        });
        let t_exit = math::min(t_max_x, t_max_y);
        if (best.is_some() && best_t <= t_exit) || t_exit > t1 {
            break;
        }
        if t_max_x < t_max_y {
            cell.ix += step_x;
            t_max_x += dt_x;
        } else {
            cell.iy += step_y;
            t_max_y += dt_y;
        }
        if !b.contains(cell) {
            break;
        }
    }
    let (t, ms) = best?;
    Some(RayHit {
        range_m: t,
        point: origin.add(d.scale(t)),
        kind: ms.kind,
    })
}

/// Calls `f(index, segment)` once for every segment accepted by `keep` with a point
/// within `radius_m` of `center`.
pub(crate) fn for_each_segment_near<I: CellIndex>(
    index: &I,
    center: Point2,
    radius_m: f32,
    keep: &dyn Fn(&MapSegment) -> bool,
    f: &mut dyn FnMut(usize, &MapSegment),
) {
    if !center.is_finite() || radius_m.is_nan() || radius_m < 0.0 {
        return;
    }
    let Some(b) = index.bounds() else {
        return;
    };
    let spec = index.spec();
    let r = Point2::new(radius_m, radius_m);
    let query = spec.rect_of_box(center.sub(r), center.add(r));
    let Some(rect) = query.intersect(&b) else {
        return;
    };
    for iy in rect.min.iy..=rect.max.iy {
        for ix in rect.min.ix..=rect.max.ix {
            let cell = Cell { ix, iy };
            index.for_each_ref(cell, |i| {
                let Some(ms) = index.segment(i) else {
                    return;
                };
                if !keep(&ms) || ms.segment.project(center).distance_m > radius_m {
                    return;
                }
                // Report each segment from one cell only: its first cell inside the
                // query rectangle, in the same row-major order as this loop.
                if spec.first_cell_of_segment_in(&ms.segment, &rect) == Some(cell) {
                    f(usize::from(i), &ms);
                }
            });
        }
    }
}

/// Calls `f(id, segment)` once for every landmark segment with a point within `radius_m` of
/// `center` ([`MapQuery::for_each_landmark_segment_near`](super::MapQuery) for every layout).
pub(crate) fn for_each_landmark_segment_near<I: CellIndex>(
    index: &I,
    center: Point2,
    radius_m: f32,
    f: &mut dyn FnMut(u16, Segment),
) {
    for_each_segment_near(
        index,
        center,
        radius_m,
        &|ms| ms.kind.is_landmark(),
        &mut |_, ms| {
            if let super::FeatureKind::Landmark { id } = ms.kind {
                f(id, ms.segment);
            }
        },
    );
}
