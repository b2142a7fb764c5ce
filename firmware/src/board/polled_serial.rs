//! A USART of an STM32 (H743, F407) as an `embedded-io` byte stream, over its HAL's polled
//! serial (the embedded-hal 0.2 `serial::Read` / `serial::Write` both HALs implement).

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

/// A HAL's serial error, as far as the controller cares.
pub trait LineError {
    /// True for an overrun (a byte lost because the port was not read in time).
    fn is_overrun(&self) -> bool;
}

fn line_error(e: &impl LineError) -> UsartError {
    if e.is_overrun() {
        UsartError::Overrun
    } else {
        UsartError::Line
    }
}

/// A USART, polled.
pub struct Usart<S> {
    serial: S,
    /// A byte `read_ready` pulled out of the receiver and not yet handed to `read`.
    pending: Option<u8>,
}

impl<S> Usart<S>
where
    S: embedded_hal_02::serial::Read<u8> + embedded_hal_02::serial::Write<u8>,
    <S as embedded_hal_02::serial::Read<u8>>::Error: LineError,
{
    /// Wraps the HAL's configured serial port.
    pub fn new(serial: S) -> Self {
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
            Err(nb::Error::Other(e)) => Err(line_error(&e)),
        }
    }
}

impl<S> embedded_io::ErrorType for Usart<S>
where
    S: embedded_hal_02::serial::Read<u8> + embedded_hal_02::serial::Write<u8>,
    <S as embedded_hal_02::serial::Read<u8>>::Error: LineError,
{
    type Error = UsartError;
}

impl<S> embedded_io::Write for Usart<S>
where
    S: embedded_hal_02::serial::Read<u8> + embedded_hal_02::serial::Write<u8>,
    <S as embedded_hal_02::serial::Read<u8>>::Error: LineError,
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

impl<S> embedded_io::ReadReady for Usart<S>
where
    S: embedded_hal_02::serial::Read<u8> + embedded_hal_02::serial::Write<u8>,
    <S as embedded_hal_02::serial::Read<u8>>::Error: LineError,
{
    fn read_ready(&mut self) -> Result<bool, UsartError> {
        if self.pending.is_none() {
            self.pending = self.poll_byte()?;
        }
        Ok(self.pending.is_some())
    }
}

impl<S> embedded_io::Read for Usart<S>
where
    S: embedded_hal_02::serial::Read<u8> + embedded_hal_02::serial::Write<u8>,
    <S as embedded_hal_02::serial::Read<u8>>::Error: LineError,
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
