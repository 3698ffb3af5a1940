//! Board support. Each board provides the same interface:
//!
//! - `BOARD_ID` (`HelloAck::board`), `cost_counter()` / `cost_counter_hz()`;
//! - `init() -> Board`: clocks, time driver, host-link UART, the reset cause and the
//!   independent watchdog (`Watchdog`: `keep_alive_period_s`, `keep_alive`,
//!   `arm(timeout_us)`, `feed`; armed only in real-time mode, see control.rs);
//! - `LinkRx::read(&mut [u8]) -> usize` (async, at least one byte),
//!   `LinkTx::write_all(&[u8])` (async);
//! - `exit_failure() -> !`, the defmt global logger and the panic handler.

#[cfg(all(feature = "board-qemu", feature = "board-stm32f405"))]
compile_error!("features `board-qemu` and `board-stm32f405` are exclusive (use --no-default-features)");

#[cfg(feature = "board-qemu")]
mod qemu;
#[cfg(feature = "board-qemu")]
pub use qemu::*;

#[cfg(all(feature = "board-stm32f405", not(feature = "board-qemu")))]
mod stm32f405;
#[cfg(all(feature = "board-stm32f405", not(feature = "board-qemu")))]
pub use stm32f405::*;

#[cfg(all(feature = "debug-hang", feature = "board-stm32f405"))]
compile_error!("feature `debug-hang` is a test hook for the QEMU image and must stay out of flight images");

/// What `init` brings up.
pub struct Board {
    pub rx: LinkRx,
    pub tx: LinkTx,
    pub watchdog: Watchdog,
    pub reset_cause: acs_flight::link::ResetCause,
}

/// Reset when no control cycle completed in time for this long (real-time mode).
pub const WATCHDOG_TIMEOUT_US: u32 = 1_000_000;

#[cfg(not(any(feature = "board-qemu", feature = "board-stm32f405")))]
compile_error!("select a board: feature `board-qemu` (default) or `board-stm32f405`");
