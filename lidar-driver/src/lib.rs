//! # lidar-driver: SICK LMS5xx telegrams, CoLa-A and CoLa-B, on any transport
//!
//! Layers, bottom up (each `no_std`, no heap unless noted):
//!
//! | module | holds |
//! |---|---|
//! | [`frame`] | one checked frame ([`Frame`]), dialects, the CoLa-B checksum |
//! | [`framer`] | streaming [`Framer`]: bytes in any chunking → frames, resync, [`FramerStats`] |
//! | [`command`] | [`CommandType`]: `sRN` … `sFA` |
//! | [`telegram`] | [`Telegram`]: command type, name, argument bytes |
//! | [`args`] | typed argument reader/writer for both dialects ([`ArgReader`], [`TelegramWriter`]) |
//! | [`request`] | host requests of the start-up sequence: encoder and parser ([`Request`]) |
//! | [`answer`] | sensor answers, typed ([`Answer`]); `sFA` codes in [`sopas_error`] |
//! | [`scandata`] | zero-copy `LMDscandata` decoder ([`ScanData`]) |
//! | `scan_repr` | owned scan ([`ScanRepr`], feature `alloc`) emitted as CoLa-A / CoLa-B |
//! | `recording` | readers for raw streams, pcap, pcapng and SICK `.pcapng.json` (feature `std`) |
//! | [`clock`] | the caller-given millisecond [`Clock`] of the session's time-outs |
//! | [`transport`] | the re-connectable byte-stream contract ([`Transport`]); TCP link (feature `std`), serial link (feature `serial`) |
//! | [`session`] | poll-driven start-up sequence, readiness wait, scan stream, re-connect ([`Session`]) |
//!
//! Beside this crate, not burdening a user of the library: `lms5xx-emulator` (an emulated
//! LMS5xx for tests, a library and a binary), `sick-dump` (a recording dumper) and
//! `scan-input` (telegram to `loc-core` scan).
//!
//! ```
//! use lidar_driver::{Framer, Answer, Dialect, Request};
//! let mut out = [0u8; 64];
//! let n = Request::SUBSCRIBE_SCANS.emit(Dialect::ColaB, &mut out).unwrap();
//! let mut framer = Framer::new([0u8; 16384]);
//! framer.feed(&out[..n], |frame| {
//!     let frame = frame.unwrap();
//!     assert!(Answer::from_frame(frame).is_err()); // a request, not an answer
//! });
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod answer;
pub mod args;
pub mod clock;
pub mod command;
pub mod frame;
pub mod framer;
pub mod request;
pub mod scandata;
pub mod session;
pub mod sopas_error;
pub mod telegram;
pub mod transport;

#[cfg(feature = "alloc")]
mod scan_repr;

#[cfg(feature = "std")]
pub mod recording;

pub use answer::{Answer, AnswerError, DeviceState, ScanConfigError};
pub use args::{ArgError, ArgErrorKind, ArgReader, EmitError, LenWidth, TelegramWriter};
pub use clock::Clock;
pub use frame::{xor_checksum, Dialect, Frame, FrameError};
pub use framer::{Framer, FramerStats};
pub use request::{
    names, AccessLevel, EchoFilter, OutputRange, Request, RequestError, ScanConfig, ScanDataConfig,
};
#[cfg(feature = "alloc")]
pub use scan_repr::{ChannelRepr, ScanRepr};
pub use scandata::{Channel, ChannelBits, ChannelKind, ScanData, ScanError, ScanField, ScanHeader};
pub use session::{Event, Session, SessionConfig, SessionError};
pub use sopas_error::SopasError;
pub use telegram::{CommandType, Telegram, TelegramError};
pub use transport::Transport;
