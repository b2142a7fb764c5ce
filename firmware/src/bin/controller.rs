//! The localisation controller: LMS511 on the board's serial port, a pose frame (postcard +
//! COBS) out after every scan. See `firmware::controller`.
//!
//! Test builds (QEMU against the LMS5xx emulator), by environment variables at build time:
//! `FW_CONTROLLER_SCANS=N` stops after N scans; `FW_STALL_AFTER_SCANS=N` hangs after N scans
//! of the first run (the watchdog must reset the controller, which then resumes).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::controller::{
    self, Controller, RunOptions, StartSource, DEFAULT_RUN, SESSION_BUFFER_BYTES,
};
use loc_core::localizer::StartPose;

/// Scans after which a test build stops (`FW_CONTROLLER_SCANS` at build time).
const SCAN_LIMIT: Option<u32> = parse_limit(option_env!("FW_CONTROLLER_SCANS"));
/// Scans after which a test build hangs, once (`FW_STALL_AFTER_SCANS` at build time).
const STALL_AFTER_SCANS: Option<u32> = parse_limit(option_env!("FW_STALL_AFTER_SCANS"));

const fn parse_limit(text: Option<&str>) -> Option<u32> {
    let Some(text) = text else { return None };
    let bytes = text.as_bytes();
    let mut value = 0u32;
    let mut i = 0;
    while i < bytes.len() {
        let digit = bytes[i].wrapping_sub(b'0');
        if digit > 9 {
            return None;
        }
        value = value * 10 + digit as u32;
        i += 1;
    }
    if bytes.is_empty() {
        None
    } else {
        Some(value)
    }
}

#[entry]
fn main() -> ! {
    // For the RAM report of test runs (`firmware::ram`): the free stack, painted.
    firmware::ram::paint_stack();
    let boot = firmware::retained::boot();
    let Some(mut board) = SelectedBoard::take() else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let (Some(controller), Some(session_buf)) = (
        Controller::take(),
        cortex_m::singleton!(: [u8; SESSION_BUFFER_BYTES] = [0; SESSION_BUFFER_BYTES]),
    ) else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let region = board.map_region();
    let map = match controller::load_map(region) {
        Ok(map) => map,
        Err(e) => controller::wait_without_map(&mut board, &e),
    };
    match controller::configuration(region) {
        Ok(Some(config)) => {
            defmt::println!("configuration from the flash record");
            controller.configure(config);
        }
        Ok(None) => defmt::warn!(
            "no configuration record: loc-core's defaults (the LMS511 at the vehicle origin looking forward)"
        ),
        Err(e) => controller::wait_without_map(&mut board, &e),
    }
    let (mut source, mut start, record_error) = controller::start_pose(region);
    if boot.resets > 0 {
        defmt::warn!(
            "restarted after a reset while running (reset {=u32}): re-initialising the scanner session; poses marked after_reset until tracking",
            boot.resets
        );
        // Where the vehicle last was beats the start-pose record: it has not gone far.
        if let Some(last) = boot.last {
            start = Some(StartPose {
                pose: last.pose,
                sigma_xy_m: controller::DEFAULT_START_SIGMA[0],
                sigma_theta_rad: controller::DEFAULT_START_SIGMA[1],
            });
            source = StartSource::LastPoseBeforeReset;
            defmt::warn!(
                "  starting from the last tracked pose before the reset (carried over the outage by the odometry at the first scan)"
            );
        }
        controller::quiet_scanner(&mut board);
    }
    if let Some(e) = record_error {
        defmt::warn!("start pose record unusable ({}): relocalising", e);
    }
    defmt::println!(
        "controller on {=str}: map image of {=usize} bytes, {=usize} landmarks, read in place; start: {}",
        SelectedBoard::NAME,
        map.len_bytes(),
        map.landmark_count(),
        source
    );
    match start {
        Some(start) => {
            defmt::println!(
                "  at ({=f32}, {=f32}, {=f32})",
                start.pose.x_m,
                start.pose.y_m,
                start.pose.theta_rad
            );
            if let Err(e) = controller.start(&start) {
                defmt::error!("start pose rejected by the filter: {}", e);
                SelectedBoard::exit(ExitStatus::Failure)
            }
        }
        None => {
            defmt::println!(
                "  no start pose: relocalising (searching the map for the landmarks seen while driving)"
            );
            controller.relocalise();
        }
    }
    let options = RunOptions {
        scan_limit: SCAN_LIMIT,
        resets: boot.resets,
        resume: boot.last.filter(|_| boot.resets > 0),
        stall_after_scans: STALL_AFTER_SCANS,
        ..DEFAULT_RUN
    };
    controller::run(&mut board, controller, session_buf, &options)
}
