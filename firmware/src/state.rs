//! State shared by the link task and the real-time control task. Both run on the one
//! thread-mode executor, so `ThreadModeRawMutex` suffices (and, unlike a critical section,
//! never masks interrupts while a step runs).

use core::sync::atomic::{AtomicU32, Ordering};

use acs_flight::link::{encode_frame, ActuatorCommand, FswMsg, SensorFrame, MAX_FRAME};
use acs_flight::session::Session;
use acs_flight::Fsw;
use embassy_sync::blocking_mutex::raw::ThreadModeRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_sync::signal::Signal;

use crate::board;

/// The flight side of the link (`acs_flight::session::Session`, the same code as the
/// host's virtual flight computer): owns the `Fsw`, the real-time flag and the
/// deadline-miss count.
pub type SharedSession = Mutex<ThreadModeRawMutex, Session>;

/// The transmit half of the link, shared by both tasks (one frame at a time).
pub type SharedTx = Mutex<ThreadModeRawMutex, board::LinkTx>;

/// Real-time mode: the newest sensor frame (overwritten, never queued).
pub static LATEST_FRAME: Signal<ThreadModeRawMutex, SensorFrame> = Signal::new();

/// Starts the control task (signalled once, when the session enters real-time mode).
pub static START_REAL_TIME: Signal<ThreadModeRawMutex, ()> = Signal::new();

/// Frames the link's accumulator dropped so far (mirrored for the control task).
pub static FRAMES_DROPPED: AtomicU32 = AtomicU32::new(0);

pub fn frames_dropped() -> u32 {
    FRAMES_DROPPED.load(Ordering::Relaxed)
}

/// Encode and send one message.
pub async fn send(tx: &SharedTx, msg: &FswMsg) {
    let mut buf = [0u8; MAX_FRAME];
    match encode_frame(msg, &mut buf) {
        Ok(frame) => tx.lock().await.write_all(frame).await,
        Err(e) => defmt::error!("cannot encode reply: {}", e),
    }
}

/// The cost counter as the session's `counter` callback.
pub fn counter() -> u32 {
    board::cost_counter()
}

/// One `Fsw::step`, with its cost in cost-counter ticks (real-time mode; lockstep steps
/// go through `Session::handle`, which reads the counter the same way).
///
/// On QEMU (`-icount shift=0`) one tick is 40 instructions, so the result is the step's
/// instruction count / 40 (±1 tick).
#[inline(never)]
pub fn measured_step(fsw: &mut Fsw, frame: &SensorFrame) -> (ActuatorCommand, u32) {
    let frame = core::hint::black_box(frame);
    let t0 = board::cost_counter();
    let cmd = fsw.step(frame);
    let cmd = core::hint::black_box(cmd);
    let t1 = board::cost_counter();
    (cmd, t1.wrapping_sub(t0))
}
