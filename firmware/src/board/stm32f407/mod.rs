//! STM32F407 (168 MHz Cortex-M4F with single-precision FPU, 192 KiB RAM, 1 MiB flash), the
//! part the controller's memory budget is set for; pins as on the STM32F4DISCOVERY.
//!
//! - Lidar: USART2 on PA2 (TX) / PA3 (RX), 115200 8N1 (the LMS511's RS-232/RS-422 converter).
//! - Vehicle port: USART3 on PD8 (TX) / PD9 (RX), 115200 8N1: `controller_wire`
//!   odometry frames in, pose frames out.
//! - Watchdog: the IWDG (LSI clock, independent of the core clock).
//! - Counter: the DWT cycle counter (core cycles), extended to 64 bits in software.
//! - Log: defmt over RTT, read by `probe-rs run`.
//! - Exit: semihosting `SYS_EXIT` when a debugger is attached, otherwise a system reset.
//!
//! Clocks: 168 MHz from the 8 MHz HSE crystal of the DISCOVERY board through the PLL.
//! Memory (`memory/stm32f407.x`): code in the first 512 KiB of flash, the map flash region in
//! the last 512 KiB (`0x0808_0000`: a 1 km map image is 83 KiB), SRAM1 + SRAM2 (128 KiB) as
//! RAM.
//!
//! Build and flash: `cd firmware && cargo build --release --no-default-features --features
//! board-stm32f407`, then `probe-rs download --chip STM32F407VGTx --binary-format bin
//! --base-address 0x08080000 MAP.image` and `probe-rs run --chip STM32F407VGTx
//! target/thumbv7em-none-eabihf/release/controller`.

use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::serial::Serial;
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use stm32f4xx_hal::{pac, prelude::*};

pub use super::cycle_counter::CycleCounter;
pub use super::polled_serial::{LineError, Usart, UsartError};

use super::{Board, CounterUnit, ExitStatus};

// The defmt global logger: RTT, read by the probe.
use defmt_rtt as _;

/// Core clock, Hz.
pub const SYS_CLK_HZ: u32 = 168_000_000;
/// HSE crystal of the STM32F4DISCOVERY, Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// Line rate of both USARTs, baud.
pub const BAUD: u32 = 115_200;

/// Start of the map flash region: flash sectors 8–11 (`memory/stm32f407.x` gives the
/// program sectors 0–7).
pub const MAP_REGION_ADDR: usize = 0x0808_0000;
/// Length of the map flash region, bytes (512 KiB).
pub const MAP_REGION_LEN: usize = 0x0008_0000;

/// USART2: the lidar.
pub type LidarUsart = Usart<Serial<pac::USART2>>;
/// USART3: the vehicle port.
pub type VehicleUsart = Usart<Serial<pac::USART3>>;

impl LineError for stm32f4xx_hal::serial::Error {
    fn is_overrun(&self) -> bool {
        matches!(self, stm32f4xx_hal::serial::Error::Overrun)
    }
}

/// The STM32F407 board: USART2 (lidar), USART3 (vehicle), the IWDG and the DWT cycle counter.
pub struct Stm32f407 {
    lidar: LidarUsart,
    vehicle: VehicleUsart,
    watchdog: IndependentWatchdog,
    counter: CycleCounter,
}

impl Board for Stm32f407 {
    type Serial = LidarUsart;
    type VehicleSerial = VehicleUsart;
    const NAME: &'static str = "STM32F407 (Cortex-M4F @ 168 MHz)";
    const COUNTER_UNIT: CounterUnit = CounterUnit::Cycles;
    const COUNTER_RESOLUTION: u64 = 1;

    /// Sets the clocks (168 MHz from the HSE), both USARTs and the cycle counter. `None` if
    /// the peripherals were taken or a USART cannot be set up.
    fn take() -> Option<Self> {
        let cp = cortex_m::Peripherals::take()?;
        let dp = pac::Peripherals::take()?;
        let mut rcc = dp
            .RCC
            .freeze(Config::hse(HSE_HZ.Hz()).sysclk(SYS_CLK_HZ.Hz()));
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiod = dp.GPIOD.split(&mut rcc);
        let lidar = dp
            .USART2
            .serial((gpioa.pa2, gpioa.pa3), BAUD.bps(), &mut rcc)
            .ok()?;
        let vehicle = dp
            .USART3
            .serial((gpiod.pd8, gpiod.pd9), BAUD.bps(), &mut rcc)
            .ok()?;
        let counter = CycleCounter::start(cp.DCB, cp.DWT);
        Some(Self {
            lidar: Usart::new(lidar),
            vehicle: Usart::new(vehicle),
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

    fn serial(&mut self) -> &mut LidarUsart {
        &mut self.lidar
    }

    fn vehicle_serial(&mut self) -> &mut VehicleUsart {
        &mut self.vehicle
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
