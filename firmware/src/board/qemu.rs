//! QEMU `mps2-an386` (Arm MPS2 board, AN386 FPGA image, Cortex-M4F) board support.
//!
//! Memory map (QEMU `hw/arm/mps2.c`, AN386 = AN385 with a Cortex-M4):
//! - `0x0000_0000` 4 MiB ZBT SSRAM1 (code, vector table), `0x2000_0000` 4 MiB SSRAM2/3.
//! - `0x4000_4000` CMSDK APB UART0: RX interrupt = IRQ 0, TX interrupt = IRQ 1. QEMU's
//!   model has a 1-byte RX buffer and only accepts the next byte from the chardev once
//!   DATA was read, so input is flow-controlled (never lost), one byte per interrupt.
//! - `0x4000_8000` CMSDK APB watchdog, interrupt wired to NMI (see `Watchdog`).
//! - `0x4002_8000` FPGA I/O block; `+0x18` COUNTER is a free-running 32-bit counter at the
//!   25 MHz system clock (PRESCALE = 0 after reset), `+0x14` CLK100HZ a 100 Hz counter.
//! - SysTick with CLKSOURCE = core runs at 25 MHz.
//!
//! Under `-icount shift=0` one guest instruction is 1 ns of virtual time, so one COUNTER
//! tick is 40 instructions. DWT CYCCNT is not emulated by QEMU.
//!
//! Time driver (embassy-time, 1 MHz ticks): `now()` extends COUNTER to 64 bits; alarms
//! use SysTick as a one-shot timer that is only armed while a timer is pending, so an
//! idle lockstep link arms no timer at all (with `-icount …,sleep=off` virtual time then
//! stands still while the guest waits for the host, instead of racing ahead).

use core::cell::{Cell, RefCell, UnsafeCell};
use core::future::poll_fn;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use core::task::{Poll, Waker};

use cortex_m::peripheral::{NVIC, SCB, SYST};
use cortex_m_rt::{exception, ExceptionFrame};
use critical_section::{CriticalSection, Mutex as CsMutex};
use embassy_sync::waitqueue::AtomicWaker;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

use acs_flight::link::ResetCause;

use super::Board;
use defmt_semihosting as _;

/// `HelloAck::board`.
pub const BOARD_ID: u8 = 1;

/// Frequency of [`cost_counter`] (the FPGAIO counter runs at the 25 MHz system clock).
pub const COST_COUNTER_HZ: u32 = 25_000_000;

pub fn cost_counter_hz() -> u32 {
    COST_COUNTER_HZ
}

// ---------------------------------------------------------------------------------------
// FPGA I/O counters

const FPGAIO_CLK100HZ: usize = 0x4002_8014;
const FPGAIO_COUNTER: usize = 0x4002_8018;

/// The 25 MHz free-running counter (wraps every 171.8 s).
#[inline(always)]
pub fn cost_counter() -> u32 {
    // SAFETY: read-only MMIO register of the FPGA I/O block.
    unsafe { read_volatile(FPGAIO_COUNTER as *const u32) }
}

fn clk100hz() -> u32 {
    // SAFETY: read-only MMIO register of the FPGA I/O block.
    unsafe { read_volatile(FPGAIO_CLK100HZ as *const u32) }
}

/// Counter ticks per CLK100HZ period (10 ms); 250 000 when COUNTER runs at 25 MHz.
/// Busy-waits about 20 ms of virtual time (bounded: gives up after 2^26 polls).
fn measure_counter_per_10ms() -> Option<u32> {
    let wait_edge = || {
        let start = clk100hz();
        for _ in 0..(1u32 << 26) {
            if clk100hz() != start {
                return Some(cost_counter());
            }
        }
        None
    };
    let a = wait_edge()?;
    let b = wait_edge()?;
    Some(b.wrapping_sub(a))
}

// ---------------------------------------------------------------------------------------
// CMSDK APB watchdog

const WDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = WDOG;
const WDOG_CONTROL: usize = WDOG + 0x08;
const WDOG_INTCLR: usize = WDOG + 0x0C;
const WDOG_RIS: usize = WDOG + 0x10;
const WDOG_LOCK: usize = WDOG + 0xC00;
const WDOG_UNLOCK: u32 = 0x1ACC_E551;
const WDOG_INTEN: u32 = 1 << 0;
const WDOG_RESEN: u32 = 1 << 1;

/// Stop the CMSDK watchdog's counter (lockstep boots only).
///
/// QEMU 7.2's model counts down from reset even with CONTROL = 0 (no interrupt, no reset)
/// and only stops after its second expiry. A running device timer is an "active timer"
/// to QEMU: with `-icount …,sleep=off` the first idle `WFI` warps virtual time to its
/// expiries (2 × 2^32 / 25 MHz = 343.6 s). Forcing both expiries now (LOAD = 1) stops it,
/// so afterwards an idle guest arms no timer at all and virtual time stands still. In
/// QEMU 7.2 a stopped watchdog cannot be restarted (only a system reset does), and its
/// latched reset status would reset the board the moment RESEN is set: a lockstep boot
/// has no watchdog.
fn stop_watchdog() {
    wr(WDOG_LOCK, WDOG_UNLOCK);
    wr(WDOG_CONTROL, 0);
    wr(WDOG_LOAD, 1);
    // First expiry after 1 tick (RIS set), second one tick later; wait ~100 µs.
    let t0 = cost_counter();
    while rd(WDOG_RIS) & 1 == 0 && cost_counter().wrapping_sub(t0) < 2_500 {}
    let t1 = cost_counter();
    while cost_counter().wrapping_sub(t1) < 2_500 {}
    wr(WDOG_LOCK, 0);
}

/// The host started QEMU with a real-time clock (no `-icount`): `scripts/firmware.sh
/// run-qemu PORT --realtime` and the tests pass the semihosting argument `realtime`.
/// QEMU gives the guest no other way to tell the two clocks apart.
fn realtime_clock() -> bool {
    let mut buf = [core::mem::MaybeUninit::<u8>::uninit(); 256];
    match semihosting::sys::arm_compat::sys_get_cmdline_uninit(&mut buf) {
        Ok(cmdline) => cmdline.split(|b| *b == b' ').any(|w| w == b"realtime"),
        Err(_) => false,
    }
}

// Reset-cause word: the last 256 bytes of SSRAM2 are outside every ELF segment
// (`NOINIT` in the root memory.x), so neither QEMU's system reset (which reloads the
// ELF's segments, zero-filling `.bss`) nor cortex-m-rt's start-up touches them.
// Power-on: QEMU's RAM starts zeroed.
unsafe extern "C" {
    static mut _reset_cause_word: u32;
}

/// Written by the watchdog NMI just before the reset ("WDOG").
const RESET_MAGIC_WATCHDOG: u32 = 0x5744_4F47;

fn reset_word_ptr() -> *mut u32 {
    // Only the address is taken (no access); the symbol is defined by the memory map.
    core::ptr::addr_of_mut!(_reset_cause_word)
}

/// Read and clear the recorded reset cause (called once, at boot).
fn take_reset_cause() -> ResetCause {
    let p = reset_word_ptr();
    // SAFETY: a word of RAM reserved for this purpose (see `_reset_cause_word`).
    let w = unsafe { read_volatile(p) };
    // SAFETY: as above.
    unsafe { write_volatile(p, 0) };
    if w == RESET_MAGIC_WATCHDOG {
        ResetCause::Watchdog
    } else {
        ResetCause::PowerOn
    }
}

/// The watchdog's first expiry (no in-time control cycle for `WATCHDOG_TIMEOUT_US`):
/// record the cause and wait for the second expiry, which resets the board (RESEN). The
/// NMI preempts everything, so nothing can feed the watchdog any more: the reset is
/// certain once this runs.
///
/// SAFETY (cortex-m-rt requires `unsafe fn` for NMI): it touches only the reset-cause
/// word, never state shared with preempted code.
#[exception]
unsafe fn NonMaskableInt() {
    // SAFETY: see `_reset_cause_word`.
    unsafe { write_volatile(reset_word_ptr(), RESET_MAGIC_WATCHDOG) };
    loop {
        cortex_m::asm::wfi();
    }
}

