//! A USART of the STM32H743 (USART3: lidar and poses; USART2: odometry) as an
//! `embedded-io` byte stream, over the HAL's polled serial.

use embedded_hal_02::serial::{Read as _, Write as _};
use stm32h7xx_hal::serial::{Error as HalError, Serial};

/// What went wrong on the USART.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum UsartError {
    /// A received byte was lost (overrun): read the port more often or lower the baud rate.
    Overrun,
    /// Framing, parity or noise error: check the baud rate and the wiring.
    Line,
}

impl core::fmt::Display for UsartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            UsartError::Overrun => f.write_str(
                "USART overrun: a byte was lost, read the port more often or lower the baud rate",
            ),
            UsartError::Line => {
                f.write_str("USART framing/parity/noise error: check the baud rate and the wiring")
            }
        }
    }
}

impl core::error::Error for UsartError {}

impl embedded_io::Error for UsartError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

impl From<HalError> for UsartError {
    fn from(e: HalError) -> Self {
        match e {
            HalError::Overrun => UsartError::Overrun,
            _ => UsartError::Line,
        }
    }
}

/// A USART, polled.
pub struct Usart<U> {
    serial: Serial<U>,
    /// A byte `read_ready` pulled out of the receiver and not yet handed to `read`.
    pending: Option<u8>,
}

impl<U> Usart<U>
where
    Serial<U>:
        embedded_hal_02::serial::Read<u8, Error = HalError> + embedded_hal_02::serial::Write<u8>,
{
    /// Wraps the HAL's configured serial port.
    pub fn new(serial: Serial<U>) -> Self {
        Self {
            serial,
            pending: None,
        }
    }

    fn poll_byte(&mut self) -> Result<Option<u8>, UsartError> {
        if let Some(b) = self.pending.take() {
            return Ok(Some(b));
        }
        match self.serial.read() {
            Ok(b) => Ok(Some(b)),
            Err(nb::Error::WouldBlock) => Ok(None),
            Err(nb::Error::Other(e)) => Err(e.into()),
        }
    }
}

impl<U> embedded_io::ErrorType for Usart<U>
where
    Serial<U>:
        embedded_hal_02::serial::Read<u8, Error = HalError> + embedded_hal_02::serial::Write<u8>,
{
    type Error = UsartError;
}

impl<U> embedded_io::Write for Usart<U>
where
    Serial<U>:
        embedded_hal_02::serial::Read<u8, Error = HalError> + embedded_hal_02::serial::Write<u8>,
{
    fn write(&mut self, buf: &[u8]) -> Result<usize, UsartError> {
        for &b in buf {
            nb::block!(self.serial.write(b)).map_err(|_| UsartError::Line)?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), UsartError> {
        nb::block!(self.serial.flush()).map_err(|_| UsartError::Line)
    }
}

impl<U> embedded_io::ReadReady for Usart<U>
where
    Serial<U>:
        embedded_hal_02::serial::Read<u8, Error = HalError> + embedded_hal_02::serial::Write<u8>,
{
    fn read_ready(&mut self) -> Result<bool, UsartError> {
        if self.pending.is_none() {
            self.pending = self.poll_byte()?;
        }
        Ok(self.pending.is_some())
    }
}

impl<U> embedded_io::Read for Usart<U>
where
    Serial<U>:
        embedded_hal_02::serial::Read<u8, Error = HalError> + embedded_hal_02::serial::Write<u8>,
{
    /// Blocks until at least one byte arrived, then returns every byte already waiting.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UsartError> {
        let mut n = 0;
        for slot in buf.iter_mut() {
            let byte = loop {
                match self.poll_byte()? {
                    Some(b) => break Some(b),
                    None if n == 0 => continue,
                    None => break None,
                }
            };
            let Some(b) = byte else { break };
            *slot = b;
            n += 1;
        }
        Ok(n)
    }
}
