//! `sSN LMDscandata` / `sRA LMDscandata`: the scan telegram, decoded zero-copy.
//!
//! [`ScanData::new_checked`] walks the whole telegram once (every field, every channel value
//! token in CoLa-A) and keeps the fixed fields by value and the channels as borrowed regions, so
//! values are iterated without allocation and without further checks. CoLa-A and CoLa-B give
//! identical values. The fields are read in wire order through [`crate::args::ArgReader`]
//! ([`ScanField`] names them in that order), not by fixed offsets: after the encoder count
//! everything depends on the counts, and CoLa-A has no offsets at all.

mod channel;
mod error;

pub use channel::{
    Channel, ChannelBits, ChannelHeader, ChannelIter, ChannelKind, ChannelValues, Channels,
};
pub use error::{ScanError, ScanField};

use crate::args::{ArgReader, LenWidth};
use crate::frame::{Dialect, Frame};
use crate::request::names;
use crate::telegram::{CommandType, Telegram};

/// The fixed fields at the start of every scan telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScanHeader {
    /// Telegram version (0 on LMS511 V1.80, 1 on LMS111 and TiM).
    pub version: u16,
    /// Device number.
    pub device_number: u16,
    /// Serial number.
    pub serial_number: u32,
    /// Device status, two bytes (`01 00` on the first scan after start, then `00 00`).
    pub device_status: [u8; 2],
    /// Telegram counter.
    pub telegram_counter: u16,
    /// Scan counter, +1 per scan.
    pub scan_counter: u16,
    /// Time since start-up at the first shot, µs (wraps after 71.6 min).
    pub time_since_startup_us: u32,
    /// Time of transmission, µs.
    pub time_of_transmission_us: u32,
    /// Input status, two bytes.
    pub input_status: [u8; 2],
    /// Output status, two bytes.
    pub output_status: [u8; 2],
    /// Reserved; the layer angle on multi-layer models.
    pub reserved_layer_angle: i16,
    /// Scan frequency, 1/100 Hz (2500 = 25 Hz).
    pub scan_frequency_1e2_hz: u32,
    /// Measurement (shot) frequency, 100 Hz units (540 = 54 kHz).
    pub measurement_frequency_100hz: u32,
}

impl ScanHeader {
    fn read(r: &mut ArgReader<'_>) -> Result<Self, ScanError> {
        use ScanField as F;
        let at = ScanError::at;
        let pair = |r: &mut ArgReader<'_>, f| -> Result<[u8; 2], ScanError> {
            Ok([r.u8().map_err(at(f))?, r.u8().map_err(at(f))?])
        };
        Ok(ScanHeader {
            version: r.u16().map_err(at(F::Version))?,
            device_number: r.u16().map_err(at(F::DeviceNumber))?,
            serial_number: r.u32().map_err(at(F::SerialNumber))?,
            device_status: pair(r, F::DeviceStatus)?,
            telegram_counter: r.u16().map_err(at(F::TelegramCounter))?,
            scan_counter: r.u16().map_err(at(F::ScanCounter))?,
            time_since_startup_us: r.u32().map_err(at(F::TimeSinceStartup))?,
            time_of_transmission_us: r.u32().map_err(at(F::TimeOfTransmission))?,
            input_status: pair(r, F::InputStatus)?,
            output_status: pair(r, F::OutputStatus)?,
            reserved_layer_angle: r.i16().map_err(at(F::ReservedLayerAngle))?,
            scan_frequency_1e2_hz: r.u32().map_err(at(F::ScanFrequency))?,
            measurement_frequency_100hz: r.u32().map_err(at(F::MeasurementFrequency))?,
        })
    }

    /// Scan frequency, Hz.
    pub fn scan_frequency_hz(&self) -> f32 {
        self.scan_frequency_1e2_hz as f32 / 100.0
    }
}

/// One encoder: position and speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Encoder {
    /// Position, increments.
    pub position: u32,
    /// Speed, increments per ms (signed).
    pub speed: i16,
}

/// The encoders of a scan, checked; iterate without allocation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Encoders<'a> {
    reader: ArgReader<'a>,
    count: u16,
}

impl<'a> Encoders<'a> {
    fn read(r: &mut ArgReader<'a>) -> Result<Self, ScanError> {
        let count = r.u16().map_err(ScanError::at(ScanField::EncoderCount))?;
        let start = *r;
        for _ in 0..count {
            r.u32().map_err(ScanError::at(ScanField::Encoder))?;
            r.i16().map_err(ScanError::at(ScanField::Encoder))?;
        }
        Ok(Encoders {
            reader: start,
            count,
        })
    }

