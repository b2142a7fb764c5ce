//! # loc-core: drift-free 2D-lidar localisation in smooth mining tunnels
//!
//! The allocation-free core that keeps a vehicle localised from 2D lidar scans, wheel
//! odometry and a stored map of tunnel walls and passive landmarks (Torres-Torriti et al.,
//! "Passive Landmark Geometry Optimization and Evaluation for Reliable Autonomous Navigation
//! in Mining Tunnels Using 2D Lidars").
//!
//! ## Frames
//! - **sensor**: origin at the lidar's optical centre, x along the beam at angle 0.
//! - **vehicle**: origin at the vehicle reference point, x forward, y left. The sensor's
//!   mounting pose is given in this frame.
//! - **world**: the map's frame, metres.
//!
//! All lengths are metres (`_m`), all angles radians (`_rad`), `f32` throughout: the target
//! MCU (Cortex-M4F) has a single-precision FPU. Every transcendental function goes through
//! [`math`] so host tests compute exactly what the MCU computes.
//!
//! ## Guarantees
//! `#![no_std]`, no `alloc`, `#![forbid(unsafe_code)]`; clippy denies `unwrap`, `expect`,
//! `panic!` and slice indexing outside tests, so no input can make the core panic, and
//! `f32::max`/`f32::min` (library calls on the M4F; [`math::max`]/[`math::min`] compare).
#![no_std]
#![forbid(unsafe_code)]
// Tests compare against std's f32::max / f32::min freely.
#![cfg_attr(test, allow(clippy::disallowed_methods))]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        // f32::max / f32::min are libcalls on the Cortex-M4F (clippy.toml): math::max / min.
        clippy::disallowed_methods
    )
)]

pub mod crc;
pub mod filter;
pub mod geometry;
pub mod landmark;
pub mod localizer;
pub mod map;
pub mod matching;
pub mod math;
pub mod relocalise;
pub mod rng;
pub mod scan;
pub mod strip;
pub mod testkit;
