//! On-target tests, run under QEMU mps2-an386 by `run-qemu-tests.sh`; prints
//! `N passed, N failed` and exits with failure if any test failed.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::controller::Controller;
use firmware_testbench::test_harness::TestRunner;
use loc_core::map::TunnelMap;
use loc_core::scan::Scan;

mod tests;

#[entry]
fn main() -> ! {
    let Some(mut board) = SelectedBoard::take() else {
        defmt::error!("board peripherals already taken");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let (Some(map), Some(scan), Some(controller), Some(map_copy)) = (
        cortex_m::singleton!(: TunnelMap = TunnelMap::new()),
        cortex_m::singleton!(: Scan = Scan::new()),
        cortex_m::singleton!(: Option<Controller<'static>> = None),
        cortex_m::singleton!(: [u8; firmware_testbench::recorded::MAP_BYTES_LEN] =
            [0; firmware_testbench::recorded::MAP_BYTES_LEN]),
    ) else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    defmt::println!("selftest on {=str}", SelectedBoard::NAME);
    let mut runner = TestRunner::new();
    let memory = tests::Memory {
        map,
        scan,
        controller,
        map_copy,
    };
    tests::run_all(&mut runner, &mut board, memory);
    if runner.finish() {
        SelectedBoard::exit(ExitStatus::Success)
    } else {
        SelectedBoard::exit(ExitStatus::Failure)
    }
}
