//! Byte transports for the session: the [`Transport`] contract (`no_std`) and, with feature
//! `std`, TCP (`TcpLink`); with feature `serial`, a serial port (`SerialLink`).
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
#[cfg(feature = "serial")]
mod serial;
#[cfg(feature = "std")]
mod tcp;

#[cfg(feature = "serial")]
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

/// A link that cannot be re-opened, such as an MCU's UART (`embedded-io` Read + Write +
/// ReadReady): `reconnect` drops the input waiting in it (stale answers, half scans), `close`
/// does nothing. Wrap the firmware's serial port in it to run a [`crate::Session`] on it.
#[derive(Debug)]
pub struct FixedLink<T>(pub T);

/// Most bytes `FixedLink::reconnect` discards (bounds its time if the sensor keeps sending).
const FIXED_LINK_DRAIN_MAX: usize = 64 * 1024;

impl<T: embedded_io::ErrorType> embedded_io::ErrorType for FixedLink<T> {
    type Error = T::Error;
}

impl<T: Read> Read for FixedLink<T> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        self.0.read(buf)
    }
}

impl<T: ReadReady> ReadReady for FixedLink<T> {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        self.0.read_ready()
    }
}

impl<T: Write> Write for FixedLink<T> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.write(buf)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush()
    }
}

impl<T: Read + Write + ReadReady> Transport for FixedLink<T> {
    fn reconnect(&mut self) -> Result<(), Self::Error> {
        let mut scratch = [0u8; 64];
        let mut dropped = 0;
        while dropped < FIXED_LINK_DRAIN_MAX && self.0.read_ready()? {
            match self.0.read(&mut scratch)? {
                0 => break,
                n => dropped += n,
            }
        }
        Ok(())
    }

    fn close(&mut self) {}
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn reconnect(&mut self) -> Result<(), Self::Error> {
        T::reconnect(self)
    }

    fn close(&mut self) {
        T::close(self)
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    #[test]
    fn fixed_link_reconnect_drops_stale_input_only() {
        let mut uart: std::collections::VecDeque<u8> = b"stale half scan".iter().copied().collect();
        let mut link = FixedLink(&mut uart);
        link.reconnect().unwrap();
        let mut out = [0u8; 32];
        assert_eq!(link.read(&mut out).unwrap(), 0, "stale bytes dropped");
        link.write_all(b"\x02sRN SCdevicestate\x03").unwrap();
        link.close();
        let n = link.read(&mut out).unwrap();
        assert_eq!(&out[..n], b"\x02sRN SCdevicestate\x03");
    }
}
