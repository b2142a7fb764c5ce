//! `ScanRepr`: an owned scan telegram, parsed from a [`ScanData`] or built by a simulator, and
//! emitted as a real LMS5xx `LMDscandata` frame in CoLa-B or CoLa-A.
//!
//! Emitting a parsed CoLa-B scan in CoLa-B reproduces the original bytes exactly.

use alloc::vec::Vec;

use crate::args::{EmitError, LenWidth, TelegramWriter};
use crate::frame::Dialect;
use crate::request::names;
use crate::scandata::{
    Channel, ChannelBits, Encoder, EventBlock, PositionBlock, ScanData, ScanHeader, TimeBlock,
};
use crate::telegram::CommandType;

/// One owned channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelRepr {
    /// Five ASCII characters, e.g. `DIST1`.
    pub name: [u8; 5],
    /// Scale factor (raw × factor + offset).
    pub scale_factor: f32,
    /// Scale offset.
    pub scale_offset: f32,
    /// Angle of the first value, 1/10000°, sensor frame.
    pub start_angle_1e4_deg: i32,
    /// Angle between values, 1/10000°.
    pub step_1e4_deg: u16,
    /// Raw values as sent (for 8-bit channels each must be ≤ 255).
    pub values: Vec<u16>,
}

impl ChannelRepr {
    /// Copies a decoded channel.
    pub fn from_channel(c: &Channel<'_>) -> Self {
        ChannelRepr {
            name: c.header.name,
            scale_factor: c.header.scale_factor,
            scale_offset: c.header.scale_offset,
            start_angle_1e4_deg: c.header.start_angle_1e4_deg,
            step_1e4_deg: c.header.step_1e4_deg,
            values: c.values().collect(),
        }
    }

    fn emit(&self, w: &mut TelegramWriter<'_>, bits: ChannelBits) -> Result<(), EmitError> {
        let n = u16::try_from(self.values.len()).map_err(|_| EmitError::TooLong)?;
        w.fixed_text(&self.name)?
            .f32(self.scale_factor)?
            .f32(self.scale_offset)?
            .i32(self.start_angle_1e4_deg)?
            .u16(self.step_1e4_deg)?
            .u16(n)?;
        match bits {
            ChannelBits::U16 => {
                w.u16_values(&self.values)?;
            }
            ChannelBits::U8 => {
                let bytes: Vec<u8> = self
                    .values
                    .iter()
                    .map(|&v| u8::try_from(v).map_err(|_| EmitError::TooLong))
                    .collect::<Result<_, _>>()?;
                w.u8_values(&bytes)?;
            }
        }
        Ok(())
    }
}

/// An owned `LMDscandata` telegram: every field of the notes.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanRepr {
    /// `sSN` (streamed, the usual) or `sRA` (answer to a poll).
    pub command_type: CommandType,
    /// The fixed fields.
    pub header: ScanHeader,
    /// Encoders (position, speed).
    pub encoders: Vec<Encoder>,
    /// 16-bit channels in wire order (DIST1…5, 16-bit RSSI).
    pub channels16: Vec<ChannelRepr>,
    /// 8-bit channels in wire order (RSSI on the LMS5xx).
    pub channels8: Vec<ChannelRepr>,
    /// Optional position block.
    pub position: Option<PositionBlock>,
    /// Optional device name, with the CoLa-B length width to write it with.
    pub device_name: Option<(Vec<u8>, LenWidth)>,
    /// Optional comment, with the CoLa-B length width to write it with.
    pub comment: Option<(Vec<u8>, LenWidth)>,
    /// Optional time block.
    pub time: Option<TimeBlock>,
    /// Optional event block.
    pub event: Option<EventBlock>,
}

impl ScanRepr {
    /// Copies every field of a decoded scan.
    pub fn parse(s: &ScanData<'_>) -> Self {
        ScanRepr {
            command_type: s.command_type(),
            header: s.header,
            encoders: s.encoders().iter().collect(),
            channels16: s
                .channels16()
                .iter()
                .map(|c| ChannelRepr::from_channel(&c))
                .collect(),
            channels8: s
                .channels8()
                .iter()
                .map(|c| ChannelRepr::from_channel(&c))
                .collect(),
            position: s.position(),
            device_name: s
                .device_name()
                .map(|n| (n.to_vec(), s.device_name_len_width().unwrap_or_default())),
            comment: s
                .comment()
                .map(|n| (n.to_vec(), s.comment_len_width().unwrap_or_default())),
            time: s.time(),
            event: s.event(),
        }
    }

