//! Stack high-water mark: the stack is painted with a pattern at boot and scanned on
//! request for the deepest overwritten word.
//!
//! - `paint()` runs first thing in `main`, before any interrupt is unmasked: it fills the
//!   window from its bottom up to 256 bytes below its own stack pointer (the gap covers
//!   its own frame) with `PATTERN`.
//! - `high_water_mark()` scans the window upwards from its bottom to the first word that
//!   is not the pattern: the stack never reached below it. Cost: one load per untouched
//!   word of the window (at most `WINDOW / 4` = 32 768 loads), so it is only called on
//!   request (the link task, when answering `Hello`), never per step.
//!
//! The window is the lowest 128 KiB below the top of the stack (`_stack_start`), cut at the
//! end of static RAM (`_stack_end`, cortex-m-rt): the whole stack region on the STM32F405
//! (~108 KiB), the top 128 KiB of the 4 MiB on QEMU. The static bound (tools/elf-check,
//! ~44 KiB) is far inside it; a stack that went below the window would read as the full
//! window (a lower bound), reported as such by `high_water_mark`.

use core::ptr::{addr_of, read_volatile, write_volatile};
use core::sync::atomic::{AtomicUsize, Ordering};

/// Arbitrary word, unlikely as data (not a small integer, float or RAM/flash address).
const PATTERN: u32 = 0x5AC5_F00D;
const WINDOW: usize = 128 * 1024;
/// Unpainted gap below `paint`'s stack pointer (its own frame and call).
const GUARD: usize = 256;

extern "C" {
    /// Initial stack pointer (top of RAM), from cortex-m-rt's link.x.
    static _stack_start: u32;
    /// Lowest address the stack may use (end of .bss/.uninit), cortex-m-rt 0.7.5.
    static _stack_end: u32;
}

/// Top of the painted range (exclusive), 0 before `paint`.
static PAINTED_TOP: AtomicUsize = AtomicUsize::new(0);

fn top() -> usize {
    // Only the address of the linker symbol is taken (no read: no `unsafe` needed).
    addr_of!(_stack_start) as usize
}

fn window_bottom() -> usize {
    let end = addr_of!(_stack_end) as usize;
    // Word-aligned (the region ends are 8-aligned by cortex-m-rt).
    end.max(top().saturating_sub(WINDOW)) & !3
}

/// Paint the stack window. Call once, first thing in `main`, with interrupts still masked
/// at the NVIC (nothing may use the stack below the current frame meanwhile).
#[inline(never)]
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let painted_top = sp.saturating_sub(GUARD) & !3;
    let mut a = window_bottom();
    while a < painted_top {
        // SAFETY: `a` is a word-aligned RAM address between the end of the static data and
        // 256 bytes below the current stack pointer: memory no Rust object lives in.
        unsafe { write_volatile(a as *mut u32, PATTERN) };
        a = a.wrapping_add(4);
    }
    PAINTED_TOP.store(painted_top, Ordering::Release);
}

/// Deepest stack use since boot, bytes below `_stack_start` (0 if `paint` did not run).
pub fn high_water_mark() -> u32 {
    let painted_top = PAINTED_TOP.load(Ordering::Acquire);
    if painted_top == 0 {
        return 0;
    }
    let mut a = window_bottom();
    // SAFETY: as in `paint`; reading the painted (possibly since used) stack words.
    while a < painted_top && unsafe { read_volatile(a as *const u32) } == PATTERN {
        a = a.wrapping_add(4);
    }
    u32::try_from(top().saturating_sub(a)).unwrap_or(u32::MAX)
}
