//! A loop of exactly known instruction count, to calibrate the board's counter.
//!
//! Under QEMU `-icount shift=0` the SysTick tick is documented as 40 instructions; this
//! loop lets the self-tests and the benchmark check that figure instead of trusting it.

/// Instructions executed per iteration of [`run`]'s loop body (`nop; nop; subs; bne`).
pub const INSTRUCTIONS_PER_ITERATION: u64 = 4;

/// Executes `iterations` × [`INSTRUCTIONS_PER_ITERATION`] instructions (plus a fixed
/// handful of set-up instructions) and returns. `iterations` must be at least 1.
#[inline(never)]
pub fn run(iterations: u32) {
    let n = iterations.max(1);
    // SAFETY: pure register arithmetic on a scratch register; no memory access, no stack.
    unsafe {
        core::arch::asm!(
            "2:",
            "nop",
            "nop",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}

/// Iterations of the calibration loop (4 instructions each): 1 M instructions.
pub const CALIBRATION_ITERATIONS: u32 = 250_000;

/// Runs the calibration loop on `board`: `(instructions executed, counter difference)`.
pub fn calibrate<B: firmware::board::Board>(board: &B) -> (u64, u64) {
    let expected = u64::from(CALIBRATION_ITERATIONS) * INSTRUCTIONS_PER_ITERATION;
    let t0 = board.counter_now();
    run(CALIBRATION_ITERATIONS);
    (expected, board.counter_now() - t0)
}