    /// Number of encoders.
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// True without encoders.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The encoders in wire order.
    pub fn iter(&self) -> impl Iterator<Item = Encoder> + 'a {
        let mut r = self.reader;
        (0..self.count).map_while(move |_| {
            Some(Encoder {
                position: r.u32().ok()?,
                speed: r.i16().ok()?,
            })
        })
    }
}

/// Optional position block (6 × f32 + rotation type u8). Documented only (not seen on the wire): no capture has one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionBlock {
    /// X position.
    pub x: f32,
    /// Y position.
    pub y: f32,
    /// Z position.
    pub z: f32,
    /// Rotation about X.
    pub rot_x: f32,
    /// Rotation about Y.
    pub rot_y: f32,
    /// Rotation about Z.
    pub rot_z: f32,
    /// Rotation type.
    pub rotation_type: u8,
}

impl PositionBlock {
    fn read(r: &mut ArgReader<'_>) -> Result<Self, ScanError> {
        let at = ScanError::at(ScanField::Position);
        Ok(PositionBlock {
            x: r.f32().map_err(&at)?,
            y: r.f32().map_err(&at)?,
            z: r.f32().map_err(&at)?,
            rot_x: r.f32().map_err(&at)?,
            rot_y: r.f32().map_err(&at)?,
            rot_z: r.f32().map_err(&at)?,
            rotation_type: r.u8().map_err(&at)?,
        })
    }
}

/// Optional time block: the sensor's clock at the scan (11 bytes in CoLa-B).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TimeBlock {
    /// Year.
    pub year: u16,
    /// Month 1…12.
    pub month: u8,
    /// Day 1…31.
    pub day: u8,
    /// Hour 0…23.
    pub hour: u8,
    /// Minute.
    pub minute: u8,
    /// Second.
    pub second: u8,
    /// Microseconds within the second.
    pub microsecond: u32,
}

impl TimeBlock {
    fn read(r: &mut ArgReader<'_>) -> Result<Self, ScanError> {
        let at = ScanError::at(ScanField::Time);
        Ok(TimeBlock {
            year: r.u16().map_err(&at)?,
            month: r.u8().map_err(&at)?,
            day: r.u8().map_err(&at)?,
            hour: r.u8().map_err(&at)?,
            minute: r.u8().map_err(&at)?,
            second: r.u8().map_err(&at)?,
            microsecond: r.u32().map_err(&at)?,
        })
    }
}

/// Optional event block (`FDIN`, encoder position, time, angle). Documented only (not seen on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EventBlock {
    /// Event type, 4 ASCII characters (`FDIN`).
    pub kind: [u8; 4],
    /// Encoder position at the event.
    pub encoder_position: u32,
    /// Time of the event, µs.
    pub time_us: u32,
    /// Angle of the event, 1/10000°.
    pub angle_1e4_deg: i32,
}

impl EventBlock {
    fn read(r: &mut ArgReader<'_>) -> Result<Self, ScanError> {
        let at = ScanError::at(ScanField::Event);
        let k = r.fixed_text(4).map_err(&at)?;
        let mut kind = [0u8; 4];
        kind.copy_from_slice(k);
        Ok(EventBlock {
            kind,
            encoder_position: r.u32().map_err(&at)?,
            time_us: r.u32().map_err(&at)?,
            angle_1e4_deg: r.i32().map_err(&at)?,
        })
    }
}

