//! Register-level driver for the ARM CMSDK APB UART (UART0 of MPS2 AN385/AN386 at
//! `0x4000_4000`), as an `embedded-io` byte stream.
//!
//! Registers (ARM DDI 0479C, CMSDK technical reference, "APB UART"), 32-bit, offsets from
//! the base:
//!
//! | offset | name | bits used here |
//! |---|---|---|
//! | `0x000` | DATA | `[7:0]` write: byte to send; read: byte received |
//! | `0x004` | STATE | `0` TX buffer full, `1` RX buffer full, `2` TX overrun, `3` RX overrun (write 1 to clear) |
//! | `0x008` | CTRL | `0` TX enable, `1` RX enable, `2`/`3` TX/RX interrupt enable, `4`/`5` TX/RX overrun interrupt enable |
//! | `0x00C` | INTSTATUS / INTCLEAR | interrupt flags (polled driver: unused) |
//! | `0x010` | BAUDDIV | PCLK / baud, at least 16 (QEMU does not transmit below 16) |
//!
//! The buffer is one byte deep each way, so the driver polls: a byte received while the
//! previous one has not been read sets RX overrun, which `read` reports as an error.

use core::ptr;

/// Register offsets from the UART base, bytes.
mod reg {
    pub const DATA: usize = 0x000;
    pub const STATE: usize = 0x004;
    pub const CTRL: usize = 0x008;
    pub const BAUDDIV: usize = 0x010;
}

/// STATE register bits.
mod state {
    pub const TX_FULL: u32 = 1 << 0;
    pub const RX_FULL: u32 = 1 << 1;
    pub const RX_OVERRUN: u32 = 1 << 3;
}

/// CTRL register bits.
mod ctrl {
    pub const TX_EN: u32 = 1 << 0;
    pub const RX_EN: u32 = 1 << 1;
}

/// Smallest baud divisor the CMSDK UART accepts.
const MIN_BAUDDIV: u32 = 16;

/// What went wrong on the UART.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum UartError {
    /// A received byte was lost because the previous one had not been read yet: the reader
    /// is too slow for the line rate. The stream has a gap; a framer must resynchronise.
    RxOverrun,
}

impl core::fmt::Display for UartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            UartError::RxOverrun => f.write_str(
                "UART receive overrun: a byte was lost, read the port more often or lower the baud rate",
            ),
        }
    }
}

impl core::error::Error for UartError {}

impl embedded_io::Error for UartError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// One CMSDK APB UART, polled.
pub struct CmsdkUart {
    base: usize,
}

impl CmsdkUart {
    /// Sets up the UART at `base` for `baud` with peripheral clock `pclk_hz` and enables TX
    /// and RX (interrupts off).
    ///
    /// # Safety
    /// `base` must be the address of a CMSDK APB UART, and no other `CmsdkUart` (or other
    /// code) may use it while this one lives.
    pub unsafe fn new(base: usize, pclk_hz: u32, baud: u32) -> Self {
        let uart = Self { base };
        let div = (pclk_hz / baud.max(1)).max(MIN_BAUDDIV);
        uart.write_reg(reg::CTRL, 0);
        uart.write_reg(reg::BAUDDIV, div);
        // Clear stale overrun flags (write-one-to-clear).
        uart.write_reg(reg::STATE, 0b1100);
        uart.write_reg(reg::CTRL, ctrl::TX_EN | ctrl::RX_EN);
        uart
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: `new`'s contract: `base + offset` is a register of this UART, which this
        // value owns; MMIO needs volatile access.
        unsafe { ptr::read_volatile((self.base + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        // SAFETY: as in `read_reg`.
        unsafe { ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// Blocks until the transmit buffer has room, then sends `byte`.
    pub fn write_byte(&mut self, byte: u8) {
        while self.read_reg(reg::STATE) & state::TX_FULL != 0 {}
        self.write_reg(reg::DATA, u32::from(byte));
    }

    /// The received byte if one is waiting; `Err(RxOverrun)` (and the overrun flag cleared)
    /// if bytes were lost since the last read.
    pub fn try_read_byte(&mut self) -> Result<Option<u8>, UartError> {
        let st = self.read_reg(reg::STATE);
        if st & state::RX_OVERRUN != 0 {
            self.write_reg(reg::STATE, state::RX_OVERRUN);
            return Err(UartError::RxOverrun);
        }
        if st & state::RX_FULL != 0 {
            // Only the low 8 bits of DATA hold the byte.
            Ok(Some((self.read_reg(reg::DATA) & 0xFF) as u8))
        } else {
            Ok(None)
        }
    }
}

impl embedded_io::ErrorType for CmsdkUart {
    type Error = UartError;
}

impl embedded_io::Write for CmsdkUart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, UartError> {
        for &b in buf {
            self.write_byte(b);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), UartError> {
        while self.read_reg(reg::STATE) & state::TX_FULL != 0 {}
        Ok(())
    }
}

impl embedded_io::ReadReady for CmsdkUart {
    fn read_ready(&mut self) -> Result<bool, UartError> {
        Ok(self.read_reg(reg::STATE) & (state::RX_FULL | state::RX_OVERRUN) != 0)
    }
}

impl embedded_io::Read for CmsdkUart {
    /// Blocks until at least one byte arrived, then returns every byte already waiting (at
    /// most `buf.len()`).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        let mut n = 0;
        for slot in buf.iter_mut() {
            let byte = loop {
                match self.try_read_byte()? {
                    Some(b) => break Some(b),
                    // Block only for the first byte.
                    None if n == 0 => continue,
                    None => break None,
                }
            };
            match byte {
                Some(b) => {
                    *slot = b;
                    n += 1;
                }
                None => break,
            }
        }
        Ok(n)
    }
}
