//! From a decoded `LMDscandata` telegram to a `loc-core` scan: the first 16-bit distance
//! channel (`DIST1`), its beam layout and its scale, exactly as the telegram gives them.

use lidar_driver::{ChannelKind, ScanData};
use loc_core::scan::{Scan, ScanGeometry, SensorSetup, LMS511_MAX_BEAMS};

/// Why a scan telegram could not be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ScanInputError {
    /// The telegram has no 16-bit `DIST1` channel: enable it in `LMDscandatacfg` (the session's
    /// default configuration does).
    NoDistanceChannel,
    /// More beams than an LMS511 sends (1141): the scanner is configured for another
    /// resolution or angular range than this firmware is built for.
    TooManyBeams {
        /// Beams in the telegram.
        beams: u16,
    },
}

impl core::fmt::Display for ScanInputError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ScanInputError::NoDistanceChannel => f.write_str(
                "scan telegram without a 16-bit DIST1 channel: enable DIST1 in LMDscandatacfg",
            ),
            ScanInputError::TooManyBeams { beams } => write!(
                f,
                "scan telegram with {beams} beams, at most {LMS511_MAX_BEAMS}: configure the LMS511 for 190° at 0.1667° or coarser"
            ),
        }
    }
}

/// Fills `scan` from `telegram`'s `DIST1` channel, with the beam layout the telegram gives
/// and the mounting of `sensor`; `raw` is scratch for the values. Returns the beams read.
pub fn load_scan(
    telegram: &ScanData<'_>,
    sensor: &SensorSetup,
    raw: &mut [u16; LMS511_MAX_BEAMS],
    scan: &mut Scan,
) -> Result<usize, ScanInputError> {
    let channel = telegram
        .channels16()
        .iter()
        .find(|c| c.header.kind() == ChannelKind::Distance(1))
        .ok_or(ScanInputError::NoDistanceChannel)?;
    let h = channel.header;
    if usize::from(h.count) > LMS511_MAX_BEAMS {
        return Err(ScanInputError::TooManyBeams { beams: h.count });
    }
    let mut n = 0;
    for (slot, value) in raw.iter_mut().zip(channel.values()) {
        *slot = value;
        n += 1;
    }
    let setup = SensorSetup {
        geometry: ScanGeometry::from_telegram_units(
            h.start_angle_1e4_deg,
            u32::from(h.step_1e4_deg),
            sensor.geometry.min_range_m,
            sensor.geometry.max_range_m,
        ),
        mounting: sensor.mounting,
    };
    scan.load_raw_mm(
        &setup,
        raw.get(..n).unwrap_or(&[]),
        h.scale_factor,
        h.scale_offset,
    );
    Ok(n)
}
