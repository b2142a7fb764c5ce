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
use loc_core::map::TunnelMap;

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
    let Some(mut board) = SelectedBoard::take() else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let (Some(map), Some(slot), Some(session_buf)) = (
        cortex_m::singleton!(: TunnelMap = TunnelMap::new()),
        cortex_m::singleton!(: Option<Controller<'static>> = None),
        cortex_m::singleton!(: [u8; SESSION_BUFFER_BYTES] = [0; SESSION_BUFFER_BYTES]),
    ) else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let region = board.map_region();
    let start =
        controller::load_map(region, map).and_then(|()| controller::start_pose(region, map));
    let (source, start, record_error) = match start {
        Ok(s) => s,
        Err(e) => controller::wait_without_map(&mut board, &e),
    };
    if let Some(e) = record_error {
        defmt::warn!(
            "start pose record unusable ({}): starting at the tunnel entrance",
            e
        );
    }
    let map: &'static TunnelMap = map;
    defmt::println!(
        "controller on {=str}: map of {=usize} landmarks; start ({=f32}, {=f32}, {=f32}) from {}",
        SelectedBoard::NAME,
        map.landmarks().len(),
        start.pose.x_m,
        start.pose.y_m,
        start.pose.theta_rad,
        source
    );
    let Some(controller) = Controller::new(map, &start) else {
        defmt::error!("start covariance rejected by the filter");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let controller = slot.insert(controller);
    controller::run(&mut board, controller, session_buf, SCAN_LIMIT)
}
