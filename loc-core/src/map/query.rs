//! What the estimator asks of a map: the nearest geometry to a point, and ray casts.
//!
//! Stripping, matching and the filter are written against [`MapQuery`], not against the
//! concrete stored map, so they work with any map that answers these questions (the
//! fixed-capacity stored map on the MCU, a larger one on the host).

use crate::geometry::{Point2, Segment, SegmentProjection};
use crate::map::WallSide;

/// What a piece of map geometry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeatureKind {
    /// The tunnel's left wall (left of the direction of increasing chainage).
    LeftWall,
    /// The tunnel's right wall.
    RightWall,
    /// A passive landmark; `id` is its index in the map's landmark table.
    Landmark {
        /// Index of the landmark in the map.
        id: u16,
    },
}

impl FeatureKind {
    /// True for landmark geometry.
    #[inline]
    pub fn is_landmark(self) -> bool {
        matches!(self, FeatureKind::Landmark { .. })
    }

    /// The landmark's index in the map; `None` for a wall.
    #[inline]
    pub fn landmark_id(self) -> Option<u16> {
        match self {
            FeatureKind::Landmark { id } => Some(id),
            _ => None,
        }
    }
}

/// The map geometry nearest to a query point (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapHit {
    /// The nearest segment, world frame, metres.
    pub segment: Segment,
    /// What the segment belongs to.
    pub kind: FeatureKind,
    /// Projection of the query point onto `segment` (closest point, distance, normal).
    pub projection: SegmentProjection,
}

/// Where a ray first meets map geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance from the ray origin to the hit, metres.
    pub range_m: f32,
    /// The hit point, world frame.
    pub point: Point2,
    /// What was hit.
    pub kind: FeatureKind,
}

/// A landmark's base on its wall: where its polyline meets the wall, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkBase {
    /// The wall it is mounted on.
    pub wall: WallSide,
    /// The base, from its end at the smaller arc position to the one at the larger (the
    /// direction of increasing chainage), world frame, metres.
    pub base: Segment,
}

impl LandmarkBase {
    /// The centre of the base (the landmark's anchor on the wall), world frame.
    pub fn anchor(&self) -> Point2 {
        self.base.a.add(self.base.b).scale(0.5)
    }
}

/// Which end of a wall's polyline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WallEndAt {
    /// Its first vertex (the smallest chainage).
    Start,
    /// Its last vertex (the largest chainage).
    Finish,
}

impl WallEndAt {
    /// Both ends, start first.
    pub const BOTH: [WallEndAt; 2] = [WallEndAt::Start, WallEndAt::Finish];
}

/// Where a wall's polyline stops, world frame: the tunnel's portal, its face, or the edge
/// of the surveyed stretch. Past it the map claims no wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallEnd {
    /// The wall.
    pub wall: WallSide,
    /// Which end.
    pub at: WallEndAt,
    /// The end vertex, world frame, metres.
    pub point: Point2,
    /// Unit vector along the wall pointing out of it past the end (the last segment's
    /// direction at the finish, the first's reversed at the start), world frame.
    pub outward: Point2,
}

impl WallEnd {
    /// The wall's unit tangent at the end in the direction of increasing chainage.
    pub fn tangent(&self) -> Point2 {
        match self.at {
            WallEndAt::Start => self.outward.scale(-1.0),
            WallEndAt::Finish => self.outward,
        }
    }

    /// The wall's unit normal into the tunnel at the end.
    pub fn inward_normal(&self) -> Point2 {
        self.wall.inward_normal(self.tangent())
    }
}

/// The queries the estimator makes against a map. All inputs and outputs are in the world
/// frame, metres and radians. Implementations must be bounded in time (a spatial index, not
/// a scan of the whole map) and must never panic, whatever the input (NaN included: a
/// non-finite query returns `None`).
pub trait MapQuery {
    /// The segment nearest to `p` among those within `max_distance_m`, or `None`.
    fn nearest(&self, p: Point2, max_distance_m: f32) -> Option<MapHit>;

    /// The first geometry a ray from `origin` at heading `angle_rad` meets within
    /// `max_range_m`, or `None`.
    fn raycast(&self, origin: Point2, angle_rad: f32, max_range_m: f32) -> Option<RayHit>;

    /// Calls `f` once for every landmark segment with any part within `radius_m` of
    /// `center` (a landmark with several segments calls `f` for each of them).
    fn for_each_landmark_segment_near(
        &self,
        center: Point2,
        radius_m: f32,
        f: &mut dyn FnMut(u16, Segment),
    );

    /// Number of landmarks (ids `0..landmark_count()`); 0 for a map that does not list them
    /// (such a map cannot relocalise a vehicle).
    fn landmark_count(&self) -> u16 {
        0
    }

    /// Landmark `id`'s base on its wall; `None` past the end (or for a map that does not
    /// list its landmarks). Bounded in time: a table lookup.
    fn landmark_base(&self, id: u16) -> Option<LandmarkBase> {
        let _ = id;
        None
    }

    /// Where wall `wall`'s polyline starts or finishes ([`WallEnd`]); `None` for an empty
    /// wall, a degenerate end segment, or a map that does not list its walls. Bounded in
    /// time: a table lookup.
    fn wall_end(&self, wall: WallSide, at: WallEndAt) -> Option<WallEnd> {
        let _ = (wall, at);
        None
    }
}
