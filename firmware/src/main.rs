//! Flight-computer firmware: runs `acs_flight::Fsw` behind the COBS/CRC host link.
//!
//! Boards (cargo features, exactly one): `board-qemu` (default, QEMU `mps2-an386`) and
//! `board-stm32f405`. See docs/firmware.md.
//!
//! Tasks (one thread-mode executor, `executor.rs`):
//! - `link::link_task` owns the UART receive side, answers Hello / UploadParams /
//!   SetTarget / StartRealTime and, in lockstep mode, steps every `Sensor` frame;
//! - `control::control_task` runs the real-time loop after `StartRealTime`.
#![no_std]
#![no_main]
// Lints: the `[lints]` table of firmware/Cargo.toml (flight rules).

mod board;
mod control;
mod executor;
mod link;
mod stack;
mod state;

use acs_flight::session::Session;
use embassy_sync::mutex::Mutex;
use static_cell::StaticCell;

use crate::executor::Executor;
use crate::state::{SharedSession, SharedTx};

static EXECUTOR: StaticCell<Executor> = StaticCell::new();
/// Built at compile time in static RAM: constructing it in `main` and moving it into a
/// cell put the whole session (the flight state, ~13 KiB and growing) on the stack once.
static SESSION: SharedSession = Mutex::new(Session::new(board::BOARD_ID, 0));
static TX: StaticCell<SharedTx> = StaticCell::new();

#[cortex_m_rt::entry]
fn main() -> ! {
    // Before anything else uses the stack below this frame (see stack.rs).
    stack::paint();
    defmt::info!(
        "acs-firmware {=str} (board {=u8}), cost counter {=u32} Hz",
        env!("CARGO_PKG_VERSION"),
        board::BOARD_ID,
        board::cost_counter_hz()
    );
    let board::Board { rx, tx, watchdog, reset_cause } = board::init();
    // After any reset the flight side starts unconfigured, in lockstep: every sensor frame
    // gets the safe command (`NOT_CONFIGURED`) until the host uploads parameters again.
    match reset_cause {
        acs_flight::link::ResetCause::PowerOn => defmt::info!("reset cause: {}", reset_cause),
        _ => defmt::warn!("reset cause: {} (safe hold until the host reconfigures)", reset_cause),
    }
    match SESSION.try_lock() {
        Ok(mut s) => {
            s.set_reset_cause(reset_cause);
            s.set_cost_counter_hz(board::cost_counter_hz());
        }
        Err(_) => {
            defmt::error!("session locked at start-up");
            board::exit_failure()
        }
    }
    let session: &'static SharedSession = &SESSION;
    let (Some(tx), Some(executor)) = (TX.try_init(Mutex::new(tx)), EXECUTOR.try_init(Executor::new())) else {
        defmt::error!("main entered twice");
        board::exit_failure()
    };
    executor.run(|spawner| {
        match link::link_task(rx, session, tx) {
            Ok(t) => spawner.spawn(t),
            Err(e) => {
                defmt::error!("spawn link task: {}", e);
                board::exit_failure()
            }
        }
        match control::control_task(session, tx, watchdog) {
            Ok(t) => spawner.spawn(t),
            Err(e) => {
                defmt::error!("spawn control task: {}", e);
                board::exit_failure()
            }
        }
    })
}
