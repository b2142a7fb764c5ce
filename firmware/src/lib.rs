//! # firmware: the localisation controller for Cortex-M4F / M7
//!
//! Runs `loc-core` on a microcontroller: LMS511 telegrams in, pose with covariance out, no
//! heap, fixed memory, bounded time. This crate is the product:
//!
//! - [`board`]: the board abstraction (serial port, counter, clock, map flash region, exit)
//!   and one module per board; one board is compiled in (under QEMU: `mps2-an386`);
//! - [`controller`]: the loop a vehicle runs (LMS session, localiser, pose frames), the
//!   stored map and the start pose read from the map flash region;
//! - [`flash_map`]: the map image read in place from the map flash region;
//! - [`odometry`]: the vehicle's wheel odometry from its serial port, per scan;
//! - the vehicle interface's frames (pose out, odometry in) are the `controller-wire` crate
//!   beside this one, shared with the host tools;
//! - [`fault`]: panic and HardFault handlers;
//! - [`ram`]: static RAM and the stack's high-water mark (painted stack);
//! - [`retained`]: what survives a reset (that the controller was running, its last tracked
//!   scan: pose, uncertainty, odometry reading).
//! - [`resume`]: the start after a reset, the last tracked pose carried over the outage by
//!   the vehicle's odometry.
//!
//! The benchmark, the on-target self-tests and the recorded fixtures they replay are the
//! `firmware-testbench` crate beside this one; nothing here reaches them.
#![no_std]
#![warn(missing_docs)]

pub mod board;
pub mod controller;
pub mod fault;
pub mod flash_map;
pub mod odometry;
pub mod ram;
pub mod resume;
pub mod retained;
pub mod stage_costs;

pub use board::{Board, ExitStatus, SelectedBoard};
