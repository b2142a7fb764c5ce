//! The board abstraction: what the application needs from the hardware, and one module per
//! supported board.
//!
//! The application (benchmark, self-tests, controller loop) is written against [`Board`]
//! only. Exactly one board is compiled in, chosen by a cargo feature:
//!
//! | feature | board | lidar UART | vehicle UART (odometry in, poses out) | counter | log transport |
//! |---|---|---|---|---|---|
//! | `board-mps2-an386` (default) | QEMU MPS2 AN386, Cortex-M4F | CMSDK UART0 | CMSDK UART1 | SysTick under `-icount shift=0` (instructions) | defmt over semihosting |
//! | `board-nucleo-h743zi` | ST NUCLEO-H743ZI2, STM32H743ZI Cortex-M7 | USART3 (ST-LINK VCP) | USART2 (PD5 TX, PD6 RX) | DWT CYCCNT (core cycles) | defmt over RTT |
//! | `board-stm32f407` | STM32F407 (e.g. STM32F4DISCOVERY, 168 MHz Cortex-M4F, 192 KiB RAM, 1 MiB flash) | USART2 (PA2 TX, PA3 RX) | USART3 (PD8 TX, PD9 RX) | DWT CYCCNT (core cycles) | defmt over RTT |

#[cfg(any(
    all(feature = "board-mps2-an386", feature = "board-nucleo-h743zi"),
    all(feature = "board-mps2-an386", feature = "board-stm32f407"),
    all(feature = "board-nucleo-h743zi", feature = "board-stm32f407"),
))]
compile_error!(
    "select exactly one board: build an STM32 board with \
     `--no-default-features --features board-nucleo-h743zi` (or `board-stm32f407`)"
);

// Shared by the STM32 boards.
#[cfg(any(feature = "board-nucleo-h743zi", feature = "board-stm32f407"))]
mod cycle_counter;
#[cfg(any(feature = "board-nucleo-h743zi", feature = "board-stm32f407"))]
mod debug_exit;
#[cfg(any(feature = "board-nucleo-h743zi", feature = "board-stm32f407"))]
mod polled_serial;

#[cfg(feature = "board-mps2-an386")]
pub mod mps2_an386;
#[cfg(feature = "board-mps2-an386")]
pub use mps2_an386::Mps2An386 as SelectedBoard;

#[cfg(feature = "board-nucleo-h743zi")]
pub mod nucleo_h743zi;
#[cfg(feature = "board-nucleo-h743zi")]
pub use nucleo_h743zi::NucleoH743zi as SelectedBoard;

#[cfg(feature = "board-stm32f407")]
pub mod stm32f407;
#[cfg(feature = "board-stm32f407")]
pub use stm32f407::Stm32f407 as SelectedBoard;

/// How the process ends: the status a test harness (QEMU, probe-rs) sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ExitStatus {
    /// Everything passed; QEMU exits with status 0.
    Success,
    /// A test failed, a budget was exceeded, or the firmware panicked / faulted; QEMU exits
    /// with status 1.
    Failure,
}

/// What the unit of [`Board::counter_now`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum CounterUnit {
    /// Executed instructions (QEMU with `-icount shift=0`: one instruction per virtual ns).
    Instructions,
    /// Core clock cycles (real silicon: DWT CYCCNT).
    Cycles,
}

/// What the application needs from a board.
pub trait Board {
    /// The serial port that carries lidar bytes in and pose frames out. It speaks
    /// `embedded-io`, the interface `lidar-driver`'s no_std session is generic over:
    /// `read` blocks for at least one byte, `read_ready` tells whether it would block.
    type Serial: embedded_io::Read + embedded_io::Write + embedded_io::ReadReady;

    /// Human-readable board name, for logs.
    const NAME: &'static str;
    /// Unit of [`Board::counter_now`].
    const COUNTER_UNIT: CounterUnit;

    /// Takes the peripherals and sets the board up; `None` when called a second time (the
    /// peripherals are singletons).
    fn take() -> Option<Self>
    where
        Self: Sized;

    /// The serial port wired to the lidar.
    fn serial(&mut self) -> &mut Self::Serial;

    /// The serial port wired to the vehicle computer: its wheel odometry comes in
    /// (`controller_wire::OdometryFrame`s, read without blocking: `read_ready` first) and the
    /// pose frames go out (`controller_wire::PoseFrame`).
    type VehicleSerial: embedded_io::Read + embedded_io::Write + embedded_io::ReadReady;

    /// The vehicle port.
    fn vehicle_serial(&mut self) -> &mut Self::VehicleSerial;

    /// Starts the hardware watchdog: the board resets unless [`Board::feed_watchdog`] is
    /// called within `timeout_ms` (QEMU: the CMSDK watchdog; STM32: the IWDG).
    fn start_watchdog(&mut self, timeout_ms: u32);

    /// Feeds the watchdog.
    fn feed_watchdog(&mut self);

    /// A monotonic 64-bit count of [`Board::COUNTER_UNIT`] since start-up. The resolution is
    /// board-specific ([`Board::COUNTER_RESOLUTION`]); differences of two reads measure the
    /// code between them.
    fn counter_now(&self) -> u64;

    /// Resolution of [`Board::counter_now`] in its unit (40 instructions on QEMU mps2-an386,
    /// where SysTick ticks at 25 MHz against a 1 GHz virtual instruction clock).
    const COUNTER_RESOLUTION: u64;

    /// The flash region a stored map is written to (by the flasher, or QEMU's
    /// `-device loader,file=MAP,addr=…`), whole; erased flash or zeros when nothing was
    /// written.
    fn map_region(&self) -> &'static [u8];

    /// Milliseconds since start-up (the LMS session's time-outs run on this clock). Under
    /// QEMU it is virtual time: with `-icount shift=0` one instruction is one nanosecond.
    fn now_ms(&self) -> u64;

    /// Ends the program with `status` (QEMU: semihosting exit; hardware: breakpoint so the
    /// attached probe-rs session stops, then a loop).
    fn exit(status: ExitStatus) -> !;
}
