//! What can go wrong building, loading or saving a stored map.

use core::fmt;

use crate::landmark::Gene;

use super::WallSide;

/// A fixed capacity of the stored map (a const generic of
/// [`StoredMap`](super::StoredMap)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Capacity {
    /// Map segments (wall segments plus expanded landmark segments): `SEGMENTS`.
    Segments,
    /// Landmarks: `LANDMARKS`.
    Landmarks,
    /// Non-empty cells of the spatial index: `CELLS`.
    Cells,
    /// Segment references of the spatial index (one per segment per cell it crosses):
    /// `CELL_REFS`.
    CellRefs,
    /// Segment indices are u16: at most 65 536 segments, whatever `SEGMENTS` says.
    SegmentIndex,
}

/// Geometry the map refuses.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum GeometryError {
    /// A wall vertex is NaN or infinite.
    NonFiniteVertex {
        /// Which wall.
        wall: WallSide,
        /// Index of the vertex in the wall polyline.
        index: u32,
    },
    /// A wall vertex lies too far from the origin for the spatial index (cell indices are
    /// i16: keep coordinates within ±30 000 cells, ±60 km with 2 m cells).
    VertexOutOfRange {
        /// Which wall.
        wall: WallSide,
        /// Index of the vertex.
        index: u32,
    },
    /// A wall has exactly one vertex (a wall is empty or has at least two).
    WallTooShort {
        /// Which wall.
        wall: WallSide,
    },
    /// The index cell size is not finite and positive (or too small for the map's extent).
    BadCellSize {
        /// The size given, metres.
        cell_size_m: f32,
    },
    /// A landmark's gene is non-finite or outside [`GeneBounds::for_model`](crate::landmark::GeneBounds::for_model).
    GenomeOutOfBounds {
        /// Index of the landmark.
        landmark: u16,
        /// The offending gene.
        gene: Gene,
    },
    /// A landmark's arc position is not on its wall (`0 ≤ s ≤ length`, finite).
    NotOnWall {
        /// Index of the landmark.
        landmark: u16,
        /// The arc position given, metres.
        s_m: f32,
        /// Length of the wall, metres.
        wall_length_m: f32,
    },
    /// A landmark's stand-off from the wall is non-finite or beyond ±1 m.
    BadOffset {
        /// Index of the landmark.
        landmark: u16,
        /// The offset given, metres.
        offset_m: f32,
    },
}

/// Errors of building, loading ([`StoredMap::from_bytes`](super::StoredMap::from_bytes))
/// and saving ([`StoredMap::to_slice`](super::StoredMap::to_slice)) a map.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MapError {
    /// The bytes end early: the header or its payload needs `needed` bytes, `got` were given.
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        got: usize,
    },
    /// The bytes do not start with the map magic `LCMP`: not a map file.
    BadMagic {
        /// The first four bytes found.
        found: [u8; 4],
    },
    /// The bytes are not a map flash image (magic `LCMI`): a map file (`LCMP`) must be
    /// converted first (`host-sim export-map --format image`), anything else is not a map.
    NotAnImage {
        /// The first four bytes found.
        found: [u8; 4],
    },
    /// The file's format version is not one this build reads.
    UnsupportedVersion {
        /// Version in the file.
        found: u16,
        /// Version this build reads and writes.
        supported: u16,
    },
    /// A reserved header byte is not 0 (the header's bytes 6 and 7, outside the CRC): the
    /// file was written by a different encoder, or its header is damaged.
    ReservedNotZero {
        /// Offset of the byte in the file.
        offset: usize,
        /// The byte found.
        found: u8,
    },
    /// Bytes follow the map where none may (outside the CRC): after a map file's payload
    /// ([`StoredMap::load_from_bytes`](super::StoredMap::load_from_bytes)) any byte, after a
    /// map in a flash region ([`StoredMap::load_from_region`](super::StoredMap::load_from_region))
    /// a byte that is not padding (`0xFF` or `0x00`). Another file appended, or the tail of an
    /// older, longer map.
    TrailingBytes {
        /// Length of the map (header and payload), bytes.
        map_len: usize,
        /// Offset of the first byte refused.
        offset: usize,
        /// That byte.
        found: u8,
    },
    /// The payload's CRC-32 does not match the header: the file is damaged.
    ChecksumMismatch {
        /// CRC in the header.
        stored: u32,
        /// CRC of the payload as read.
        computed: u32,
    },
    /// The checksum matched but the payload does not decode (written by a buggy or
    /// different encoder).
    Corrupt {
        /// Which part failed to decode.
        part: &'static str,
        /// Index of the item within that part (0 when not a list).
        index: u32,
    },
    /// The map does not fit this build's capacity: rebuild with a larger const generic.
    CapacityExceeded {
        /// Which capacity.
        what: Capacity,
        /// How many are needed (for [`Capacity::Cells`], a lower bound: the build stops
        /// at the first cell that does not fit).
        needed: usize,
        /// The capacity.
        capacity: usize,
    },
    /// The map's geometry is invalid.
    InvalidGeometry(GeometryError),
    /// The output buffer of [`StoredMap::to_slice`](super::StoredMap::to_slice) is too small.
    BufferTooSmall {
        /// Bytes the map needs.
        needed: usize,
        /// Bytes given.
        got: usize,
    },
}

