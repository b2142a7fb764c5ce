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
//! - **when the beams were taken** ([`BeamLayout::timing`]): the header's time stamp
//!   ("time since start-up", µs) and the shot period `1 / f_shot`, so that loc-core can
//!   carry each echo over the mirror's sweep (21 ms at 25 Hz) to the scan's last beam;
//! - the channel's scale factor and offset (mm = raw · factor + offset; 2.0 in long-range
//!   modes), a raw 0 as no echo and a raw `0xFFFF` as a saturated reading, not a range;
//! - the **echo** of each beam ([`EchoSelection`]): a scanner set up for several echoes
//!   (`LMDscandatacfg` output channel `0x1F`) sends echo `n` of every beam in channel `DISTn`,
//!   in range order. Dust, spray or rain in front of the wall answers first; the last echo
//!   is the wall behind it (what SICK's own last-echo filter, `FREchoFilter 2`, keeps). The
//!   default takes the last echo; a telegram with `DIST1` alone gives the same scan either
//!   way.
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

use lidar_driver::scandata::{Channel, ChannelHeader};
use lidar_driver::{ChannelKind, ScanData, ScanHeader};
use loc_core::scan::{Scan, ScanGeometry, ScanTiming, SensorSetup, LMS511_MAX_BEAMS};

/// Most echoes per beam an LMS5xx reports (`DIST1`…`DIST5`).
pub const MAX_ECHOES: usize = 5;

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

    /// Time from one beam to the next, seconds: the time the mirror takes to turn by the
    /// step used, `step / (360° · f_scan)` (the shot period `1 / f_shot` when the header's
    /// frequencies describe the channel); `None` without a scan frequency.
    pub fn beam_period_s(&self) -> Option<f64> {
        (self.scan_frequency_1e2_hz > 0).then(|| {
            let f_scan_hz = f64::from(self.scan_frequency_1e2_hz) / 100.0;
            self.step_used_1e4_deg() / 3_600_000.0 / f_scan_hz
        })
    }

    /// Seconds from the first beam to the last (`(beams − 1)` beam periods; 0 without a
    /// beam period). The LMS5xx stamps a scan at its first shot; its pose refers to its last
    /// beam, this much later.
    pub fn sweep_s(&self) -> f64 {
        self.beam_period_s()
            .map_or(0.0, |p| p * f64::from(self.beams.saturating_sub(1)))
    }

    /// When the beams of a scan of this layout stamped `stamp_us` (the header's "time since
    /// start-up", µs on the scanner's clock) were taken; `None` without a beam period.
    pub fn timing(&self, stamp_us: u32) -> Option<ScanTiming> {
        self.beam_period_s().map(|p| ScanTiming {
            stamp_us,
            beam_period_s: p as f32,
        })
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

/// Which of a beam's echoes becomes its range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EchoSelection {
    /// The first echo (`DIST1`): the nearest thing the beam met, dust included.
    First,
    /// The last echo (the highest channel with an echo for the beam): the surface behind
    /// any dust or spray, as SICK's last-echo filter gives it. Also behind glass or a
    /// wire mesh, which a tunnel wall does not have.
    #[default]
    Last,
}

/// The beams of up to [`MAX_ECHOES`] distance channels read in step, one raw value per beam:
/// the echo `selection` chooses (0 where the beam has none). A channel that ends early
/// reads as no further echo; an absent one (`None`) as none at all.
#[derive(Debug, Clone)]
pub struct SelectedEchoes<I> {
    channels: [Option<I>; MAX_ECHOES],
    selection: EchoSelection,
    left: usize,
}

impl<I: Iterator<Item = u16>> SelectedEchoes<I> {
    /// `beams` values chosen by `selection` from `channels` (index `n − 1`: channel `DISTn`).
    pub fn new(channels: [Option<I>; MAX_ECHOES], beams: usize, selection: EchoSelection) -> Self {
        Self {
            channels,
            selection,
            left: beams,
        }
    }
}

impl<I: Iterator<Item = u16>> Iterator for SelectedEchoes<I> {
    type Item = u16;

