//! The spatial index: a sparse uniform grid over map segments.
//!
//! Only cells that some segment crosses are stored, as sorted u32 keys (packed i16 cell
//! coordinates) found by binary search; each cell's segment indices sit in one CSR array
//! (`refs[start..end]`). A curved 1 km tunnel touches ~1–2 thousand 2 m cells where a dense
//! grid over its bounding box would need hundreds of thousands.
//!
//! A segment is registered in every cell that contains a point of it (cells are half-open,
//! `[ix·c, (ix+1)·c)`), so a query that visits every cell overlapping a region sees every
//! segment with a point in that region.

use crate::geometry::{Point2, Segment};
use crate::math;

use super::error::{Capacity, GeometryError, MapError};
use super::search::CellIndex;
use super::MapSegment;

/// Largest cell coordinate magnitude accepted (keeps ring/DDA arithmetic inside i32 and
/// keys inside i16).
pub(crate) const MAX_CELL_COORD: i32 = 30_000;

/// Widening of a segment's extent when listing its cells, metres: keeps float rounding at
/// cell borders from losing a cell (an extra cell is harmless).
const EDGE_EPS_M: f32 = 1e-4;

/// Integer cell coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Cell {
    pub ix: i32,
    pub iy: i32,
}

impl Cell {
    /// The sort key of the index: packed i16 coordinates.
    #[inline]
    pub(crate) fn key(self) -> u32 {
        // i16 range is guaranteed by MAX_CELL_COORD checks at build and query time.
        (u32::from(self.ix as i16 as u16) << 16) | u32::from(self.iy as i16 as u16)
    }
}

/// Inclusive rectangle of cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct CellRect {
    pub min: Cell,
    pub max: Cell,
}

impl CellRect {
    #[inline]
    pub fn contains(&self, c: Cell) -> bool {
        c.ix >= self.min.ix && c.ix <= self.max.ix && c.iy >= self.min.iy && c.iy <= self.max.iy
    }

    /// Intersection, `None` when empty.
    #[inline]
    pub fn intersect(&self, o: &CellRect) -> Option<CellRect> {
        let r = CellRect {
            min: Cell {
                ix: self.min.ix.max(o.min.ix),
                iy: self.min.iy.max(o.min.iy),
            },
            max: Cell {
                ix: self.max.ix.min(o.max.ix),
                iy: self.max.iy.min(o.max.iy),
            },
        };
        (r.min.ix <= r.max.ix && r.min.iy <= r.max.iy).then_some(r)
    }
}

/// Cell size and the arithmetic of cell coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CellSpec {
    pub cell_size_m: f32,
    pub inv_cell_m: f32,
}

impl CellSpec {
    pub const fn new(cell_size_m: f32) -> Self {
        Self {
            cell_size_m,
            inv_cell_m: 1.0 / cell_size_m,
        }
    }

    /// The cell holding `p` (floor), unclamped; `None` for non-finite input or beyond the
    /// coordinate range.
    #[inline]
    pub fn cell_of(&self, p: Point2) -> Option<Cell> {
        let fx = math::floor(p.x_m * self.inv_cell_m);
        let fy = math::floor(p.y_m * self.inv_cell_m);
        let lim = MAX_CELL_COORD as f32;
        if !(fx.abs() <= lim && fy.abs() <= lim) {
            return None; // NaN fails this test too
        }
        Some(Cell {
            ix: fx as i32,
            iy: fy as i32,
        })
    }

    /// Cell coordinate of a value, saturated to ±MAX_CELL_COORD (NaN → 0).
    #[inline]
    fn coord_sat(&self, v_m: f32) -> i32 {
        let f = math::floor(v_m * self.inv_cell_m);
        let lim = MAX_CELL_COORD as f32;
        if f.is_nan() {
            0
        } else {
            f.clamp(-lim, lim) as i32
        }
    }

