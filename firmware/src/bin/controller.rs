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
    let (source, pose, cov) = match controller::load_map(board.map_region(), map) {
        Ok(loaded) => loaded,
        Err(e) => {
            defmt::error!("stored map unusable: {}", defmt::Display2Format(&e));
            SelectedBoard::exit(ExitStatus::Failure)
        }
    };
    let map: &'static TunnelMap = map;
    defmt::println!(
        "controller on {=str}: map from {} ({=usize} landmarks), start ({=f32}, {=f32}, {=f32})",
        SelectedBoard::NAME,
        source,
        map.landmarks().len(),
        pose.x_m,
        pose.y_m,
        pose.theta_rad
    );
    let Some(controller) = Controller::new(map, pose, cov) else {
        defmt::error!("initial covariance rejected by the filter");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let controller = slot.insert(controller);
    controller::run(&mut board, controller, session_buf, SCAN_LIMIT)
}
