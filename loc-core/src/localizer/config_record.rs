//! The localiser's configuration as a record a controller reads from flash (written beside
//! the map by the flasher, `host-sim export-map --config-out`): the sensor's beam layout and
//! mounting on the vehicle, the matcher and its noise and roughness model, the odometry's
//! noise — everything [`LocalizerConfig`] holds, so the controller localises as the host
//! tools do for the same vehicle.
//!
//! Layout: a 16-byte header, little-endian — magic `LCCF`, format version u16 (10), reserved
//! u16 (0), payload length u32, CRC-32 (IEEE) of the payload u32 — then the payload, the
//! `postcard` encoding of [`LocalizerConfig`] (at most [`CONFIG_RECORD_MAX_BYTES`] in all).
//! Erased flash or zeros read as [`ConfigRecordError::NotPresent`]; bytes after the record
//! are not looked at (the record sits in a block of its own).

use core::fmt;

use super::LocalizerConfig;
use crate::crc::crc32;

/// The record's magic.
pub const CONFIG_MAGIC: [u8; 4] = *b"LCCF";
/// The format version this crate writes and reads (10: the matches' shared error across
/// the walls, `UpdateConfig::max_shared_scans`; 9: the sweep's de-skew,
/// `LocalizerConfig::deskew`; 8: the landmark points' budget,
/// `LocalizerConfig::max_landmark_points`; 7: the roughness model's correlation
/// length, `RoughnessModel::correlation_m`, where 6 held a patch length; 6: weakly observed
/// directions, `MatchConfig::weak_information_points` and `UpdateConfig::weak_refix_ratio`,
/// and no wall range limit; 5 added the wall-end observation's configuration,
/// `LocalizerConfig::wall_end`; 4 added the protection level's, 3 the
/// relocaliser's, 2 the matcher's work budget; older records lack them and are refused).
pub const CONFIG_FORMAT_VERSION: u16 = 10;
/// Bytes of the header.
const HEADER_BYTES: usize = 16;
/// Upper bound on a whole record, bytes.
pub const CONFIG_RECORD_MAX_BYTES: usize = 1024;

/// Why bytes are not a usable configuration record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigRecordError {
    /// Erased flash or zeros: nothing was written. The controller uses the defaults.
    NotPresent,
    /// Fewer bytes than the header or its payload length says.
    Truncated,
    /// Not a configuration record (no `LCCF` magic): write one with `host-sim export-map
    /// --config-out`.
    BadMagic,
    /// A format version this build cannot read: write the record with a matching host-sim.
    UnsupportedVersion {
        /// The version found.
        found: u16,
    },
    /// The CRC does not match: the record is damaged; write it again.
    ChecksumMismatch,
    /// The checksum matched but the payload does not decode, or holds a value no localiser
    /// can run with (a non-finite or non-positive noise, step or range): written by another
    /// encoder.
    Corrupt,
    /// The output buffer is too small: pass [`CONFIG_RECORD_MAX_BYTES`].
    BufferTooSmall,
}

impl fmt::Display for ConfigRecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotPresent => f.write_str("no configuration record (erased): using the defaults"),
            Self::Truncated => f.write_str("configuration record truncated: write it again"),
            Self::BadMagic => f.write_str(
                "not a configuration record (no LCCF magic): write one with `host-sim export-map --config-out`",
            ),
            Self::UnsupportedVersion { found } => write!(
                f,
                "configuration record version {found} not supported (this build reads {CONFIG_FORMAT_VERSION}): write it with a matching host-sim"
            ),
            Self::ChecksumMismatch => {
                f.write_str("configuration record damaged (CRC mismatch): write it again")
            }
            Self::Corrupt => f.write_str(
                "configuration record does not decode to a usable configuration: write it again with host-sim",
            ),
            Self::BufferTooSmall => write!(
                f,
                "buffer too small for a configuration record: pass {CONFIG_RECORD_MAX_BYTES} bytes"
            ),
        }
    }
}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

fn non_negative(v: f32) -> bool {
    v.is_finite() && v >= 0.0
}

impl LocalizerConfig {
    /// The values a localiser cannot run with: a non-finite or non-positive beam step, range,
    /// noise or tolerance, a non-finite mounting.
    fn usable(&self) -> bool {
        let g = &self.sensor.geometry;
        let m = &self.sensor.mounting;
        let o = &self.odometry;
        [
            g.step_rad,
            g.max_range_m,
            self.matching.range_noise_sigma_m,
            self.matching.min_information_points,
        ]
        .into_iter()
        .all(positive)
            && [g.start_angle_rad, m.x_m, m.y_m, m.theta_rad]
                .iter()
                .all(|v| v.is_finite())
            && [
                g.min_range_m,
                self.matching.roughness.sigma_m,
                self.matching.roughness.correlation_m,
                o.drift_fraction,
                o.scale_sd,
                o.scale_drift_sd,
                o.heading_drift_rad_per_m,
                self.matching.weak_information_points,
                self.update.weak_refix_ratio,
            ]
            .into_iter()
            .all(non_negative)
            && self.update.max_shared_scans >= 1.0
            && self.update.max_shared_scans.is_finite()
            && self.relocalise.is_usable()
            && self.wall_end.is_usable()
            && self.protection.is_usable()
    }