    /// Cells covering the axis-aligned box `[lo, hi]`, saturated.
    pub fn rect_of_box(&self, lo: Point2, hi: Point2) -> CellRect {
        CellRect {
            min: Cell {
                ix: self.coord_sat(lo.x_m),
                iy: self.coord_sat(lo.y_m),
            },
            max: Cell {
                ix: self.coord_sat(hi.x_m),
                iy: self.coord_sat(hi.y_m),
            },
        }
    }

    /// Calls `f` for every cell containing a point of `seg`, in row-major order (iy, then
    /// ix, ascending), each cell once, until `f` returns false. Returns false when stopped.
    pub fn for_each_cell_of_segment(&self, seg: &Segment, f: &mut dyn FnMut(Cell) -> bool) -> bool {
        let (a, b) = (seg.a, seg.b);
        let lo_y = math::min(a.y_m, b.y_m) - EDGE_EPS_M;
        let hi_y = math::max(a.y_m, b.y_m) + EDGE_EPS_M;
        let (iy0, iy1) = (self.coord_sat(lo_y), self.coord_sat(hi_y));
        let dy = b.y_m - a.y_m;
        let dx = b.x_m - a.x_m;
        for iy in iy0..=iy1 {
            // Portion of the segment within this row's band (widened by EDGE_EPS_M).
            let y0 = iy as f32 * self.cell_size_m - EDGE_EPS_M;
            let y1 = (iy + 1) as f32 * self.cell_size_m + EDGE_EPS_M;
            let (t0, t1) = if dy.abs() <= f32::EPSILON * (a.y_m.abs() + 1.0) {
                (0.0, 1.0)
            } else {
                let ta = (y0 - a.y_m) / dy;
                let tb = (y1 - a.y_m) / dy;
                (
                    math::max(math::min(ta, tb), 0.0),
                    math::min(math::max(ta, tb), 1.0),
                )
            };
            if t0 > t1 {
                continue;
            }
            let xa = a.x_m + dx * t0;
            let xb = a.x_m + dx * t1;
            let ix0 = self.coord_sat(math::min(xa, xb) - EDGE_EPS_M);
            let ix1 = self.coord_sat(math::max(xa, xb) + EDGE_EPS_M);
            for ix in ix0..=ix1 {
                if !f(Cell { ix, iy }) {
                    return false;
                }
            }
        }
        true
    }

    /// The first cell (row-major) of `seg` inside `rect`.
    pub fn first_cell_of_segment_in(&self, seg: &Segment, rect: &CellRect) -> Option<Cell> {
        let mut found = None;
        self.for_each_cell_of_segment(seg, &mut |c| {
            if rect.contains(c) {
                found = Some(c);
                false
            } else {
                true
            }
        });
        found
    }
}

/// Sparse grid with at most `CELLS` non-empty cells and `REFS` segment references.
#[derive(Debug, Clone)]
pub(crate) struct SparseGrid<const CELLS: usize, const REFS: usize> {
    spec: CellSpec,
    /// Sorted keys of the non-empty cells.
    keys: heapless::Vec<u32, CELLS>,
    /// `ends[i]`: one past the last entry of cell `i` in `refs` (start = `ends[i-1]` or 0).
    ends: heapless::Vec<u32, CELLS>,
    /// Segment indices, grouped by cell.
    refs: heapless::Vec<u16, REFS>,
    /// Bounding rectangle of the non-empty cells (meaningless when `keys` is empty).
    bounds: CellRect,
}

impl<const CELLS: usize, const REFS: usize> SparseGrid<CELLS, REFS> {
    pub const fn new(cell_size_m: f32) -> Self {
        Self {
            spec: CellSpec::new(cell_size_m),
            keys: heapless::Vec::new(),
            ends: heapless::Vec::new(),
            refs: heapless::Vec::new(),
            bounds: CellRect {
                min: Cell { ix: 0, iy: 0 },
                max: Cell { ix: -1, iy: -1 },
            },
        }
    }

    /// Empties the index in place (no large temporary on the stack) with a new cell size.
    pub fn reset(&mut self, cell_size_m: f32) {
        self.spec = CellSpec::new(cell_size_m);
        self.keys.clear();
        self.ends.clear();
        self.refs.clear();
        self.bounds = CellRect {
            min: Cell { ix: 0, iy: 0 },
            max: Cell { ix: -1, iy: -1 },
        };
    }

