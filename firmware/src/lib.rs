//! # firmware: the localisation controller for Cortex-M4F / M7
//!
//! Runs `loc-core` on a microcontroller: LMS511 ranges in, pose with covariance out, no heap,
//! fixed memory, bounded time. The library holds everything; the binaries are thin:
//!
//! - `bench`: the end-to-end loc-core pipeline (strip, match, filter) on recorded synthetic
//!   1141-point scans, instructions per scan per stage, checked against the budget;
//! - `selftest`: on-target tests printing `N passed, N failed`.
//!
//! One board is compiled in ([`board`]); under QEMU it is `mps2-an386`.
#![no_std]
#![warn(missing_docs)]

pub mod board;
pub mod controller;
pub mod fault;
pub mod instruction_loop;
pub mod math_costs;
pub mod pipeline;
pub mod pose_frame;
pub mod recorded;
pub mod replay;
pub mod scan_input;
pub mod stage_stats;
pub mod test_harness;

pub use board::{Board, ExitStatus, SelectedBoard};