    fn next(&mut self) -> Option<u16> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let mut chosen = 0u16;
        for (k, channel) in self.channels.iter_mut().enumerate() {
            // Every channel steps on, whichever echo is kept.
            let value = channel.as_mut().and_then(Iterator::next).unwrap_or(0);
            chosen = match self.selection {
                EchoSelection::First if k == 0 => value,
                EchoSelection::Last if value != 0 => value,
                _ => chosen,
            };
        }
        Some(chosen)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }
}

impl<I: Iterator<Item = u16>> ExactSizeIterator for SelectedEchoes<I> {}

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
    /// A further echo channel (`DIST2`…`DIST5`) does not describe the beams of `DIST1`
    /// (another start angle, step, beam count or scale): not the echoes of the same beams.
    EchoChannelMismatch {
        /// The channel's echo number (2…5).
        echo: u8,
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
            ScanInputError::EchoChannelMismatch { echo } => write!(
                f,
                "scan telegram whose DIST{echo} has another layout or scale than DIST1: not the echoes of the same beams"
            ),
        }
    }
}

/// Fills `scan` from `telegram`'s distance channels: per beam the echo `selection` chooses
/// among `DIST1`…`DIST5` (those the telegram carries), `DIST1`'s beam layout (exact step
/// where the telegram allows) and scale, and `sensor`'s mounting and range limits, with
/// the beams' timing from the header's time stamp and frequencies. Returns the layout used. Allocation-free; with `DIST1` alone (or [`EchoSelection::First`]) the
/// values are read straight from it.
pub fn load_scan(
    telegram: &ScanData<'_>,
    sensor: &SensorSetup,
    selection: EchoSelection,
    scan: &mut Scan,
) -> Result<BeamLayout, ScanInputError> {
    let mut echoes: [Option<Channel<'_>>; MAX_ECHOES] = [None; MAX_ECHOES];
    for channel in telegram.channels16().iter() {
        if let ChannelKind::Distance(n) = channel.header.kind() {
            // A repeated channel counts once: the first of its name.
            if let Some(slot @ None) = echoes.get_mut(usize::from(n).wrapping_sub(1)) {
                *slot = Some(channel);
            }
        }
    }
    let [first, ..] = echoes;
    let dist1 = first.ok_or(ScanInputError::NoDistanceChannel)?;
    let h = dist1.header;
    for (n, channel) in (1u8..).zip(echoes.iter()) {
        if channel.is_some_and(|c| !same_beams(&c.header, &h)) {
            return Err(ScanInputError::EchoChannelMismatch { echo: n });
        }
    }
    let layout = BeamLayout::of(&telegram.header, &h);
    let further = echoes.iter().skip(1).any(Option::is_some);
    if selection == EchoSelection::First || !further {
        load_values(
            &layout,
            dist1.values(),
            h.scale_factor,
            h.scale_offset,
            sensor,
            scan,
        )?;
    } else {
        let values = SelectedEchoes::new(
            echoes.map(|c| c.map(|c| c.values())),
            dist1.len(),
            selection,
        );
        load_values(
            &layout,
            values,
            h.scale_factor,
            h.scale_offset,
            sensor,
            scan,
        )?;
    }
    scan.set_timing(layout.timing(telegram.header.time_since_startup_us));
    Ok(layout)
}

/// Whether two channels describe the same beams at the same scale.
fn same_beams(a: &ChannelHeader, b: &ChannelHeader) -> bool {
    (a.start_angle_1e4_deg, a.step_1e4_deg, a.count)
        == (b.start_angle_1e4_deg, b.step_1e4_deg, b.count)
        && a.scale_factor.to_bits() == b.scale_factor.to_bits()
        && a.scale_offset.to_bits() == b.scale_offset.to_bits()
}

/// Fills `scan` from raw distance values laid out as `layout` (what [`load_scan`] does once
/// it has the channel; the simulator calls it with the values it puts in its telegrams).
/// Range in mm = `raw · scale_factor + scale_offset_mm`; raw 0 is no echo, raw `0xFFFF`
/// saturated. The scan has no timing: a caller that knows the scan's stamp sets it with
/// [`BeamLayout::timing`] and [`Scan::set_timing`].
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
