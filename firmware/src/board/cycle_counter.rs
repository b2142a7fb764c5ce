//! A 64-bit core-cycle counter from the DWT's 32-bit CYCCNT.
//!
//! CYCCNT wraps every 2^32 cycles (10.7 s at 400 MHz); each read folds the elapsed cycles
//! into a 64-bit total, so reads at least once per wrap period (every scan does) keep it
//! exact.

use core::cell::Cell;

use cortex_m::peripheral::{DCB, DWT};

/// The running cycle counter.
pub struct CycleCounter {
    _dwt: DWT,
    last_raw: Cell<u32>,
    total: Cell<u64>,
}

impl CycleCounter {
    /// Enables tracing and starts CYCCNT.
    pub fn start(mut dcb: DCB, mut dwt: DWT) -> Self {
        dcb.enable_trace();
        // The M7 locks the DWT registers until the software lock access register is written.
        DWT::unlock();
        dwt.set_cycle_count(0);
        dwt.enable_cycle_counter();
        Self {
            _dwt: dwt,
            last_raw: Cell::new(0),
            total: Cell::new(0),
        }
    }

    /// Core cycles since `start`.
    pub fn cycles(&self) -> u64 {
        let raw = DWT::cycle_count();
        let delta = raw.wrapping_sub(self.last_raw.get());
        self.last_raw.set(raw);
        let total = self.total.get() + u64::from(delta);
        self.total.set(total);
        total
    }
}
