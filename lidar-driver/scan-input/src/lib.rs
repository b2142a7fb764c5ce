//! # scan-input: an `LMDscandata` telegram becomes a `loc-core` scan, in one place
//!
//! `loc-core` knows nothing of SICK telegrams and `lidar-driver` nothing of localisation;
//! this crate is where the two meet, and the only place that turns a telegram's distance
//! channel into a [`loc_core::scan::Scan`]. The firmware's controller, `host-sim replay` and
//! the simulator's live runs all go through it, so a scan means the same beams wherever it
//! is localised.
//!
//! What it takes from the telegram ([`BeamLayout`]):
//! - the layout of the `DIST1` channel: start angle, step and beam count, as the scanner
//!   sends them (any start angle, any resolution: nothing is assumed from a configuration);
//! - the **exact step**: the telegram rounds the step to 1/10000° (1667 for the LMS511's
//!   1/6°: 0.04° off at the last of 1141 beams, 5 cm at 80 m). The header also carries the
//!   scan frequency and the shot (measurement) frequency, and `360° · f_scan / f_shot` is
//!   the step the scanner really steps by. It is used when it rounds to the telegram's own
//!   step (so a header that does not describe the channel is never trusted over it);
//! - the channel's scale factor and offset (mm = raw · factor + offset; 2.0 in long-range
//!   modes), a raw 0 as no echo and a raw `0xFFFF` as a saturated reading, not a range.
//!
//! `no_std`, no allocation, no panics: it runs on the controller.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

use core::fmt;

use lidar_driver::scandata::ChannelHeader;
use lidar_driver::{ChannelKind, ScanData, ScanHeader};
use loc_core::scan::{Scan, ScanGeometry, SensorSetup, LMS511_MAX_BEAMS};

/// Radians per 1/10000 degree.
const RAD_PER_1E4_DEG: f64 = core::f64::consts::PI / 180.0 / 10_000.0;

/// The beam layout of a telegram's distance channel, with the header's frequencies that
/// give the exact step. Sensor frame: beam `i` at `start + i · step`, counter-clockwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BeamLayout {
    /// Angle of the first beam, 1/10000° (−50000 = −5° on the LMS5xx).
    pub start_angle_1e4_deg: i32,
    /// Step between beams as the telegram rounds it, 1/10000° (1667 for 1/6°).
    pub step_1e4_deg: u16,
    /// Beams in the channel.
    pub beams: u16,
    /// Scan frequency, 1/100 Hz (2500 = 25 Hz); 0 when unknown.
    pub scan_frequency_1e2_hz: u32,
    /// Shot (measurement) frequency, 100 Hz units (540 = 54 kHz); 0 when unknown.
    pub measurement_frequency_100hz: u32,
}

impl BeamLayout {
    /// The layout of `channel` in a telegram with header `header`.
    pub fn of(header: &ScanHeader, channel: &ChannelHeader) -> Self {
        Self {
            start_angle_1e4_deg: channel.start_angle_1e4_deg,
            step_1e4_deg: channel.step_1e4_deg,
            beams: channel.count,
            scan_frequency_1e2_hz: header.scan_frequency_1e2_hz,
            measurement_frequency_100hz: header.measurement_frequency_100hz,
        }
    }

    /// `360° · f_scan / f_shot` in 1/10000°, when both frequencies are known and it rounds
    /// to the telegram's step (within half a unit); `None` otherwise.
    pub fn exact_step_1e4_deg(&self) -> Option<f64> {
        if self.measurement_frequency_100hz == 0 || self.scan_frequency_1e2_hz == 0 {
            return None;
        }
        // f_scan [Hz] = s / 100, f_shot [Hz] = m · 100, step [1e-4 deg] = 360e4 · f_scan / f_shot.
        let exact = 360.0 * f64::from(self.scan_frequency_1e2_hz)
            / f64::from(self.measurement_frequency_100hz);
        let diff = exact - f64::from(self.step_1e4_deg);
        (diff.abs() <= 0.5).then_some(exact)
    }

