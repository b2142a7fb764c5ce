//! Serial link (RS-232 / RS-422 host interface of the LMS5xx Heavy Duty, or a pty in tests)
//! over the `serialport` crate, built without `libudev` so it needs no system packages.
//! CoLa framing over serial is the same byte stream as over TCP.

use std::io;
use std::time::Duration;

use serialport::SerialPort;

use super::read_ahead::{connected, is_no_data, read_through_ahead, ReadAhead};
use super::Transport;

/// Settings of a [`SerialLink`]: 8 data bits, no parity, 1 stop bit, no flow control.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialConfig {
    /// Baud rate (the sensor's host-interface setting).
    pub baud_rate: u32,
    /// Longest wait of `read_ready` for the first bytes (keeps poll loops from spinning).
    pub ready_wait: Duration,
    /// Longest a write may wait for the port to take its bytes.
    pub write_timeout: Duration,
    /// Receive buffer, bytes.
    pub read_ahead_len: usize,
}

impl SerialConfig {
    /// Defaults at this baud rate.
    pub fn new(baud_rate: u32) -> Self {
        SerialConfig {
            baud_rate,
            ready_wait: Duration::from_millis(5),
            write_timeout: Duration::from_secs(1),
            read_ahead_len: 16 * 1024,
        }
    }
}

/// A serial port that can be re-opened. Created closed; [`Transport::reconnect`] opens it and
/// drops input that arrived while nobody listened.
pub struct SerialLink {
    path: String,
    config: SerialConfig,
    port: Option<Box<dyn SerialPort>>,
    ahead: ReadAhead,
}

impl core::fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SerialLink")
            .field("path", &self.path)
            .field("config", &self.config)
            .field("open", &self.port.is_some())
            .finish()
    }
}

impl SerialLink {
    /// A closed link to the device at `path` (`/dev/ttyUSB0`, `COM3`, a pty).
    pub fn new(path: impl Into<String>, config: SerialConfig) -> Self {
        SerialLink {
            path: path.into(),
            config,
            port: None,
            ahead: ReadAhead::new(config.read_ahead_len),
        }
    }

    /// True while the port is open.
    pub fn is_open(&self) -> bool {
        self.port.is_some()
    }

    fn port(&mut self) -> io::Result<&mut Box<dyn SerialPort>> {
        connected(&mut self.port)
    }
}

read_through_ahead!(SerialLink, port);

impl embedded_io::Write for SerialLink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        // The port's time-out is the short read wait; writes get their own, longer limit.
        let deadline = std::time::Instant::now() + self.config.write_timeout;
        let port = self.port()?;
        loop {
            match io::Write::write(port, buf) {
                Err(e) if is_no_data(&e) && std::time::Instant::now() < deadline => {}
                r => return r,
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        io::Write::flush(self.port()?)
    }
}

impl Transport for SerialLink {
    fn reconnect(&mut self) -> io::Result<()> {
        self.close();
        let port = serialport::new(&self.path, self.config.baud_rate)
            .timeout(self.config.ready_wait.max(Duration::from_millis(1)))
            .open()
            .map_err(io::Error::from)?;
        port.clear(serialport::ClearBuffer::Input)
            .map_err(io::Error::from)?;
        self.port = Some(port);
        Ok(())
    }

    fn close(&mut self) {
        self.port = None;
        self.ahead.clear();
    }
}
