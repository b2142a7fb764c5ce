//! Ending a QEMU run with a status through ARM semihosting (`SYS_EXIT`).
//!
//! QEMU maps `ADP_Stopped_ApplicationExit` to host exit status 0 and every other reason to 1,
//! which is all a test runner needs.

use crate::board::ExitStatus;
use cortex_m_semihosting::debug;

/// Exits QEMU with `status`. Loops forever if no debugger/emulator handles semihosting.
pub fn exit(status: ExitStatus) -> ! {
    let code = match status {
        ExitStatus::Success => debug::EXIT_SUCCESS,
        ExitStatus::Failure => debug::EXIT_FAILURE,
    };
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}
