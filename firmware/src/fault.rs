//! Panic and HardFault handlers: log what happened over defmt, then end the run with
//! [`ExitStatus::Failure`] so QEMU (and CI) see a failure instead of a hang.
//!
//! `panic-probe` is not used: under QEMU it spins on a breakpoint and the run never ends.

use cortex_m_rt::{exception, ExceptionFrame};

use crate::board::{Board, ExitStatus, SelectedBoard};

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    SelectedBoard::exit(ExitStatus::Failure)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    SelectedBoard::exit(ExitStatus::Failure)
}
