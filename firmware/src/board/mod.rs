//! Board support. Each board provides the same interface:
//!
//! - `BOARD_ID` (`HelloAck::board`), `cost_counter()` / `cost_counter_hz()`;
//! - `init() -> (LinkRx, LinkTx)`: clocks, time driver, host-link UART;
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

#[cfg(not(any(feature = "board-qemu", feature = "board-stm32f405")))]
compile_error!("select a board: feature `board-qemu` (default) or `board-stm32f405`");