/// The independent watchdog (CMSDK APB watchdog, interrupt = NMI, reset = RESEN).
/// Available only on real-time boots (see `stop_watchdog`).
pub struct Watchdog {
    available: bool,
    armed: bool,
}

impl Watchdog {
    /// Before arming, the counter still runs from reset (LOAD = 2^32 − 1, CONTROL = 0);
    /// it must not expire twice (that latches its reset status for good), so the idle
    /// control task calls `keep_alive` at least this often.
    pub fn keep_alive_period_s(&self) -> Option<u64> {
        (self.available && !self.armed).then_some(60)
    }

    pub fn keep_alive(&mut self) {
        if self.available && !self.armed {
            wr(WDOG_INTCLR, 1);
        }
    }

    /// Start it: the first expiry after `timeout_us` without `feed` raises the NMI
    /// (cause recorded, reset committed), the second one, `timeout_us` later, resets.
    pub fn arm(&mut self, timeout_us: u32) -> bool {
        if !self.available {
            return false;
        }
        let ticks = u64::from(timeout_us).saturating_mul(COUNTER_TICKS_PER_US);
        wr(WDOG_LOCK, WDOG_UNLOCK);
        wr(WDOG_LOAD, u32::try_from(ticks).unwrap_or(u32::MAX).max(1));
        wr(WDOG_INTCLR, 1);
        wr(WDOG_CONTROL, WDOG_INTEN | WDOG_RESEN);
        wr(WDOG_LOCK, 0);
        self.armed = true;
        true
    }

    /// Restart the count (INTCLR reloads it from LOAD).
    pub fn feed(&mut self) {
        if self.armed {
            wr(WDOG_LOCK, WDOG_UNLOCK);
            wr(WDOG_INTCLR, 1);
            wr(WDOG_LOCK, 0);
        }
    }
}

// ---------------------------------------------------------------------------------------
// CMSDK APB UART0

const UART0: usize = 0x4000_4000;
const UART_DATA: usize = UART0;
const UART_STATE: usize = UART0 + 0x04;
const UART_CTRL: usize = UART0 + 0x08;
const UART_INTSTATUS: usize = UART0 + 0x0C;
const UART_BAUDDIV: usize = UART0 + 0x10;

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_TX_INTEN: u32 = 1 << 2;
const CTRL_RX_INTEN: u32 = 1 << 3;
const INT_TX: u32 = 1 << 0;
const INT_RX: u32 = 1 << 1;

/// 25 MHz / 217 ≈ 115 200 Bd (QEMU ignores the rate but requires BAUDDIV >= 16).
const BAUDDIV: u32 = 217;

#[inline(always)]
fn rd(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the board's MMIO register addresses defined in this file.
    unsafe { read_volatile(addr as *const u32) }
}

#[inline(always)]
fn wr(addr: usize, v: u32) {
    // SAFETY: `addr` is one of the board's MMIO register addresses defined in this file.
    unsafe { write_volatile(addr as *mut u32, v) }
}

/// Read-modify-write of CTRL; interrupt handlers also modify it, hence the critical section.
fn ctrl_modify(set: u32, clear: u32) {
    critical_section::with(|_| wr(UART_CTRL, (rd(UART_CTRL) & !clear) | set));
}

#[derive(Clone, Copy)]
#[repr(u16)]
enum Irq {
    Uart0Rx = 0,
    Uart0Tx = 1,
}

// SAFETY: the numbers are the board's UART0 RX/TX interrupt lines.
unsafe impl cortex_m::interrupt::InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

/// Single-producer (RX interrupt) single-consumer (link task) byte ring.
const RX_RING_LEN: usize = 1024;
const RX_RING_MASK: usize = RX_RING_LEN - 1;

struct RxRing {
    buf: UnsafeCell<[u8; RX_RING_LEN]>,
    /// Bytes written (only the interrupt handler stores it).
    head: AtomicUsize,
    /// Bytes read (only the link task stores it).
    tail: AtomicUsize,
}

