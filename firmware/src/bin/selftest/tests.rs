//! The on-target tests themselves, one function each, registered in [`run_all`].

use firmware::board::{Board, CounterUnit, SelectedBoard};
use firmware::instruction_loop;
use firmware::pipeline::Pipeline;
use firmware::pose_frame::{PoseFrame, PoseStatus, MAX_FRAME_BYTES};
use firmware::recorded::{self, BEAMS_PER_SCAN, SCAN_COUNT, TRUE_POSES};
use firmware::test_harness::{check, TestResult, TestRunner};
use loc_core::geometry::Pose2;
use loc_core::scan::Scan;

/// Runs every test.
pub fn run_all(runner: &mut TestRunner, board: &mut SelectedBoard) {
    runner.run("counter_calibrates_against_known_loop", || {
        counter_calibrates(board)
    });
    runner.run("counter_is_deterministic", || {
        counter_is_deterministic(board)
    });
    runner.run("pose_frame_round_trips", pose_frame_round_trips);
    runner.run(
        "pose_frame_rejects_corruption",
        pose_frame_rejects_corruption,
    );
    runner.run("uart_sends_pose_frame", || uart_sends_pose_frame(board));
    runner.run("recorded_scans_convert_and_strip", || {
        recorded_scans_convert_and_strip(board)
    });
}

/// Iterations of the calibration loop (4 instructions each): 1 M instructions.
const CALIBRATION_ITERATIONS: u32 = 250_000;

/// Under QEMU (instruction counter) the counter agrees with a loop of known instruction
/// count to within one counter resolution plus the loop's fixed set-up. On hardware (cycle
/// counter) cycles per instruction vary with the pipeline, so only the order of magnitude
/// is checked (0.4 to 3 cycles per instruction).
fn counter_calibrates(board: &SelectedBoard) -> TestResult {
    let expected = u64::from(CALIBRATION_ITERATIONS) * instruction_loop::INSTRUCTIONS_PER_ITERATION;
    let t0 = board.counter_now();
    instruction_loop::run(CALIBRATION_ITERATIONS);
    let measured = board.counter_now() - t0;
    defmt::println!(
        "  loop of {=u64} instructions measured as {=u64} {}",
        expected,
        measured,
        SelectedBoard::COUNTER_UNIT
    );
    match SelectedBoard::COUNTER_UNIT {
        CounterUnit::Instructions => {
            let slack = 2 * SelectedBoard::COUNTER_RESOLUTION + 64;
            check(
                measured + slack >= expected && measured <= expected + slack,
                "counter disagrees with the known-length loop (is QEMU run with -icount shift=0?)",
            )
        }
        CounterUnit::Cycles => check(
            measured * 10 >= expected * 4 && measured <= expected * 3,
            "cycle counter far from the known-length loop (is the DWT running?)",
        ),
    }
}

/// The same code measures the same count twice (QEMU icount is deterministic).
fn counter_is_deterministic(board: &SelectedBoard) -> TestResult {
    let mut counts = [0u64; 3];
    for c in counts.iter_mut() {
        let t0 = board.counter_now();
        instruction_loop::run(10_000);
        *c = board.counter_now() - t0;
    }
    let spread =
        counts.iter().max().copied().unwrap_or(0) - counts.iter().min().copied().unwrap_or(0);
    check(
        spread <= SelectedBoard::COUNTER_RESOLUTION,
        "repeated measurements of the same loop differ by more than one tick",
    )
}

fn sample_frame() -> PoseFrame {
    PoseFrame {
        sequence: 42,
        x_m: 12.5,
        y_m: -0.75,
        theta_rad: 0.125,
        covariance_upper: [1e-3, 0.0, 0.0, 2e-3, 0.0, 1e-4],
        status: PoseStatus::Tracking,
    }
}

fn pose_frame_round_trips() -> TestResult {
    let frame = sample_frame();
    let mut buf = [0u8; MAX_FRAME_BYTES];
    let encoded = frame.encode(&mut buf).map_err(|_| "encode failed")?;
    check(
        encoded.last() == Some(&0),
        "frame does not end in the 0x00 delimiter",
    )?;
    check(
        encoded.iter().rev().skip(1).all(|&b| b != 0),
        "COBS frame holds a 0x00 before its end",
    )?;
    let decoded = PoseFrame::decode(encoded).map_err(|_| "decode failed")?;
    check(decoded == frame, "decoded frame differs from the original")
}

fn pose_frame_rejects_corruption() -> TestResult {
    let mut buf = [0u8; MAX_FRAME_BYTES];
    let len = sample_frame()
        .encode(&mut buf)
        .map_err(|_| "encode failed")?
        .len();
    // Cut the frame short: the tail of the payload is missing.
    let Some(prefix) = buf.get_mut(..len / 2) else {
        return Err("frame shorter than expected");
    };
    if let Some(last) = prefix.last_mut() {
        *last = 0;
    }
    check(
        PoseFrame::decode(prefix).is_err(),
        "a truncated frame decoded",
    )
}

/// Sends a pose frame over the board UART (the runner captures UART0 to a file and checks
/// it). Exercises the UART's transmit path end to end.
fn uart_sends_pose_frame(board: &mut SelectedBoard) -> TestResult {
    use embedded_io::Write;
    let mut buf = [0u8; MAX_FRAME_BYTES];
    let encoded = sample_frame()
        .encode(&mut buf)
        .map_err(|_| "encode failed")?;
    let serial = board.serial();
    serial.write_all(encoded).map_err(|_| "UART write failed")?;
    serial.flush().map_err(|_| "UART flush failed")?;
    defmt::println!(
        "  uart0 frame {=usize} bytes: {=[u8]:02x}",
        encoded.len(),
        encoded
    );
    Ok(())
}

/// Every recorded scan converts to points and both tunnel walls are found in it, with most
/// points on them (the recording is a straight tunnel).
fn recorded_scans_convert_and_strip(board: &SelectedBoard) -> TestResult {
    let Some(scan) = cortex_m::singleton!(: Scan = Scan::new()) else {
        return Err("scan buffer already taken");
    };
    let mut raw = [0u16; BEAMS_PER_SCAN];
    for (k, &[x, y, th]) in TRUE_POSES.iter().enumerate().take(SCAN_COUNT) {
        check(recorded::load_scan_mm(k, &mut raw), "recorded scan missing")?;
        let mut pipeline = Pipeline::new(Pose2::new(x, y, th));
        let outcome = pipeline.process(board, scan, &raw);
        check(
            scan.len() > 1000,
            "fewer than 1000 valid beams in a recorded scan",
        )?;
        check(
            outcome.strip.left.is_some() && outcome.strip.right.is_some(),
            "stripping did not find both walls",
        )?;
        let c = outcome.strip.counts;
        check(
            u32::from(c.left_wall) + u32::from(c.right_wall) > 500,
            "fewer than 500 wall points",
        )?;
    }
    Ok(())
}
