//! The stored map: wall polylines and landmarks, expanded once into segments and indexed
//! by a sparse grid, answering [`MapQuery`] in bounded time with fixed memory.

use crate::geometry::{Point2, Segment};
use crate::landmark::{Genome, LandmarkModel, LandmarkShape, WallFrame};

use super::error::{Capacity, GeometryError, MapError};
use super::grid::{GridView, SparseGrid};
use super::search;
use super::wall::{frame_at, polyline_length_m, WallSide};
use super::{FeatureKind, LandmarkBase, MapHit, MapQuery, RayHit, WallEnd, WallEndAt};

/// Side length of the index cells unless the builder sets another, metres. 2 m: a 5 m
/// tunnel cross-section spans ~3 cells, a cell holds 1–3 wall segments sampled every
/// 1–2 m plus the odd landmark, and a 80 m ray crosses at most ~80 cells.
pub const DEFAULT_CELL_SIZE_M: f32 = 2.0;

/// Largest stand-off of a landmark from its wall accepted, metres.
pub const MAX_LANDMARK_OFFSET_M: f32 = 1.0;

/// One segment of the map with what it belongs to, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSegment {
    /// The segment, world frame, metres. Wall segments run in the direction of increasing
    /// chainage; landmark segments in the direction of increasing `u`.
    pub segment: Segment,
    /// Wall or landmark (with the landmark's index).
    pub kind: FeatureKind,
}

/// Where a landmark goes: the stored, compact description of one landmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkPlacement {
    /// The wall it is mounted on.
    pub wall: WallSide,
    /// Arc length along that wall's polyline to the landmark's centre, metres
    /// (`0 ≤ s_m ≤ wall length`).
    pub s_m: f32,
    /// Stand-off of the landmark's base from the wall surface, metres, positive into the
    /// tunnel (brackets, uneven shotcrete); usually 0. Within ±[`MAX_LANDMARK_OFFSET_M`].
    pub offset_m: f32,
    /// Model and genome.
    pub shape: LandmarkShape,
}

impl LandmarkPlacement {
    /// A landmark flush with `wall` at arc position `s_m`.
    pub fn new(wall: WallSide, s_m: f32, model: LandmarkModel, genome: Genome) -> Self {
        Self {
            wall,
            s_m,
            offset_m: 0.0,
            shape: LandmarkShape::new(model, genome),
        }
    }
}

/// A landmark of a built map: its placement, where it ended up, and its segments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapLandmark {
    /// The placement it was built from.
    pub placement: LandmarkPlacement,
    /// Its frame on the wall (anchor = centre on the wall surface, world frame).
    pub frame: WallFrame,
    /// Index of its first segment in [`StoredMap::segments`].
    pub first_segment: u16,
    /// Number of its segments (consecutive from `first_segment`).
    pub segment_count: u8,
}

/// Sizes of the spatial index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IndexStats {
    /// Non-empty cells (≤ `CELLS`).
    pub cells: usize,
    /// Segment references (≤ `CELL_REFS`).
    pub cell_refs: usize,
}

/// A map of tunnel walls and landmarks with fixed capacities:
/// `SEGMENTS` map segments (walls + expanded landmarks), `LANDMARKS` landmarks, `CELLS`
/// non-empty index cells and `CELL_REFS` index entries. See [`TunnelMap`] for the default
/// sizes and their memory.
///
/// Large instances (host maps with tens of thousands of segments) are big values: keep one
/// and refill it in place ([`StoredMap::builder`], [`StoredMap::load_from_bytes`]), box it
/// on the host, and avoid moving it on small stacks.
#[derive(Debug, Clone)]
pub struct StoredMap<
    const SEGMENTS: usize,
    const LANDMARKS: usize,
    const CELLS: usize,
    const CELL_REFS: usize,
> {
    /// Left wall segments, then right wall segments, then landmark segments.
    segments: heapless::Vec<MapSegment, SEGMENTS>,
    /// Number of left and right wall segments.
    wall_segments: [usize; 2],
    landmarks: heapless::Vec<MapLandmark, LANDMARKS>,
    grid: SparseGrid<CELLS, CELL_REFS>,
    cell_size_m: f32,
}

