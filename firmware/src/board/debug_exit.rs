//! How an STM32 board ends a run: semihosting `SYS_EXIT` when a debugger (probe-rs) is
//! attached, so it returns the status; otherwise a system reset (a semihosting breakpoint
//! without a debugger would fault).

use super::ExitStatus;

/// Ends the run with `status`.
pub fn exit(status: ExitStatus) -> ! {
    // C_DEBUGEN: a debugger is attached and will answer semihosting.
    // SAFETY: read-only access to the core debug register DHCSR.
    let debugger_attached = unsafe { (*cortex_m::peripheral::DCB::PTR).dhcsr.read() } & 1 != 0;
    if debugger_attached {
        let code = match status {
            ExitStatus::Success => cortex_m_semihosting::debug::EXIT_SUCCESS,
            ExitStatus::Failure => cortex_m_semihosting::debug::EXIT_FAILURE,
        };
        cortex_m_semihosting::debug::exit(code);
    }
    cortex_m::peripheral::SCB::sys_reset()
}