// SAFETY: one producer (UART0 RX interrupt) and one consumer (thread mode); each slot is
// written only while it is outside the consumer's window (head/tail with Release/Acquire).
unsafe impl Sync for RxRing {}

impl RxRing {
    const fn new() -> Self {
        Self { buf: UnsafeCell::new([0; RX_RING_LEN]), head: AtomicUsize::new(0), tail: AtomicUsize::new(0) }
    }

    fn is_full(&self) -> bool {
        let h = self.head.load(Ordering::Relaxed);
        let t = self.tail.load(Ordering::Acquire);
        h.wrapping_sub(t) >= RX_RING_LEN
    }

    /// Producer side; the caller checked `!is_full()`.
    fn push(&self, b: u8) {
        let h = self.head.load(Ordering::Relaxed);
        // SAFETY: slot `h` is not readable by the consumer until `head` moves past it.
        if let Some(slot) = unsafe { (*self.buf.get()).get_mut(h & RX_RING_MASK) } {
            *slot = b;
        }
        self.head.store(h.wrapping_add(1), Ordering::Release);
    }

    /// Consumer side.
    fn pop(&self) -> Option<u8> {
        let t = self.tail.load(Ordering::Relaxed);
        let h = self.head.load(Ordering::Acquire);
        if h == t {
            return None;
        }
        // SAFETY: slot `t` was published by the producer (Release on head).
        let b = unsafe { (*self.buf.get()).get(t & RX_RING_MASK).copied() };
        self.tail.store(t.wrapping_add(1), Ordering::Release);
        b
    }
}

static RX_RING: RxRing = RxRing::new();
/// The RX interrupt stopped taking bytes because the ring was full (QEMU then holds the
/// rest of the input: the UART only accepts a byte when its 1-byte buffer is empty).
static RX_PAUSED: AtomicBool = AtomicBool::new(false);
static RX_WAKER: AtomicWaker = AtomicWaker::new();
static TX_WAKER: AtomicWaker = AtomicWaker::new();

extern "C" fn uart0_rx_isr() {
    while rd(UART_STATE) & STATE_RX_FULL != 0 {
        // Clear the interrupt *before* reading DATA: a byte that arrives after the read
        // raises it again.
        wr(UART_INTSTATUS, INT_RX);
        if RX_RING.is_full() {
            // Back-pressure: leave the byte in DATA; the link task re-enables us.
            wr(UART_CTRL, rd(UART_CTRL) & !CTRL_RX_INTEN);
            RX_PAUSED.store(true, Ordering::Release);
            break;
        }
        // The received character is the low byte of DATA.
        let [byte, ..] = rd(UART_DATA).to_le_bytes();
        RX_RING.push(byte);
    }
    RX_WAKER.wake();
}

extern "C" fn uart0_tx_isr() {
    wr(UART_INTSTATUS, INT_TX);
    wr(UART_CTRL, rd(UART_CTRL) & !CTRL_TX_INTEN);
    TX_WAKER.wake();
}

/// Receive half of the host link (UART0).
pub struct LinkRx {
    _private: (),
}

/// Transmit half of the host link (UART0).
pub struct LinkTx {
    _private: (),
}

impl LinkRx {
    fn drain(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0usize;
        for slot in buf.iter_mut() {
            match RX_RING.pop() {
                Some(b) => {
                    *slot = b;
                    n = n.saturating_add(1);
                }
                None => break,
            }
        }
        if n > 0 && RX_PAUSED.swap(false, Ordering::AcqRel) {
            ctrl_modify(CTRL_RX_INTEN, 0);
            // A byte may already sit in DATA (RXFULL) without a fresh interrupt edge.
            NVIC::pend(Irq::Uart0Rx);
        }
        n
    }

    /// Wait for at least one received byte; returns how many were copied into `buf`.
    pub async fn read(&mut self, buf: &mut [u8]) -> usize {
        if buf.is_empty() {
            return 0;
        }
        poll_fn(|cx| {
            let n = self.drain(buf);
            if n > 0 {
                return Poll::Ready(n);
            }
            RX_WAKER.register(cx.waker());
            let n = self.drain(buf);
            if n > 0 {
                Poll::Ready(n)
            } else {
                Poll::Pending
            }
        })
        .await
    }
}

