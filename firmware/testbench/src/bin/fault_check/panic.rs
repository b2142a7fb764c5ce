//! Checks the panic path: panics on purpose; `run-qemu-tests.sh` expects the logged panic
//! message and QEMU's failure exit status (not a hang).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, SelectedBoard};

#[entry]
fn main() -> ! {
    let _board = SelectedBoard::take();
    let limit = core::hint::black_box(3usize);
    let values = [1u8, 2, 3];
    // Out of bounds on purpose: the index is hidden from the optimiser.
    let v = values[limit];
    panic!("fault check reached the end (value {v})");
}
