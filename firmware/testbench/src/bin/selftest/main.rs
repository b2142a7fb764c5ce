//! On-target tests, run under QEMU mps2-an386 by `run-qemu-tests.sh`; prints
//! `N passed, N failed` and exits with failure if any test failed.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::controller::Controller;
use firmware_testbench::test_harness::TestRunner;
use loc_core::scan::Scan;
use static_cell::ConstStaticCell;

mod tests;

// The large buffers built at compile time (no copy of them on the stack).
static SCAN: ConstStaticCell<Scan> = ConstStaticCell::new(Scan::new());
static MAP_COPY: ConstStaticCell<[u8; firmware_testbench::recorded::MAP_BYTES_LEN]> =
    ConstStaticCell::new([0; firmware_testbench::recorded::MAP_BYTES_LEN]);

#[entry]
fn main() -> ! {
    let Some(mut board) = SelectedBoard::take() else {
        defmt::error!("board peripherals already taken");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    let (Some(scan), Some(controller), Some(map_copy)) =
        (SCAN.try_take(), Controller::take(), MAP_COPY.try_take())
    else {
        SelectedBoard::exit(ExitStatus::Failure)
    };
    defmt::println!("selftest on {=str}", SelectedBoard::NAME);
    let mut runner = TestRunner::new();
    let memory = tests::Memory {
        map: None,
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
