//! The map file: how a [`StoredMap`] is saved to flash or disk and read back.
//!
//! ## Layout (format version 1)
//! A 16-byte header, little-endian:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 4]` | magic `LCMP` |
//! | 4 | u16 | format version ([`MAP_FORMAT_VERSION`]) |
//! | 6 | u16 | reserved, 0 |
//! | 8 | u32 | payload length in bytes |
//! | 12 | u32 | CRC-32 (IEEE) of the payload |
//!
//! then the payload, a sequence of `postcard` items:
//! `cell_size_m: f32`, left wall (`count: varint u32`, `count × (x_m, y_m): (f32, f32)`),
//! right wall (same), landmarks (`count: varint u32`, then per landmark `model: u8` (tag of
//! [`LandmarkModel`]), `wall: u8` (0 left, 1 right), `s_m: f32`, `offset_m: f32`,
//! `W, H, D: f32`, and for F1…F4 only `h1…h6: [f32; 6]`).
//!
//! Landmarks are stored compactly (model, genes, arc position), not as expanded polylines;
//! loading expands them and rebuilds the index.
//!
//! The CRC covers the payload only, so the bytes outside it are checked on their own: the
//! reserved header bytes must be 0 ([`MapError::ReservedNotZero`]: a different encoder, or
//! damage), and nothing may follow the payload ([`MapError::TrailingBytes`]: another file
//! appended, or the tail of an older, longer map). A map in a flash region that is longer
//! than the map is read with [`StoredMap::load_from_region`], which takes erased or
//! zero-filled padding (`0xFF` or `0x00` bytes) after the map and nothing else.

use crate::crc::{crc32, Crc32};
use crate::geometry::Point2;
use crate::landmark::{Genome, LandmarkModel, LandmarkShape};

use super::error::{Capacity, MapError};
use super::stored::WallCursor;
use super::{LandmarkPlacement, StoredMap, WallSide};

/// First four bytes of every map file.
pub const MAP_MAGIC: [u8; 4] = *b"LCMP";

/// The format version this build reads and writes.
pub const MAP_FORMAT_VERSION: u16 = 1;

/// Size of the header, bytes.
pub const MAP_HEADER_LEN: usize = 16;

/// What may follow the map's payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum After {
    /// Nothing: the bytes are one map file.
    Nothing,
    /// Flash padding: `0xFF` (erased) or `0x00` (zero-filled) bytes.
    Padding,
}

impl After {
    pub(crate) fn allows(self, byte: u8) -> bool {
        self == After::Padding && (byte == 0xFF || byte == 0x00)
    }
}

/// The fixed part of a landmark record.
#[derive(serde::Serialize, serde::Deserialize)]
struct LandmarkRecord {
    model: u8,
    wall: u8,
    s_m: f32,
    offset_m: f32,
    width_m: f32,
    height_m: f32,
    spacing_m: f32,
}

/// Writes postcard items one after the other into a buffer, or only counts their size.
struct Writer<'b> {
    buf: Option<&'b mut [u8]>,
    len: usize,
    overflow: bool,
}

impl Writer<'_> {
    fn item<T: serde::Serialize>(&mut self, value: &T) {
        let mut scratch = [0u8; 64];
        let written = match self.buf.as_deref_mut() {
            Some(buf) => match buf.get_mut(self.len..) {
                Some(rest) => postcard::to_slice(value, rest).map(|s| s.len()),
                None => Err(postcard::Error::SerializeBufferFull),
            },
            None => postcard::to_slice(value, &mut scratch).map(|s| s.len()),
        };
        match written {
            Ok(n) => self.len += n,
            Err(_) => {
                // Keep counting so the caller learns the size needed.
                self.overflow = true;
                self.len += postcard::to_slice(value, &mut scratch).map_or(0, |s| s.len());
            }
        }
    }
}

/// Reads postcard items one after the other.
struct Reader<'b> {
    rest: &'b [u8],
}

