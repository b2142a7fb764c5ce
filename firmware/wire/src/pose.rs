//! The pose output frame: what the controller sends to the vehicle computer after each scan.
//!
//! Wire format: the [`PoseFrame`] struct serialised with `postcard` (varint integers, f32
//! little-endian), then COBS-encoded and terminated by a `0x00` byte, so a reader that
//! starts mid-stream resynchronises on the next zero. At most [`MAX_FRAME_BYTES`] bytes.

use serde::{Deserialize, Serialize};

/// Upper bound on an encoded frame, bytes (postcard worst case for the fields plus the COBS
/// overhead and the terminating zero).
pub const MAX_FRAME_BYTES: usize = 96;

/// Localiser status as sent on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PoseStatus {
    /// The last scan matched and updated every direction of the estimate.
    Tracking,
    /// The last scan updated the estimate except along the tunnel (no landmark in view):
    /// there the pose is carried by the motion prediction.
    Degenerate,
    /// The last scan could not be used: the pose is carried by the motion prediction.
    OdometryOnly,
    /// No pose yet (waiting for an initial pose or the first match).
    NotInitialised,
    /// The controller has no usable map and does not localise: flash a map and reset. The
    /// pose fields are zero.
    NoMap,
    /// No scan arrived for longer than the controller's stale time: the pose is the last
    /// estimate, not where the vehicle is now. Check the scanner and its link.
    Stale,
    /// The last scan updated the estimate, but the map is not confirmed: the landmarks in
    /// view have not fitted it lately (another tunnel's map, landmarks moved or damaged). The
    /// pose may be confidently wrong: do not steer by it.
    MapUnconfirmed,
    /// Searching the map for where the vehicle is, from the landmarks seen while it drives
    /// (at power-up without a start pose, or after the controller declared itself lost).
    /// The pose fields are the last estimate carried on by the motion prediction (zero
    /// without one): do not steer by them. Drive on: the search needs landmarks.
    Relocalising,
}

/// Whether the vehicle may act on the pose (loc-core's protection level against the alert
/// limit; see [`PoseFrame::protection_m`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PoseAvailability {
    /// The protection level is within the alert limit and no fault stands: use the pose.
    Available,
    /// The protection level exceeds the alert limit (long without a landmark, or on motion
    /// prediction alone): bounded, but not well enough.
    AboveAlertLimit,
    /// A fault was detected and not excluded (landmarks not fitting the map, a match refused
    /// by the filter's gate): no bound.
    FaultDetected,
    /// No pose to bound (no map, not initialised, relocalising).
    NoPose,
    /// No scan lately ([`PoseStatus::Stale`]): the bound was for an earlier moment.
    Stale,
}

/// What the motion prediction before the scan rested on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionSource {
    /// Wheel odometry from the vehicle ([`crate::OdometryFrame`]s on the odometry port).
    Odometry,
    /// No fresh odometry: the motion between the two previous estimates (constant
    /// velocity), with a generous uncertainty. Check the odometry link.
    ConstantVelocity,
    /// No motion was predicted (no map, or before the first scan).
    None,
}

