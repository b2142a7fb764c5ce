//! The wheel-odometry frame: what the vehicle computer sends the controller on its
//! odometry port (UART1 on QEMU's MPS2, USART2 on the NUCLEO-H743ZI2), as often as it
//! likes (the controller uses the latest before each scan; 50–100 Hz is typical).
//!
//! The frame carries the vehicle's **cumulative** odometry pose — dead reckoning from the
//! track or wheel encoders (and gyro), in the vehicle's own odometry frame, which drifts
//! and need not match the map's world frame — rather than an increment: the controller
//! differences two poses, so a frame lost on the line loses no motion.
//!
//! Wire format: the [`OdometryFrame`] struct serialised with `postcard` (varint integers,
//! f32 little-endian), then COBS-encoded and terminated by a `0x00` byte; at most
//! [`MAX_ODOMETRY_FRAME_BYTES`] bytes.

use serde::{Deserialize, Serialize};

use crate::FrameError;

/// Upper bound on an encoded odometry frame, bytes (postcard worst case: 5 + 10 + 3 × 4,
/// plus the COBS overhead and the terminating zero).
pub const MAX_ODOMETRY_FRAME_BYTES: usize = 40;

/// The vehicle's cumulative odometry pose, odometry frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OdometryFrame {
    /// Frame counter of the sender (wraps); a gap tells the controller frames were lost.
    pub sequence: u32,
    /// The vehicle computer's time stamp of the reading, microseconds (its own clock).
    pub time_us: u64,
    /// Odometry x, metres (odometry frame: where the vehicle's dead reckoning started).
    pub x_m: f32,
    /// Odometry y, metres.
    pub y_m: f32,
    /// Odometry heading, radians (unwrapped or wrapped: only differences are used).
    pub theta_rad: f32,
}

impl OdometryFrame {
    /// Encodes the frame into `buf` (postcard + COBS + `0x00` terminator); returns the used
    /// prefix of `buf`.
    pub fn encode<'b>(&self, buf: &'b mut [u8]) -> Result<&'b mut [u8], FrameError> {
        postcard::to_slice_cobs(self, buf).map_err(|_| FrameError::BufferTooSmall)
    }

    /// Decodes one frame from `frame` (COBS bytes up to and including the `0x00`), in place.
    pub fn decode(frame: &mut [u8]) -> Result<Self, FrameError> {
        postcard::from_bytes_cobs(frame).map_err(|_| FrameError::Malformed)
    }

    /// True when every value is finite (a frame with NaN or infinity is refused).
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.theta_rad.is_finite()
    }
}