impl LinkTx {
    fn try_put(b: u8) -> bool {
        if rd(UART_STATE) & STATE_TX_FULL == 0 {
            wr(UART_DATA, u32::from(b));
            true
        } else {
            false
        }
    }

    /// Send all bytes (QEMU drains the 1-byte TX buffer immediately unless the TCP
    /// socket is full; then we sleep on the TX interrupt).
    pub async fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if Self::try_put(b) {
                continue;
            }
            poll_fn(|cx| {
                if Self::try_put(b) {
                    return Poll::Ready(());
                }
                TX_WAKER.register(cx.waker());
                ctrl_modify(CTRL_TX_INTEN, 0);
                if Self::try_put(b) {
                    Poll::Ready(())
                } else {
                    Poll::Pending
                }
            })
            .await;
        }
    }
}

// ---------------------------------------------------------------------------------------
// Interrupt vector table (no PAC for this board): 32 external interrupts.

#[repr(C)]
#[derive(Clone, Copy)]
pub union Vector {
    handler: extern "C" fn(),
    reserved: usize,
}

extern "C" fn unexpected_irq() {
    let v = SCB::vect_active();
    defmt::error!("unexpected interrupt {}", defmt::Debug2Format(&v));
    exit_failure();
}

const UNUSED: Vector = Vector { handler: unexpected_irq };

/// IRQ 0 = UART0 RX, IRQ 1 = UART0 TX; every other line is unused by this firmware.
#[rustfmt::skip]
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
pub static __INTERRUPTS: [Vector; 32] = [
    Vector {
        handler: uart0_rx_isr,
    },
    Vector {
        handler: uart0_tx_isr,
    },
    UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, // 2..9
    UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, // 10..17
    UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, // 18..25
    UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, UNUSED, // 26..31
];

// ---------------------------------------------------------------------------------------
// Time driver: FPGAIO COUNTER (now) + SysTick one-shot (alarms), 1 µs embassy ticks.

const COUNTER_TICKS_PER_US: u64 = 25;
const SYST_MAX_RELOAD: u64 = 0x00FF_FFFF;
/// Shortest SysTick period programmed, ticks.
const SYST_MIN_TICKS: u64 = 2;
// The alarm's tick count is limited by `max(SYST_MIN_TICKS).min(SYST_MAX_RELOAD + 1)`
// (no panicking `clamp`); the bounds are ordered, so it is the clamp.
const _: () = assert!(SYST_MIN_TICKS <= SYST_MAX_RELOAD + 1);

struct QemuTimeDriver {
    /// Last COUNTER value seen and the number of COUNTER wraps (extends it to 64 bits).
    last_lo: CsMutex<Cell<u32>>,
    hi: CsMutex<Cell<u32>>,
    queue: CsMutex<RefCell<Queue>>,
}

impl QemuTimeDriver {
    fn counter64(&self, cs: CriticalSection<'_>) -> u64 {
        let lo = cost_counter();
        let last = self.last_lo.borrow(cs);
        let hi = self.hi.borrow(cs);
        if lo < last.get() {
            hi.set(hi.get().wrapping_add(1));
        }
        last.set(lo);
        (u64::from(hi.get()) << 32) | u64::from(lo)
    }

    fn now_us(&self, cs: CriticalSection<'_>) -> u64 {
        self.counter64(cs) / COUNTER_TICKS_PER_US
    }

    /// Program SysTick for `next` (µs), waking everything already due.
    fn arm(&self, cs: CriticalSection<'_>, queue: &mut Queue, mut next: u64) {
        loop {
            if next == u64::MAX {
                systick_stop();
                return;
            }
            let now = self.now_us(cs);
            if next <= now {
                next = queue.next_expiration(now);
                continue;
            }
            // max/min rather than `clamp`, which panics on inverted bounds (these are ordered).
            #[allow(clippy::manual_clamp)]
            let ticks = next
                .saturating_sub(now)
                .saturating_mul(COUNTER_TICKS_PER_US)
                .max(SYST_MIN_TICKS)
                .min(SYST_MAX_RELOAD + 1);
            // Fires after `ticks` 40 ns periods: never before `next` (now_us rounds down).
            systick_start(ticks as u32);
            return;
        }
    }

