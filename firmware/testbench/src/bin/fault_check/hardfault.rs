//! Checks the HardFault path: reads unmapped memory on purpose; `run-qemu-tests.sh` expects
//! the logged HardFault and QEMU's failure exit status (not a hang).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use firmware::board::{Board, ExitStatus, SelectedBoard};

/// An address no MPS2 AN386 memory or peripheral decodes (a bus error).
const UNMAPPED: usize = 0xF000_0000;

#[entry]
fn main() -> ! {
    let _board = SelectedBoard::take();
    // SAFETY: deliberately faulting read; the HardFault handler ends the program.
    let v = unsafe { core::ptr::read_volatile(UNMAPPED as *const u32) };
    defmt::error!(
        "read of unmapped memory returned {=u32} instead of faulting",
        v
    );
    SelectedBoard::exit(ExitStatus::Success)
}
