//! Benchmark: the product's controller on the recorded 1141-point LMS511 telegrams against
//! the flashed map; instructions per scan for each stage (telegram to scan, strip, select,
//! match, filter — loc-core's stages timed through its stage hook) and end to end (mean and
//! max), checked against the budget.
//!
//! Under QEMU (`-icount shift=0`) the counter is in executed instructions; on hardware in
//! core cycles. Exits with failure when the end-to-end maximum exceeds the budget, or when
//! the replay itself fails.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::controller::Controller;
use firmware_testbench::instruction_loop;
use firmware_testbench::recorded::{BEAMS_PER_SCAN, MAP_BYTES_LEN, MAP_LANDMARKS, SCAN_COUNT};
use firmware_testbench::replay;
use firmware_testbench::stage_stats::{BenchStage, StageStats};
use loc_core::map::TunnelMap;

/// End-to-end budget per 1141-point scan, instructions (about 9 ms of a 168 MHz Cortex-M4F
/// at one instruction per cycle, well under the 40 ms scan period at 25 Hz).
const BUDGET_INSTRUCTIONS: u64 = 1_500_000;

fn fail() -> ! {
    SelectedBoard::exit(ExitStatus::Failure)
}

fn print_stats(name: &str, s: &StageStats) {
    defmt::println!(
        "stage {=str}: mean {=u64} max {=u64}",
        name,
        s.mean(),
        s.max
    );
}

#[entry]
fn main() -> ! {
    let Some(board) = SelectedBoard::take() else {
        defmt::error!("board peripherals already taken");
        fail()
    };
    defmt::println!(
        "bench on {=str}, counter unit {}",
        SelectedBoard::NAME,
        SelectedBoard::COUNTER_UNIT
    );

    // Calibration: a loop of known length against the counter.
    let (expected, measured) = instruction_loop::calibrate(&board);
    defmt::println!(
        "calibration: {=u64} instructions executed, counter says {=u64} (resolution {=u64})",
        expected,
        measured,
        SelectedBoard::COUNTER_RESOLUTION
    );

    for cost in firmware_testbench::math_costs::measure_all(&board) {
        defmt::println!("math {=str}: {=u64} per call", cost.name, cost.per_call);
    }

    let (Some(map), Some(slot)) = (
        cortex_m::singleton!(: TunnelMap = TunnelMap::new()),
        cortex_m::singleton!(: Option<Controller<'static>> = None),
    ) else {
        fail()
    };
    let map_cost = match replay::load_map(&board, map) {
        Ok(cost) => cost,
        Err(e) => {
            defmt::error!("map failed to load: {}", e);
            fail()
        }
    };
    defmt::println!(
        "map: {=usize} bytes, {=usize} landmarks, loaded and indexed in {=u64}",
        MAP_BYTES_LEN,
        MAP_LANDMARKS,
        map_cost
    );
    let map: &'static TunnelMap = map;

    let report = match replay::replay(&board, map, slot) {
        Ok(r) => r,
        Err(e) => {
            defmt::error!("replay failed: {}", e);
            fail()
        }
    };

    defmt::println!(
        "per scan over {=usize} scans of {=usize} beams ({}):",
        SCAN_COUNT,
        BEAMS_PER_SCAN,
        SelectedBoard::COUNTER_UNIT
    );
    for (stage, s) in BenchStage::ALL.iter().zip(report.stages.iter()) {
        print_stats(stage.name(), s);
    }
    print_stats("end-to-end (controller)", &report.end_to_end);
    print_stats(
        "end-to-end (controller) without the first, acquisition scan",
        &report.tracking,
    );
    defmt::println!(
        "localizer: {=u32} tracking, {=u32} degenerate, {=u32} rejected, {=u32} map unconfirmed; final error {=f32} m, {=f32} rad; max error over the second half {=f32} m",
        report.statuses[0],
        report.statuses[1],
        report.statuses[2],
        report.statuses[3],
        report.final_error_m,
        report.final_heading_error_rad,
        report.max_late_error_m
    );

    let (worst_k, worst) = report.worst_scan;
    defmt::println!("worst scan {=usize}:", worst_k);
    for (stage, cost) in BenchStage::ALL.iter().zip(worst.0) {
        defmt::println!(
            "  {=str}: {=u64} ({=u64} % of the budget)",
            stage.name(),
            cost,
            cost * 100 / BUDGET_INSTRUCTIONS
        );
    }

    let mut ok = true;
    let worst = report.end_to_end.max;
    if worst <= BUDGET_INSTRUCTIONS {
        defmt::println!(
            "budget PASS: max {=u64} <= {=u64} instructions per scan end to end",
            worst,
            BUDGET_INSTRUCTIONS
        );
    } else {
        defmt::println!(
            "budget FAIL: max {=u64} > {=u64} instructions per scan end to end ({=u64} over, {=u64} % of the budget)",
            worst,
            BUDGET_INSTRUCTIONS,
            worst - BUDGET_INSTRUCTIONS,
            worst * 100 / BUDGET_INSTRUCTIONS
        );
        ok = false;
    }
    SelectedBoard::exit(if ok {
        ExitStatus::Success
    } else {
        ExitStatus::Failure
    })
}