    /// The step used: the exact one when the telegram allows it, else the rounded field,
    /// 1/10000°.
    pub fn step_used_1e4_deg(&self) -> f64 {
        self.exact_step_1e4_deg()
            .unwrap_or(f64::from(self.step_1e4_deg))
    }

    /// Angle of the first beam, radians (sensor frame).
    pub fn start_angle_rad(&self) -> f64 {
        f64::from(self.start_angle_1e4_deg) * RAD_PER_1E4_DEG
    }

    /// The step used, radians.
    pub fn step_rad(&self) -> f64 {
        self.step_used_1e4_deg() * RAD_PER_1E4_DEG
    }

    /// Angle of beam `index`, radians (sensor frame, not wrapped).
    pub fn beam_angle_rad(&self, index: usize) -> f64 {
        self.start_angle_rad() + index as f64 * self.step_rad()
    }

    /// The layout as loc-core's beam geometry, with the range limits `min_range_m` and
    /// `max_range_m` of the sensor setup.
    pub fn geometry(&self, min_range_m: f32, max_range_m: f32) -> ScanGeometry {
        ScanGeometry {
            start_angle_rad: self.start_angle_rad() as f32,
            step_rad: self.step_rad() as f32,
            min_range_m,
            max_range_m,
        }
    }
}

/// Why a scan telegram could not be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ScanInputError {
    /// The telegram has no 16-bit `DIST1` channel: enable it in `LMDscandatacfg` (the
    /// session's default configuration does).
    NoDistanceChannel,
    /// More beams than a [`Scan`] holds (1141, the LMS511 at 190° / 0.1667°): the scanner is
    /// configured for a finer resolution or a wider field than the localiser is built for.
    TooManyBeams {
        /// Beams in the telegram.
        beams: u16,
    },
}

impl fmt::Display for ScanInputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanInputError::NoDistanceChannel => f.write_str(
                "scan telegram without a 16-bit DIST1 channel: enable DIST1 in LMDscandatacfg",
            ),
            ScanInputError::TooManyBeams { beams } => write!(
                f,
                "scan telegram with {beams} beams, at most {LMS511_MAX_BEAMS}: configure the scanner for 0.1667° over 190° or coarser"
            ),
        }
    }
}

/// Fills `scan` from `telegram`'s `DIST1` channel: its own beam layout (exact step where the
/// telegram allows), its scale, and `sensor`'s mounting and range limits. Returns the
/// layout used.
pub fn load_scan(
    telegram: &ScanData<'_>,
    sensor: &SensorSetup,
    scan: &mut Scan,
) -> Result<BeamLayout, ScanInputError> {
    let channel = telegram
        .channels16()
        .iter()
        .find(|c| c.header.kind() == ChannelKind::Distance(1))
        .ok_or(ScanInputError::NoDistanceChannel)?;
    let h = channel.header;
    let layout = BeamLayout::of(&telegram.header, &h);
    load_values(
        &layout,
        channel.values(),
        h.scale_factor,
        h.scale_offset,
        sensor,
        scan,
    )?;
    Ok(layout)
}

/// Fills `scan` from raw distance values laid out as `layout` (what [`load_scan`] does once
/// it has the channel; the simulator calls it with the values it puts in its telegrams).
/// Range in mm = `raw · scale_factor + scale_offset_mm`; raw 0 is no echo, raw `0xFFFF`
/// saturated.
pub fn load_values(
    layout: &BeamLayout,
    values: impl ExactSizeIterator<Item = u16>,
    scale_factor: f32,
    scale_offset_mm: f32,
    sensor: &SensorSetup,
    scan: &mut Scan,
) -> Result<(), ScanInputError> {
    if usize::from(layout.beams) > LMS511_MAX_BEAMS || values.len() > LMS511_MAX_BEAMS {
        return Err(ScanInputError::TooManyBeams {
            beams: layout.beams,
        });
    }
    let g = &sensor.geometry;
    let setup = SensorSetup {
        geometry: layout.geometry(g.min_range_m, g.max_range_m),
        mounting: sensor.mounting,
    };
    scan.load_raw_values(&setup, values, scale_factor, scale_offset_mm);
    Ok(())
}

#[cfg(test)]
mod tests;
