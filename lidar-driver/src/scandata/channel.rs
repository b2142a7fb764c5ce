//! Measurement channels of a scan (DIST1…DIST5, RSSI1…RSSI5, …): header and values, zero-copy.

use crate::args::{ArgError, ArgReader};
use crate::frame::Dialect;

use super::error::{ScanError, ScanField};

/// Width of a channel's values on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ChannelBits {
    /// 8-bit values (RSSI on the LMS5xx).
    U8,
    /// 16-bit values (distances; RSSI on the TiM).
    U16,
}

impl ChannelBits {
    /// Bytes per value in CoLa-B.
    pub fn bytes(self) -> usize {
        match self {
            ChannelBits::U8 => 1,
            ChannelBits::U16 => 2,
        }
    }
}

/// What a channel measures, from its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ChannelKind {
    /// `DISTn`: distance of echo n (1…5).
    Distance(u8),
    /// `RSSIn`: received signal strength of echo n (1…5).
    Rssi(u8),
    /// Any other name (`ANGL`, `VANG` on multi-layer models).
    Other,
}

/// The 21-byte (CoLa-B) header of a channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelHeader {
    /// Five ASCII characters, e.g. `DIST1`.
    pub name: [u8; 5],
    /// Multiply raw values by this (1.0; 2.0 in long-range modes).
    pub scale_factor: f32,
    /// Then add this (mm for distance channels).
    pub scale_offset: f32,
    /// Angle of the first value, 1/10000°, sensor frame.
    pub start_angle_1e4_deg: i32,
    /// Angle between values, 1/10000°.
    pub step_1e4_deg: u16,
    /// Number of values.
    pub count: u16,
}

impl ChannelHeader {
    pub(crate) fn read(r: &mut ArgReader<'_>) -> Result<Self, ScanError> {
        let name_bytes = r
            .fixed_text(5)
            .map_err(ScanError::at(ScanField::ChannelName))?;
        let mut name = [0u8; 5];
        name.copy_from_slice(name_bytes);
        Ok(ChannelHeader {
            name,
            scale_factor: r.f32().map_err(ScanError::at(ScanField::ScaleFactor))?,
            scale_offset: r.f32().map_err(ScanError::at(ScanField::ScaleOffset))?,
            start_angle_1e4_deg: r.i32().map_err(ScanError::at(ScanField::StartAngle))?,
            step_1e4_deg: r.u16().map_err(ScanError::at(ScanField::AngularStep))?,
            count: r.u16().map_err(ScanError::at(ScanField::ValueCount))?,
        })
    }

    /// The name as text.
    pub fn name_str(&self) -> &str {
        core::str::from_utf8(&self.name).unwrap_or("?????")
    }

    /// What the channel measures.
    pub fn kind(&self) -> ChannelKind {
        let echo = self.name[4].wrapping_sub(b'0');
        match &self.name[..4] {
            b"DIST" if (1..=5).contains(&echo) => ChannelKind::Distance(echo),
            b"RSSI" if (1..=5).contains(&echo) => ChannelKind::Rssi(echo),
            _ => ChannelKind::Other,
        }
    }

    /// Angle of value `i`, 1/10000°, sensor frame.
    pub fn angle_1e4_deg(&self, i: usize) -> i64 {
        self.start_angle_1e4_deg as i64 + i as i64 * self.step_1e4_deg as i64
    }

    /// Angle of value `i`, degrees, sensor frame.
    pub fn angle_deg(&self, i: usize) -> f64 {
        self.angle_1e4_deg(i) as f64 / 10_000.0
    }
}

/// One channel: header plus its values, borrowed from the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channel<'a> {
    /// The header fields.
    pub header: ChannelHeader,
    bits: ChannelBits,
    dialect: Dialect,
    values: &'a [u8],
}

impl<'a> Channel<'a> {
    /// Value width.
    pub fn bits(&self) -> ChannelBits {
        self.bits
    }

