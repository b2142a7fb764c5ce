//! The on-target tests themselves, one function each, registered in [`run_all`].

use controller_wire::{MotionSource, PoseAvailability, PoseFrame, PoseStatus, MAX_FRAME_BYTES};
use firmware::board::{Board, CounterUnit, SelectedBoard};
use firmware::controller::{self, Controller, StartSource, START_POSE_BLOCK_BYTES};
use firmware::odometry::OdometryInput;
use firmware_testbench::instruction_loop;
use firmware_testbench::recorded::{
    self, BEAMS_PER_SCAN, INITIAL_ERROR, MAP_BYTES_LEN, MAP_LANDMARKS, SCAN_COUNT,
};
use firmware_testbench::replay;
use firmware_testbench::test_harness::{check, TestResult, TestRunner};
use lidar_driver::{Frame, ScanData};
use loc_core::geometry::Point2;
use loc_core::localizer::{LocalizerConfig, StartPoseError};
use loc_core::map::{MapError, MapImage, MapQuery};
use loc_core::scan::Scan;
use loc_core::scan::LMS511_MAX_BEAMS;
use loc_core::strip::{strip_walls, PointLabel};

/// The large buffers the tests share (statics owned by `main`).
pub struct Memory {
    /// The program's map image, once opened.
    pub map: Option<&'static MapImage<'static>>,
    /// A scan buffer.
    pub scan: &'static mut Scan,
    /// The controller under test.
    pub controller: &'static mut Controller<'static>,
    /// A RAM copy of the map bytes to damage.
    pub map_copy: &'static mut [u8; MAP_BYTES_LEN],
}

/// Runs every test.
pub fn run_all(runner: &mut TestRunner, board: &mut SelectedBoard, memory: Memory) {
    let Memory {
        mut map,
        scan,
        controller,
        map_copy,
    } = memory;
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
    runner.run("vehicle_port_sends_pose_frame", || {
        vehicle_port_sends_pose_frame(board)
    });
    runner.run("odometry_frames_arrive_on_uart1", || {
        odometry_arrives(board)
    });
    runner.run(
        "a_scan_without_a_new_odometry_frame_is_not_a_standstill",
        no_new_odometry_frame_is_no_increment,
    );
    runner.run(
        "the_first_scan_is_predicted_from_the_first_odometry_frame",
        first_scan_is_predicted_from_the_first_frame,
    );
    runner.run(
        "streamed_odometry_is_carried_to_each_scans_time",
        streamed_odometry_is_carried_to_each_scan,
    );
    runner.run(
        "a_repeated_frame_keeps_odometry_fresh_and_adds_no_motion",
        repeated_frame_is_no_new_reading,
    );
    runner.run(
        "an_outage_is_bridged_by_odometry_and_a_restarted_sender_is_not",
        outage_is_bridged_by_odometry,
    );
    runner.run("damaged_map_bytes_are_rejected", || {
        damaged_map_is_rejected(map_copy)
    });
    runner.run("map_loads_from_flash_bytes", || map_loads(board, &mut map));
    runner.run("map_flash_region_holds_the_flashed_map", || {
        map_region_loads(board)
    });
    runner.run("recorded_scans_strip_to_both_walls", || scans_strip(scan));
    runner.run("telegram_scans_step_by_the_exact_beam_angle", || {
        telegram_scans_use_the_exact_step(scan)
    });
    runner.run(
        "start_pose_record_and_its_damage",
        start_pose_record_and_its_damage,
    );
    runner.run("controller_converges_on_recorded_telegrams", || match map {
        Some(_) => controller_converges(board, controller),
        None => Err("no map to localise against (map_loads_from_flash_bytes failed)"),
    });
    runner.run(
        "controller_without_a_start_pose_relocalises_on_recorded_telegrams",
        || match map {
            Some(_) => controller_relocalises(board, controller),
            None => Err("no map to localise against (map_loads_from_flash_bytes failed)"),
        },
    );
}