impl From<GeometryError> for MapError {
    fn from(e: GeometryError) -> Self {
        MapError::InvalidGeometry(e)
    }
}

impl fmt::Display for Capacity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Capacity::Segments => "segments (SEGMENTS)",
            Capacity::Landmarks => "landmarks (LANDMARKS)",
            Capacity::Cells => "index cells (CELLS)",
            Capacity::CellRefs => "index cell references (CELL_REFS)",
            Capacity::SegmentIndex => "u16 segment index",
        })
    }
}

impl fmt::Display for GeometryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            GeometryError::NonFiniteVertex { wall, index } => {
                write!(f, "{wall:?} wall vertex {index} is not finite")
            }
            GeometryError::VertexOutOfRange { wall, index } => write!(
                f,
                "{wall:?} wall vertex {index} is too far from the origin for the index; \
                 shift the map's origin or use larger cells"
            ),
            GeometryError::WallTooShort { wall } => {
                write!(
                    f,
                    "{wall:?} wall has a single vertex; give none or at least two"
                )
            }
            GeometryError::BadCellSize { cell_size_m } => {
                write!(
                    f,
                    "index cell size {cell_size_m} m must be finite and positive"
                )
            }
            GeometryError::GenomeOutOfBounds { landmark, gene } => {
                write!(
                    f,
                    "landmark {landmark}: gene {gene:?} is non-finite or outside Table 1"
                )
            }
            GeometryError::NotOnWall {
                landmark,
                s_m,
                wall_length_m,
            } => write!(
                f,
                "landmark {landmark}: arc position {s_m} m is not on its wall (0…{wall_length_m} m)"
            ),
            GeometryError::BadOffset { landmark, offset_m } => {
                write!(
                    f,
                    "landmark {landmark}: offset {offset_m} m must be finite, within ±1 m"
                )
            }
        }
    }
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MapError::Truncated { needed, got } => write!(
                f,
                "map bytes truncated: {needed} bytes needed, {got} given; re-export the map"
            ),
            MapError::BadMagic { found } if *found == super::IMAGE_MAGIC => write!(
                f,
                "this is a map flash image (\"LCMI\"), not a map file (\"LCMP\"): \
                 give the map file it was written from"
            ),
            MapError::BadMagic { found } => {
                write!(f, "not a map file: magic {found:02x?}, expected \"LCMP\"")
            }
            MapError::NotAnImage { found } if *found == super::MAP_MAGIC => write!(
                f,
                "this is a map file (\"LCMP\"), not a map flash image (\"LCMI\"): \
                 write the image with `host-sim export-map --format image` and flash that"
            ),
            MapError::NotAnImage { found } => write!(
                f,
                "not a map flash image: magic {found:02x?}, expected \"LCMI\"; \
                 write one with `host-sim export-map --format image`"
            ),
            MapError::UnsupportedVersion { found, supported } => write!(
                f,
                "map format version {found} not supported (this build reads {supported}); \
                 re-export the map with a matching host-sim"
            ),
            MapError::ChecksumMismatch { stored, computed } => write!(
                f,
                "map checksum mismatch: header {stored:#010x}, payload {computed:#010x}; \
                 the map is damaged, re-flash it"
            ),
            MapError::ReservedNotZero { offset, found } => write!(
                f,
                "map header byte {offset} is reserved and must be 0, found {found:#04x}: \
                 not written by this format's encoder, or damaged; re-export the map"
            ),
            MapError::TrailingBytes {
                map_len,
                offset,
                found,
            } => write!(
                f,
                "bytes after the map: it ends at byte {map_len}, byte {offset} is {found:#04x}; \
                 give the map file alone, or erase the flash region before writing the map"
            ),
            MapError::Corrupt { part, index } => {
                write!(
                    f,
                    "map payload corrupt: {part} (item {index}) does not decode"
                )
            }
            MapError::CapacityExceeded {
                what,
                needed,
                capacity,
            } => write!(
                f,
                "map too large: needs {needed} {what}, capacity {capacity}; \
                 use a StoredMap with larger capacities"
            ),
            MapError::InvalidGeometry(e) => write!(f, "invalid map geometry: {e}"),
            MapError::BufferTooSmall { needed, got } => {
                write!(
                    f,
                    "output buffer too small: map needs {needed} bytes, {got} given"
                )
            }
        }
    }
}