    /// Name, e.g. `DIST1`.
    pub fn name(&self) -> &str {
        self.header.name_str()
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.header.count as usize
    }

    /// True for a channel without values.
    pub fn is_empty(&self) -> bool {
        self.header.count == 0
    }

    /// The raw values as sent (8-bit values widened), without allocation.
    pub fn values(&self) -> ChannelValues<'a> {
        let inner = match (self.dialect, self.bits) {
            (Dialect::ColaB, ChannelBits::U16) => Inner::B16(self.values.chunks_exact(2)),
            (Dialect::ColaB, ChannelBits::U8) => Inner::B8(self.values.iter()),
            (Dialect::ColaA, _) => Inner::A(self.values),
        };
        ChannelValues {
            inner,
            left: self.header.count as usize,
        }
    }

    /// Value `i` as sent. O(1) in CoLa-B, O(i) in CoLa-A.
    pub fn get(&self, i: usize) -> Option<u16> {
        match (self.dialect, self.bits) {
            (Dialect::ColaB, ChannelBits::U16) => {
                let b = self.values.get(2 * i..2 * i + 2)?;
                Some(u16::from_be_bytes([b[0], b[1]]))
            }
            (Dialect::ColaB, ChannelBits::U8) => self.values.get(i).map(|&v| v as u16),
            (Dialect::ColaA, _) => self.values().nth(i),
        }
    }

    /// Value `i` scaled: `value × scale_factor + scale_offset` (mm for distance channels).
    pub fn scaled(&self, raw: u16) -> f32 {
        raw as f32 * self.header.scale_factor + self.header.scale_offset
    }

    /// Distances in mm (scale and offset applied); `None` where the raw value is 0 (no echo).
    pub fn distances_mm(&self) -> impl Iterator<Item = Option<f32>> + 'a {
        let (f, o) = (self.header.scale_factor, self.header.scale_offset);
        self.values()
            .map(move |v| (v != 0).then_some(v as f32 * f + o))
    }

    /// Distances in m (scale and offset applied); `None` where the raw value is 0 (no echo).
    pub fn ranges_m(&self) -> impl Iterator<Item = Option<f32>> + 'a {
        self.distances_mm().map(|d| d.map(|mm| mm * 1e-3))
    }

    /// The bytes (CoLa-B) or text (CoLa-A) holding the values.
    pub fn raw_values(&self) -> &'a [u8] {
        self.values
    }
}

#[derive(Debug, Clone)]
enum Inner<'a> {
    B16(core::slice::ChunksExact<'a, u8>),
    B8(core::slice::Iter<'a, u8>),
    A(&'a [u8]),
}

/// Iterator over a channel's raw values (checked when the scan was decoded).
#[derive(Debug, Clone)]
pub struct ChannelValues<'a> {
    inner: Inner<'a>,
    left: usize,
}

impl Iterator for ChannelValues<'_> {
    type Item = u16;

    #[inline]
    fn next(&mut self) -> Option<u16> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        match &mut self.inner {
            Inner::B16(c) => c.next().map(|b| u16::from_be_bytes([b[0], b[1]])),
            Inner::B8(i) => i.next().map(|&b| b as u16),
            Inner::A(text) => {
                let t = *text;
                let start = t.iter().position(|&b| b != b' ')?;
                let t = t.get(start..)?;
                let len = t.iter().position(|&b| b == b' ').unwrap_or(t.len());
                *text = t.get(len..).unwrap_or(&[]);
                let tok = t.get(..len)?;
                // Validated at decode time: hex, or signed decimal that fits.
                crate::args::hex_fast(tok)
                    .or_else(|| crate::args::parse_number(tok).map(|(v, _)| v))
                    .map(|v| v as u16)
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }

    /// Dispatches on the representation once, not per value (fast `sum`, `for_each`, …).
    fn fold<Acc, F: FnMut(Acc, u16) -> Acc>(self, init: Acc, mut f: F) -> Acc {
        let n = self.left;
        match self.inner {
            Inner::B16(c) => c
                .take(n)
                .fold(init, |a, b| f(a, u16::from_be_bytes([b[0], b[1]]))),
            Inner::B8(i) => i.take(n).fold(init, |a, &b| f(a, b as u16)),
            Inner::A(text) => {
                let mut acc = init;
                let rest = ChannelValues {
                    inner: Inner::A(text),
                    left: n,
                };
                for v in rest {
                    acc = f(acc, v);
                }
                acc
            }
        }
    }
}

impl ExactSizeIterator for ChannelValues<'_> {}

/// A block of channels of one width (all 16-bit ones, or all 8-bit ones), checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Channels<'a> {
    dialect: Dialect,
    bits: ChannelBits,
    count: u16,
    region: &'a [u8],
    base: usize,
}