    /// The sorted cell keys, each cell's end in the references, and the references.
    pub fn parts(&self) -> (&[u32], &[u32], &[u16]) {
        (&self.keys, &self.ends, &self.refs)
    }

    pub fn cell_count(&self) -> usize {
        self.keys.len()
    }

    pub fn ref_count(&self) -> usize {
        self.refs.len()
    }

    pub fn bounds(&self) -> Option<CellRect> {
        (!self.keys.is_empty()).then_some(self.bounds)
    }

    /// The segment indices stored in `c` (empty when the cell holds nothing).
    #[inline]
    pub fn cell_refs(&self, c: Cell) -> &[u16] {
        let key = c.key();
        let Ok(i) = self.keys.binary_search(&key) else {
            return &[];
        };
        let start = match i.checked_sub(1) {
            Some(j) => self.ends.get(j).copied().unwrap_or(0),
            None => 0,
        } as usize;
        let end = self.ends.get(i).copied().unwrap_or(0) as usize;
        self.refs.get(start..end).unwrap_or(&[])
    }

    /// Rebuilds the index over `segments` with cells of `cell_size_m`.
    pub fn build(&mut self, cell_size_m: f32, segments: &[MapSegment]) -> Result<(), MapError> {
        if !(cell_size_m.is_finite() && cell_size_m > 1e-3) {
            return Err(GeometryError::BadCellSize { cell_size_m }.into());
        }
        self.reset(cell_size_m);
        if segments.len() > usize::from(u16::MAX) + 1 {
            return Err(MapError::CapacityExceeded {
                what: Capacity::SegmentIndex,
                needed: segments.len(),
                capacity: usize::from(u16::MAX) + 1,
            });
        }
        // Pass 1: distinct cells (sorted insert) and a count per cell (kept in `ends`).
        let mut total: usize = 0;
        let mut failure: Option<MapError> = None;
        let spec = self.spec;
        for seg in segments {
            let keys = &mut self.keys;
            let ends = &mut self.ends;
            let grid_ok = spec.for_each_cell_of_segment(&seg.segment, &mut |c| {
                let key = c.key();
                let idx = match keys.binary_search(&key) {
                    Ok(i) => i,
                    Err(i) => {
                        if keys.insert(i, key).is_err() || ends.insert(i, 0).is_err() {
                            failure = Some(MapError::CapacityExceeded {
                                what: Capacity::Cells,
                                needed: CELLS + 1,
                                capacity: CELLS,
                            });
                            return false;
                        }
                        i
                    }
                };
                if let Some(n) = ends.get_mut(idx) {
                    *n = n.saturating_add(1);
                }
                total += 1;
                true
            });
            if !grid_ok {
                break;
            }
        }
        if let Some(e) = failure {
            self.reset(cell_size_m);
            return Err(e);
        }
        if total > REFS || total > u32::MAX as usize {
            self.reset(cell_size_m);
            return Err(MapError::CapacityExceeded {
                what: Capacity::CellRefs,
                needed: total,
                capacity: REFS,
            });
        }
        // Counts → start offsets.
        let mut running: u32 = 0;
        for n in self.ends.iter_mut() {
            let count = *n;
            *n = running;
            running = running.saturating_add(count);
        }
        let _ = self.refs.resize(total, 0); // total ≤ REFS checked above
                                            // Pass 2: fill; `ends[i]` advances from the cell's start to its end.
        for (si, seg) in segments.iter().enumerate() {
            let id = crate::math::saturating_u16(si); // range checked above
            let keys = &self.keys;
            let ends = &mut self.ends;
            let refs = &mut self.refs;
            spec.for_each_cell_of_segment(&seg.segment, &mut |c| {
                if let Ok(i) = keys.binary_search(&c.key()) {
                    if let Some(pos) = ends.get_mut(i) {
                        if let Some(slot) = refs.get_mut(*pos as usize) {
                            *slot = id;
                        }
                        *pos += 1;
                    }
                }
                true
            });
        }
        // Bounding rectangle of the cells.
        let mut first = true;
        for &k in self.keys.iter() {
            let c = Cell {
                ix: i32::from((k >> 16) as u16 as i16),
                iy: i32::from(k as u16 as i16),
            };
            if first {
                self.bounds = CellRect { min: c, max: c };
                first = false;
            } else {
                self.bounds.min.ix = self.bounds.min.ix.min(c.ix);
                self.bounds.min.iy = self.bounds.min.iy.min(c.iy);
                self.bounds.max.ix = self.bounds.max.ix.max(c.ix);
                self.bounds.max.iy = self.bounds.max.iy.max(c.iy);
            }
        }
        Ok(())
    }
}