/// The default capacity, sized for a 1 km tunnel: walls sampled every ~1–2 m (up to ~3 000
/// wall segments in all) with a landmark every ~7–10 m on both walls (up to 320 landmarks,
/// P1 adds 2 segments each, P3 10, F-shapes ≤ 15). RAM: 140 376 bytes (137 KiB:
/// segments 4 096 × 20 B, landmarks 320 × 80 B, cells 2 048 × 8 B, refs 8 192 × 2 B;
/// checked by a unit test). A straight 1 km tunnel with walls every 1 m and 213 P1
/// landmarks uses 2 426 segments, 1 004 cells and 4 481 refs, and its file is 20 728 bytes of
/// flash (checked by the serialisation tests: ≤ 64 KiB). Code: the map, landmark, scan and
/// CRC functions take about 15 KiB of flash in the firmware's release selftest image
/// (`nm -S`, thumbv7em; inlined callers not counted) plus the 1 KiB CRC table.
pub type TunnelMap = StoredMap<4096, 320, 2048, 8192>;

/// A host-side capacity for long or rough simulated tunnels (32 768 segments): 1.28 MiB
/// (1 343 576 bytes). Box it (`Box::new(HostMap::new())`), build it in place
/// ([`StoredMap::builder_from_iters`], [`StoredMap::load_from_bytes`]); debug builds move
/// the value through the stack first, so do that on the main thread (8 MiB) or on a thread
/// spawned with a larger stack (test threads have 2 MiB; see `tests/map_host_capacity.rs`).
pub type HostMap = StoredMap<32768, 2048, 32768, 131072>;

impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    Default for StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    /// An empty map (usable in a `static`).
    pub const fn new() -> Self {
        Self {
            segments: heapless::Vec::new(),
            wall_segments: [0, 0],
            landmarks: heapless::Vec::new(),
            grid: SparseGrid::new(DEFAULT_CELL_SIZE_M),
            cell_size_m: DEFAULT_CELL_SIZE_M,
        }
    }

    /// Empties the map in place.
    pub fn clear(&mut self) {
        self.segments.clear();
        self.wall_segments = [0, 0];
        self.landmarks.clear();
        self.cell_size_m = DEFAULT_CELL_SIZE_M;
        self.grid.reset(DEFAULT_CELL_SIZE_M);
    }

    /// Starts rebuilding this map in place from two wall polylines (world frame, both in
    /// the direction of increasing chainage; each empty or with ≥ 2 vertices). Add
    /// landmarks on the returned builder, then [`MapBuilder::finish`] builds the index.
    /// Until then the map answers no query.
    pub fn builder(
        &mut self,
        left: &[Point2],
        right: &[Point2],
    ) -> Result<MapBuilder<'_, SEGMENTS, LANDMARKS, CELLS, CELL_REFS>, MapError> {
        self.clear();
        let needed = left.len().saturating_sub(1) + right.len().saturating_sub(1);
        if needed > SEGMENTS {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Segments,
                needed,
                capacity: SEGMENTS,
            });
        }
        self.builder_from_iters(left.iter().copied(), right.iter().copied())
    }

    /// [`StoredMap::builder`] with the wall vertices generated on the fly (no buffer for
    /// the polylines). On a capacity error `needed` counts the segments up to the first
    /// one that did not fit.
    pub fn builder_from_iters(
        &mut self,
        left: impl IntoIterator<Item = Point2>,
        right: impl IntoIterator<Item = Point2>,
    ) -> Result<MapBuilder<'_, SEGMENTS, LANDMARKS, CELLS, CELL_REFS>, MapError> {
        self.clear();
        let mut cursor = WallCursor::new(WallSide::Left);
        for p in left {
            self.push_wall_vertex(&mut cursor, p)?;
        }
        self.end_wall(&cursor)?;
        let mut cursor = WallCursor::new(WallSide::Right);
        for p in right {
            self.push_wall_vertex(&mut cursor, p)?;
        }
        self.end_wall(&cursor)?;
        Ok(MapBuilder { map: self })
    }

    /// Rebuilds this map in place from walls and landmark placements (see
    /// [`StoredMap::builder`]), with index cells of `cell_size_m`. Capacity errors give the
    /// exact totals needed.
    pub fn rebuild(
        &mut self,
        left: &[Point2],
        right: &[Point2],
        landmarks: &[LandmarkPlacement],
        cell_size_m: f32,
    ) -> Result<(), MapError> {
        if landmarks.len() > LANDMARKS {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Landmarks,
                needed: landmarks.len(),
                capacity: LANDMARKS,
            });
        }
        let needed = left.len().saturating_sub(1)
            + right.len().saturating_sub(1)
            + landmarks
                .iter()
                .map(|l| l.shape.profile().vertices().len().saturating_sub(1))
                .sum::<usize>();
        if needed > SEGMENTS {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Segments,
                needed,
                capacity: SEGMENTS,
            });
        }
        let mut b = self.builder(left, right)?;
        b.cell_size_m(cell_size_m);
        for l in landmarks {
            b.add(*l)?;
        }
        b.finish()
    }

    /// Appends one wall vertex (and the segment from the previous one).
    pub(crate) fn push_wall_vertex(
        &mut self,
        cursor: &mut WallCursor,
        p: Point2,
    ) -> Result<(), MapError> {
        let index = cursor.count;
        if !p.is_finite() {
            return Err(GeometryError::NonFiniteVertex {
                wall: cursor.side,
                index,
            }
            .into());
        }
        if let Some(prev) = cursor.prev {
            let seg = MapSegment {
                segment: Segment::new(prev, p),
                kind: cursor.side.kind(),
            };
            if self.segments.push(seg).is_err() {
                return Err(MapError::CapacityExceeded {
                    what: Capacity::Segments,
                    needed: self.segments.len() + 1,
                    capacity: SEGMENTS,
                });
            }
            if let Some(n) = self.wall_segments.get_mut(cursor.slot()) {
                *n += 1;
            }
        }
        cursor.prev = Some(p);
        cursor.count = cursor.count.saturating_add(1);
        Ok(())
    }

    /// Checks a finished wall (not a single vertex).
    pub(crate) fn end_wall(&mut self, cursor: &WallCursor) -> Result<(), MapError> {
        if cursor.count == 1 {
            return Err(GeometryError::WallTooShort { wall: cursor.side }.into());
        }
        Ok(())
    }

    /// Expands and appends one landmark; on error the map is unchanged.
    pub(crate) fn add_landmark(&mut self, placement: LandmarkPlacement) -> Result<u16, MapError> {
        let index = self.landmarks.len();
        let id = crate::math::saturating_u16(index);
        if index >= LANDMARKS || index > usize::from(u16::MAX) {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Landmarks,
                needed: index + 1,
                capacity: LANDMARKS,
            });
        }
        placement
            .shape
            .check()
            .map_err(|gene| GeometryError::GenomeOutOfBounds { landmark: id, gene })?;
        if placement.offset_m.is_nan() || placement.offset_m.abs() > MAX_LANDMARK_OFFSET_M {
            return Err(GeometryError::BadOffset {
                landmark: id,
                offset_m: placement.offset_m,
            }
            .into());
        }
        let frame =
            self.wall_frame_at(placement.wall, placement.s_m)
                .ok_or(GeometryError::NotOnWall {
                    landmark: id,
                    s_m: placement.s_m,
                    wall_length_m: self.wall_length_m(placement.wall),
                })?;
        let world = frame.place(&placement.shape.profile(), placement.offset_m);
        let first = self.segments.len();
        let count = world.len().saturating_sub(1);
        if first + count > SEGMENTS {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Segments,
                needed: first + count,
                capacity: SEGMENTS,
            });
        }
        let kind = FeatureKind::Landmark { id };
        for w in world.windows(2) {
            if let [a, b] = w {
                let _ = self.segments.push(MapSegment {
                    segment: Segment::new(*a, *b),
                    kind,
                }); // room checked above
            }
        }
        let landmark = MapLandmark {
            placement,
            frame,
            first_segment: crate::math::saturating_u16(first),
            segment_count: u8::try_from(count).unwrap_or(u8::MAX),
        };
        if self.landmarks.push(landmark).is_err() {
            self.segments.truncate(first);
            return Err(MapError::CapacityExceeded {
                what: Capacity::Landmarks,
                needed: index + 1,
                capacity: LANDMARKS,
            });
        }
        Ok(id)
    }

    /// Builds the spatial index over all segments.
    pub(crate) fn build_index(&mut self, cell_size_m: f32) -> Result<(), MapError> {
        if !(cell_size_m.is_finite() && cell_size_m > 1e-3) {
            return Err(GeometryError::BadCellSize { cell_size_m }.into());
        }
        self.cell_size_m = cell_size_m;
        let spec = super::grid::CellSpec::new(cell_size_m);
        for (i, ms) in self.segments.iter().enumerate() {
            if spec.cell_of(ms.segment.a).is_none() || spec.cell_of(ms.segment.b).is_none() {
                let wall = match ms.kind {
                    FeatureKind::LeftWall => WallSide::Left,
                    FeatureKind::RightWall => WallSide::Right,
                    FeatureKind::Landmark { id } => self
                        .landmarks
                        .get(usize::from(id))
                        .map_or(WallSide::Left, |l| l.placement.wall),
                };
                return Err(GeometryError::VertexOutOfRange {
                    wall,
                    index: u32::try_from(i).unwrap_or(u32::MAX),
                }
                .into());
            }
        }
        self.grid.build(cell_size_m, &self.segments)
    }

    /// All segments: left wall, right wall, then landmarks in landmark order.
    #[inline]
    pub fn segments(&self) -> &[MapSegment] {
        &self.segments
    }

    /// The segments of one wall, in the direction of increasing chainage.
    pub fn wall_segments(&self, side: WallSide) -> &[MapSegment] {
        let [l, r] = self.wall_segments;
        let range = match side {
            WallSide::Left => 0..l,
            WallSide::Right => l..l + r,
        };
        self.segments.get(range).unwrap_or(&[])
    }

    /// The vertices of one wall's polyline (empty for an empty wall).
    pub fn wall_vertices(&self, side: WallSide) -> impl Iterator<Item = Point2> + '_ {
        let segs = self.wall_segments(side);
        segs.iter()
            .map(|s| s.segment.a)
            .chain(segs.last().map(|s| s.segment.b))
    }

    /// All landmark segments.
    pub fn landmark_segments(&self) -> &[MapSegment] {
        let [l, r] = self.wall_segments;
        self.segments.get(l + r..).unwrap_or(&[])
    }

    /// The landmarks, indexed by the `id` of [`FeatureKind::Landmark`].
    #[inline]
    pub fn landmarks(&self) -> &[MapLandmark] {
        &self.landmarks
    }

    /// Length of one wall's polyline, metres.
    pub fn wall_length_m(&self, side: WallSide) -> f32 {
        polyline_length_m(self.wall_segments(side).iter().map(|s| s.segment))
    }

    /// The point, unit tangent and inward normal at arc length `s_m` along a wall (world
    /// frame); `None` off the wall or for non-finite `s_m`.
    pub fn wall_frame_at(&self, side: WallSide, s_m: f32) -> Option<WallFrame> {
        frame_at(
            side,
            self.wall_segments(side).iter().map(|s| s.segment),
            s_m,
        )
    }

    /// Side length of the index cells, metres.
    #[inline]
    pub fn cell_size_m(&self) -> f32 {
        self.cell_size_m
    }

    /// How full the spatial index is.
    pub fn index_stats(&self) -> IndexStats {
        IndexStats {
            cells: self.grid.cell_count(),
            cell_refs: self.grid.ref_count(),
        }
    }

    /// True when the map has no segment.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// The spatial index's arrays (for the flash image).
    pub(crate) fn index_parts(&self) -> (&[u32], &[u32], &[u16]) {
        self.grid.parts()
    }

    /// The index with its segments, as the queries see it.
    #[inline]
    fn view(&self) -> GridView<'_, CELLS, CELL_REFS> {
        GridView {
            grid: &self.grid,
            segments: &self.segments,
        }
    }
}

