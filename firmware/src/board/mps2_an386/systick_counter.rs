//! A 64-bit instruction counter from SysTick under QEMU `-icount shift=0`.
//!
//! QEMU has no cycle model: DWT CYCCNT reads 0. With `-icount shift=0` every guest
//! instruction advances the virtual clock by exactly 1 ns, and SysTick, clocked from the
//! MPS2 25 MHz processor clock, ticks once per 40 ns, i.e. once per 40 executed instructions,
//! deterministically run to run. The self-test `systick_counts_40_instructions_per_tick`
//! calibrates this against an assembly loop of known length.
//!
//! SysTick is a 24-bit down-counter; the SysTick exception counts wraps so the count
//! extends to 64 bits (one wrap every 2^24 ticks = 671 million instructions).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;

/// Executed instructions per SysTick tick under `-icount shift=0` on mps2 (1 GHz virtual
/// instruction clock / 25 MHz SysTick clock).
pub const INSTRUCTIONS_PER_TICK: u64 = 40;

/// SysTick reload value: the full 24-bit range.
const RELOAD: u32 = 0x00FF_FFFF;

/// Completed SysTick periods (wraps) since `start`.
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// The running SysTick counter.
pub struct SysTickCounter {
    _syst: SYST,
}

impl SysTickCounter {
    /// Starts SysTick on the processor clock with the full 24-bit reload and its wrap
    /// exception enabled.
    pub fn start(mut syst: SYST) -> Self {
        syst.disable_counter();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        WRAPS.store(0, Ordering::Relaxed);
        syst.enable_interrupt();
        syst.enable_counter();
        Self { _syst: syst }
    }

    /// SysTick ticks since `start` (64-bit). Must not be called with interrupts masked for
    /// longer than one SysTick period, or a wrap is missed.
    pub fn ticks(&self) -> u64 {
        loop {
            let before = WRAPS.load(Ordering::Acquire);
            let current = SYST::get_current();
            let after = WRAPS.load(Ordering::Acquire);
            // A wrap between the two loads makes `current` ambiguous: read again.
            if before == after {
                let in_period = u64::from(RELOAD - current);
                return u64::from(before) * (u64::from(RELOAD) + 1) + in_period;
            }
        }
    }

    /// Executed instructions since `start`, with a resolution of [`INSTRUCTIONS_PER_TICK`].
    pub fn instructions(&self) -> u64 {
        self.ticks() * INSTRUCTIONS_PER_TICK
    }
}