impl<'b> Reader<'b> {
    fn item<T: serde::Deserialize<'b>>(
        &mut self,
        part: &'static str,
        index: usize,
    ) -> Result<T, MapError> {
        let (v, rest) =
            postcard::take_from_bytes::<T>(self.rest).map_err(|_| MapError::Corrupt {
                part,
                index: u32::try_from(index).unwrap_or(u32::MAX),
            })?;
        self.rest = rest;
        Ok(v)
    }
}

impl<const SEGMENTS: usize, const LANDMARKS: usize, const CELLS: usize, const CELL_REFS: usize>
    StoredMap<SEGMENTS, LANDMARKS, CELLS, CELL_REFS>
{
    fn write_payload(&self, w: &mut Writer<'_>) {
        w.item(&self.cell_size_m());
        for side in [WallSide::Left, WallSide::Right] {
            let n = self.wall_vertices(side).count();
            w.item(&u32::try_from(n).unwrap_or(u32::MAX));
            for p in self.wall_vertices(side) {
                w.item(&(p.x_m, p.y_m));
            }
        }
        w.item(&u32::try_from(self.landmarks().len()).unwrap_or(u32::MAX));
        for l in self.landmarks() {
            let p = &l.placement;
            let g = &p.shape.genome;
            w.item(&LandmarkRecord {
                model: p.shape.model.tag(),
                wall: p.wall.tag(),
                s_m: p.s_m,
                offset_m: p.offset_m,
                width_m: g.width_m,
                height_m: g.height_m,
                spacing_m: g.spacing_m,
            });
            if p.shape.model.is_piecewise() {
                w.item(&g.heights);
            }
        }
    }

    /// Bytes [`StoredMap::to_slice`] writes for this map (header included).
    pub fn serialized_len(&self) -> usize {
        let mut w = Writer {
            buf: None,
            len: 0,
            overflow: false,
        };
        self.write_payload(&mut w);
        MAP_HEADER_LEN + w.len
    }

    /// Saves the map (header + postcard payload) into `buf`; returns the bytes written.
    /// [`MapError::BufferTooSmall`] tells how many bytes are needed.
    pub fn to_slice(&self, buf: &mut [u8]) -> Result<usize, MapError> {
        let got = buf.len();
        let Some((header, payload)) = buf.split_at_mut_checked(MAP_HEADER_LEN) else {
            return Err(MapError::BufferTooSmall {
                needed: self.serialized_len(),
                got,
            });
        };
        let mut w = Writer {
            buf: Some(payload),
            len: 0,
            overflow: false,
        };
        self.write_payload(&mut w);
        let len = w.len;
        if w.overflow {
            return Err(MapError::BufferTooSmall {
                needed: MAP_HEADER_LEN + len,
                got,
            });
        }
        let payload_len = u32::try_from(len).map_err(|_| MapError::BufferTooSmall {
            needed: MAP_HEADER_LEN + len,
            got,
        })?;
        let crc = crc32(w.buf.as_deref().and_then(|b| b.get(..len)).unwrap_or(&[]));
        let mut h = [0u8; MAP_HEADER_LEN];
        h[..4].copy_from_slice(&MAP_MAGIC);
        h[4..6].copy_from_slice(&MAP_FORMAT_VERSION.to_le_bytes());
        h[8..12].copy_from_slice(&payload_len.to_le_bytes());
        h[12..16].copy_from_slice(&crc.to_le_bytes());
        header.copy_from_slice(&h);
        Ok(MAP_HEADER_LEN + len)
    }

    /// Loads a map saved by [`StoredMap::to_slice`]: `bytes` are the file, nothing more
    /// (see [`StoredMap::load_from_bytes`]).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, MapError> {
        let mut map = Self::new();
        map.load_from_bytes(bytes)?;
        Ok(map)
    }

    /// Loads a map in place (no second copy of a large map on the stack) from `bytes`, which
    /// are one map file and nothing more: a byte after the payload is refused
    /// ([`MapError::TrailingBytes`]), as is a reserved header byte that is not 0
    /// ([`MapError::ReservedNotZero`]). On error the map is left empty.
    pub fn load_from_bytes(&mut self, bytes: &[u8]) -> Result<(), MapError> {
        self.load_checked(bytes, After::Nothing)
    }

    /// Loads the map at the start of a flash region (the firmware's map partition): as
    /// [`StoredMap::load_from_bytes`], except that the region's bytes after the map may be
    /// padding, each `0xFF` (erased flash) or `0x00` (a zero-filled image). Any other byte
    /// there is refused ([`MapError::TrailingBytes`]): left-overs of an older, longer map
    /// flashed without an erase, or a region that does not hold what its writer meant.
    pub fn load_from_region(&mut self, region: &[u8]) -> Result<(), MapError> {
        self.load_checked(region, After::Padding)
    }

    fn load_checked(&mut self, bytes: &[u8], after: After) -> Result<(), MapError> {
        let r = self.load_inner(bytes, after);
        if r.is_err() {
            self.clear();
        }
        r
    }

    fn load_inner(&mut self, bytes: &[u8], allowed_after: After) -> Result<(), MapError> {
        let got = bytes.len();
        let Some((header, after)) = bytes.split_first_chunk::<MAP_HEADER_LEN>() else {
            return Err(MapError::Truncated {
                needed: MAP_HEADER_LEN,
                got,
            });
        };
        let [m0, m1, m2, m3, v0, v1, r0, r1, l0, l1, l2, l3, c0, c1, c2, c3] = *header;
        let magic = [m0, m1, m2, m3];
        if magic != MAP_MAGIC {
            return Err(MapError::BadMagic { found: magic });
        }
        let version = u16::from_le_bytes([v0, v1]);
        if version != MAP_FORMAT_VERSION {
            return Err(MapError::UnsupportedVersion {
                found: version,
                supported: MAP_FORMAT_VERSION,
            });
        }
        if let Some((offset, found)) = [(6, r0), (7, r1)].into_iter().find(|&(_, b)| b != 0) {
            return Err(MapError::ReservedNotZero { offset, found });
        }
        let payload_len = u32::from_le_bytes([l0, l1, l2, l3]) as usize;
        let stored = u32::from_le_bytes([c0, c1, c2, c3]);
        let Some(payload) = after.get(..payload_len) else {
            return Err(MapError::Truncated {
                needed: MAP_HEADER_LEN.saturating_add(payload_len),
                got,
            });
        };
        let mut crc = Crc32::new();
        crc.update(payload);
        let computed = crc.finish();
        if computed != stored {
            return Err(MapError::ChecksumMismatch { stored, computed });
        }
        // Checked after the CRC: a damaged length field is reported as the damage it is.
        let map_len = MAP_HEADER_LEN.saturating_add(payload_len);
        let rest = after.get(payload_len..).unwrap_or(&[]);
        if let Some((i, &found)) = rest
            .iter()
            .enumerate()
            .find(|&(_, &b)| !allowed_after.allows(b))
        {
            return Err(MapError::TrailingBytes {
                map_len,
                offset: map_len.saturating_add(i),
                found,
            });
        }
        self.decode_payload(payload)
    }

    fn decode_payload(&mut self, payload: &[u8]) -> Result<(), MapError> {
        self.clear();
        let mut r = Reader { rest: payload };
        let cell_size_m: f32 = r.item("cell size", 0)?;
        for (side, part, count_part) in [
            (WallSide::Left, "left wall vertex", "left wall vertex count"),
            (
                WallSide::Right,
                "right wall vertex",
                "right wall vertex count",
            ),
        ] {
            let n: u32 = r.item(count_part, 0)?;
            let n = n as usize;
            let needed = self.segments().len() + n.saturating_sub(1);
            if needed > SEGMENTS {
                return Err(MapError::CapacityExceeded {
                    what: Capacity::Segments,
                    needed,
                    capacity: SEGMENTS,
                });
            }
            let mut cursor = WallCursor::new(side);
            for i in 0..n {
                let (x_m, y_m): (f32, f32) = r.item(part, i)?;
                self.push_wall_vertex(&mut cursor, Point2::new(x_m, y_m))?;
            }
            self.end_wall(&cursor)?;
        }
        let n: u32 = r.item("landmark count", 0)?;
        let n = n as usize;
        if n > LANDMARKS {
            return Err(MapError::CapacityExceeded {
                what: Capacity::Landmarks,
                needed: n,
                capacity: LANDMARKS,
            });
        }
        for i in 0..n {
            let rec: LandmarkRecord = r.item("landmark", i)?;
            let model = LandmarkModel::from_tag(rec.model).ok_or(MapError::Corrupt {
                part: "landmark model tag",
                index: u32::try_from(i).unwrap_or(u32::MAX),
            })?;
            let wall = WallSide::from_tag(rec.wall).ok_or(MapError::Corrupt {
                part: "landmark wall tag",
                index: u32::try_from(i).unwrap_or(u32::MAX),
            })?;
            let heights: [f32; 6] = if model.is_piecewise() {
                r.item("landmark heights", i)?
            } else {
                [0.0; 6]
            };
            let genome = Genome::piecewise(rec.width_m, rec.height_m, rec.spacing_m, heights);
            self.add_landmark(LandmarkPlacement {
                wall,
                s_m: rec.s_m,
                offset_m: rec.offset_m,
                shape: LandmarkShape::new(model, genome),
            })?;
        }
        if !r.rest.is_empty() {
            return Err(MapError::Corrupt {
                part: "trailing bytes after the landmarks",
                index: u32::try_from(r.rest.len()).unwrap_or(u32::MAX),
            });
        }
        self.build_index(cell_size_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{MapQuery, TunnelMap};
    use crate::testkit::{LandmarkLayout, TunnelSpec};

    type Small = StoredMap<512, 64, 512, 2048>;

    fn sample() -> Small {
        let spec = TunnelSpec::curved(60.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::F4SymmetricInverted, 2));
        let mut m = Small::new();
        spec.build_into(&mut m).unwrap();
        m
    }

    #[test]
    fn round_trip_is_exact() {
        let m = sample();
        let mut buf = [0u8; 8192];
        let n = m.to_slice(&mut buf).unwrap();
        assert_eq!(n, m.serialized_len());
        let back = Small::from_bytes(&buf[..n]).unwrap();
        assert_eq!(back.segments(), m.segments());
        assert_eq!(back.landmarks(), m.landmarks());
        assert_eq!(back.cell_size_m(), m.cell_size_m());
        assert_eq!(back.index_stats(), m.index_stats());
        let p = Point2::new(20.0, 3.0);
        assert_eq!(back.nearest(p, 5.0), m.nearest(p, 5.0));
        // A flash region may pad the map with erased or zero bytes.
        buf[n..n + 8].fill(0xFF);
        let mut region = Small::new();
        region.load_from_region(&buf[..n + 16]).unwrap();
        assert_eq!(region.segments(), m.segments());
        assert_eq!(region.landmarks(), m.landmarks());
        region.load_from_region(&buf[..n]).unwrap();
    }

    #[test]
    fn bytes_outside_the_checksum_are_checked() {
        let m = sample();
        let mut buf = [0u8; 8192];
        let n = m.to_slice(&mut buf).unwrap();
        let bytes = &buf[..n];
        // A flipped reserved header byte.
        for (offset, flip) in [(6, 0x01), (7, 0x80)] {
            let mut bad = bytes.to_vec();
            bad[offset] ^= flip;
            assert_eq!(
                Small::from_bytes(&bad).unwrap_err(),
                MapError::ReservedNotZero {
                    offset,
                    found: flip
                }
            );
            let mut target = sample();
            assert!(target.load_from_region(&bad).is_err());
            assert!(target.is_empty());
        }
        // One byte appended to the file, whatever its value.
        for extra in [0x00, 0xFF, 0x42] {
            let mut longer = bytes.to_vec();
            longer.push(extra);
            assert_eq!(
                Small::from_bytes(&longer).unwrap_err(),
                MapError::TrailingBytes {
                    map_len: n,
                    offset: n,
                    found: extra
                }
            );
        }
        // In a flash region, padding is taken and anything else after the map is not: the
        // tail of an older map left in the region, say.
        let mut region = bytes.to_vec();
        region.extend_from_slice(&[0xFF; 32]);
        region.extend_from_slice(&[0x00; 32]);
        assert!(Small::new().load_from_region(&region).is_ok());
        region[n + 40] = 0x3F;
        assert_eq!(
            Small::new().load_from_region(&region).unwrap_err(),
            MapError::TrailingBytes {
                map_len: n,
                offset: n + 40,
                found: 0x3F
            }
        );
        // The checksum still comes first: a damaged payload is reported as damaged.
        let mut flip = region.clone();
        flip[n / 2] ^= 0x10;
        assert!(matches!(
            Small::new().load_from_region(&flip),
            Err(MapError::ChecksumMismatch { .. })
        ));
    }

    #[test]
    fn damaged_bytes_give_named_errors() {
        let m = sample();
        let mut buf = [0u8; 8192];
        let n = m.to_slice(&mut buf).unwrap();
        let bytes = &buf[..n];
        assert_eq!(
            Small::from_bytes(&bytes[..10]).unwrap_err(),
            MapError::Truncated {
                needed: 16,
                got: 10
            }
        );
        assert_eq!(
            Small::from_bytes(&bytes[..n - 1]).unwrap_err(),
            MapError::Truncated {
                needed: n,
                got: n - 1
            }
        );
        let mut bad = bytes.to_vec();
        bad[0] = b'X';
        assert!(matches!(
            Small::from_bytes(&bad),
            Err(MapError::BadMagic { .. })
        ));
        let mut v2 = bytes.to_vec();
        v2[4] = 2;
        assert_eq!(
            Small::from_bytes(&v2).unwrap_err(),
            MapError::UnsupportedVersion {
                found: 2,
                supported: 1
            }
        );
        let mut flip = bytes.to_vec();
        flip[n / 2] ^= 0x10;
        assert!(matches!(
            Small::from_bytes(&flip),
            Err(MapError::ChecksumMismatch { .. })
        ));
        // A valid checksum over a payload that does not decode: named part.
        let mut junk = bytes.to_vec();
        junk[16..20].copy_from_slice(&[0xFF; 4]); // cell size NaN-ish, then the count
        junk[20] = 0xFF; // varint continuation without end
        junk.truncate(21);
        let len = (junk.len() - 16) as u32;
        junk[8..12].copy_from_slice(&len.to_le_bytes());
        let crc = crc32(&junk[16..]);
        junk[12..16].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            Small::from_bytes(&junk).unwrap_err(),
            MapError::Corrupt {
                part: "left wall vertex count",
                index: 0
            }
        );
        // Too small a buffer says how much is needed.
        let mut tiny = [0u8; 100];
        assert_eq!(
            m.to_slice(&mut tiny).unwrap_err(),
            MapError::BufferTooSmall {
                needed: n,
                got: 100
            }
        );
        // A map too big for a smaller capacity names the capacity.
        assert!(matches!(
            StoredMap::<64, 64, 512, 2048>::from_bytes(bytes),
            Err(MapError::CapacityExceeded {
                what: Capacity::Segments,
                ..
            })
        ));
        // A failed load leaves the map empty.
        let mut target = sample();
        assert!(target.load_from_bytes(&flip).is_err());
        assert!(target.is_empty());
    }

    extern crate std;

    #[test]
    fn one_km_tunnel_with_landmarks_fits_in_64_kib() {
        let spec = TunnelSpec::straight(1000.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 11));
        let mut m = TunnelMap::new();
        spec.build_into(&mut m).unwrap();
        let mut buf = std::vec![0u8; 128 * 1024];
        let n = m.to_slice(&mut buf).unwrap();
        std::println!(
            "1 km tunnel, walls every 1 m, {} P1 landmarks: {n} bytes; index {:?}",
            m.landmarks().len(),
            m.index_stats()
        );
        assert!(m.landmarks().len() >= 200);
        assert!(n <= 64 * 1024, "{n} bytes");
        let back = TunnelMap::from_bytes(&buf[..n]).unwrap();
        assert_eq!(back.segments(), m.segments());
    }
}
