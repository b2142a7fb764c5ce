//! The board's serial port as the `lidar-driver` session's transport.
//!
//! A UART has no connection to open: `reconnect` and `close` only reset nothing and succeed,
//! so the session's re-connect after a failure becomes a fresh start-up sequence on the same
//! line (what a power-cycled LMS511 on RS-232/422 needs anyway).

use embedded_io::{ErrorType, Read, ReadReady, Write};
use lidar_driver::Transport;

/// A serial port lent to the session.
pub struct UartLink<'a, S> {
    port: &'a mut S,
}

impl<'a, S> UartLink<'a, S> {
    /// Wraps `port` for the duration of the borrow.
    pub fn new(port: &'a mut S) -> Self {
        Self { port }
    }
}

impl<S: ErrorType> ErrorType for UartLink<'_, S> {
    type Error = S::Error;
}

impl<S: Read> Read for UartLink<'_, S> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, S::Error> {
        self.port.read(buf)
    }
}

impl<S: ReadReady> ReadReady for UartLink<'_, S> {
    fn read_ready(&mut self) -> Result<bool, S::Error> {
        self.port.read_ready()
    }
}

impl<S: Write> Write for UartLink<'_, S> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, S::Error> {
        self.port.write(buf)
    }

    fn flush(&mut self) -> Result<(), S::Error> {
        self.port.flush()
    }
}

impl<S: Read + Write + ReadReady> Transport for UartLink<'_, S> {
    fn reconnect(&mut self) -> Result<(), S::Error> {
        Ok(())
    }

    fn close(&mut self) {}
}