/// A grid with the segments it indexes: the [`CellIndex`] the queries of a RAM map run on.
pub(crate) struct GridView<'a, const CELLS: usize, const REFS: usize> {
    pub grid: &'a SparseGrid<CELLS, REFS>,
    pub segments: &'a [MapSegment],
}

impl<const CELLS: usize, const REFS: usize> CellIndex for GridView<'_, CELLS, REFS> {
    #[inline]
    fn spec(&self) -> CellSpec {
        self.grid.spec
    }

    #[inline]
    fn bounds(&self) -> Option<CellRect> {
        self.grid.bounds()
    }

    #[inline]
    fn for_each_ref(&self, c: Cell, f: impl FnMut(u16)) {
        self.grid.cell_refs(c).iter().copied().for_each(f);
    }

    #[inline]
    fn segment(&self, i: u16) -> Option<MapSegment> {
        self.segments.get(usize::from(i)).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_cells_cover_the_segment_once_each() {
        let g: SparseGrid<16, 64> = SparseGrid::new(1.0);
        let seg = Segment::new(Point2::new(0.5, 0.5), Point2::new(3.5, 1.5));
        let mut cells: heapless::Vec<Cell, 32> = heapless::Vec::new();
        g.spec.for_each_cell_of_segment(&seg, &mut |c| {
            cells.push(c).unwrap();
            true
        });
        for i in 0..=100 {
            let p = Point2::new(0.5 + 0.03 * i as f32, 0.5 + 0.01 * i as f32);
            let c = g.spec.cell_of(p).unwrap();
            assert!(cells.contains(&c), "{p:?} in {c:?} missing");
        }
        for (i, a) in cells.iter().enumerate() {
            assert!(!cells[i + 1..].contains(a), "duplicate {a:?}");
        }
        assert!(cells.len() <= 6, "{cells:?}");
    }

    #[test]
    fn build_and_lookup() {
        let mut g: SparseGrid<16, 64> = SparseGrid::new(1.0);
        let segs = [
            Segment::new(Point2::new(0.5, 0.5), Point2::new(2.5, 0.5)),
            Segment::new(Point2::new(-0.5, -0.5), Point2::new(-0.5, 0.5)),
        ]
        .map(|segment| MapSegment {
            segment,
            kind: crate::map::FeatureKind::LeftWall,
        });
        g.build(1.0, &segs).unwrap();
        assert_eq!(g.cell_refs(Cell { ix: 1, iy: 0 }), &[0]);
        assert_eq!(g.cell_refs(Cell { ix: -1, iy: 0 }), &[1]);
        assert_eq!(g.cell_refs(Cell { ix: 5, iy: 5 }), &[] as &[u16]);
        let b = g.bounds().unwrap();
        assert_eq!((b.min.ix, b.max.ix, b.min.iy, b.max.iy), (-1, 2, -1, 0));
        let mut small: SparseGrid<2, 64> = SparseGrid::new(1.0);
        assert!(matches!(
            small.build(1.0, &segs),
            Err(MapError::CapacityExceeded {
                what: Capacity::Cells,
                ..
            })
        ));
        let mut few: SparseGrid<16, 3> = SparseGrid::new(1.0);
        assert_eq!(
            few.build(1.0, &segs),
            Err(MapError::CapacityExceeded {
                what: Capacity::CellRefs,
                needed: 5,
                capacity: 3
            })
        );
    }
}
