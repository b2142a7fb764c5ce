//! Cost per call of the `loc_core::math` functions on the target, to tell which ones a hot
//! loop can afford (on the Cortex-M4F, libm's single-precision functions partly compute in
//! double precision, which the FPU cannot do: those steps run in software).

use core::hint::black_box;

use loc_core::math;

use firmware::board::Board;

/// Calls per function measured.
const CALLS: u32 = 256;

/// One measured function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MathCost {
    /// Function name as in `loc_core::math`.
    pub name: &'static str,
    /// Mean cost per call including the loop and `black_box` overhead (about 10
    /// instructions), counter units.
    pub per_call: u64,
}

fn measure<B: Board>(board: &B, name: &'static str, f: impl Fn(f32) -> f32) -> MathCost {
    let t0 = board.counter_now();
    let mut acc = 0.0f32;
    for i in 0..CALLS {
        // Inputs spread over (-3.2, 3.2) rad so range reduction takes its usual paths.
        let x = black_box(i as f32 * 0.025 - 3.2);
        acc += f(x);
    }
    black_box(acc);
    let total = board.counter_now() - t0;
    MathCost {
        name,
        per_call: total / u64::from(CALLS),
    }
}

/// Measures the maths functions the core's hot loops use.
pub fn measure_all<B: Board>(board: &B) -> [MathCost; 7] {
    [
        measure(board, "mul_add (baseline)", |x| x * 1.5 + 0.25),
        measure(board, "sqrt", |x| math::sqrt(x * x + 1.0)),
        measure(board, "sin", math::sin),
        measure(board, "cos", math::cos),
        measure(board, "sin_cos", |x| {
            let (s, c) = math::sin_cos(x);
            s + c
        }),
        measure(board, "atan2", |x| math::atan2(x, 1.0 - x)),
        measure(board, "hypot", |x| math::hypot(x, 2.0)),
    ]
}
