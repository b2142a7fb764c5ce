//! RAM use as the part sees it: static RAM from the linker's symbols and the stack's
//! high-water mark by painting.
//!
//! cortex-m-rt lays RAM out as `.data`, `.bss`, `.uninit` from the start of RAM (up to
//! `__sheap`) and the stack from the end of RAM (`_stack_start`) downwards. [`paint_stack`]
//! fills the free gap between them with [`PAINT`]; [`usage`] later finds the lowest word the
//! stack overwrote. Static RAM plus that high-water mark is what the program needs; on a
//! part with less RAM the stack would have run into the statics.

/// The word painted into the free stack.
pub const PAINT: u32 = 0xC0FF_EE5A;

/// Words left unpainted below the stack pointer when painting (the painter's own frame).
const GUARD_WORDS: usize = 64;

extern "C" {
    // cortex-m-rt's link.x symbols: start of .data (start of the program's RAM), the end of
    // the statics (start of the would-be heap) and the initial stack pointer (end of RAM).
    static mut __sdata: u32;
    static mut __sheap: u32;
    static mut _stack_start: u32;
}

/// What the program uses of RAM, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct RamUsage {
    /// `.data` + `.bss` + `.uninit`.
    pub static_bytes: u32,
    /// Deepest the stack has been since [`paint_stack`].
    pub stack_high_water_bytes: u32,
    /// RAM between the statics and the stack's end (what the linker script gives the stack).
    pub stack_room_bytes: u32,
    /// False when no painted word is left: the stack may have reached the statics (the
    /// high-water mark is then a lower bound).
    pub headroom_left: bool,
}

impl RamUsage {
    /// Static RAM plus the stack's high-water mark, bytes.
    pub fn total_bytes(&self) -> u32 {
        self.static_bytes + self.stack_high_water_bytes
    }
}

fn bounds() -> (usize, usize, usize) {
    // Only the addresses of the linker symbols are taken, never their contents.
    (
        core::ptr::addr_of!(__sdata) as usize,
        core::ptr::addr_of!(__sheap) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}

/// Paints the free stack (from the end of the statics up to a little below the current
/// stack pointer) with [`PAINT`]. Call once, early in `main`.
pub fn paint_stack() {
    let (_, heap_start, _) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(GUARD_WORDS * 4) & !3;
    let mut p = (heap_start + 3) & !3;
    while p < end {
        // SAFETY: [heap_start, sp − guard) is RAM between the statics and the live stack:
        // nothing else uses it (no heap), and it is word-aligned.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Static RAM and the stack's high-water mark since [`paint_stack`].
pub fn usage() -> RamUsage {
    let (data_start, heap_start, stack_end) = bounds();
    let mut p = (heap_start + 3) & !3;
    // SAFETY: reads of word-aligned RAM between the statics and the end of RAM.
    while p < stack_end && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    let word = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    RamUsage {
        static_bytes: word(heap_start - data_start),
        stack_high_water_bytes: word(stack_end - p),
        stack_room_bytes: word(stack_end - heap_start),
        headroom_left: p > ((heap_start + 3) & !3),
    }
}
