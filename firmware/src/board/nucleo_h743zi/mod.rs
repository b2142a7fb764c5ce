//! ST NUCLEO-H743ZI2 (STM32H743ZI, Cortex-M7 with double-precision FPU, 400 MHz here): the
//! real board the firmware is built for.
//!
//! - Serial: USART3 on PD8 (TX) / PD9 (RX), the ST-LINK virtual COM port, 115200 8N1; wire
//!   the LMS511's RS-232/RS-422 converter there (or change the pins in [`NucleoH743zi::take`]).
//! - Vehicle port: USART2 on PD5 (TX) / PD6 (RX), 115200 8N1: the vehicle computer's
//!   `controller_wire::OdometryFrame`s in, the pose frames out.
//! - Counter: the DWT cycle counter (core cycles), extended to 64 bits in software.
//! - Log: defmt over RTT, read by `probe-rs run`.
//! - Exit: semihosting `SYS_EXIT` when a debugger is attached (probe-rs returns the status),
//!   otherwise a system reset.
//!
//! Memory (`memory/nucleo-h743zi.x`): 2 MiB flash at `0x0800_0000`, AXI SRAM 512 KiB at
//! `0x2400_0000` as RAM.
//!
//! Flash and run: `cd firmware && probe-rs run --chip STM32H743ZITx
//! target/thumbv7em-none-eabihf/release/bench` after
//! `cargo build --release --no-default-features --features board-nucleo-h743zi`.

pub use super::cycle_counter::CycleCounter;
pub use super::polled_serial::{LineError, Usart, UsartError};

/// USART3: the lidar.
pub type Usart3 = Usart<stm32h7xx_hal::serial::Serial<pac::USART3>>;
/// USART2: the vehicle port (odometry frames in, pose frames out).
pub type Usart2 = Usart<stm32h7xx_hal::serial::Serial<pac::USART2>>;

impl LineError for stm32h7xx_hal::serial::Error {
    fn is_overrun(&self) -> bool {
        matches!(self, stm32h7xx_hal::serial::Error::Overrun)
    }
}

use stm32h7xx_hal::independent_watchdog::IndependentWatchdog;
use stm32h7xx_hal::{pac, prelude::*};

use super::{Board, CounterUnit, ExitStatus};

// The defmt global logger: RTT, read by the probe.
use defmt_rtt as _;

/// Core clock, Hz.
pub const SYS_CLK_HZ: u32 = 400_000_000;
/// USART3 line rate, baud.
pub const USART3_BAUD: u32 = 115_200;
/// USART2 (vehicle port) line rate, baud.
pub const USART2_BAUD: u32 = 115_200;

/// Start of the stored-map flash region: the last 256 KiB (two 128 KiB sectors of bank 2)
/// of the 2 MiB flash (`memory/nucleo-h743zi.x` gives the program the rest). Write a map
/// file there with `probe-rs download --chip STM32H743ZITx --binary-format bin
/// --base-address 0x081C0000 MAP.bin`.
pub const MAP_REGION_ADDR: usize = 0x081C_0000;
/// Length of the stored-map flash region, bytes.
pub const MAP_REGION_LEN: usize = 0x0004_0000;

/// The NUCLEO-H743ZI2 board: USART3 (lidar), USART2 (vehicle: odometry in, poses out), the
/// IWDG and the DWT cycle counter.
pub struct NucleoH743zi {
    usart3: Usart3,
    usart2: Usart2,
    watchdog: IndependentWatchdog,
    counter: CycleCounter,
}

impl Board for NucleoH743zi {
    type Serial = Usart3;
    type VehicleSerial = Usart2;
    const NAME: &'static str = "NUCLEO-H743ZI2 (STM32H743ZI, Cortex-M7 @ 400 MHz)";
    const COUNTER_UNIT: CounterUnit = CounterUnit::Cycles;
    const COUNTER_RESOLUTION: u64 = 1;

    /// Sets the clocks (400 MHz core from the HSI through PLL1, LDO supply), USART3 and the
    /// cycle counter. `None` if the peripherals were taken or USART3 cannot be set up.
    fn take() -> Option<Self> {
        let cp = cortex_m::Peripherals::take()?;
        let dp = pac::Peripherals::take()?;
        let pwrcfg = dp.PWR.constrain().freeze();
        let ccdr = dp
            .RCC
            .constrain()
            .sys_ck(SYS_CLK_HZ.Hz())
            .freeze(pwrcfg, &dp.SYSCFG);
        let gpiod = dp.GPIOD.split(ccdr.peripheral.GPIOD);
        let tx = gpiod.pd8.into_alternate();
        let rx = gpiod.pd9.into_alternate();
        let serial = dp
            .USART3
            .serial(
                (tx, rx),
                USART3_BAUD.bps(),
                ccdr.peripheral.USART3,
                &ccdr.clocks,
            )
            .ok()?;
        let odometry = dp
            .USART2
            .serial(
                (gpiod.pd5.into_alternate(), gpiod.pd6.into_alternate()),
                USART2_BAUD.bps(),
                ccdr.peripheral.USART2,
                &ccdr.clocks,
            )
            .ok()?;
        let counter = CycleCounter::start(cp.DCB, cp.DWT);
        Some(Self {
            usart3: Usart3::new(serial),
            usart2: Usart2::new(odometry),
            watchdog: IndependentWatchdog::new(dp.IWDG),
            counter,
        })
    }

    fn now_ms(&self) -> u64 {
        self.counter.cycles() / (SYS_CLK_HZ as u64 / 1000)
    }

    fn map_region(&self) -> &'static [u8] {
        // SAFETY: the region lies in flash outside every linker section (memory.x ends FLASH
        // below it); nothing programs flash while the firmware runs.
        unsafe { core::slice::from_raw_parts(MAP_REGION_ADDR as *const u8, MAP_REGION_LEN) }
    }

    fn serial(&mut self) -> &mut Usart3 {
        &mut self.usart3
    }

    fn vehicle_serial(&mut self) -> &mut Usart2 {
        &mut self.usart2
    }

    fn start_watchdog(&mut self, timeout_ms: u32) {
        self.watchdog.start(timeout_ms.millis());
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    fn counter_now(&self) -> u64 {
        self.counter.cycles()
    }

    fn exit(status: ExitStatus) -> ! {
        super::debug_exit::exit(status)
    }
}
