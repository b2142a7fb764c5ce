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
use firmware::stage_costs::ScanStage;
use firmware_testbench::instruction_loop;
use firmware_testbench::recorded::{BEAMS_PER_SCAN, MAP_LANDMARKS, SCAN_COUNT};
use firmware_testbench::replay;
use firmware_testbench::stage_stats::StageStats;

/// End-to-end budget per 1141-point scan, instructions (about 9 ms of a 168 MHz Cortex-M4F
/// at one instruction per cycle, well under the 40 ms scan period at 25 Hz).
const BUDGET_INSTRUCTIONS: u64 = 1_500_000;

/// RAM budget of the controller: static RAM plus the stack's high-water mark, bytes (half
/// of an STM32F407's 192 KiB, leaving the rest to the vehicle interface).
const RAM_BUDGET_BYTES: u32 = 96 * 1024;

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
    firmware::ram::paint_stack();
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

    let Some(controller) = Controller::take() else {
        fail()
    };
    // The map the controller gets: the image in the board's map flash region (the recorded
    // 120 m tunnel, or the same tunnel's 1 km or 10 km one the test script flashes instead),
    // opened in place.
    let (map, map_cost) = match replay::load_map(&board) {
        Ok(m) => m,
        Err(e) => {
            defmt::error!("the map flash region holds no usable map image: {}", e);
            fail()
        }
    };
    defmt::println!(
        "map: image of {=usize} bytes, {=usize} segments, {=usize} landmarks, checked in {=u64} and queried in place",
        map.len_bytes(),
        map.segment_count(),
        map.landmark_count(),
        map_cost
    );
    if map.landmark_count() < MAP_LANDMARKS {
        defmt::error!("the map region holds a smaller map than the recording's");
        fail()
    }

    let report = match replay::replay(&board, controller, replay::ReplayStart::RecordedPose) {
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
    for (stage, s) in ScanStage::ALL.iter().zip(report.stages.iter()) {
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
    for (stage, cost) in ScanStage::ALL.iter().zip(worst.0) {
        defmt::println!(
            "  {=str}: {=u64} ({=u64} % of the budget)",
            stage.name(),
            cost,
            cost * 100 / BUDGET_INSTRUCTIONS
        );
    }

    // The same recording without a start pose: the controller relocalises (the search in
    // the match stage's place) until a placement wins, then tracks.
    let reloc = match replay::replay(&board, controller, replay::ReplayStart::Relocalise) {
        Ok(r) => r,
        Err(e) => {
            defmt::error!("replay without a start pose failed: {}", e);
            fail()
        }
    };
    print_stats("relocalising scan (no start pose)", &reloc.relocalising);
    print_stats(
        "end-to-end without a start pose, all scans",
        &reloc.end_to_end,
    );
    defmt::println!(
        "without a start pose: {=u32} scans relocalising, first tracking at scan {}, {=u32} tracking scans off by more than 0.3 m, final error {=f32} m",
        reloc.statuses[4],
        reloc.first_tracking_scan,
        reloc.wrong_tracking_scans,
        reloc.final_error_m
    );

    let mut ok = true;
    let ram = firmware::ram::usage();
    defmt::println!(
        "ram: static {=u32} bytes + stack high-water mark {=u32} bytes = {=u32} bytes ({=u32} KiB) of {=u32} bytes of stack room",
        ram.static_bytes,
        ram.stack_high_water_bytes,
        ram.total_bytes(),
        ram.total_bytes().div_ceil(1024),
        ram.stack_room_bytes
    );
    if ram.headroom_left && ram.total_bytes() <= RAM_BUDGET_BYTES {
        defmt::println!(
            "ram PASS: {=u32} <= {=u32} bytes",
            ram.total_bytes(),
            RAM_BUDGET_BYTES
        );
    } else {
        defmt::println!(
            "ram FAIL: {=u32} bytes (budget {=u32}; headroom left: {=bool})",
            ram.total_bytes(),
            RAM_BUDGET_BYTES,
            ram.headroom_left
        );
        ok = false;
    }
    let worst = report.end_to_end.max.max(reloc.end_to_end.max);
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
