//! Register-level driver for the ARM CMSDK APB watchdog (MPS2 AN385/AN386 at
//! `0x4000_8000`; QEMU models it and resets the machine when it fires).
//!
//! Registers (ARM DDI 0479C, "APB watchdog"), 32-bit, offsets from the base:
//!
//! | offset | name | use here |
//! |---|---|---|
//! | `0x000` | WDOGLOAD | count to load, watchdog clock cycles (25 MHz on MPS2) |
//! | `0x008` | WDOGCONTROL | `0` INTEN (counter and interrupt enable), `1` RESEN (reset enable) |
//! | `0x00C` | WDOGINTCLR | any write clears the interrupt and reloads the counter (feeding) |
//! | `0xC00` | WDOGLOCK | `0x1ACCE551` unlocks writes, anything else locks them |
//!
//! The counter counts down from WDOGLOAD; at zero it raises its interrupt (the NMI on
//! MPS2) and reloads; at zero again with the interrupt still set it resets the system. So a
//! program that stops feeding is reset after two periods: the load is half the timeout.

use core::ptr;

mod reg {
    pub const LOAD: usize = 0x000;
    pub const CONTROL: usize = 0x008;
    pub const INTCLR: usize = 0x00C;
    pub const LOCK: usize = 0xC00;
}

const UNLOCK_KEY: u32 = 0x1ACC_E551;
const INTEN: u32 = 1 << 0;
const RESEN: u32 = 1 << 1;

/// The CMSDK watchdog of the board.
pub struct CmsdkWatchdog {
    base: usize,
    clock_hz: u32,
}

impl CmsdkWatchdog {
    /// The watchdog at `base`, clocked at `clock_hz`, not started.
    ///
    /// # Safety
    /// `base` must be the address of a CMSDK APB watchdog, and this the only value driving
    /// it.
    pub const unsafe fn new(base: usize, clock_hz: u32) -> Self {
        Self { base, clock_hz }
    }

    fn write(&mut self, offset: usize, value: u32) {
        // SAFETY: `new`'s contract: `base` is this watchdog's register block and we own it.
        unsafe { ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// Starts it: the system resets if not fed within `timeout_ms`.
    pub fn start(&mut self, timeout_ms: u32) {
        let cycles = u64::from(self.clock_hz) * u64::from(timeout_ms) / 1000 / 2;
        self.write(reg::LOCK, UNLOCK_KEY);
        self.write(reg::LOAD, u32::try_from(cycles.max(1)).unwrap_or(u32::MAX));
        self.write(reg::INTCLR, 1);
        self.write(reg::CONTROL, INTEN | RESEN);
        self.write(reg::LOCK, 0);
    }

    /// Feeds it: the counter starts its period again.
    pub fn feed(&mut self) {
        self.write(reg::LOCK, UNLOCK_KEY);
        self.write(reg::INTCLR, 1);
        self.write(reg::LOCK, 0);
    }
}
