//! QEMU's MPS2 AN386 board (Cortex-M4F with FPU): the board CI runs the firmware on.
//!
//! Memory (QEMU `-machine mps2-an386`): 4 MiB "flash" (SSRAM1) at `0x0000_0000`, 4 MiB RAM
//! (SSRAM2/3) at `0x2000_0000` (`memory/mps2-an386.x`). The processor and peripheral clock is
//! 25 MHz. Run with
//! `qemu-system-arm -machine mps2-an386 -nographic -semihosting-config enable=on,target=native -icount shift=0 -kernel ELF`.

mod cmsdk_uart;
mod cmsdk_watchdog;
mod semihosting_exit;
mod systick_counter;

pub use cmsdk_uart::{CmsdkUart, UartError};
pub use cmsdk_watchdog::CmsdkWatchdog;
pub use systick_counter::{SysTickCounter, INSTRUCTIONS_PER_TICK};

use super::{Board, CounterUnit, ExitStatus};

// The defmt global logger: frames go to the host over semihosting stdout, decoded there by
// `defmt-print -e ELF`.
use defmt_semihosting as _;

/// Base address of UART0 (CMSDK APB UART) on MPS2 AN385/AN386.
pub const UART0_BASE: usize = 0x4000_4000;
/// Peripheral clock of the MPS2 FPGA images, Hz (UART baud divisor reference).
pub const PCLK_HZ: u32 = 25_000_000;
/// UART0 line rate, baud (QEMU ignores it, but the divisor must be at least 16 to transmit).
pub const UART0_BAUD: u32 = 115_200;
/// Base address of UART1 (CMSDK APB UART), the vehicle port (odometry in, poses out):
/// QEMU's second `-serial`.
pub const UART1_BASE: usize = 0x4000_5000;
/// Base address of the CMSDK APB watchdog (clocked at [`PCLK_HZ`]).
pub const WATCHDOG_BASE: usize = 0x4000_8000;

/// Start of the stored-map flash region: the last MiB of the 4 MiB code memory
/// (`memory/mps2-an386.x` gives the program the first 3 MiB). Load a map file there with
/// `-device loader,file=MAP.bin,addr=0x00300000`.
pub const MAP_REGION_ADDR: usize = 0x0030_0000;
/// Length of the stored-map flash region, bytes.
pub const MAP_REGION_LEN: usize = 0x0010_0000;

/// The MPS2 AN386 board: UART0 (lidar), UART1 (vehicle: odometry in, poses out), the CMSDK
/// watchdog and the SysTick instruction counter.
pub struct Mps2An386 {
    uart0: CmsdkUart,
    uart1: CmsdkUart,
    watchdog: CmsdkWatchdog,
    counter: SysTickCounter,
}

impl Board for Mps2An386 {
    type Serial = CmsdkUart;
    type VehicleSerial = CmsdkUart;
    const NAME: &'static str = "mps2-an386 (QEMU, Cortex-M4F)";
    const COUNTER_UNIT: CounterUnit = CounterUnit::Instructions;
    const COUNTER_RESOLUTION: u64 = INSTRUCTIONS_PER_TICK;

    /// Sets up UART0 and UART1 (115200 8N1, TX and RX enabled) and the SysTick counter.
    fn take() -> Option<Self> {
        let cp = cortex_m::Peripherals::take()?;
        // SAFETY: UART0_BASE is the CMSDK UART0 of this board; `Peripherals::take` above
        // succeeded, so this is the only place the board (and its UART) is constructed.
        let uart0 = unsafe { CmsdkUart::new(UART0_BASE, PCLK_HZ, UART0_BAUD) };
        // SAFETY: as above, for UART1.
        let uart1 = unsafe { CmsdkUart::new(UART1_BASE, PCLK_HZ, UART0_BAUD) };
        // SAFETY: WATCHDOG_BASE is the board's CMSDK watchdog, constructed once here.
        let watchdog = unsafe { CmsdkWatchdog::new(WATCHDOG_BASE, PCLK_HZ) };
        let counter = SysTickCounter::start(cp.SYST);
        Some(Self {
            uart0,
            uart1,
            watchdog,
            counter,
        })
    }

    fn now_ms(&self) -> u64 {
        // SysTick runs on the 25 MHz processor clock in QEMU's virtual time, with or without
        // -icount.
        self.counter.ticks() / (u64::from(PCLK_HZ) / 1000)
    }

    fn map_region(&self) -> &'static [u8] {
        // SAFETY: the region lies in the board's code memory, outside every linker section
        // (memory.x ends FLASH below it); nothing writes it while the program runs.
        unsafe { core::slice::from_raw_parts(MAP_REGION_ADDR as *const u8, MAP_REGION_LEN) }
    }

    fn serial(&mut self) -> &mut CmsdkUart {
        &mut self.uart0
    }

    fn vehicle_serial(&mut self) -> &mut CmsdkUart {
        &mut self.uart1
    }

    fn start_watchdog(&mut self, timeout_ms: u32) {
        self.watchdog.start(timeout_ms);
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    fn counter_now(&self) -> u64 {
        self.counter.instructions()
    }

    fn exit(status: ExitStatus) -> ! {
        semihosting_exit::exit(status)
    }
}