    /// Upper bound of the emitted frame length in `dialect`, bytes (exact for CoLa-B).
    pub fn max_frame_len(&self, dialect: Dialect) -> usize {
        let values: usize = self
            .channels16
            .iter()
            .map(|c| c.values.len())
            .sum::<usize>()
            * 2
            + self.channels8.iter().map(|c| c.values.len()).sum::<usize>();
        let nch = self.channels16.len() + self.channels8.len();
        let strings = self.device_name.as_ref().map_or(0, |(n, _)| n.len() + 2)
            + self.comment.as_ref().map_or(0, |(n, _)| n.len() + 2);
        let b = 9
            + 16
            + 38
            + 6 * self.encoders.len()
            + 4
            + 21 * nch
            + values
            + 10
            + 25
            + 11
            + 16
            + strings;
        match dialect {
            Dialect::ColaB => b,
            // Every byte becomes at most 2 hex digits + a space, plus 8-digit floats.
            Dialect::ColaA => 3 * b + 64,
        }
    }

    /// Writes the frame into `buf`; returns its length.
    pub fn emit(&self, dialect: Dialect, buf: &mut [u8]) -> Result<usize, EmitError> {
        let mut w = TelegramWriter::begin(dialect, buf, self.command_type, names::SCAN_DATA)?;
        let h = &self.header;
        w.u16(h.version)?
            .u16(h.device_number)?
            .u32(h.serial_number)?
            .u8(h.device_status[0])?
            .u8(h.device_status[1])?
            .u16(h.telegram_counter)?
            .u16(h.scan_counter)?
            .u32(h.time_since_startup_us)?
            .u32(h.time_of_transmission_us)?
            .u8(h.input_status[0])?
            .u8(h.input_status[1])?
            .u8(h.output_status[0])?
            .u8(h.output_status[1])?
            .i16(h.reserved_layer_angle)?
            .u32(h.scan_frequency_1e2_hz)?
            .u32(h.measurement_frequency_100hz)?;
        w.u16(u16::try_from(self.encoders.len()).map_err(|_| EmitError::TooLong)?)?;
        for e in &self.encoders {
            w.u32(e.position)?.i16(e.speed)?;
        }
        for (chans, bits) in [
            (&self.channels16, ChannelBits::U16),
            (&self.channels8, ChannelBits::U8),
        ] {
            w.u16(u16::try_from(chans.len()).map_err(|_| EmitError::TooLong)?)?;
            for c in chans {
                c.emit(&mut w, bits)?;
            }
        }
        w.flag_u16(self.position.is_some())?;
        if let Some(p) = &self.position {
            w.f32(p.x)?
                .f32(p.y)?
                .f32(p.z)?
                .f32(p.rot_x)?
                .f32(p.rot_y)?
                .f32(p.rot_z)?
                .u8(p.rotation_type)?;
        }
        for s in [&self.device_name, &self.comment] {
            w.flag_u16(s.is_some())?;
            if let Some((text, width)) = s {
                w.string(text, *width)?;
            }
        }
        w.flag_u16(self.time.is_some())?;
        if let Some(t) = &self.time {
            w.u16(t.year)?
                .u8(t.month)?
                .u8(t.day)?
                .u8(t.hour)?
                .u8(t.minute)?
                .u8(t.second)?
                .u32(t.microsecond)?;
        }
        w.flag_u16(self.event.is_some())?;
        if let Some(e) = &self.event {
            w.fixed_text(&e.kind)?
                .u32(e.encoder_position)?
                .u32(e.time_us)?
                .i32(e.angle_1e4_deg)?;
        }
        w.finish()
    }

    /// Emits into a new vector.
    pub fn to_vec(&self, dialect: Dialect) -> Result<Vec<u8>, EmitError> {
        let mut v = alloc::vec![0u8; self.max_frame_len(dialect)];
        let n = self.emit(dialect, &mut v)?;
        v.truncate(n);
        Ok(v)
    }
}
