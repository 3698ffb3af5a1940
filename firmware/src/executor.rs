//! A thread-mode executor that sleeps with `WFI`.
//!
//! embassy-executor's stock Cortex-M thread executor sleeps with `WFE` and wakes with
//! `SEV`. QEMU implements `WFE` as a no-op (a busy spin), which under `-icount` burns
//! virtual time and host CPU. This one sleeps with `WFI`, which QEMU does emulate (and
//! with `-icount …,sleep=off` skips idle time entirely).
//!
//! Lost-wake-up freedom: the pender only sets a flag. The main loop masks interrupts
//! (PRIMASK), checks the flag and only then executes `WFI`. An interrupt that becomes
//! pending while PRIMASK is set still ends `WFI` (ARMv7-M), and is taken as soon as
//! interrupts are unmasked again, so a wake between "poll finished" and "WFI" can never
//! be slept through.

use core::marker::PhantomData;
use core::sync::atomic::{AtomicBool, Ordering};

use embassy_executor::{raw, Spawner};

/// Set by the pender (any context), cleared by the main loop before it decides to sleep.
static WORK_PENDING: AtomicBool = AtomicBool::new(true);

/// Called by embassy-executor whenever a task is woken (from tasks or interrupts).
#[unsafe(export_name = "__pender")]
fn __pender(_context: *mut ()) {
    WORK_PENDING.store(true, Ordering::Release);
}

pub struct Executor {
    inner: raw::Executor,
    not_send: PhantomData<*mut ()>,
}

impl Executor {
    pub fn new() -> Self {
        Self { inner: raw::Executor::new(core::ptr::null_mut()), not_send: PhantomData }
    }

    /// Spawn the initial tasks with `init`, then run forever.
    pub fn run(&'static mut self, init: impl FnOnce(Spawner)) -> ! {
        init(self.inner.spawner());
        loop {
            // Clear before polling: a wake during the poll sets it again.
            WORK_PENDING.store(false, Ordering::Release);
            // SAFETY: called from the single thread that owns this executor.
            unsafe { self.inner.poll() };
            cortex_m::interrupt::disable();
            if !WORK_PENDING.load(Ordering::Acquire) {
                cortex_m::asm::wfi();
            }
            // SAFETY: we are not inside a critical section here (thread mode main loop);
            // pending interrupts run now and may set WORK_PENDING.
            unsafe { cortex_m::interrupt::enable() };
        }
    }
}