/// Queries go through the sparse grid: `nearest` searches rings of cells outwards from the
/// query point and stops once no closer segment can exist; `raycast` walks the cells along
/// the ray (DDA) and stops at the first cell whose exit lies beyond the best hit; both are
/// clipped to the map's bounding box. A query point more than 30 000 cells from the origin
/// (60 km with 2 m cells) gets `None` from `nearest`, whatever the distance allowed.
impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    MapQuery for StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    fn nearest(&self, p: Point2, max_distance_m: f32) -> Option<MapHit> {
        search::nearest(&self.view(), p, max_distance_m)
    }

    fn raycast(&self, origin: Point2, angle_rad: f32, max_range_m: f32) -> Option<RayHit> {
        search::raycast(&self.view(), origin, angle_rad, max_range_m)
    }

    fn for_each_landmark_segment_near(
        &self,
        center: Point2,
        radius_m: f32,
        f: &mut dyn FnMut(u16, Segment),
    ) {
        search::for_each_landmark_segment_near(&self.view(), center, radius_m, f);
    }

    fn landmark_count(&self) -> u16 {
        u16::try_from(self.landmarks.len()).unwrap_or(u16::MAX)
    }

    fn landmark_base(&self, id: u16) -> Option<LandmarkBase> {
        let l = self.landmarks.get(usize::from(id))?;
        let first = usize::from(l.first_segment);
        let count = usize::from(l.segment_count);
        let segments = self.segments.get(first..first.checked_add(count)?)?;
        landmark_base(l.placement.wall, segments.iter().map(|s| s.segment))
    }

    fn wall_end(&self, wall: WallSide, at: WallEndAt) -> Option<WallEnd> {
        super::wall::polyline_end(wall, at, self.wall_segments(wall).iter().map(|s| s.segment))
    }
}

