//! [`StartPose`]: the pose a localiser starts from at power-up, as a 32-byte record a
//! controller reads from flash (written there beside the map by the flasher) or a host tool
//! writes to a file.
//!
//! Layout (little-endian): magic `LCSP` (4 bytes), format version u16 (1), reserved u16
//! (0), `x_m`, `y_m`, `theta_rad`, `sigma_xy_m`, `sigma_theta_rad` (5 × f32, world frame),
//! CRC-32 (IEEE) of the 28 bytes before it. Erased flash (all `0xFF`) or zeros read as
//! [`StartPoseError::NotPresent`]: there is no start pose, the controller falls back to its
//! documented default.

use core::fmt;

use nalgebra::{Matrix3, Vector3};

use crate::crc::crc32;
use crate::geometry::Pose2;

/// Bytes of a start-pose record.
pub const START_POSE_BYTES: usize = 32;

/// The record's magic.
pub const START_POSE_MAGIC: [u8; 4] = *b"LCSP";

/// The format version this crate writes and reads.
pub const START_POSE_VERSION: u16 = 1;

/// Where the vehicle is at power-up, and how sure that is (world frame of the map).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartPose {
    /// Vehicle pose in the world frame (metres, radians).
    pub pose: Pose2,
    /// 1σ of the position, each axis, metres (> 0).
    pub sigma_xy_m: f32,
    /// 1σ of the heading, radians (> 0).
    pub sigma_theta_rad: f32,
}

/// Why bytes are not a usable start pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StartPoseError {
    /// Erased flash or zeros: nothing was written. Use the default start.
    NotPresent,
    /// Fewer than [`START_POSE_BYTES`] bytes.
    Truncated,
    /// Not a start-pose record (no `LCSP` magic): write one with `host-sim export-map
    /// --start-pose-out`.
    BadMagic,
    /// A format version this build cannot read.
    UnsupportedVersion {
        /// The version found.
        found: u16,
    },
    /// The CRC does not match: the record is damaged; write it again.
    ChecksumMismatch,
    /// A field is not finite, or a σ is not positive.
    InvalidValue,
}

impl fmt::Display for StartPoseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StartPoseError::NotPresent => f.write_str("no start pose written (erased)"),
            StartPoseError::Truncated => write!(f, "start pose shorter than {START_POSE_BYTES} bytes"),
            StartPoseError::BadMagic => f.write_str(
                "not a start-pose record (no LCSP magic): write one with host-sim export-map --start-pose-out",
            ),
            StartPoseError::UnsupportedVersion { found } => write!(
                f,
                "start-pose format version {found}, this build reads {START_POSE_VERSION}"
            ),
            StartPoseError::ChecksumMismatch => {
                f.write_str("start-pose record damaged (CRC mismatch): write it again")
            }
            StartPoseError::InvalidValue => {
                f.write_str("start pose not finite or with a non-positive sigma")
            }
        }
    }
}

impl StartPose {
    /// The covariance of `(x_m, y_m, theta_rad)` it stands for: diagonal, `σ_xy²`, `σ_xy²`,
    /// `σ_θ²`.
    pub fn covariance(&self) -> Matrix3<f32> {
        let (p, h) = (self.sigma_xy_m, self.sigma_theta_rad);
        Matrix3::from_diagonal(&Vector3::new(p * p, p * p, h * h))
    }

    /// The record's bytes.
    pub fn to_bytes(&self) -> [u8; START_POSE_BYTES] {
        let mut out = [0u8; START_POSE_BYTES];
        let fields = [
            self.pose.x_m,
            self.pose.y_m,
            self.pose.theta_rad,
            self.sigma_xy_m,
            self.sigma_theta_rad,
        ];
        let mut bytes = START_POSE_MAGIC
            .into_iter()
            .chain(START_POSE_VERSION.to_le_bytes())
            .chain([0, 0])
            .chain(fields.into_iter().flat_map(f32::to_le_bytes));
        for slot in out.iter_mut().take(28) {
            *slot = bytes.next().unwrap_or(0);
        }
        let crc = crc32(out.get(..28).unwrap_or(&[]));
        for (slot, b) in out.iter_mut().skip(28).zip(crc.to_le_bytes()) {
            *slot = b;
        }
        out
    }

    /// Reads a record from the first [`START_POSE_BYTES`] of `bytes`.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, StartPoseError> {
        let Some(record) = bytes.get(..START_POSE_BYTES) else {
            return Err(StartPoseError::Truncated);
        };
        if record.iter().all(|&b| b == 0xFF) || record.iter().all(|&b| b == 0) {
            return Err(StartPoseError::NotPresent);
        }
        let word = |at: usize| -> [u8; 4] {
            let mut w = [0u8; 4];
            for (slot, b) in w.iter_mut().zip(record.iter().skip(at)) {
                *slot = *b;
            }
            w
        };
        if word(0) != START_POSE_MAGIC {
            return Err(StartPoseError::BadMagic);
        }
        let [v0, v1, ..] = word(4);
        let version = u16::from_le_bytes([v0, v1]);
        if version != START_POSE_VERSION {
            return Err(StartPoseError::UnsupportedVersion { found: version });
        }
        if crc32(record.get(..28).unwrap_or(&[])) != u32::from_le_bytes(word(28)) {
            return Err(StartPoseError::ChecksumMismatch);
        }
        let f = |k: usize| f32::from_le_bytes(word(8 + 4 * k));
        let s = Self {
            pose: Pose2::new(f(0), f(1), f(2)),
            sigma_xy_m: f(3),
            sigma_theta_rad: f(4),
        };
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !s.pose.is_finite() || !positive(s.sigma_xy_m) || !positive(s.sigma_theta_rad) {
            return Err(StartPoseError::InvalidValue);
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> StartPose {
        StartPose {
            pose: Pose2::new(20.3, -0.15, 0.06),
            sigma_xy_m: 0.5,
            sigma_theta_rad: 0.05,
        }
    }

    #[test]
    fn round_trips_and_refuses_damage() {
        let bytes = sample().to_bytes();
        assert_eq!(&bytes[..4], b"LCSP");
        assert_eq!(StartPose::from_bytes(&bytes), Ok(sample()));
        // Trailing bytes (the rest of a flash block) are not part of the record.
        let mut block = [0xFFu8; 64];
        block[..32].copy_from_slice(&bytes);
        assert_eq!(StartPose::from_bytes(&block), Ok(sample()));
        for i in 0..START_POSE_BYTES {
            let mut flipped = bytes;
            flipped[i] ^= 0x04;
            assert!(
                StartPose::from_bytes(&flipped).is_err(),
                "bit flip at {i} accepted"
            );
        }
        assert_eq!(
            StartPose::from_bytes(&[0xFF; 32]),
            Err(StartPoseError::NotPresent)
        );
        assert_eq!(
            StartPose::from_bytes(&[0; 32]),
            Err(StartPoseError::NotPresent)
        );
        assert_eq!(
            StartPose::from_bytes(&bytes[..31]),
            Err(StartPoseError::Truncated)
        );
        let nan = StartPose {
            sigma_xy_m: f32::NAN,
            ..sample()
        };
        assert_eq!(
            StartPose::from_bytes(&nan.to_bytes()),
            Err(StartPoseError::InvalidValue)
        );
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..64)) {
            let _ = StartPose::from_bytes(&bytes);
        }
    }
}
