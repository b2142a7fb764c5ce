//! # controller-wire: the localisation controller's vehicle interface on the wire
//!
//! What crosses the serial ports between the controller and the vehicle computer, in one
//! `no_std` crate the firmware and the host tools (hardware-in-the-loop, test fixtures)
//! share, so the two ends cannot disagree:
//!
//! - [`pose`]: the pose frame the controller sends after every scan (pose, covariance,
//!   status, what the motion prediction rested on);
//! - [`odometry`]: the wheel-odometry frame the vehicle sends (its cumulative odometry pose
//!   with its own time stamp);
//! - [`assembler`]: bytes from a serial port into whole frames, resynchronising after
//!   damage.
//!
//! Every frame is a `postcard` struct, COBS-encoded and terminated by one `0x00` byte: a
//! reader that starts mid-stream, or meets a damaged frame, drops bytes up to the next
//! `0x00` and carries on.
#![no_std]
#![warn(missing_docs)]

pub mod assembler;
pub mod odometry;
pub mod pose;

pub use assembler::{Assembled, FrameAssembler};
pub use odometry::{OdometryFrame, MAX_ODOMETRY_FRAME_BYTES};
pub use pose::{
    FrameError, MotionSource, PoseAvailability, PoseFrame, PoseStatus, MAX_FRAME_BYTES, STAGE_NAMES,
};