/// The base of a landmark from its segments in polyline order (increasing `u`, so the
/// first segment's start is at the smaller arc position): the polyline's two ends.
pub(crate) fn landmark_base(
    wall: WallSide,
    mut segments: impl Iterator<Item = Segment>,
) -> Option<LandmarkBase> {
    let first = segments.next()?;
    let last = segments.last().unwrap_or(first);
    Some(LandmarkBase {
        wall,
        base: Segment::new(first.a, last.b),
    })
}

/// Progress through one wall's vertices while building.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WallCursor {
    pub side: WallSide,
    pub prev: Option<Point2>,
    pub count: u32,
}

impl WallCursor {
    pub fn new(side: WallSide) -> Self {
        Self {
            side,
            prev: None,
            count: 0,
        }
    }

    fn slot(&self) -> usize {
        match self.side {
            WallSide::Left => 0,
            WallSide::Right => 1,
        }
    }
}

/// Adds landmarks to a map whose walls are set, then builds its index
/// ([`StoredMap::builder`]).
#[derive(Debug)]
pub struct MapBuilder<
    'm,
    const SEGMENTS: usize,
    const LANDMARKS: usize,
    const CELLS: usize,
    const CELL_REFS: usize,
> {
    map: &'m mut StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>,
}

impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    MapBuilder<'_, SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    /// Sets the index cell size, metres (default [`DEFAULT_CELL_SIZE_M`]; checked by
    /// [`MapBuilder::finish`]).
    pub fn cell_size_m(&mut self, cell_size_m: f32) -> &mut Self {
        self.map.cell_size_m = cell_size_m;
        self
    }

    /// Adds a landmark flush with `wall` at arc length `s_m` along it; returns its id.
    pub fn add_landmark(
        &mut self,
        wall: WallSide,
        s_m: f32,
        model: LandmarkModel,
        genome: Genome,
    ) -> Result<u16, MapError> {
        self.map
            .add_landmark(LandmarkPlacement::new(wall, s_m, model, genome))
    }

    /// Adds a landmark from a full placement (with stand-off); returns its id.
    pub fn add(&mut self, placement: LandmarkPlacement) -> Result<u16, MapError> {
        self.map.add_landmark(placement)
    }

    /// The map so far (walls and landmarks added; no index yet).
    pub fn map(&self) -> &StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS> {
        self.map
    }

    /// Builds the spatial index; the map answers queries from now on.
    pub fn finish(self) -> Result<(), MapError> {
        let cs = self.map.cell_size_m;
        self.map.build_index(cs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::search::ray_segment;
    use crate::math;
    use crate::rng::Pcg32;

    type SmallMap = StoredMap<1024, 64, 1024, 4096>;

    fn straight_walls(
        len_m: f32,
        step_m: f32,
    ) -> (heapless::Vec<Point2, 256>, heapless::Vec<Point2, 256>) {
        let mut l = heapless::Vec::new();
        let mut r = heapless::Vec::new();
        let n = (len_m / step_m) as usize;
        for i in 0..=n {
            let x = i as f32 * step_m;
            l.push(Point2::new(x, 2.5)).unwrap();
            r.push(Point2::new(x, -2.5)).unwrap();
        }
        (l, r)
    }

    fn tunnel() -> SmallMap {
        let (l, r) = straight_walls(99.0, 1.5);
        let mut map = SmallMap::new();
        let mut b = map.builder(&l, &r).unwrap();
        let g = Genome::paper_default(LandmarkModel::P1Triangle);
        assert_eq!(
            b.add_landmark(WallSide::Left, 10.0, LandmarkModel::P1Triangle, g),
            Ok(0)
        );
        assert_eq!(
            b.add_landmark(WallSide::Right, 20.0, LandmarkModel::P1Triangle, g),
            Ok(1)
        );
        b.finish().unwrap();
        map
    }

    #[test]
    fn straight_tunnel_queries() {
        let map = tunnel();
        assert_eq!(map.wall_segments(WallSide::Left).len(), 66);
        assert_eq!(map.landmark_segments().len(), 4);
        assert!((map.wall_length_m(WallSide::Right) - 99.0).abs() < 1e-3);
        let lm = map.landmarks()[0];
        assert_eq!(lm.frame.anchor, Point2::new(10.0, 2.5));
        assert_eq!(lm.frame.inward_normal, Point2::new(0.0, -1.0));

        let hit = map.nearest(Point2::new(10.0, 2.0), 1.0).unwrap();
        assert_eq!(hit.kind, FeatureKind::Landmark { id: 0 });
        assert!((hit.projection.distance_m - 0.25).abs() < 1e-5); // the apex
        let wall = map.nearest(Point2::new(50.0, -2.0), 1.0).unwrap();
        assert_eq!(wall.kind, FeatureKind::RightWall);
        assert!((wall.projection.distance_m - 0.5).abs() < 1e-5);
        assert!(map.nearest(Point2::new(50.0, 0.0), 1.0).is_none());
        assert!(map.nearest(Point2::new(50.0, 0.0), 3.0).is_some());

        let ray = map
            .raycast(Point2::new(10.0, 0.0), core::f32::consts::FRAC_PI_2, 80.0)
            .unwrap();
        assert_eq!(ray.kind, FeatureKind::Landmark { id: 0 });
        assert!((ray.range_m - 2.25).abs() < 1e-4);
        let down = map
            .raycast(Point2::new(50.0, 0.0), -core::f32::consts::FRAC_PI_2, 80.0)
            .unwrap();
        assert_eq!(down.kind, FeatureKind::RightWall);
        assert!((down.range_m - 2.5).abs() < 1e-4);
        assert!(map
            .raycast(Point2::new(50.0, 0.0), -core::f32::consts::FRAC_PI_2, 2.0)
            .is_none());
        // Along the axis of an open-ended tunnel nothing is hit.
        assert!(map.raycast(Point2::new(1.0, 0.0), 0.0, 1000.0).is_none());
        // A shallow ray from far outside the map still finds the wall.
        let far = map
            .raycast(Point2::new(-20.0, 0.0), 0.1, f32::INFINITY)
            .unwrap();
        assert_eq!(far.kind, FeatureKind::LeftWall);

        let mut seen: heapless::Vec<(u16, Segment), 8> = heapless::Vec::new();
        map.for_each_landmark_segment_near(Point2::new(10.0, 2.0), 1.0, &mut |id, s| {
            seen.push((id, s)).unwrap();
        });
        assert_eq!(seen.len(), 2, "{seen:?}");
        assert!(seen.iter().all(|(id, _)| *id == 0));
    }

    #[test]
    fn non_finite_queries_return_nothing() {
        let map = tunnel();
        let nan = Point2::new(f32::NAN, 0.0);
        assert!(map.nearest(nan, 1.0).is_none());
        assert!(map.nearest(Point2::new(10.0, 2.0), f32::NAN).is_none());
        assert!(map.nearest(Point2::new(10.0, 2.0), -1.0).is_none());
        assert!(map.raycast(nan, 0.0, 10.0).is_none());
        assert!(map.raycast(Point2::ORIGIN, f32::NAN, 10.0).is_none());
        assert!(map.raycast(Point2::ORIGIN, 1.0, f32::NAN).is_none());
        let mut n = 0;
        map.for_each_landmark_segment_near(nan, 1.0, &mut |_, _| n += 1);
        map.for_each_landmark_segment_near(Point2::ORIGIN, f32::NAN, &mut |_, _| n += 1);
        assert_eq!(n, 0);
        assert!(map.nearest(Point2::new(1e30, 0.0), f32::INFINITY).is_none());
        let empty = SmallMap::new();
        assert!(empty.nearest(Point2::ORIGIN, 10.0).is_none());
        assert!(empty.raycast(Point2::ORIGIN, 0.0, 10.0).is_none());
    }

    #[test]
    fn builder_rejects_bad_input_with_named_errors() {
        let (l, r) = straight_walls(30.0, 1.5);
        let mut map = SmallMap::new();
        let g = Genome::paper_default(LandmarkModel::P1Triangle);
        let mut b = map.builder(&l, &r).unwrap();
        assert!(matches!(
            b.add_landmark(WallSide::Left, 31.0, LandmarkModel::P1Triangle, g),
            Err(MapError::InvalidGeometry(GeometryError::NotOnWall {
                landmark: 0,
                ..
            }))
        ));
        let mut tall = g;
        tall.height_m = 0.9;
        assert!(matches!(
            b.add_landmark(WallSide::Left, 5.0, LandmarkModel::P1Triangle, tall),
            Err(MapError::InvalidGeometry(
                GeometryError::GenomeOutOfBounds { .. }
            ))
        ));
        let mut p = LandmarkPlacement::new(WallSide::Left, 5.0, LandmarkModel::P1Triangle, g);
        p.offset_m = f32::INFINITY;
        assert!(matches!(
            b.add(p),
            Err(MapError::InvalidGeometry(GeometryError::BadOffset { .. }))
        ));
        assert!(b.map().landmarks().is_empty());
        b.cell_size_m(0.0);
        assert!(matches!(
            b.finish(),
            Err(MapError::InvalidGeometry(GeometryError::BadCellSize { .. }))
        ));
        let bad = [Point2::new(0.0, 0.0), Point2::new(f32::NAN, 1.0)];
        assert!(matches!(
            map.builder(&bad, &r),
            Err(MapError::InvalidGeometry(GeometryError::NonFiniteVertex {
                wall: WallSide::Left,
                index: 1
            }))
        ));
        assert!(matches!(
            map.builder(&l, &r[..1]),
            Err(MapError::InvalidGeometry(GeometryError::WallTooShort {
                wall: WallSide::Right
            }))
        ));
        let far = [Point2::new(0.0, 0.0), Point2::new(1e6, 0.0)];
        assert!(matches!(
            map.rebuild(&far, &[], &[], 2.0),
            Err(MapError::InvalidGeometry(
                GeometryError::VertexOutOfRange { .. }
            ))
        ));
        let mut tiny: StoredMap<8, 4, 64, 64> = StoredMap::new();
        assert_eq!(
            tiny.rebuild(&l, &r, &[], 2.0).unwrap_err(),
            MapError::CapacityExceeded {
                what: Capacity::Segments,
                needed: 40,
                capacity: 8
            }
        );
        let mut few_refs: StoredMap<64, 4, 64, 16> = StoredMap::new();
        assert!(matches!(
            few_refs.rebuild(&l, &r, &[], 2.0),
            Err(MapError::CapacityExceeded {
                what: Capacity::CellRefs,
                capacity: 16,
                ..
            })
        ));
        // The error display tells what to do.
        let msg = std::format!(
            "{}",
            MapError::CapacityExceeded {
                what: Capacity::CellRefs,
                needed: 9,
                capacity: 8
            }
        );
        assert!(msg.contains("larger capacities"), "{msg}");
    }

    extern crate std;

    #[test]
    fn default_capacity_memory_is_as_documented() {
        let bytes = core::mem::size_of::<TunnelMap>();
        std::println!(
            "TunnelMap: {bytes} bytes of RAM; HostMap: {} bytes",
            core::mem::size_of::<HostMap>()
        );
        assert_eq!(core::mem::size_of::<MapSegment>(), 20);
        assert!(core::mem::size_of::<MapLandmark>() <= 80);
        assert!(bytes <= 160 * 1024, "{bytes}");
    }

    /// A wiggly closed-ish map with landmarks, for comparing against brute force.
    fn random_map(rng: &mut Pcg32) -> SmallMap {
        let mut l: heapless::Vec<Point2, 256> = heapless::Vec::new();
        let mut r: heapless::Vec<Point2, 256> = heapless::Vec::new();
        let radius = 40.0;
        for i in 0..120 {
            let a = i as f32 * 0.02;
            let (s, c) = math::sin_cos(a);
            let jitter = rng.uniform(-0.05, 0.05);
            l.push(Point2::new(
                c * (radius - 2.5 + jitter),
                s * (radius - 2.5 + jitter),
            ))
            .unwrap();
            r.push(Point2::new(c * (radius + 2.5), s * (radius + 2.5)))
                .unwrap();
        }
        let mut map = SmallMap::new();
        let mut b = map.builder(&l, &r).unwrap();
        b.cell_size_m(rng.uniform(0.7, 2.5));
        let mut s = 3.0;
        let models = LandmarkModel::ALL;
        while s < 90.0 {
            let m = models[rng.index(models.len())];
            let side = if rng.uniform01() < 0.5 {
                WallSide::Left
            } else {
                WallSide::Right
            };
            b.add_landmark(side, s, m, Genome::paper_default(m))
                .unwrap();
            s += rng.uniform(4.0, 9.0);
        }
        b.finish().unwrap();
        map
    }

    #[test]
    fn grid_queries_match_brute_force() {
        let mut rng = Pcg32::seeded(7);
        for _ in 0..4 {
            let map = random_map(&mut rng);
            let segs = map.segments();
            for _ in 0..400 {
                let p = Point2::new(rng.uniform(-50.0, 50.0), rng.uniform(-5.0, 50.0));
                let maxd = rng.uniform(0.0, 30.0);
                let brute = segs
                    .iter()
                    .map(|s| s.segment.project(p).distance_m)
                    .filter(|d| *d <= maxd)
                    .fold(f32::INFINITY, f32::min);
                match map.nearest(p, maxd) {
                    Some(h) => assert!((h.projection.distance_m - brute).abs() < 1e-5),
                    None => assert!(brute.is_infinite(), "missed {brute} at {p:?}"),
                }
                let angle = rng.uniform(-3.2, 3.2);
                let range = rng.uniform(0.0, 120.0);
                let (sn, cs) = math::sin_cos(angle);
                let d = Point2::new(cs, sn);
                let brute_t = segs
                    .iter()
                    .filter_map(|s| ray_segment(p, d, &s.segment))
                    .filter(|t| *t <= range)
                    .fold(f32::INFINITY, f32::min);
                match map.raycast(p, angle, range) {
                    Some(h) => assert!(
                        (h.range_m - brute_t).abs() < 1e-4,
                        "{} vs {brute_t}",
                        h.range_m
                    ),
                    None => assert!(
                        brute_t.is_infinite(),
                        "ray missed {brute_t} from {p:?} at {angle}"
                    ),
                }
                let radius = rng.uniform(0.0, 10.0);
                let mut got: std::vec::Vec<(u16, Segment)> = std::vec::Vec::new();
                map.for_each_landmark_segment_near(p, radius, &mut |id, s| got.push((id, s)));
                let want: std::vec::Vec<(u16, Segment)> = map
                    .landmark_segments()
                    .iter()
                    .filter(|s| s.segment.project(p).distance_m <= radius)
                    .filter_map(|s| match s.kind {
                        FeatureKind::Landmark { id } => Some((id, s.segment)),
                        _ => None,
                    })
                    .collect();
                assert_eq!(got.len(), want.len(), "at {p:?} r={radius}");
                for w in &want {
                    assert!(got.contains(w));
                }
            }
        }
    }
}
