//! On-target tests, run under QEMU mps2-an386 by `run-qemu-tests.sh`; prints
//! `N passed, N failed` and exits with failure if any test failed.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};
use firmware::test_harness::TestRunner;

mod tests;

#[entry]
fn main() -> ! {
    let Some(mut board) = SelectedBoard::take() else {
        defmt::error!("board peripherals already taken");
        SelectedBoard::exit(ExitStatus::Failure)
    };
    defmt::println!("selftest on {=str}", SelectedBoard::NAME);
    let mut runner = TestRunner::new();
    tests::run_all(&mut runner, &mut board);
    if runner.finish() {
        SelectedBoard::exit(ExitStatus::Success)
    } else {
        SelectedBoard::exit(ExitStatus::Failure)
    }
}