    fn on_alarm(&self) {
        critical_section::with(|cs| {
            systick_stop();
            if let Ok(mut q) = self.queue.borrow(cs).try_borrow_mut() {
                let now = self.now_us(cs);
                let next = q.next_expiration(now);
                self.arm(cs, &mut q, next);
            }
        });
    }
}

impl Driver for QemuTimeDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.now_us(cs))
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            if let Ok(mut q) = self.queue.borrow(cs).try_borrow_mut() {
                if q.schedule_wake(at, waker) {
                    let now = self.now_us(cs);
                    let next = q.next_expiration(now);
                    self.arm(cs, &mut q, next);
                }
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static DRIVER: QemuTimeDriver = QemuTimeDriver {
    last_lo: CsMutex::new(Cell::new(0)),
    hi: CsMutex::new(Cell::new(0)),
    queue: CsMutex::new(RefCell::new(Queue::new())),
});

fn syst() -> &'static cortex_m::peripheral::syst::RegisterBlock {
    // SAFETY: SysTick is owned by this driver; the register block is always mapped.
    unsafe { &*SYST::PTR }
}

fn systick_start(ticks: u32) {
    let s = syst();
    // SAFETY: plain SysTick register writes (disable, reload, clear, enable+irq, core clock).
    unsafe {
        s.csr.write(0);
        s.rvr.write(ticks.saturating_sub(1).max(1));
        s.cvr.write(0);
        s.csr.write(0b111);
    }
}

fn systick_stop() {
    // SAFETY: disabling SysTick has no other effect.
    unsafe { syst().csr.write(0) };
    SCB::clear_pendst();
}

#[exception]
fn SysTick() {
    DRIVER.on_alarm();
}

// ---------------------------------------------------------------------------------------
// Faults, panics, exit

/// Leave QEMU with a failure status (semihosting SYS_EXIT).
pub fn exit_failure() -> ! {
    semihosting::process::exit(1)
}

static PANICKING: AtomicBool = AtomicBool::new(false);

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // A panic inside the logger (or a second panic) must not recurse.
    if !PANICKING.swap(true, Ordering::AcqRel) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }
    exit_failure()
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    if !PANICKING.swap(true, Ordering::AcqRel) {
        defmt::error!("HardFault at pc={=u32:#x} lr={=u32:#x}", ef.pc(), ef.lr());
    }
    exit_failure()
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    defmt::error!("unhandled exception {=i16}", irqn);
    exit_failure()
}

// ---------------------------------------------------------------------------------------

/// Board bring-up: reset cause, watchdog, UART0 (interrupt-driven RX, polled/interrupt
/// TX) and a check that the cost counter runs at the expected rate.
pub fn init() -> Board {
    let reset_cause = take_reset_cause();
    let realtime = realtime_clock();
    if realtime {
        defmt::info!("real-time clock (no -icount): watchdog available for real-time mode");
    } else {
        stop_watchdog();
    }
    match measure_counter_per_10ms() {
        Some(t) => defmt::info!("FPGAIO counter: {=u32} ticks per 10 ms (expect {=u32})", t, COST_COUNTER_HZ / 100),
        None => defmt::warn!("FPGAIO CLK100HZ does not advance"),
    }

    wr(UART_CTRL, 0);
    wr(UART_INTSTATUS, INT_TX | INT_RX);
    wr(UART_BAUDDIV, BAUDDIV);
    wr(UART_CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INTEN);
    // SAFETY: the handlers are in __INTERRUPTS and only touch UART0 and atomics.
    unsafe {
        NVIC::unmask(Irq::Uart0Rx);
        NVIC::unmask(Irq::Uart0Tx);
    }
    Board {
        rx: LinkRx { _private: () },
        tx: LinkTx { _private: () },
        watchdog: Watchdog { available: realtime, armed: false },
        reset_cause,
    }
}