/// The optional blocks after the channels.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Tail<'a> {
    position: Option<PositionBlock>,
    device_name: Option<(&'a [u8], LenWidth)>,
    comment: Option<(&'a [u8], LenWidth)>,
    time: Option<TimeBlock>,
    event: Option<EventBlock>,
}

impl<'a> Tail<'a> {
    fn read(
        r: &mut ArgReader<'a>,
        name_w: LenWidth,
        comment_w: LenWidth,
    ) -> Result<Self, ScanError> {
        use ScanField as F;
        let at = ScanError::at;
        let position = if r.flag_u16().map_err(at(F::PositionFlag))? {
            Some(PositionBlock::read(r)?)
        } else {
            None
        };
        let device_name = if r.flag_u16().map_err(at(F::DeviceNameFlag))? {
            Some((r.string(name_w).map_err(at(F::DeviceName))?, name_w))
        } else {
            None
        };
        let comment = if r.flag_u16().map_err(at(F::CommentFlag))? {
            Some((r.string(comment_w).map_err(at(F::Comment))?, comment_w))
        } else {
            None
        };
        let time = if r.flag_u16().map_err(at(F::TimeFlag))? {
            Some(TimeBlock::read(r)?)
        } else {
            None
        };
        let event = if r.flag_u16().map_err(at(F::EventFlag))? {
            Some(EventBlock::read(r)?)
        } else {
            None
        };
        r.finish().map_err(at(F::End))?;
        Ok(Tail {
            position,
            device_name,
            comment,
            time,
            event,
        })
    }

    /// The device name / comment length width is not settled (u8 or u16): accept what the
    /// device sends. Tries u16 (the SOPAS string rule) first; the first combination that reads
    /// the telegram exactly to its end wins. CoLa-A has a length token, so one try suffices.
    fn read_any(r: &mut ArgReader<'a>) -> Result<Self, ScanError> {
        use LenWidth::{U16, U8};
        let combos: &[(LenWidth, LenWidth)] = match r.dialect() {
            Dialect::ColaA => &[(U16, U16)],
            Dialect::ColaB => &[(U16, U16), (U8, U8), (U16, U8), (U8, U16)],
        };
        let mut first_err = None;
        for &(n, c) in combos {
            let mut attempt = *r;
            match Tail::read(&mut attempt, n, c) {
                Ok(t) => {
                    *r = attempt;
                    return Ok(t);
                }
                Err(e) => {
                    first_err.get_or_insert(e);
                }
            }
        }
        Err(first_err.unwrap_or(ScanError::Field {
            field: ScanField::End,
            offset: r.offset(),
            kind: crate::args::ArgErrorKind::Truncated,
        }))
    }
}

/// A decoded scan telegram: fixed fields by value, channels borrowed from the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanData<'a> {
    dialect: Dialect,
    kind: CommandType,
    /// The fixed fields.
    pub header: ScanHeader,
    encoders: Encoders<'a>,
    channels16: Channels<'a>,
    channels8: Channels<'a>,
    tail: Tail<'a>,
}

impl<'a> ScanData<'a> {
    /// Decodes and checks a whole scan frame (either dialect).
    pub fn new_checked(frame: Frame<'a>) -> Result<Self, ScanError> {
        let t = Telegram::parse(frame).map_err(ScanError::Telegram)?;
        Self::from_telegram(&t)
    }

    /// True if the telegram is `sSN LMDscandata` or `sRA LMDscandata`.
    pub fn is_scan_telegram(t: &Telegram<'_>) -> bool {
        matches!(t.kind(), CommandType::Event | CommandType::ReadAnswer)
            && t.name() == names::SCAN_DATA
    }

    /// Decodes and checks a scan telegram.
    pub fn from_telegram(t: &Telegram<'a>) -> Result<Self, ScanError> {
        if !Self::is_scan_telegram(t) {
            return Err(ScanError::NotScanData { kind: t.kind() });
        }
        let mut r = t.reader();
        let header = ScanHeader::read(&mut r)?;
        let encoders = Encoders::read(&mut r)?;
        let channels16 = Channels::read(&mut r, ChannelBits::U16)?;
        let channels8 = Channels::read(&mut r, ChannelBits::U8)?;
        let tail = Tail::read_any(&mut r)?;
        Ok(ScanData {
            dialect: t.dialect(),
            kind: t.kind(),
            header,
            encoders,
            channels16,
            channels8,
            tail,
        })
    }

    /// Dialect the scan came in.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// `sSN` (streamed) or `sRA` (polled).
    pub fn command_type(&self) -> CommandType {
        self.kind
    }

