//! The stored map as the controller queries it: loc-core's map image read in place from
//! the map flash region, behind one `static` ([`MAP`]) so that the controller — which
//! refers to its map — can itself be built at compile time in a static (see
//! [`crate::controller::Controller::take`]): no large value is ever built on the stack.

use loc_core::geometry::{Point2, Segment};
use loc_core::map::{
    LandmarkBase, MapError, MapHit, MapImage, MapQuery, RayHit, WallEnd, WallEndAt, WallSide,
};

/// A map image opened once for the program's life (the map flash region does not move).
/// Until it is opened every query answers `None` (and a localiser on it sees no map).
pub struct FlashMap {
    image: spin::Once<MapImage<'static>>,
}

/// The program's map.
pub static MAP: FlashMap = FlashMap::new();

impl FlashMap {
    /// A map not opened yet.
    pub const fn new() -> Self {
        Self {
            image: spin::Once::new(),
        }
    }

    /// Opens the map image at the start of `region` (padding after it allowed, see
    /// [`MapImage::from_region`]) and keeps it. The first successful open holds for the
    /// program's life: later calls return that image whatever `region` they give.
    pub fn open(&self, region: &'static [u8]) -> Result<&MapImage<'static>, MapError> {
        self.image.try_call_once(|| MapImage::from_region(region))
    }

    /// The opened image, if any.
    pub fn image(&self) -> Option<&MapImage<'static>> {
        self.image.get()
    }
}

impl Default for FlashMap {
    fn default() -> Self {
        Self::new()
    }
}

impl MapQuery for FlashMap {
    #[inline]
    fn nearest(&self, p: Point2, max_distance_m: f32) -> Option<MapHit> {
        self.image.get()?.nearest(p, max_distance_m)
    }

    #[inline]
    fn raycast(&self, origin: Point2, angle_rad: f32, max_range_m: f32) -> Option<RayHit> {
        self.image.get()?.raycast(origin, angle_rad, max_range_m)
    }

    #[inline]
    fn for_each_landmark_segment_near(
        &self,
        center: Point2,
        radius_m: f32,
        f: &mut dyn FnMut(u16, Segment),
    ) {
        if let Some(image) = self.image.get() {
            image.for_each_landmark_segment_near(center, radius_m, f);
        }
    }

    #[inline]
    fn landmark_count(&self) -> u16 {
        self.image.get().map_or(0, MapQuery::landmark_count)
    }

    #[inline]
    fn landmark_base(&self, id: u16) -> Option<LandmarkBase> {
        self.image.get()?.landmark_base(id)
    }

    #[inline]
    fn wall_end(&self, wall: WallSide, at: WallEndAt) -> Option<WallEnd> {
        self.image.get()?.wall_end(wall, at)
    }
}