impl<'a> Channels<'a> {
    /// Reads the count and checks every channel in the block, leaving `r` after it.
    pub(crate) fn read(r: &mut ArgReader<'a>, bits: ChannelBits) -> Result<Self, ScanError> {
        let count_field = match bits {
            ChannelBits::U16 => ScanField::Channel16Count,
            ChannelBits::U8 => ScanField::Channel8Count,
        };
        let count = r.u16().map_err(ScanError::at(count_field))?;
        let start = r.position();
        let base = r.offset();
        let all = r.rest();
        for _ in 0..count {
            let h = ChannelHeader::read(r)?;
            r.values_region(h.count as usize, bits.bytes())
                .map_err(ScanError::at(ScanField::Values))?;
        }
        let len = r.position() - start;
        Ok(Channels {
            dialect: r.dialect(),
            bits,
            count,
            region: all.get(..len).unwrap_or(&[]),
            base,
        })
    }

    /// Number of channels.
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// True without channels.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Value width of this block.
    pub fn bits(&self) -> ChannelBits {
        self.bits
    }

    /// The channels in wire order.
    pub fn iter(&self) -> ChannelIter<'a> {
        ChannelIter {
            reader: ArgReader::new(self.dialect, self.region, self.base),
            bits: self.bits,
            left: self.count,
        }
    }
}

impl<'a> IntoIterator for Channels<'a> {
    type Item = Channel<'a>;
    type IntoIter = ChannelIter<'a>;
    fn into_iter(self) -> ChannelIter<'a> {
        self.iter()
    }
}

/// Iterator over the channels of a block.
#[derive(Debug, Clone)]
pub struct ChannelIter<'a> {
    reader: ArgReader<'a>,
    bits: ChannelBits,
    left: u16,
}

impl<'a> Iterator for ChannelIter<'a> {
    type Item = Channel<'a>;

    fn next(&mut self) -> Option<Channel<'a>> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        // The block was checked when decoded, so these reads succeed.
        let header = ChannelHeader::read(&mut self.reader).ok()?;
        let values = skip_values(&mut self.reader, header.count as usize, self.bits).ok()?;
        Some(Channel {
            header,
            bits: self.bits,
            dialect: self.reader.dialect(),
            values,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left as usize, Some(self.left as usize))
    }
}

/// Skips values already checked: CoLa-B by length, CoLa-A by splitting tokens only.
fn skip_values<'a>(
    r: &mut ArgReader<'a>,
    n: usize,
    bits: ChannelBits,
) -> Result<&'a [u8], ArgError> {
    match r.dialect() {
        Dialect::ColaB => r.values_region(n, bits.bytes()),
        Dialect::ColaA => {
            let rest = r.rest();
            let mut pos = 0;
            for _ in 0..n {
                let t = rest.get(pos..).unwrap_or(&[]);
                let s = t.iter().position(|&b| b != b' ').unwrap_or(t.len());
                let l = t
                    .get(s..)
                    .unwrap_or(&[])
                    .iter()
                    .position(|&b| b == b' ')
                    .unwrap_or(t.len() - s);
                pos += s + l;
            }
            let region = rest.get(..pos).unwrap_or(&[]);
            r.skip_bytes(pos);
            Ok(region)
        }
    }
}
