//! The localisation controller: LMS511 on the board's serial port, a pose frame (postcard +
//! COBS) out after every scan. See `firmware::controller`.
//!
//! Build with `FW_CONTROLLER_SCANS=N` in the environment to stop after N scans (test runs
//! under QEMU against the LMS5xx emulator).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::controller::{self, Controller, SESSION_BUFFER_BYTES};

/// Scans after which a test build stops (`FW_CONTROLLER_SCANS` at build time).
const SCAN_LIMIT: Option<u32> = parse_limit(option_env!("FW_CONTROLLER_SCANS"));

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
    let (source, start, record_error) = match controller::start_pose(region, map) {
        Ok(s) => s,
        Err(e) => controller::wait_without_map(&mut board, &e),
    };
    if let Some(e) = record_error {
        defmt::warn!(
            "start pose record unusable ({}): starting at the tunnel entrance",
            e
        );
    }
    defmt::println!(
        "controller on {=str}: map image of {=usize} bytes, {=usize} landmarks, read in place; start ({=f32}, {=f32}, {=f32}) from {}",
        SelectedBoard::NAME,
        map.len_bytes(),
        map.landmark_count(),
        start.pose.x_m,
        start.pose.y_m,
        start.pose.theta_rad,
        source
    );
    if let Err(e) = controller.start(&start) {
        defmt::error!("start pose rejected by the filter: {}", e);
        SelectedBoard::exit(ExitStatus::Failure)
    }
    controller::run(&mut board, controller, session_buf, SCAN_LIMIT)
}
