//! Byte transports for the session: the [`Transport`] contract (`no_std`) and, with feature
//! `std`, TCP ([`TcpLink`]) and serial ([`SerialLink`]) implementations.
//!
//! # Contract
//! A transport is an `embedded-io` byte stream plus a way to re-open it:
//! - [`embedded_io::ReadReady::read_ready`] says whether `read` has data (or end of stream)
//!   now. It may wait a short, bounded time for data (the std links wait up to their
//!   `ready_wait`, 5 ms by default, so a poll loop does not spin); it must never block without
//!   bound. The session reads only after `read_ready` said `true`.
//! - `read` returning `Ok(0)` means the peer closed the stream (the session re-connects).
//!   Errors of kind [`embedded_io::ErrorKind::TimedOut`] or `Interrupted` mean "no data yet".
//! - `write` / `write_all` may block, but only for a bounded time (a write time-out, or a UART
//!   pushing out its bytes).
//! - [`Transport::reconnect`] closes whatever is open and opens it again (TCP: new connection,
//!   bounded by a connect time-out; serial: re-open the port and drop stale input; a firmware
//!   UART: flush its receive buffer). [`Transport::close`] closes it and returns at once.

use embedded_io::{Read, ReadReady, Write};

#[cfg(feature = "std")]
mod read_ahead;
#[cfg(feature = "std")]
mod serial;
#[cfg(feature = "std")]
mod tcp;

#[cfg(feature = "std")]
pub use serial::{SerialConfig, SerialLink};
#[cfg(feature = "std")]
pub use tcp::{TcpConfig, TcpLink, SICK_TCP_PORT};

/// A re-connectable byte stream to the sensor. See the [module docs](self) for the contract.
pub trait Transport: Read + Write + ReadReady {
    /// Closes the link if open and opens it again. Bounded in time (connect time-out).
    fn reconnect(&mut self) -> Result<(), Self::Error>;

    /// Closes the link; reads and writes fail until the next [`Transport::reconnect`].
    fn close(&mut self);
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn reconnect(&mut self) -> Result<(), Self::Error> {
        T::reconnect(self)
    }

    fn close(&mut self) {
        T::close(self)
    }
}