/// One pose estimate, world frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseFrame {
    /// Scan sequence number (the scanner's telegram counter, or a local count).
    pub sequence: u32,
    /// Vehicle x in the world frame, metres.
    pub x_m: f32,
    /// Vehicle y in the world frame, metres.
    pub y_m: f32,
    /// Vehicle heading in the world frame, radians in `(-π, π]`.
    pub theta_rad: f32,
    /// Upper triangle of the 3×3 covariance of (x, y, θ), row major:
    /// `[σxx, σxy, σxθ, σyy, σyθ, σθθ]`, units m², m², m·rad, m², m·rad, rad².
    pub covariance_upper: [f32; 6],
    /// What the estimate rests on.
    pub status: PoseStatus,
    /// The protection level: a bound on the horizontal position error, metres, holding
    /// except with the localiser's integrity risk (10⁻⁵ per scan by default);
    /// `f32::INFINITY` when there is no bound (see `availability`).
    pub protection_m: f32,
    /// Whether the vehicle may act on the pose.
    pub availability: PoseAvailability,
    /// What the motion prediction before this scan rested on.
    pub motion: MotionSource,
    /// The controller restarted after a reset (watchdog, fault) and has not tracked since:
    /// the pose started from the last one stored before the reset, with a wide uncertainty.
    pub after_reset: bool,
    /// The controller's work on this scan (prediction, telegram to scan, localisation) in its
    /// counter's unit: instructions under QEMU with `-icount`, core cycles on silicon; 0 for
    /// frames that answer no scan.
    pub work: u32,
    /// That work by stage, indexed like [`STAGE_NAMES`]: the telegram's conversion into a
    /// scan, loc-core's strip, select and match stages, and the filter (the motion prediction
    /// plus loc-core's update); their sum is `work` less the loop's own bookkeeping. All 0
    /// for frames that answer no scan.
    pub stage_work: [u32; 5],
}

/// The stages of [`PoseFrame::stage_work`], in order.
pub const STAGE_NAMES: [&str; 5] = ["scan", "strip", "select", "match", "filter"];

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The output buffer is shorter than the frame: pass a buffer of [`MAX_FRAME_BYTES`].
    BufferTooSmall,
    /// The bytes are not a valid COBS/postcard pose frame (corrupted or truncated on the
    /// line): drop them and wait for the next `0x00` delimiter.
    Malformed,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::BufferTooSmall => {
                write!(
                    f,
                    "output buffer too small: pass at least {MAX_FRAME_BYTES} bytes"
                )
            }
            FrameError::Malformed => f.write_str(
                "malformed pose frame: drop the bytes and resynchronise on the next 0x00",
            ),
        }
    }
}

impl PoseFrame {
    /// The frame a controller without a map sends ([`PoseStatus::NoMap`], pose and
    /// covariance zero).
    pub fn no_map(sequence: u32) -> Self {
        Self {
            sequence,
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: 0.0,
            covariance_upper: [0.0; 6],
            status: PoseStatus::NoMap,
            protection_m: f32::INFINITY,
            availability: PoseAvailability::NoPose,
            motion: MotionSource::None,
            after_reset: false,
            work: 0,
            stage_work: [0; 5],
        }
    }

    /// Encodes the frame into `buf` (postcard + COBS + `0x00` terminator); returns the used
    /// prefix of `buf`.
    pub fn encode<'b>(&self, buf: &'b mut [u8]) -> Result<&'b mut [u8], FrameError> {
        postcard::to_slice_cobs(self, buf).map_err(|_| FrameError::BufferTooSmall)
    }

    /// Decodes one frame from `frame` (COBS bytes up to and including the `0x00`); the
    /// buffer is decoded in place.
    pub fn decode(frame: &mut [u8]) -> Result<Self, FrameError> {
        postcard::from_bytes_cobs(frame).map_err(|_| FrameError::Malformed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_frame_fits_its_bound_and_round_trips() {
        let frame = PoseFrame {
            sequence: u32::MAX,
            x_m: -1.0e30,
            y_m: f32::MAX,
            theta_rad: -3.14,
            covariance_upper: [f32::MAX; 6],
            status: PoseStatus::MapUnconfirmed,
            protection_m: f32::MAX,
            availability: PoseAvailability::AboveAlertLimit,
            motion: MotionSource::ConstantVelocity,
            after_reset: true,
            work: u32::MAX,
            stage_work: [u32::MAX; 5],
        };
        let mut buf = [0u8; MAX_FRAME_BYTES];
        let encoded = frame.encode(&mut buf).unwrap();
        assert!(encoded.len() <= MAX_FRAME_BYTES);
        assert_eq!(PoseFrame::decode(encoded).unwrap(), frame);
    }
}