    /// Writes the configuration record into `buf`; returns the bytes written.
    pub fn to_record(&self, buf: &mut [u8]) -> Result<usize, ConfigRecordError> {
        let (header, payload) = buf
            .split_at_mut_checked(HEADER_BYTES)
            .ok_or(ConfigRecordError::BufferTooSmall)?;
        let n = postcard::to_slice(self, payload)
            .map_err(|_| ConfigRecordError::BufferTooSmall)?
            .len();
        let crc = crc32(payload.get(..n).unwrap_or(&[]));
        header.fill(0);
        let fields = [
            (0..4, &CONFIG_MAGIC[..]),
            (4..6, &CONFIG_FORMAT_VERSION.to_le_bytes()[..]),
            (
                8..12,
                &u32::try_from(n).unwrap_or(u32::MAX).to_le_bytes()[..],
            ),
            (12..16, &crc.to_le_bytes()[..]),
        ];
        for (range, bytes) in fields {
            if let Some(dst) = header.get_mut(range) {
                dst.copy_from_slice(bytes);
            }
        }
        Ok(HEADER_BYTES + n)
    }

    /// Reads a configuration record from the start of `bytes`.
    pub fn from_record(bytes: &[u8]) -> Result<Self, ConfigRecordError> {
        let (header, rest) = bytes
            .split_first_chunk::<HEADER_BYTES>()
            .ok_or(ConfigRecordError::Truncated)?;
        if header.iter().all(|&b| b == 0xFF) || header.iter().all(|&b| b == 0) {
            return Err(ConfigRecordError::NotPresent);
        }
        let [m0, m1, m2, m3, v0, v1, _, _, l0, l1, l2, l3, c0, c1, c2, c3] = *header;
        if [m0, m1, m2, m3] != CONFIG_MAGIC {
            return Err(ConfigRecordError::BadMagic);
        }
        let version = u16::from_le_bytes([v0, v1]);
        if version != CONFIG_FORMAT_VERSION {
            return Err(ConfigRecordError::UnsupportedVersion { found: version });
        }
        let len = u32::from_le_bytes([l0, l1, l2, l3]) as usize;
        let payload = rest.get(..len).ok_or(ConfigRecordError::Truncated)?;
        if crc32(payload) != u32::from_le_bytes([c0, c1, c2, c3]) {
            return Err(ConfigRecordError::ChecksumMismatch);
        }
        let config: Self = postcard::from_bytes(payload).map_err(|_| ConfigRecordError::Corrupt)?;
        if config.usable() {
            Ok(config)
        } else {
            Err(ConfigRecordError::Corrupt)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matching::{MatcherKind, RoughnessModel};
    use crate::scan::SensorSetup;

    fn custom() -> LocalizerConfig {
        let mut c = LocalizerConfig::with_matcher(MatcherKind::Icp);
        c.sensor = SensorSetup::lms511_forward(1.2, -0.3);
        c.matching.roughness = RoughnessModel {
            sigma_m: 0.01,
            correlation_m: 0.5,
        };
        c.odometry.scale_sd = 0.02;
        c
    }

    #[test]
    fn a_record_round_trips_and_fits_its_bound() {
        let mut buf = [0u8; CONFIG_RECORD_MAX_BYTES];
        let n = custom().to_record(&mut buf).unwrap();
        assert!(n <= CONFIG_RECORD_MAX_BYTES);
        assert_eq!(LocalizerConfig::from_record(&buf[..n]), Ok(custom()));
        // Padding after it (the rest of its flash block) is not looked at.
        buf[n..].fill(0xFF);
        assert_eq!(LocalizerConfig::from_record(&buf), Ok(custom()));
    }

    #[test]
    fn erased_damaged_and_unusable_records_say_so() {
        assert_eq!(
            LocalizerConfig::from_record(&[0xFF; 64]),
            Err(ConfigRecordError::NotPresent)
        );
        assert_eq!(
            LocalizerConfig::from_record(&[0; 64]),
            Err(ConfigRecordError::NotPresent)
        );
        let mut buf = [0u8; CONFIG_RECORD_MAX_BYTES];
        let n = custom().to_record(&mut buf).unwrap();
        let mut d = buf;
        d[HEADER_BYTES + 3] ^= 0x40;
        assert_eq!(
            LocalizerConfig::from_record(&d[..n]),
            Err(ConfigRecordError::ChecksumMismatch)
        );
        assert_eq!(
            LocalizerConfig::from_record(&buf[..n - 1]),
            Err(ConfigRecordError::Truncated)
        );
        let mut d = buf;
        d[0] = b'X';
        assert_eq!(
            LocalizerConfig::from_record(&d),
            Err(ConfigRecordError::BadMagic)
        );
        // A NaN noise, or a weak direction's ratio or threshold that compares as nothing,
        // behind a valid CRC: refused.
        let spoilers: [fn(&mut LocalizerConfig); 4] = [
            |c| c.matching.range_noise_sigma_m = f32::NAN,
            |c| c.update.weak_refix_ratio = f32::NAN,
            |c| c.update.max_shared_scans = 0.5,
            |c| c.matching.min_information_points = 0.0,
        ];
        for spoil in spoilers {
            let mut bad = custom();
            spoil(&mut bad);
            let n = bad.to_record(&mut buf).unwrap();
            assert_eq!(
                LocalizerConfig::from_record(&buf[..n]),
                Err(ConfigRecordError::Corrupt)
            );
        }
    }
}