/// Under QEMU (instruction counter) the counter agrees with a loop of known instruction
/// count to within one counter resolution plus the loop's fixed set-up. On hardware (cycle
/// counter) cycles per instruction vary with the pipeline, so only the order of magnitude
/// is checked (0.4 to 3 cycles per instruction).
fn counter_calibrates(board: &SelectedBoard) -> TestResult {
    let (expected, measured) = instruction_loop::calibrate(board);
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
    let max = counts.iter().max().copied().unwrap_or(0);
    let min = counts.iter().min().copied().unwrap_or(0);
    check(
        max - min <= SelectedBoard::COUNTER_RESOLUTION,
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
        protection_m: 0.08,
        availability: PoseAvailability::Available,
        motion: MotionSource::Odometry,
        after_reset: false,
        work: 1_234_567,
        stage_work: [120_000, 330_000, 77_000, 600_000, 55_000],
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
/// it against the bytes logged here). Exercises the UART's transmit path end to end.
fn vehicle_port_sends_pose_frame(board: &mut SelectedBoard) -> TestResult {
    use embedded_io::Write;
    let mut buf = [0u8; MAX_FRAME_BYTES];
    let encoded = sample_frame()
        .encode(&mut buf)
        .map_err(|_| "encode failed")?;
    let serial = board.vehicle_serial();
    serial
        .write_all(encoded)
        .map_err(|_| "vehicle port write failed")?;
    serial.flush().map_err(|_| "vehicle port flush failed")?;
    defmt::println!(
        "  vehicle port frame {=usize} bytes: {=[u8]:02x}",
        encoded.len(),
        encoded
    );
    Ok(())
}

/// The recorded odometry, sent to UART1 as the vehicle would (`odometry_frames.bin`: one
/// cumulative-pose frame per scan with line garbage after the tenth, fed by the runner with
/// `-chardev file,input-path=…`), arrives whole: every frame decoded, the garbage counted as
/// one malformed frame, and the motion between frames is the recorded odometry.
fn odometry_arrives(board: &mut SelectedBoard) -> TestResult {
    let mut input = OdometryInput::new();
    let mut previous_scan: Option<loc_core::filter::OdometryIncrement> = None;
    let mut k = 0usize;
    let deadline_ms = board.now_ms() + 2_000;
    while k < SCAN_COUNT && board.now_ms() < deadline_ms {
        // Byte by byte, so each frame is taken as it completes.
        use embedded_io::{Read, ReadReady};
        let port = board.vehicle_serial();
        if !port.read_ready().map_err(|_| "UART1 error")? {
            continue;
        }
        let mut byte = [0u8; 1];
        port.read(&mut byte).map_err(|_| "UART1 read failed")?;
        let before = input.counts().frames;
        input.push(byte[0], board.now_ms());
        if input.counts().frames == before {
            continue;
        }
        // One frame per scan: take it as the odometry at scan k.
        let increment = input.increment_for_scan(board.now_ms());
        if k > 0 {
            let inc = increment.ok_or("fresh odometry gave no increment")?;
            let [dx, dy, dth] = recorded::ODOMETRY[k];
            check(
                loc_core::math::abs(inc.dx_m - dx) < 1e-4
                    && loc_core::math::abs(inc.dy_m - dy) < 1e-4
                    && loc_core::math::abs(inc.dtheta_rad - dth) < 1e-5,
                "the increment between two odometry frames is not the recorded odometry",
            )?;
        }
        previous_scan = increment;
        k += 1;
    }
    let counts = input.counts();
    defmt::println!(
        "  odometry on uart1: {} (last increment {})",
        counts,
        defmt::Debug2Format(&previous_scan)
    );
    check(
        counts.frames as usize == SCAN_COUNT,
        "not every odometry frame arrived on UART1 (run QEMU with a second -serial fed odometry_frames.bin)",
    )?;
    check(
        counts.malformed == 1 && counts.lost == 0,
        "the line garbage was not counted as one malformed frame",
    )
}

/// An odometry frame on the x axis: `sequence`, sent every `period_us`.
fn odometry_frame(
    sequence: u32,
    period_us: u64,
    x_m: f32,
    theta_rad: f32,
) -> controller_wire::OdometryFrame {
    controller_wire::OdometryFrame {
        sequence,
        time_us: u64::from(sequence) * period_us,
        x_m,
        y_m: 0.0,
        theta_rad,
    }
}

/// Feeds `frame`'s bytes to `input` as received at `now_ms`.
fn push_frame(
    input: &mut OdometryInput,
    frame: controller_wire::OdometryFrame,
    now_ms: u64,
) -> TestResult {
    let mut buf = [0u8; controller_wire::MAX_ODOMETRY_FRAME_BYTES];
    let Ok(bytes) = frame.encode(&mut buf) else {
        return Err("odometry frame did not encode");
    };
    for &b in bytes.iter() {
        input.push(b, now_ms);
    }
    Ok(())
}

/// A scan for which no new odometry frame arrived (the previous scan's frame is still the
/// latest) gets no increment — a zero one would say the vehicle stood still — nor does the
/// next (its increment would span a scan already predicted); then odometry resumes.
fn no_new_odometry_frame_is_no_increment() -> TestResult {
    let mut input = OdometryInput::new();
    let push = |input: &mut OdometryInput, sequence: u32, x_m: f32, now_ms: u64| {
        push_frame(input, odometry_frame(sequence, 40_000, x_m, 0.0), now_ms)
    };
    push(&mut input, 1, 0.0, 0)?;
    check(
        input.increment_for_scan(0).is_none(),
        "the first scan has no increment",
    )?;
    push(&mut input, 2, 0.1, 40)?;
    let inc = input
        .increment_for_scan(40)
        .ok_or("a new frame gave no increment")?;
    check(
        loc_core::math::abs(inc.dx_m - 0.1) < 1e-6,
        "wrong increment",
    )?;
    // No new frame by the next scan: no increment, though frame 2 is only 40 ms old.
    check(
        input.increment_for_scan(80).is_none(),
        "the previous scan's frame was taken as fresh odometry (a standstill)",
    )?;
    push(&mut input, 4, 0.3, 110)?;
    check(
        input.increment_for_scan(120).is_none(),
        "the scan after a gap took an increment spanning a predicted scan",
    )?;
    push(&mut input, 5, 0.4, 150)?;
    let inc = input
        .increment_for_scan(160)
        .ok_or("odometry did not resume")?;
    check(
        loc_core::math::abs(inc.dx_m - 0.1) < 1e-6,
        "wrong increment after the gap",
    )
}

/// The first frame received is the reading at the start pose: a vehicle already moving
/// when its first scan comes gets that scan predicted by the motion since (not at constant
/// velocity from a standstill), and the start reading is spent on that scan.
fn first_scan_is_predicted_from_the_first_frame() -> TestResult {
    let mut input = OdometryInput::new();
    let frame =
        |sequence: u32, x_m: f32, theta_rad: f32| odometry_frame(sequence, 20_000, x_m, theta_rad);
    push_frame(&mut input, frame(0, 0.0, 0.0), 0)?;
    push_frame(&mut input, frame(1, 0.04, 0.001), 20)?;
    push_frame(&mut input, frame(2, 0.08, 0.002), 40)?;
    let inc = input
        .increment_for_scan(40)
        .ok_or("the first scan had no increment from the start reading")?;
    check(
        loc_core::math::abs(inc.dx_m - 0.08) < 1e-5
            && loc_core::math::abs(inc.dtheta_rad - 0.002) < 1e-6,
        "the first scan's increment is not the motion since the first frame",
    )?;
    push_frame(&mut input, frame(3, 0.12, 0.003), 60)?;
    let inc = input
        .increment_for_scan(60)
        .ok_or("the second scan had no increment")?;
    check(
        loc_core::math::abs(inc.dx_m - 0.04) < 1e-4,
        "the second scan's increment is not the motion since the first scan",
    )?;
    // The start reading is spent: after a gap, no increment reaches back to it.
    check(
        input.increment_for_scan(300).is_none(),
        "a scan without fresh odometry took an increment",
    )
}

/// A vehicle that streams odometry at 100 Hz while the scanner runs at 75 Hz: each scan's
/// increment is the motion between the scans' own times (to the board's millisecond), not
/// between the frames before them — those are 10 or 20 ms apart where the scans are 13 or
/// 14 ms apart, a 3 m/s drive moved 3 to 6 mm off at every scan, given back at the next.
fn streamed_odometry_is_carried_to_each_scan() -> TestResult {
    const SPEED_M_PER_MS: f32 = 0.003;
    let mut input = OdometryInput::new();
    let mut last_scan_ms = 0u64;
    let mut scans = 0u32;
    let mut worst_m = 0.0f32;
    for now_ms in 0..=400u64 {
        if now_ms % 10 == 0 {
            let seq = (now_ms / 10) as u32;
            let frame = odometry_frame(seq, 10_000, SPEED_M_PER_MS * now_ms as f32, 0.0);
            push_frame(&mut input, frame, now_ms)?;
        }
        // 75 Hz: scan k at ⌊40 k / 3⌋ ms.
        if now_ms != u64::from(scans) * 40 / 3 {
            continue;
        }
        scans += 1;
        let inc = input.increment_for_scan(now_ms);
        // From the fifth scan on: the first has only the start reading; the fourth ends
        // the first interval with two frames (26–40 ms), which shows that the vehicle
        // streams, and its increment still starts at the third's frame as it came.
        if scans >= 5 {
            let inc = inc.ok_or("a streamed frame gave no increment")?;
            let want_m = SPEED_M_PER_MS * (now_ms - last_scan_ms) as f32;
            worst_m = loc_core::math::max(worst_m, loc_core::math::abs(inc.dx_m - want_m));
        }
        last_scan_ms = now_ms;
    }
    defmt::info!(
        "  streamed odometry: {} scans, worst increment error {} m",
        scans,
        worst_m
    );
    check(scans > 25, "too few scans")?;
    check(
        worst_m < 1e-4,
        "a scan's increment is not the motion between the scans' times",
    )?;
    // The odometry's rate (a first scan's sweep speed): 3 m/s, from the frames' stamps.
    let rate = input.rate().ok_or("no rate from two frames")?;
    check(
        loc_core::math::abs(rate.v_x_mps - 1000.0 * SPEED_M_PER_MS) < 1e-3
            && rate.omega_radps == 0.0,
        "the odometry's rate is not the motion between its last two frames",
    )
}

/// One frame per scan, repeated every 20 ms while the controller works (as `host-sim hil`
/// sends them): the repeats keep the reading fresh long after it first came, and they are
/// neither new motion nor a sign of streaming — each scan's increment is the frames'
/// difference as sent, not carried on by the time since the frame came.
fn repeated_frame_is_no_new_reading() -> TestResult {
    let mut input = OdometryInput::new();
    let frame = |k: u32| odometry_frame(k, 300_000, 0.9 * k as f32, 0.0);
    for k in 0..8u32 {
        let sent_ms = u64::from(k) * 300;
        push_frame(&mut input, frame(k), sent_ms)?;
        // Even frames: the scan comes 5 ms after its frame, before any repeat (taken for
        // streaming, the frame would be carried on by 5 ms: 15 mm). Odd ones: 270 ms after
        // it, 10 ms after its last repeat (stale by its first arrival alone).
        let scan_ms = if k % 2 == 0 {
            sent_ms + 5
        } else {
            sent_ms + 270
        };
        for repeat in 1..14u64 {
            let at_ms = sent_ms + 20 * repeat;
            if at_ms < scan_ms {
                push_frame(&mut input, frame(k), at_ms)?;
            }
        }
        let inc = input.increment_for_scan(scan_ms);
        for repeat in 1..14u64 {
            let at_ms = sent_ms + 20 * repeat;
            if at_ms > scan_ms {
                push_frame(&mut input, frame(k), at_ms)?;
            }
        }
        match (k, inc) {
            (0, None) => {}
            (0, Some(_)) => return Err("the start reading alone gave an increment"),
            (_, None) => return Err("a repeated frame was taken as stale"),
            (_, Some(inc)) => check(
                loc_core::math::abs(inc.dx_m - 0.9) < 1e-5,
                "a repeated frame was taken for new motion or for streaming",
            )?,
        }
    }
    check(
        input.counts().lost == 0,
        "repeats were counted as lost frames",
    )
}

/// After a reset the last tracked pose is carried over the outage by the odometry
/// readings before and after it, its uncertainty grown with the distance; a reading from
/// a restarted sender, one from too fast a drive, or no reading kept are refused.
fn outage_is_bridged_by_odometry() -> TestResult {
    use controller_wire::OdometryFrame;
    use firmware::resume::{bridge, BridgeRefusal};
    use firmware::retained::LastScan;
    use loc_core::geometry::Pose2;
    let reading = |sequence: u32, time_s: f32, x_m: f32, theta_rad: f32| OdometryFrame {
        sequence,
        time_us: (time_s * 1e6) as u64,
        x_m,
        y_m: 0.0,
        theta_rad,
    };
    let noise = loc_core::filter::OdometryNoise::DEFAULT;
    // World heading π/2 at (10, 20); the odometry's own frame is turned against it.
    let last = LastScan {
        pose: Pose2::new(10.0, 20.0, core::f32::consts::FRAC_PI_2),
        sigma_xy_m: 0.005,
        sigma_theta_rad: 0.001,
        odometry: Some(reading(100, 4.0, 50.0, 0.0)),
    };
    // 15 m straight ahead over 1.5 s (10 m/s).
    let b = bridge(&last, &reading(140, 5.5, 65.0, 0.0), &noise)
        .map_err(|_| "a plausible outage was not bridged")?;
    let p = b.start.pose;
    check(
        loc_core::math::hypot(p.x_m - 10.0, p.y_m - 35.0) < 1e-3,
        "the start is not 15 m along the last heading",
    )?;
    // loc-core's default model over 15 m: the heading's random walk (16 mrad/√m) bends the
    // path by 0.54 m sideways, the scale error (3 %) is 0.45 m along; 0.70 m in all.
    check(
        b.start.sigma_xy_m > 0.65 && b.start.sigma_xy_m < 0.75,
        "the start's position sigma does not follow the odometry model",
    )?;
    check(
        b.start.sigma_theta_rad > 0.06 && b.start.sigma_theta_rad < 0.07,
        "the start's heading sigma does not follow the odometry model",
    )?;
    check(
        bridge(&last, &reading(3, 0.2, 0.0, 0.0), &noise) == Err(BridgeRefusal::SenderRestarted),
        "a restarted odometry sender was bridged",
    )?;
    check(
        matches!(
            bridge(&last, &reading(140, 5.5, 150.0, 0.0), &noise),
            Err(BridgeRefusal::Implausible { .. })
        ),
        "100 m in 1.5 s was bridged",
    )?;
    let unkept = LastScan {
        odometry: None,
        ..last
    };
    check(
        bridge(&unkept, &reading(140, 5.5, 65.0, 0.0), &noise)
            == Err(BridgeRefusal::NoOdometryAtLastScan),
        "bridged without a kept reading",
    )
}

/// A flipped bit, a cut-off image and a foreign header are each refused with their own
/// error.
fn damaged_map_is_rejected(copy: &mut [u8; MAP_BYTES_LEN]) -> TestResult {
    copy.copy_from_slice(recorded::MAP_BYTES);
    // A bit flip deep in the body (past the 64-byte header).
    let Some(b) = copy.get_mut(MAP_BYTES_LEN / 2) else {
        return Err("recorded map too short");
    };
    *b ^= 0x10;
    check(
        matches!(
            MapImage::from_bytes(copy),
            Err(MapError::ChecksumMismatch { .. })
        ),
        "a bit flip in the image was not reported as a checksum mismatch",
    )?;
    check(
        matches!(
            MapImage::from_bytes(&recorded::MAP_BYTES[..MAP_BYTES_LEN - 7]),
            Err(MapError::Truncated { .. })
        ),
        "a truncated image was not reported as truncated",
    )?;
    copy.copy_from_slice(recorded::MAP_BYTES);
    copy[0] = b'X';
    check(
        matches!(MapImage::from_bytes(copy), Err(MapError::NotAnImage { .. })),
        "a foreign header was not reported as not an image",
    )
}

/// The flashed map opens in place, holds the recorded landmarks, and answers a query: from
/// the centre line of the 5 m tunnel the nearest wall is 2.5 m away.
fn map_loads(board: &SelectedBoard, slot: &mut Option<&'static MapImage<'static>>) -> TestResult {
    let (map, cost) = replay::load_map(board).map_err(|_| "the flashed map did not open")?;
    *slot = Some(map);
    defmt::println!(
        "  map image of {=usize} bytes checked in {=u64}",
        MAP_BYTES_LEN,
        cost
    );
    check(
        map.landmark_count() == MAP_LANDMARKS,
        "the map has a different landmark count than the recorded one",
    )?;
    // Between landmarks? The nearest geometry is a wall or a landmark, so at most 2.5 m.
    let hit = map
        .nearest(Point2::new(60.0, 0.0), 5.0)
        .ok_or("no map geometry within 5 m of the centre line")?;
    check(
        hit.projection.distance_m <= 2.5 + 1e-3 && hit.projection.distance_m > 1.5,
        "nearest map geometry from the centre line not where the 5 m tunnel puts it",
    )
}

/// Recorded telegram `k`, decoded.
fn telegram(k: usize) -> Result<ScanData<'static>, &'static str> {
    let bytes = recorded::telegram(k).ok_or("recorded telegram missing")?;
    let frame = Frame::new_checked(bytes).map_err(|_| "a recorded telegram is not a frame")?;
    ScanData::new_checked(frame).map_err(|_| "a recorded telegram did not decode")
}

/// Every recorded telegram converts (scan-input) to > 1000 points and both tunnel walls
/// are found in it.
fn scans_strip(scan: &mut Scan) -> TestResult {
    let config = LocalizerConfig::default();
    let mut labels = [PointLabel::Outlier; LMS511_MAX_BEAMS];
    for k in 0..SCAN_COUNT {
        scan_input::load_scan(
            &telegram(k)?,
            &config.sensor,
            firmware::controller::ECHO_SELECTION,
            scan,
        )
        .map_err(|_| "scan-input refused a recorded telegram")?;
        check(
            scan.len() > 1000,
            "fewer than 1000 valid beams in a recorded scan",
        )?;
        let strip = strip_walls(scan.points(), &config.strip, &mut labels);
        check(
            strip.left.is_some() && strip.right.is_some(),
            "stripping did not find both walls",
        )?;
        check(
            strip.counts.landmark > 0,
            "no landmark point in a scan of a landmarked tunnel",
        )?;
    }
    Ok(())
}

/// The telegrams say 1667 (1/10000°) but 25 Hz and 54 kHz: the conversion steps by the
/// exact 1/6°, so the last of the 1141 beams sits at 185°, not 185.04°.
fn telegram_scans_use_the_exact_step(scan: &mut Scan) -> TestResult {
    let sensor = LocalizerConfig::default().sensor;
    for k in 0..SCAN_COUNT {
        let layout = scan_input::load_scan(
            &telegram(k)?,
            &sensor,
            firmware::controller::ECHO_SELECTION,
            scan,
        )
        .map_err(|_| "scan-input refused a recorded telegram")?;
        check(
            usize::from(layout.beams) == BEAMS_PER_SCAN,
            "telegram without 1141 beams",
        )?;
        let last_deg = layout.beam_angle_rad(BEAMS_PER_SCAN - 1) * 180.0 / core::f64::consts::PI;
        check(
            (last_deg - 185.0).abs() < 1e-6,
            "the last beam is not at 185 degrees (the rounded step was used)",
        )?;
    }
    Ok(())
}

/// The recorded start-pose record reads back as the recording's start; a damaged copy is
/// refused by its CRC, and erased flash reads as no record.
fn start_pose_record_and_its_damage() -> TestResult {
    let start = replay::start_pose().map_err(|_| "the recorded start pose did not read")?;
    let [x, y, _] = recorded::TRUE_POSES[0];
    check(
        loc_core::math::abs(start.pose.x_m - (x + INITIAL_ERROR[0])) < 1e-5
            && loc_core::math::abs(start.pose.y_m - (y + INITIAL_ERROR[1])) < 1e-5,
        "start pose is not the recording's start plus its error",
    )?;
    let mut copy = [0u8; loc_core::localizer::START_POSE_BYTES];
    copy.copy_from_slice(recorded::START_POSE_BYTES);
    copy[9] ^= 0x01;
    check(
        loc_core::localizer::StartPose::from_bytes(&copy) == Err(StartPoseError::ChecksumMismatch),
        "a damaged start pose was not refused by its CRC",
    )?;
    check(
        loc_core::localizer::StartPose::from_bytes(&[0xFF; 32]) == Err(StartPoseError::NotPresent),
        "erased flash did not read as no start pose",
    )
}

/// Without a start pose the controller searches the map for the landmarks it sees and
/// never reports tracking at a wrong place (the cost of a relocalising scan is the bench's).
/// The recording's scans are 3 m apart, too sparse for a lock (a landmark must be seen in 5
/// scans): the lock itself is shown on the host (`loc-core/tests/relocalisation.rs`,
/// `host-sim relocalise`), on the same code.
fn controller_relocalises(
    board: &SelectedBoard,
    controller: &mut Controller<'static>,
) -> TestResult {
    let report = replay::replay(board, controller, replay::ReplayStart::Relocalise)
        .map_err(|_| "replay could not run")?;
    defmt::println!(
        "  first tracking at scan {} of {=usize}; {=u32} relocalising (max {=u64} per scan), {=u32} map unconfirmed, {=u32} tracking; final error {=f32} m; {=u32} tracking scans off by more than 0.3 m",
        report.first_tracking_scan,
        SCAN_COUNT,
        report.statuses[4],
        report.relocalising.max,
        report.statuses[3],
        report.statuses[0],
        report.final_error_m,
        report.wrong_tracking_scans
    );
    check(
        report.wrong_tracking_scans == 0,
        "tracking reported at a wrong place",
    )?;
    // Until a lock every scan says it is relocalising; a lock, if any, must track the truth.
    let locked = report.statuses[4] as usize != SCAN_COUNT;
    check(
        !locked || report.final_error_m < 0.05,
        "locked, but not onto the truth",
    )
}

/// From the recorded start pose (0.34 m and 0.02 rad off), the controller pulls in and
/// stays close to the truth over the recorded drive with 2 % odometry scale error.
fn controller_converges(board: &SelectedBoard, controller: &mut Controller<'static>) -> TestResult {
    let report = replay::replay(board, controller, replay::ReplayStart::RecordedPose)
        .map_err(|_| "replay could not run")?;
    let initial_error_m = loc_core::math::hypot(INITIAL_ERROR[0], INITIAL_ERROR[1]);
    defmt::println!(
        "  initial error {=f32} m; final {=f32} m, {=f32} rad; worst over the second half {=f32} m; {=u32} tracking, {=u32} degenerate, {=u32} rejected, {=u32} map unconfirmed",
        initial_error_m,
        report.final_error_m,
        report.final_heading_error_rad,
        report.max_late_error_m,
        report.statuses[0],
        report.statuses[1],
        report.statuses[2],
        report.statuses[3]
    );
    check(
        report.final_error_m < 0.05 && report.max_late_error_m < 0.1,
        "position error does not stay within 0.05 m (final) / 0.1 m (second half)",
    )?;
    check(
        report.final_heading_error_rad < 0.01,
        "heading error above 0.01 rad",
    )?;
    check(
        report.statuses[2] as usize * 4 <= SCAN_COUNT,
        "more than a quarter of the scans rejected",
    )?;
    // The drive's own map: confirmed from the first scan that sees two landmarks, or after
    // a few metres when the acquisition scan met them only in part.
    check(
        report.statuses[3] as usize * 4 <= SCAN_COUNT,
        "the drive's own map unconfirmed on more than a quarter of the scans",
    )
}

/// The board's map flash region holds the map and the start pose the test runner put there
/// (QEMU `-device loader,file=…/map.bin,addr=0x00300000` and
/// `…/start_pose.bin,addr=0x003FF000`), and the controller's start-up reads both.
fn map_region_loads(board: &SelectedBoard) -> TestResult {
    let region = board.map_region();
    check(
        region.get(..MAP_BYTES_LEN) == Some(recorded::MAP_BYTES),
        "map flash region does not hold the recorded map (run QEMU with -device loader,file=…/map.bin,addr=0x00300000)",
    )?;
    controller::load_map(region).map_err(|_| "map in the flash region did not open")?;
    check(
        controller::configuration(region) == Ok(Some(loc_core::localizer::LocalizerConfig::default())),
        "the flashed configuration record did not read back as the recording's (run QEMU with -device loader,file=…/config.bin,addr=0x003FE000)",
    )?;
    let (source, start, _) = controller::start_pose(region);
    let expected = replay::start_pose().map_err(|_| "the recorded start pose did not read")?;
    check(
        source == StartSource::Record && start == Some(expected),
        "the controller did not take the flashed start pose (run QEMU with -device loader,file=…/start_pose.bin,addr=0x003FF000)",
    )?;
    check(
        region.len() > START_POSE_BLOCK_BYTES + controller::CONFIG_BLOCK_BYTES + MAP_BYTES_LEN,
        "map region too small for the map and the start-pose block",
    )
}
