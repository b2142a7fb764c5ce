//! # lidar-driver: SICK LMS5xx telegrams, CoLa-A and CoLa-B, on any transport
//!
//! Not built yet: this crate is an empty shell until the lidar-driver issue lands.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
