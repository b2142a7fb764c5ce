//! Time for the session's time-outs: a caller-given monotonic millisecond clock.
//!
//! The session never reads a system clock itself, so it runs the same on the MCU (SysTick or a
//! timer peripheral) and on the host ([`StdClock`], feature `std`), and tests can drive it.

/// A monotonic clock in milliseconds. Must never go backwards; its zero is arbitrary.
pub trait Clock {
    /// Milliseconds since an arbitrary fixed origin.
    fn now_ms(&self) -> u64;
}

/// Any `Fn() -> u64` returning milliseconds is a clock (e.g. a closure over a tick counter).
impl<F: Fn() -> u64> Clock for F {
    fn now_ms(&self) -> u64 {
        self()
    }
}

/// The host's monotonic clock ([`std::time::Instant`]), zero at creation.
#[cfg(feature = "std")]
#[derive(Debug, Clone, Copy)]
pub struct StdClock {
    origin: std::time::Instant,
}

#[cfg(feature = "std")]
impl StdClock {
    /// A clock reading 0 now.
    pub fn new() -> Self {
        StdClock {
            origin: std::time::Instant::now(),
        }
    }
}

#[cfg(feature = "std")]
impl Default for StdClock {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(feature = "std")]
impl Clock for StdClock {
    fn now_ms(&self) -> u64 {
        u64::try_from(self.origin.elapsed().as_millis()).unwrap_or(u64::MAX)
    }
}
