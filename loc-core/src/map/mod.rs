//! The stored map: tunnel walls and landmarks in world coordinates, and the queries the
//! estimator makes against it.
//!
//! - [`query`](MapQuery): the contract the estimator codes against.
//! - [`StoredMap`] / [`TunnelMap`]: walls and landmarks expanded into segments with a
//!   sparse-grid index ([`MapBuilder`] builds one).
//! - [`WallSide`]: left/right wall and positions along a wall by arc length.
//! - [`MapError`]: what goes wrong building, loading or saving a map.
//! - `file`: the versioned, checksummed postcard file format
//!   ([`StoredMap::to_slice`], [`StoredMap::from_bytes`]).
//! - [`MapImage`]: the flash image — segments, index and landmarks laid out to be queried
//!   in place, so a controller's RAM does not grow with the map ([`StoredMap::write_image`]).

mod error;
mod file;
mod grid;
mod image;
mod query;
mod search;
mod stored;
mod wall;

pub use error::{Capacity, GeometryError, MapError};
pub use file::{MAP_FORMAT_VERSION, MAP_HEADER_LEN, MAP_MAGIC};
pub use image::{MapImage, IMAGE_FORMAT_VERSION, IMAGE_HEADER_LEN, IMAGE_MAGIC};
pub use query::{FeatureKind, LandmarkBase, MapHit, MapQuery, RayHit, WallEnd, WallEndAt};
pub use stored::{
    HostMap, IndexStats, LandmarkPlacement, MapBuilder, MapLandmark, MapSegment, StoredMap,
    TunnelMap, DEFAULT_CELL_SIZE_M, MAX_LANDMARK_OFFSET_M,
};
pub use wall::WallSide;
