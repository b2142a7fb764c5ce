//! Benchmark: the per-scan pipeline on the recorded 1141-point LMS511 scans, instructions
//! per scan for each stage and end to end (mean and max), checked against the budget.
//!
//! Under QEMU (`-icount shift=0`) the counter is in executed instructions; on hardware in
//! core cycles. Exits with failure when the end-to-end maximum exceeds the budget.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::instruction_loop;
use firmware::pipeline::{Pipeline, Stage};
use firmware::recorded::{self, BEAMS_PER_SCAN, SCAN_COUNT, TRUE_POSES};
use firmware::stage_stats::StageStats;
use loc_core::geometry::Pose2;
use loc_core::scan::Scan;

/// End-to-end budget per 1141-point scan, instructions (about 9 ms of a 168 MHz Cortex-M4F
/// at one instruction per cycle, well under the 40 ms scan period at 25 Hz).
const BUDGET_INSTRUCTIONS: u64 = 1_500_000;

/// Iterations of the calibration loop (4 instructions each).
const CALIBRATION_ITERATIONS: u32 = 250_000;

#[entry]
fn main() -> ! {
    let Some(board) = SelectedBoard::take() else {
        defmt::error!("board peripherals already taken");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    defmt::println!(
        "bench on {=str}, counter unit {}",
        SelectedBoard::NAME,
        SelectedBoard::COUNTER_UNIT
    );

    // Calibration: a loop of known length against the counter.
    let expected = u64::from(CALIBRATION_ITERATIONS) * instruction_loop::INSTRUCTIONS_PER_ITERATION;
    let t0 = board.counter_now();
    instruction_loop::run(CALIBRATION_ITERATIONS);
    let measured = board.counter_now() - t0;
    defmt::println!(
        "calibration: {=u64} instructions executed, counter says {=u64} (resolution {=u64})",
        expected,
        measured,
        SelectedBoard::COUNTER_RESOLUTION
    );

    for cost in firmware::math_costs::measure_all(&board) {
        defmt::println!(
            "math {=str}: {=u64} instructions per call",
            cost.name,
            cost.per_call
        );
    }

    let Some(scan) = cortex_m::singleton!(: Scan = Scan::new()) else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let mut raw = [0u16; BEAMS_PER_SCAN];
    let [x, y, th] = TRUE_POSES[0];
    let mut pipeline = Pipeline::new(Pose2::new(x, y, th));
    let mut stats = [StageStats::new(); Stage::ALL.len()];
    let mut end_to_end = StageStats::new();
    for k in 0..SCAN_COUNT {
        if !recorded::load_scan_mm(k, &mut raw) {
            defmt::error!("recorded scan {=usize} missing", k);
            SelectedBoard::exit(ExitStatus::Failure)
        }
        let costs = pipeline.process(&board, scan, &raw).costs;
        for (s, c) in stats.iter_mut().zip(costs.0) {
            s.record(c);
        }
        end_to_end.record(costs.end_to_end());
    }

    defmt::println!(
        "instructions per scan over {=usize} scans of {=usize} beams:",
        SCAN_COUNT,
        BEAMS_PER_SCAN
    );
    for (stage, s) in Stage::ALL.iter().zip(stats.iter()) {
        defmt::println!(
            "stage {=str}: mean {=u64} max {=u64}",
            stage.name(),
            s.mean(),
            s.max
        );
    }
    defmt::println!(
        "stage end-to-end: mean {=u64} max {=u64}",
        end_to_end.mean(),
        end_to_end.max
    );
    if end_to_end.max <= BUDGET_INSTRUCTIONS {
        defmt::println!(
            "budget PASS: max {=u64} <= {=u64} instructions per scan",
            end_to_end.max,
            BUDGET_INSTRUCTIONS
        );
        SelectedBoard::exit(ExitStatus::Success)
    } else {
        defmt::println!(
            "budget FAIL: max {=u64} > {=u64} instructions per scan",
            end_to_end.max,
            BUDGET_INSTRUCTIONS
        );
        SelectedBoard::exit(ExitStatus::Failure)
    }
}
