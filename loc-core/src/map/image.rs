//! The map's flash image: the expanded segments, the spatial index and the landmark table,
//! laid out to be queried in place from flash, so the localiser's RAM does not grow with
//! the map's length.
//!
//! The map file ([`file`](super::StoredMap::to_slice), `LCMP`) is compact — walls as vertices,
//! landmarks as genes — and is expanded into a [`StoredMap`] in RAM when loaded (137 KiB for
//! [`TunnelMap`](super::TunnelMap)'s 1 km capacity). A controller with little RAM instead keeps
//! this image in flash and answers [`MapQuery`] from it with [`MapImage`]: the same sparse
//! grid and the same query code (`search`), reading each cell and segment from the bytes as
//! it is visited. Its RAM is the `MapImage` value itself (under 100 bytes), whatever the
//! map's size.
//!
//! ## Layout (image format version 1)
//! All integers and floats little-endian; every section starts on a 4-byte boundary.
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 4]` | magic `LCMI` |
//! | 4 | u16 | format version ([`IMAGE_FORMAT_VERSION`]) |
//! | 6 | u16 | reserved, 0 |
//! | 8 | u32 | image length in bytes, header to CRC inclusive |
//! | 12 | f32 | index cell size, metres |
//! | 16 | u32 | left wall segments `nl` |
//! | 20 | u32 | right wall segments `nr` |
//! | 24 | u32 | landmark segments `nk` |
//! | 28 | u32 | landmarks `nm` |
//! | 32 | u32 | non-empty index cells `nc` |
//! | 36 | u32 | index references `nf` |
//! | 40 | `[u8; 24]` | reserved, 0 |
//! | 64 | `n × 20` | segments, `n = nl + nr + nk` (left wall, right wall, landmarks): `ax, ay, bx, by: f32` (world frame, metres), `kind: u16` (0 left wall, 1 right wall, `2 + id` landmark `id`), `u16` 0 |
//! | | `nc × 4` | cell keys, `u32`, strictly increasing (packed i16 cell coordinates `ix << 16 \| iy`) |
//! | | `nc × 4` | cell ends, `u32`: one past the cell's last reference (the cell's first is the previous cell's end, or 0) |
//! | | `nh × 4` | cell hash table, `u32`: cell index + 1, 0 empty; `nh` the power of two ≥ 1.5 `nc` + 1 (0 without cells); a key's home slot is `(key · 0x9E3779B1 mod 2³²) · nh / 2³²`, collisions go to the next slot (linear probing) |
//! | | `nf × 2` | references, `u16` segment indices grouped by cell, padded to 4 bytes with 0 |
//! | | `nm × 52` | landmarks: `wall: u8` (0 left, 1 right), `model: u8` (tag), `segments: u8`, `u8` 0, `first_segment: u16`, `u16` 0, `s_m, offset_m, W, H, D: f32`, `h1…h6: [f32; 6]` |
//! | | u32 | CRC-32 (IEEE) of every byte before it |
//!
//! A query finds a cell's segments through the hash table (about 1.3 probes), not by a
//! binary search of the keys: the lookup costs the same on a 10 km map as on a 100 m one.
//!
//! Everything is checked once when the image is opened ([`MapImage::from_bytes`],
//! [`MapImage::from_region`]): the CRC, then every count, segment, key, reference and
//! landmark, so a query never meets a value it cannot use; queries still read through
//! checked accessors and never panic.

use crate::crc::Crc32;
use crate::geometry::{Point2, Segment};
use crate::landmark::{Genome, LandmarkModel, LandmarkShape, WallFrame, PIECEWISE_HEIGHTS};

use super::error::{Capacity, GeometryError, MapError};
use super::file::After;
use super::grid::{Cell, CellRect, CellSpec, MAX_CELL_COORD};
use super::search::{self, CellIndex};
use super::stored;
use super::wall::{frame_at, polyline_length_m};
use super::{
    FeatureKind, IndexStats, LandmarkBase, LandmarkPlacement, MapHit, MapQuery, MapSegment, RayHit,
    StoredMap, WallEnd, WallEndAt, WallSide,
};

/// First four bytes of every map image.
pub const IMAGE_MAGIC: [u8; 4] = *b"LCMI";

/// The image format version this build reads and writes.
pub const IMAGE_FORMAT_VERSION: u16 = 1;

/// Size of the image header, bytes.
pub const IMAGE_HEADER_LEN: usize = 64;

/// Bytes per stored segment.
const SEGMENT_BYTES: usize = 20;
/// Bytes per landmark record.
const LANDMARK_BYTES: usize = 52;
/// Kind code of the first landmark (landmark `id` is `LANDMARK_KIND + id`).
const LANDMARK_KIND: u16 = 2;
/// Multiplier of the cell hash (Fibonacci hashing: 2³² / φ).
const HASH_MULTIPLIER: u32 = 0x9E37_79B1;

/// Slots of the hash table for `cells` cells: the power of two at or above 1.5 × cells + 1
/// (load ≤ 2/3, so a probe sequence always ends at an empty slot).
fn hash_slots(cells: usize) -> Option<usize> {
    if cells == 0 {
        return Some(0);
    }
    cells
        .checked_add(cells / 2)?
        .checked_add(1)?
        .checked_next_power_of_two()
}

/// The home slot of `key` in a table of `slots` slots.
#[inline]
fn home_slot(key: u32, slots: usize) -> usize {
    ((u64::from(key.wrapping_mul(HASH_MULTIPLIER)) * slots as u64) >> 32) as usize
}

/// Where each section of an image starts, from its counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    left: usize,
    right: usize,
    segments: usize,
    landmarks: usize,
    cells: usize,
    refs: usize,
    keys_at: usize,
    ends_at: usize,
    hash_at: usize,
    hash_slots: usize,
    refs_at: usize,
    landmarks_at: usize,
    crc_at: usize,
}

impl Layout {
    /// The layout of these counts; `None` when the sizes overflow.
    fn new(
        left: usize,
        right: usize,
        landmark_segments: usize,
        landmarks: usize,
        cells: usize,
        refs: usize,
    ) -> Option<Self> {
        let segments = left.checked_add(right)?.checked_add(landmark_segments)?;
        let keys_at = IMAGE_HEADER_LEN.checked_add(segments.checked_mul(SEGMENT_BYTES)?)?;
        let ends_at = keys_at.checked_add(cells.checked_mul(4)?)?;
        let hash_at = ends_at.checked_add(cells.checked_mul(4)?)?;
        let hash_slots = hash_slots(cells)?;
        let refs_at = hash_at.checked_add(hash_slots.checked_mul(4)?)?;
        let refs_bytes = refs.checked_mul(2)?.checked_add(3)? & !3;
        let landmarks_at = refs_at.checked_add(refs_bytes)?;
        let crc_at = landmarks_at.checked_add(landmarks.checked_mul(LANDMARK_BYTES)?)?;
        crc_at.checked_add(4)?;
        Some(Self {
            left,
            right,
            segments,
            landmarks,
            cells,
            refs,
            keys_at,
            ends_at,
            hash_at,
            hash_slots,
            refs_at,
            landmarks_at,
            crc_at,
        })
    }

    /// Image length, bytes.
    fn len(&self) -> usize {
        self.crc_at + 4
    }
}

#[inline]
fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    let s: [u8; 2] = b.get(at..at.checked_add(2)?)?.try_into().ok()?;
    Some(u16::from_le_bytes(s))
}

#[inline]
fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    let s: [u8; 4] = b.get(at..at.checked_add(4)?)?.try_into().ok()?;
    Some(u32::from_le_bytes(s))
}

#[inline]
fn f32_at(b: &[u8], at: usize) -> Option<f32> {
    u32_at(b, at).map(f32::from_bits)
}

/// A map image opened in place: answers [`MapQuery`] from the bytes (flash), holding only
/// its layout in RAM.
#[derive(Debug, Clone, Copy)]
pub struct MapImage<'a> {
    /// The image, header to CRC (padding after it excluded).
    bytes: &'a [u8],
    layout: Layout,
    spec: CellSpec,
    bounds: Option<CellRect>,
}

impl<'a> MapImage<'a> {
    /// Opens an image that is `bytes` exactly (nothing may follow it).
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, MapError> {
        Self::open(bytes, After::Nothing)
    }

    /// Opens the image at the start of a flash region: the bytes after it may be padding,
    /// each `0xFF` (erased flash) or `0x00`; anything else is refused
    /// ([`MapError::TrailingBytes`]).
    pub fn from_region(region: &'a [u8]) -> Result<Self, MapError> {
        Self::open(region, After::Padding)
    }

    fn open(bytes: &'a [u8], after: After) -> Result<Self, MapError> {
        let got = bytes.len();
        let (header, _) =
            bytes
                .split_first_chunk::<IMAGE_HEADER_LEN>()
                .ok_or(MapError::Truncated {
                    needed: IMAGE_HEADER_LEN,
                    got,
                })?;
        let magic = [header[0], header[1], header[2], header[3]];
        if magic != IMAGE_MAGIC {
            return Err(MapError::NotAnImage { found: magic });
        }
        let word = |at: usize| u32_at(header, at).unwrap_or(0) as usize;
        let version = u16_at(header, 4).unwrap_or(0);
        if version != IMAGE_FORMAT_VERSION {
            return Err(MapError::UnsupportedVersion {
                found: version,
                supported: IMAGE_FORMAT_VERSION,
            });
        }
        let reserved = (6..8).chain(40..IMAGE_HEADER_LEN);
        if let Some((offset, &found)) = reserved
            .filter_map(|i| header.get(i).map(|b| (i, b)))
            .find(|&(_, &b)| b != 0)
        {
            return Err(MapError::ReservedNotZero { offset, found });
        }
        let declared = word(8);
        // The CRC first: a damaged count is reported as the damage it is.
        let image = bytes.get(..declared).ok_or(MapError::Truncated {
            needed: declared,
            got,
        })?;
        let Some(crc_at) = declared.checked_sub(4).filter(|&c| c >= IMAGE_HEADER_LEN) else {
            return Err(MapError::Corrupt {
                part: "image length",
                index: 0,
            });
        };
        let stored = u32_at(image, crc_at).unwrap_or(0);
        let mut crc = Crc32::new();
        crc.update(image.get(..crc_at).unwrap_or(&[]));
        let computed = crc.finish();
        if computed != stored {
            return Err(MapError::ChecksumMismatch { stored, computed });
        }
        let rest = bytes.get(declared..).unwrap_or(&[]);
        if let Some((i, &found)) = rest.iter().enumerate().find(|&(_, &b)| !after.allows(b)) {
            return Err(MapError::TrailingBytes {
                map_len: declared,
                offset: declared.saturating_add(i),
                found,
            });
        }
        let layout = Layout::new(word(16), word(20), word(24), word(28), word(32), word(36))
            .filter(|l| l.len() == declared && l.segments <= usize::from(u16::MAX) + 1)
            .ok_or(MapError::Corrupt {
                part: "section counts",
                index: 0,
            })?;
        let cell_size_m = f32_at(header, 12).unwrap_or(f32::NAN);
        if !(cell_size_m.is_finite() && cell_size_m > 1e-3) {
            return Err(GeometryError::BadCellSize { cell_size_m }.into());
        }
        let mut image = Self {
            bytes: image,
            layout,
            spec: CellSpec::new(cell_size_m),
            bounds: None,
        };
        image.check_segments()?;
        image.bounds = image.check_index()?;
        image.check_landmarks()?;
        Ok(image)
    }

    /// Every segment finite, inside the index's coordinate range, of the kind its section
    /// says.
    fn check_segments(&self) -> Result<(), MapError> {
        let l = &self.layout;
        for i in 0..l.segments {
            let corrupt = MapError::Corrupt {
                part: "segment",
                index: u32::try_from(i).unwrap_or(u32::MAX),
            };
            let at = IMAGE_HEADER_LEN + i * SEGMENT_BYTES;
            let kind = u16_at(self.bytes, at + 16).ok_or(corrupt)?;
            let pad = u16_at(self.bytes, at + 18).ok_or(corrupt)?;
            let ms = self.segment_at(i).ok_or(corrupt)?;
            let s = ms.segment;
            let placed = s.a.is_finite()
                && s.b.is_finite()
                && self.spec.cell_of(s.a).is_some()
                && self.spec.cell_of(s.b).is_some();
            let kind_ok = if i < l.left {
                kind == 0
            } else if i < l.left + l.right {
                kind == 1
            } else {
                kind >= LANDMARK_KIND && usize::from(kind - LANDMARK_KIND) < l.landmarks
            };
            if !(placed && kind_ok && pad == 0) {
                return Err(corrupt);
            }
        }
        Ok(())
    }

    /// Keys strictly increasing and in range, ends non-decreasing up to the reference
    /// count, every reference a segment; returns the cells' bounding rectangle.
    fn check_index(&self) -> Result<Option<CellRect>, MapError> {
        let l = &self.layout;
        let mut bounds: Option<CellRect> = None;
        let mut previous: Option<(u32, u32)> = None;
        for i in 0..l.cells {
            let corrupt = MapError::Corrupt {
                part: "index cell",
                index: u32::try_from(i).unwrap_or(u32::MAX),
            };
            let key = u32_at(self.bytes, l.keys_at + 4 * i).ok_or(corrupt)?;
            let end = u32_at(self.bytes, l.ends_at + 4 * i).ok_or(corrupt)?;
            if previous.is_some_and(|(k, e)| key <= k || end < e) || end as usize > l.refs {
                return Err(corrupt);
            }
            previous = Some((key, end));
            let c = Cell {
                ix: i32::from((key >> 16) as u16 as i16),
                iy: i32::from(key as u16 as i16),
            };
            if c.ix.abs() > MAX_CELL_COORD || c.iy.abs() > MAX_CELL_COORD {
                return Err(corrupt);
            }
            bounds = Some(match bounds {
                None => CellRect { min: c, max: c },
                Some(b) => CellRect {
                    min: Cell {
                        ix: b.min.ix.min(c.ix),
                        iy: b.min.iy.min(c.iy),
                    },
                    max: Cell {
                        ix: b.max.ix.max(c.ix),
                        iy: b.max.iy.max(c.iy),
                    },
                },
            });
        }
        if previous.map_or(0, |(_, e)| e as usize) != l.refs {
            return Err(MapError::Corrupt {
                part: "index references count",
                index: 0,
            });
        }
        for j in 0..l.refs {
            let r = u16_at(self.bytes, l.refs_at + 2 * j);
            if r.is_none_or(|r| usize::from(r) >= l.segments) {
                return Err(MapError::Corrupt {
                    part: "index reference",
                    index: u32::try_from(j).unwrap_or(u32::MAX),
                });
            }
        }
        // Every slot empty or a cell, and every cell found where the lookup looks.
        for s in 0..l.hash_slots {
            if u32_at(self.bytes, l.hash_at + 4 * s).is_none_or(|e| e as usize > l.cells) {
                return Err(MapError::Corrupt {
                    part: "index hash slot",
                    index: u32::try_from(s).unwrap_or(u32::MAX),
                });
            }
        }
        for i in 0..l.cells {
            let key = u32_at(self.bytes, l.keys_at + 4 * i);
            if key.and_then(|k| self.find_cell(k)) != Some(i) {
                return Err(MapError::Corrupt {
                    part: "index hash",
                    index: u32::try_from(i).unwrap_or(u32::MAX),
                });
            }
        }
        Ok(bounds)
    }

    /// Every landmark record decodes, passes the map's own checks, and owns exactly the
    /// segments that name it.
    fn check_landmarks(&self) -> Result<(), MapError> {
        let l = &self.layout;
        let first_landmark_segment = l.left + l.right;
        let mut next_segment = first_landmark_segment;
        for i in 0..l.landmarks {
            let id = crate::math::saturating_u16(i);
            let corrupt = MapError::Corrupt {
                part: "landmark",
                index: u32::from(id),
            };
            let (placement, first, count) = self.landmark_record(i).ok_or(corrupt)?;
            placement
                .shape
                .check()
                .map_err(|gene| GeometryError::GenomeOutOfBounds { landmark: id, gene })?;
            if !placement.s_m.is_finite()
                || placement.offset_m.is_nan()
                || placement.offset_m.abs() > super::MAX_LANDMARK_OFFSET_M
            {
                return Err(corrupt);
            }
            // Landmarks' segments follow each other in landmark order.
            if first != next_segment {
                return Err(corrupt);
            }
            for s in first..first + count {
                let kind = u16_at(self.bytes, IMAGE_HEADER_LEN + s * SEGMENT_BYTES + 16);
                if kind != Some(LANDMARK_KIND.saturating_add(id)) {
                    return Err(corrupt);
                }
            }
            next_segment = first + count;
        }
        if next_segment != l.segments {
            return Err(MapError::Corrupt {
                part: "landmark segments",
                index: 0,
            });
        }
        Ok(())
    }

    /// The index of the cell with `key`, through the hash table (at most one pass over it).
    #[inline]
    fn find_cell(&self, key: u32) -> Option<usize> {
        let l = &self.layout;
        if l.hash_slots == 0 {
            return None;
        }
        let mask = l.hash_slots - 1;
        let mut slot = home_slot(key, l.hash_slots);
        for _ in 0..l.hash_slots {
            let entry = u32_at(self.bytes, l.hash_at + 4 * slot)? as usize;
            let cell = entry.checked_sub(1)?;
            if u32_at(self.bytes, l.keys_at + 4 * cell)? == key {
                return Some(cell);
            }
            slot = (slot + 1) & mask;
        }
        None
    }

    /// Segment `i` as stored (kind decoded); `None` past the end or for a bad kind code.
    #[inline]
    fn segment_at(&self, i: usize) -> Option<MapSegment> {
        if i >= self.layout.segments {
            return None;
        }
        let at = IMAGE_HEADER_LEN + i * SEGMENT_BYTES;
        let rec: &[u8; SEGMENT_BYTES] = self.bytes.get(at..at + SEGMENT_BYTES)?.try_into().ok()?;
        let f = |k: usize| f32_at(rec, k).unwrap_or(f32::NAN);
        let kind = match u16_at(rec, 16)? {
            0 => FeatureKind::LeftWall,
            1 => FeatureKind::RightWall,
            k => FeatureKind::Landmark {
                id: k - LANDMARK_KIND,
            },
        };
        Some(MapSegment {
            segment: Segment::new(Point2::new(f(0), f(4)), Point2::new(f(8), f(12))),
            kind,
        })
    }

    /// Landmark `i`'s placement, first segment and segment count.
    fn landmark_record(&self, i: usize) -> Option<(LandmarkPlacement, usize, usize)> {
        if i >= self.layout.landmarks {
            return None;
        }
        let at = self.layout.landmarks_at + i * LANDMARK_BYTES;
        let rec: &[u8; LANDMARK_BYTES] =
            self.bytes.get(at..at + LANDMARK_BYTES)?.try_into().ok()?;
        let f = |k: usize| f32_at(rec, k).unwrap_or(f32::NAN);
        if rec[3] != 0 || u16_at(rec, 6)? != 0 {
            return None;
        }
        let wall = WallSide::from_tag(rec[0])?;
        let model = LandmarkModel::from_tag(rec[1])?;
        let count = usize::from(rec[2]);
        let first = usize::from(u16_at(rec, 4)?);
        let mut heights = [0.0; PIECEWISE_HEIGHTS];
        for (j, h) in heights.iter_mut().enumerate() {
            *h = f(28 + 4 * j);
        }
        let genome = Genome {
            width_m: f(16),
            height_m: f(20),
            spacing_m: f(24),
            heights,
        };
        let placement = LandmarkPlacement {
            wall,
            s_m: f(8),
            offset_m: f(12),
            shape: LandmarkShape::new(model, genome),
        };
        Some((placement, first, count))
    }

    /// Length of the image, bytes (header to CRC).
    pub fn len_bytes(&self) -> usize {
        self.bytes.len()
    }

    /// Number of segments (walls and landmarks).
    pub fn segment_count(&self) -> usize {
        self.layout.segments
    }

    /// Number of landmarks.
    pub fn landmark_count(&self) -> usize {
        self.layout.landmarks
    }

    /// Landmark `id`'s placement (wall, arc position, stand-off, shape), `None` past the
    /// end.
    pub fn landmark(&self, id: u16) -> Option<LandmarkPlacement> {
        self.landmark_record(usize::from(id)).map(|(p, _, _)| p)
    }

    /// Side length of the index cells, metres.
    pub fn cell_size_m(&self) -> f32 {
        self.spec.cell_size_m
    }

    /// Sizes of the spatial index.
    pub fn index_stats(&self) -> IndexStats {
        IndexStats {
            cells: self.layout.cells,
            cell_refs: self.layout.refs,
        }
    }

    /// The segments of one wall, in the direction of increasing chainage (world frame).
    pub fn wall_segments(&self, side: WallSide) -> impl DoubleEndedIterator<Item = Segment> + '_ {
        let l = &self.layout;
        let range = match side {
            WallSide::Left => 0..l.left,
            WallSide::Right => l.left..l.left + l.right,
        };
        range.filter_map(|i| self.segment_at(i).map(|s| s.segment))
    }

    /// Length of one wall's polyline, metres.
    pub fn wall_length_m(&self, side: WallSide) -> f32 {
        polyline_length_m(self.wall_segments(side))
    }

    /// The point, unit tangent and inward normal at arc length `s_m` along a wall (world
    /// frame); `None` off the wall or for non-finite `s_m`.
    pub fn wall_frame_at(&self, side: WallSide, s_m: f32) -> Option<WallFrame> {
        frame_at(side, self.wall_segments(side), s_m)
    }
}

impl CellIndex for MapImage<'_> {
    #[inline]
    fn spec(&self) -> CellSpec {
        self.spec
    }

    #[inline]
    fn bounds(&self) -> Option<CellRect> {
        self.bounds
    }

    fn for_each_ref(&self, c: Cell, f: impl FnMut(u16)) {
        let l = &self.layout;
        let Some(i) = self.find_cell(c.key()) else {
            return;
        };
        let start = match i.checked_sub(1) {
            Some(j) => u32_at(self.bytes, l.ends_at + 4 * j).unwrap_or(0),
            None => 0,
        } as usize;
        let end = u32_at(self.bytes, l.ends_at + 4 * i).unwrap_or(0) as usize;
        let refs = self
            .bytes
            .get(l.refs_at + 2 * start..l.refs_at + 2 * end)
            .unwrap_or(&[]);
        refs.chunks_exact(2)
            .filter_map(|b| b.try_into().ok())
            .map(u16::from_le_bytes)
            .for_each(f);
    }

    #[inline]
    fn segment(&self, i: u16) -> Option<MapSegment> {
        self.segment_at(usize::from(i))
    }
}

/// The same queries, the same answers as the [`StoredMap`] the image was written from (one
/// implementation: `search`).
impl MapQuery for MapImage<'_> {
    fn nearest(&self, p: Point2, max_distance_m: f32) -> Option<MapHit> {
        search::nearest(self, p, max_distance_m)
    }

    fn raycast(&self, origin: Point2, angle_rad: f32, max_range_m: f32) -> Option<RayHit> {
        search::raycast(self, origin, angle_rad, max_range_m)
    }

    fn for_each_landmark_segment_near(
        &self,
        center: Point2,
        radius_m: f32,
        f: &mut dyn FnMut(u16, Segment),
    ) {
        search::for_each_landmark_segment_near(self, center, radius_m, f);
    }

    fn landmark_count(&self) -> u16 {
        u16::try_from(self.layout.landmarks).unwrap_or(u16::MAX)
    }

    fn landmark_base(&self, id: u16) -> Option<LandmarkBase> {
        let (placement, first, count) = self.landmark_record(usize::from(id))?;
        let end = first.checked_add(count)?;
        stored::landmark_base(
            placement.wall,
            (first..end).filter_map(|i| self.segment_at(i).map(|s| s.segment)),
        )
    }

    fn wall_end(&self, wall: WallSide, at: WallEndAt) -> Option<WallEnd> {
        super::wall::polyline_end(wall, at, self.wall_segments(wall))
    }
}

impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    fn image_layout(&self) -> Option<Layout> {
        let (keys, _, refs) = self.index_parts();
        let left = self.wall_segments(WallSide::Left).len();
        let right = self.wall_segments(WallSide::Right).len();
        Layout::new(
            left,
            right,
            self.segments().len().checked_sub(left + right)?,
            self.landmarks().len(),
            keys.len(),
            refs.len(),
        )
    }

    /// Bytes [`StoredMap::write_image`] writes for this map.
    pub fn image_len(&self) -> usize {
        self.image_layout().map_or(usize::MAX, |l| l.len())
    }

    /// Writes the map's flash image (see the module docs) into `out`; returns the bytes
    /// written. [`MapError::BufferTooSmall`] tells how many are needed.
    pub fn write_image(&self, out: &mut [u8]) -> Result<usize, MapError> {
        let got = out.len();
        let l = self.image_layout().ok_or(MapError::CapacityExceeded {
            what: Capacity::SegmentIndex,
            needed: self.segments().len(),
            capacity: usize::from(u16::MAX) + 1,
        })?;
        let len = l.len();
        let out = out
            .get_mut(..len)
            .ok_or(MapError::BufferTooSmall { needed: len, got })?;
        out.fill(0);
        let mut w = Cursor { out, at: 0 };
        w.put(&IMAGE_MAGIC);
        w.put(&IMAGE_FORMAT_VERSION.to_le_bytes());
        w.put(&[0, 0]);
        let word = |n: usize| u32::try_from(n).unwrap_or(u32::MAX).to_le_bytes();
        w.put(&word(len));
        w.put(&self.cell_size_m().to_le_bytes());
        for n in [
            l.left,
            l.right,
            l.segments - l.left - l.right,
            l.landmarks,
            l.cells,
            l.refs,
        ] {
            w.put(&word(n));
        }
        w.at = IMAGE_HEADER_LEN;
        for ms in self.segments() {
            let s = ms.segment;
            for v in [s.a.x_m, s.a.y_m, s.b.x_m, s.b.y_m] {
                w.put(&v.to_le_bytes());
            }
            let kind = match ms.kind {
                FeatureKind::LeftWall => 0,
                FeatureKind::RightWall => 1,
                FeatureKind::Landmark { id } => id.saturating_add(LANDMARK_KIND),
            };
            w.put(&kind.to_le_bytes());
            w.put(&[0, 0]);
        }
        let (keys, ends, refs) = self.index_parts();
        for k in keys.iter().chain(ends) {
            w.put(&k.to_le_bytes());
        }
        // The hash table, filled in key order (linear probing); the buffer is zeroed above.
        let mask = l.hash_slots.wrapping_sub(1);
        for (i, &key) in keys.iter().enumerate() {
            let mut slot = home_slot(key, l.hash_slots);
            while u32_at(w.out, l.hash_at + 4 * slot).is_some_and(|e| e != 0) {
                slot = (slot + 1) & mask;
            }
            let entry = u32::try_from(i + 1).unwrap_or(u32::MAX);
            if let Some(dst) = w
                .out
                .get_mut(l.hash_at + 4 * slot..l.hash_at + 4 * slot + 4)
            {
                dst.copy_from_slice(&entry.to_le_bytes());
            }
        }
        w.at = l.refs_at;
        for r in refs {
            w.put(&r.to_le_bytes());
        }
        w.at = l.landmarks_at;
        for lm in self.landmarks() {
            let p = &lm.placement;
            let g = &p.shape.genome;
            w.put(&[p.wall.tag(), p.shape.model.tag(), lm.segment_count, 0]);
            w.put(&lm.first_segment.to_le_bytes());
            w.put(&[0, 0]);
            for v in [p.s_m, p.offset_m, g.width_m, g.height_m, g.spacing_m]
                .into_iter()
                .chain(g.heights)
            {
                w.put(&v.to_le_bytes());
            }
        }
        let mut crc = Crc32::new();
        crc.update(w.out.get(..l.crc_at).unwrap_or(&[]));
        w.at = l.crc_at;
        w.put(&crc.finish().to_le_bytes());
        Ok(len)
    }
}

/// Writes bytes one after the other into a buffer sized beforehand.
struct Cursor<'b> {
    out: &'b mut [u8],
    at: usize,
}

impl Cursor<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmark::LandmarkModel;
    use crate::map::TunnelMap;
    use crate::testkit::{LandmarkLayout, TunnelSpec};

    /// Room for the test tunnel's image (about 14 KB).
    const BUF: usize = 32 * 1024;

    fn tunnel() -> TunnelMap {
        let mut map = TunnelMap::new();
        TunnelSpec::curved(120.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 3))
            .build_into(&mut map)
            .unwrap();
        map
    }

    /// The map's image in a buffer, and its length.
    fn image_of(map: &TunnelMap) -> ([u8; BUF], usize) {
        let mut buf = [0u8; BUF];
        let n = map.write_image(&mut buf).unwrap();
        assert_eq!(n, map.image_len());
        (buf, n)
    }

    #[test]
    fn an_image_answers_every_query_as_its_map_does() {
        let map = tunnel();
        let (buf, n) = image_of(&map);
        let image = MapImage::from_bytes(&buf[..n]).unwrap();
        assert_eq!(image.segment_count(), map.segments().len());
        assert_eq!(image.landmark_count(), map.landmarks().len());
        assert_eq!(image.index_stats(), map.index_stats());
        for (i, l) in map.landmarks().iter().enumerate() {
            assert_eq!(image.landmark(i as u16), Some(l.placement));
        }
        for side in [WallSide::Left, WallSide::Right] {
            assert_eq!(image.wall_length_m(side), map.wall_length_m(side));
            assert_eq!(
                image.wall_frame_at(side, 17.3),
                map.wall_frame_at(side, 17.3)
            );
            for at in WallEndAt::BOTH {
                let end = map.wall_end(side, at).unwrap();
                assert_eq!(image.wall_end(side, at), Some(end));
                // The end is the polyline's end vertex; `outward` points out of the wall.
                let frame_s = if at == WallEndAt::Start {
                    0.0
                } else {
                    map.wall_length_m(side)
                };
                let frame = map.wall_frame_at(side, frame_s).unwrap();
                assert!(end.point.dist(frame.anchor) < 1e-3, "{end:?} {frame:?}");
                assert!(end.tangent().dot(frame.tangent) > 0.999);
                assert!(end.inward_normal().dot(frame.inward_normal) > 0.999);
            }
        }
        let mut rng = crate::rng::Pcg32::seeded(11);
        for _ in 0..2000 {
            let p = Point2::new(rng.uniform(-10.0, 130.0), rng.uniform(-10.0, 60.0));
            let a = rng.uniform(-4.0, 4.0);
            assert_eq!(image.nearest(p, 3.0), map.nearest(p, 3.0));
            assert_eq!(image.raycast(p, a, 80.0), map.raycast(p, a, 80.0));
            let mut from_image: heapless::Vec<(u16, Segment), 32> = heapless::Vec::new();
            let mut from_map: heapless::Vec<(u16, Segment), 32> = heapless::Vec::new();
            image.for_each_landmark_segment_near(p, 4.0, &mut |id, s| {
                from_image.push((id, s)).unwrap()
            });
            map.for_each_landmark_segment_near(p, 4.0, &mut |id, s| {
                from_map.push((id, s)).unwrap()
            });
            assert_eq!(from_image, from_map);
        }
    }

    #[test]
    fn a_region_takes_padding_after_the_image_and_nothing_else() {
        let (mut buf, n) = image_of(&tunnel());
        buf[n..n + 100].fill(0xFF);
        let region = &mut buf[..n + 100];
        assert!(MapImage::from_region(region).is_ok());
        assert!(matches!(
            MapImage::from_bytes(region),
            Err(MapError::TrailingBytes { map_len, offset, found: 0xFF }) if map_len == n && offset == n
        ));
        region[n + 7] = 0x42;
        assert!(matches!(
            MapImage::from_region(region),
            Err(MapError::TrailingBytes { found: 0x42, .. })
        ));
    }

    #[test]
    fn damage_and_other_files_are_refused_with_what_is_wrong() {
        let map = tunnel();
        let (bytes, n) = image_of(&map);
        // A map file is not an image: the error says so (and the fix).
        let mut file = [0u8; BUF];
        let f = map.to_slice(&mut file).unwrap();
        assert_eq!(
            MapImage::from_bytes(&file[..f]).map(|_| ()),
            Err(MapError::NotAnImage { found: *b"LCMP" })
        );
        // A byte flipped anywhere in the body: the CRC catches it.
        for at in [IMAGE_HEADER_LEN, n / 2, n - 5] {
            let mut d = bytes;
            d[at] ^= 0x10;
            assert!(matches!(
                MapImage::from_bytes(&d[..n]),
                Err(MapError::ChecksumMismatch { .. })
            ));
        }
        // Cut anywhere: truncated.
        for cut in [10, IMAGE_HEADER_LEN + 3, n - 1] {
            assert!(matches!(
                MapImage::from_bytes(&bytes[..cut]),
                Err(MapError::Truncated { .. })
            ));
        }
        let mut v = bytes;
        v[4] = 9;
        assert!(matches!(
            MapImage::from_bytes(&v[..n]),
            Err(MapError::UnsupportedVersion { found: 9, .. })
        ));
    }

    /// Re-sealing a damaged body with a fresh CRC reaches the structural checks: a segment
    /// reference past the end, unsorted keys, a landmark naming the wrong segments, a
    /// non-finite vertex.
    #[test]
    fn structure_is_checked_behind_a_valid_checksum() {
        let map = tunnel();
        let (bytes, n) = image_of(&map);
        let l = MapImage::from_bytes(&bytes[..n]).unwrap().layout;
        let reseal = |mut d: [u8; BUF]| {
            let crc = crate::crc::crc32(&d[..l.crc_at]);
            d[l.crc_at..l.crc_at + 4].copy_from_slice(&crc.to_le_bytes());
            d
        };
        let mut d = bytes;
        d[l.refs_at..l.refs_at + 2].copy_from_slice(&u16::MAX.to_le_bytes());
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "index reference",
                ..
            })
        ));
        let mut d = bytes;
        d.copy_within(l.keys_at..l.keys_at + 4, l.keys_at + 4);
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "index cell",
                index: 1
            })
        ));
        // A hash slot naming no cell; a cell's slot emptied (its lookups would miss it).
        let mut d = bytes;
        d[l.hash_at..l.hash_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "index hash slot",
                index: 0
            })
        ));
        let mut d = bytes;
        let home = home_slot(
            u32::from_le_bytes(d[l.keys_at..l.keys_at + 4].try_into().unwrap()),
            l.hash_slots,
        );
        d[l.hash_at + 4 * home..l.hash_at + 4 * home + 4].fill(0);
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "index hash",
                ..
            })
        ));
        let mut d = bytes;
        d[l.landmarks_at + 4] ^= 1;
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "landmark",
                index: 0
            })
        ));
        let mut d = bytes;
        d[IMAGE_HEADER_LEN..IMAGE_HEADER_LEN + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(matches!(
            MapImage::from_bytes(&reseal(d)[..n]),
            Err(MapError::Corrupt {
                part: "segment",
                index: 0
            })
        ));
    }

    #[test]
    fn an_empty_map_has_an_image_that_answers_nothing() {
        let mut map = TunnelMap::new();
        map.rebuild(&[], &[], &[], 2.0).unwrap();
        let (buf, n) = image_of(&map);
        let image = MapImage::from_bytes(&buf[..n]).unwrap();
        assert_eq!(image.nearest(Point2::new(0.0, 0.0), 10.0), None);
        assert_eq!(image.raycast(Point2::new(0.0, 0.0), 0.0, 10.0), None);
        assert_eq!(image.wall_frame_at(WallSide::Left, 0.0), None);
        assert_eq!(image.wall_end(WallSide::Right, WallEndAt::Finish), None);
    }
}