    /// Encoders.
    pub fn encoders(&self) -> Encoders<'a> {
        self.encoders
    }

    /// The 16-bit channels (DIST1…5, 16-bit RSSI).
    pub fn channels16(&self) -> Channels<'a> {
        self.channels16
    }

    /// The 8-bit channels (RSSI on the LMS5xx).
    pub fn channels8(&self) -> Channels<'a> {
        self.channels8
    }

    /// All channels: the 16-bit block, then the 8-bit block.
    pub fn channels(&self) -> impl Iterator<Item = Channel<'a>> + 'a {
        self.channels16.iter().chain(self.channels8.iter())
    }

    /// The channel with this name (`DIST1`, `RSSI1`, …).
    pub fn channel(&self, name: &str) -> Option<Channel<'a>> {
        self.channels().find(|c| c.header.name == name.as_bytes())
    }

    /// First-echo distances (`DIST1`), if present.
    pub fn dist1(&self) -> Option<Channel<'a>> {
        self.channels16
            .iter()
            .find(|c| c.header.kind() == ChannelKind::Distance(1))
    }

    /// Position block, if sent.
    pub fn position(&self) -> Option<PositionBlock> {
        self.tail.position
    }

    /// Device name bytes, if sent.
    pub fn device_name(&self) -> Option<&'a [u8]> {
        self.tail.device_name.map(|(n, _)| n)
    }

    /// Width of the device name's length prefix as the device sent it (CoLa-B).
    pub fn device_name_len_width(&self) -> Option<LenWidth> {
        self.tail.device_name.map(|(_, w)| w)
    }

    /// Comment bytes, if sent.
    pub fn comment(&self) -> Option<&'a [u8]> {
        self.tail.comment.map(|(n, _)| n)
    }

    /// Width of the comment's length prefix as the device sent it (CoLa-B).
    pub fn comment_len_width(&self) -> Option<LenWidth> {
        self.tail.comment.map(|(_, w)| w)
    }

    /// Time block, if sent.
    pub fn time(&self) -> Option<TimeBlock> {
        self.tail.time
    }

    /// Event block, if sent.
    pub fn event(&self) -> Option<EventBlock> {
        self.tail.event
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-written CoLa-A scan in the device's style: hex tokens, two's complement start
    /// angle, a signed decimal token, a device name with a space, a comment, a time block.
    #[test]
    fn cola_a_scan_with_every_token_form() {
        let t = b"\x02sSN LMDscandata 1 1 89A27F 0 0 343 347 27477BA9 2747813B 0 0 7 0 0 1388 168 1 3E8 -5 1 DIST1 40000000 00000000 FFF92230 1388 3 0 +100 FFFF 1 RSSI1 3F800000 00000000 FFF92230 1388 3 FE 0 1 0 1 9 LMS511 HD 1 2 ok 1 7E9 B 16 5 1F 3B F4240 0\x03";
        let f = Frame::new_checked(t).unwrap();
        let s = ScanData::new_checked(f).unwrap();
        assert_eq!(s.header.version, 1);
        assert_eq!(s.header.serial_number, 0x89A27F);
        assert_eq!(s.header.output_status, [7, 0]);
        assert_eq!(s.header.scan_frequency_1e2_hz, 5000);
        let enc: Vec<Encoder> = s.encoders().iter().collect();
        assert_eq!(
            enc,
            [Encoder {
                position: 1000,
                speed: -5
            }]
        );
        let d = s.dist1().unwrap();
        assert_eq!(d.header.start_angle_1e4_deg, -450_000);
        assert!(d.values().eq([0u16, 100, 0xFFFF]));
        let mm: Vec<Option<f32>> = d.distances_mm().collect();
        assert_eq!(mm, [None, Some(200.0), Some(131_070.0)]);
        let r = s.channel("RSSI1").unwrap();
        assert_eq!(r.bits(), ChannelBits::U8);
        assert!(r.values().eq([0xFEu16, 0, 1]));
        assert_eq!(s.device_name(), Some(&b"LMS511 HD"[..]));
        assert_eq!(s.comment(), Some(&b"ok"[..]));
        let tb = s.time().unwrap();
        assert_eq!(
            (tb.year, tb.month, tb.day, tb.microsecond),
            (2025, 11, 22, 1_000_000)
        );
    }

    #[test]
    fn cola_a_value_out_of_range_names_the_field() {
        let t = b"\x02sSN LMDscandata 1 1 89A27F 0 0 343 347 27477BA9 2747813B 0 0 7 0 0 1388 168 0 0 1 RSSI1 3F800000 00000000 FFF92230 1388 2 FE 100 0 0 0 0 0\x03";
        let e = ScanData::new_checked(Frame::new_checked(t).unwrap()).unwrap_err();
        match e {
            ScanError::Field {
                field,
                offset,
                kind,
            } => {
                assert_eq!(field, ScanField::Values);
                assert_eq!(kind, crate::args::ArgErrorKind::OutOfRange);
                assert_eq!(&t[offset..offset + 3], b"100");
            }
            other => panic!("{other:?}"),
        }
    }
}
