//! STM32F405RG board support (embassy-stm32).
//!
//! - Clocks: HSI 16 MHz → PLL → 168 MHz core (AHB 168, APB1 42, APB2 84 MHz). No crystal is
//!   assumed; boards with an 8 MHz HSE can switch `rcc_config` to it.
//! - Host link: USART2, PA2 = TX, PA3 = RX, 921 600 Bd 8N1, interrupt-driven buffered UART.
//! - Time driver: embassy-stm32's (`time-driver-any`), 1 MHz ticks.
//! - Cost counter: DWT CYCCNT at the core clock.
//! - defmt over RTT (probe-rs), panics via panic-probe (logs, then a breakpoint the probe
//!   reports).
//! - Flash: embassy-stm32 0.6 sets FLASH_ACR.LATENCY (5 wait states at 168 MHz) with a plain
//!   register write, leaving the prefetch buffer and the instruction/data caches off
//!   (src/rcc/f247.rs); `init` resets the caches and enables all three (RM0090 §3.5.2,
//!   §3.9.1), then logs FLASH_ACR read back.
//! - Reset cause: the RCC_CSR reset flags (RM0090 §7.3.21), read before anything else and
//!   then cleared (RMVF) so that the next boot sees only its own cause.
//! - Watchdog: IWDG, clocked by the LSI (nominal 32 kHz, 17–47 kHz over parts and
//!   temperature per the STM32F405 datasheet, so the 1 s timeout is 0.68–1.9 s), armed by
//!   the real-time control task. Once started it cannot be stopped: a hang in real-time
//!   mode resets the MCU.

use core::sync::atomic::{AtomicU32, Ordering};

use acs_flight::link::ResetCause;
use embassy_stm32::pac;
use embassy_stm32::usart::{self, BufferedUart, BufferedUartRx, BufferedUartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, peripherals, rcc, Peri};
use embedded_io_async::{Read as _, Write as _};
use static_cell::StaticCell;

use defmt_rtt as _;
use panic_probe as _;

use super::Board;

/// `HelloAck::board`.
pub const BOARD_ID: u8 = 2;

/// Core clock configured by `rcc_config`.
const CORE_CLOCK_HZ: u32 = 168_000_000;

/// Link baud rate.
pub const LINK_BAUD: u32 = 921_600;

static COST_HZ: AtomicU32 = AtomicU32::new(CORE_CLOCK_HZ);

pub fn cost_counter_hz() -> u32 {
    COST_HZ.load(Ordering::Relaxed)
}

/// DWT cycle counter (enabled in `init`).
#[inline(always)]
pub fn cost_counter() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

bind_interrupts!(struct Irqs {
    USART2 => usart::BufferedInterruptHandler<peripherals::USART2>;
});

fn rcc_config() -> rcc::Config {
    use rcc::*;
    let mut c = Config::default();
    c.hsi = true;
    c.pll_src = PllSource::HSI;
    c.pll = Some(Pll {
        prediv: PllPreDiv::DIV16,
        mul: PllMul::MUL336,
        divp: Some(PllPDiv::DIV2),
        divq: Some(PllQDiv::DIV7),
        divr: None,
    });
    c.sys = Sysclk::PLL1_P;
    c.ahb_pre = AHBPrescaler::DIV1;
    c.apb1_pre = APBPrescaler::DIV4;
    c.apb2_pre = APBPrescaler::DIV2;
    c
}

/// Leave the program: on hardware there is no host to return to, so trap to the debugger.
pub fn exit_failure() -> ! {
    panic_probe::hard_fault()
}

pub struct LinkRx {
    rx: BufferedUartRx<'static>,
}

pub struct LinkTx {
    tx: BufferedUartTx<'static>,
}

impl LinkRx {
    /// Wait for at least one received byte; returns how many were copied into `buf`.
    /// Receive errors (overrun, framing, noise) are logged and reading goes on: the frame
    /// they hit fails its CRC and is counted as dropped.
    pub async fn read(&mut self, buf: &mut [u8]) -> usize {
        loop {
            match self.rx.read(buf).await {
                Ok(n) => return n,
                Err(e) => defmt::warn!("USART2 rx error: {}", e),
            }
        }
    }
}

impl LinkTx {
    pub async fn write_all(&mut self, bytes: &[u8]) {
        if let Err(e) = self.tx.write_all(bytes).await {
            defmt::warn!("USART2 tx error: {}", e);
        }
    }
}

static TX_BUF: StaticCell<[u8; 1024]> = StaticCell::new();
static RX_BUF: StaticCell<[u8; 1024]> = StaticCell::new();

/// The RCC_CSR reset flags, most specific first (a pin reset flag accompanies every
/// internal reset, because the reset circuit drives NRST), then cleared.
fn take_reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read();
    let cause = if csr.wdgrstf() {
        ResetCause::Watchdog
    } else if csr.sftrstf() {
        ResetCause::Software
    } else if csr.porrstf() || csr.borrstf() {
        ResetCause::PowerOn
    } else if csr.wwdgrstf() || csr.lpwrrstf() {
        ResetCause::Other
    } else if csr.padrstf() {
        ResetCause::Pin
    } else {
        ResetCause::Other
    };
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    cause
}

/// Prefetch buffer, instruction and data caches on (after a cache reset, which is only
/// allowed while the caches are off); returns FLASH_ACR read back.
fn enable_flash_accelerator() -> u32 {
    let acr = pac::FLASH.acr();
    acr.modify(|w| {
        w.set_icen(false);
        w.set_dcen(false);
    });
    acr.modify(|w| {
        w.set_icrst(true);
        w.set_dcrst(true);
    });
    acr.modify(|w| {
        w.set_icrst(false);
        w.set_dcrst(false);
    });
    acr.modify(|w| {
        w.set_prften(true);
        w.set_icen(true);
        w.set_dcen(true);
    });
    acr.read().0
}

/// FLASH_ACR bits: LATENCY [3:0], PRFTEN 8, ICEN 9, DCEN 10.
const ACR_PRFTEN: u32 = 1 << 8;
const ACR_ICEN: u32 = 1 << 9;
const ACR_DCEN: u32 = 1 << 10;

/// The independent watchdog (IWDG); started by `arm`, never stopped.
pub struct Watchdog {
    peri: Option<Peri<'static, peripherals::IWDG>>,
    wdg: Option<IndependentWatchdog<'static, peripherals::IWDG>>,
}

/// The IWDG's timeout range at the nominal 32 kHz LSI (prescaler 4 … 256, reload ≤ 4095).
const IWDG_MIN_TIMEOUT_US: u32 = 1_000;
const IWDG_MAX_TIMEOUT_US: u32 = 32_000_000;
// `max(min).min(max)` is the clamp; the bounds are ordered (checked at compile time).
const _: () = assert!(IWDG_MIN_TIMEOUT_US <= IWDG_MAX_TIMEOUT_US);

impl Watchdog {
    /// The IWDG does not run before `arm`: nothing to keep alive.
    pub fn keep_alive_period_s(&self) -> Option<u64> {
        None
    }

    pub fn keep_alive(&mut self) {}

    /// Start it with `timeout_us` (limited to the IWDG's 1 ms … 32 s range at the nominal
    /// 32 kHz LSI). A second call does nothing (the IWDG cannot be reconfigured safely
    /// while it runs).
    pub fn arm(&mut self, timeout_us: u32) -> bool {
        if self.wdg.is_some() {
            return true;
        }
        let Some(peri) = self.peri.take() else {
            return false;
        };
        // max/min rather than `clamp`, which panics on inverted bounds (these are ordered).
        #[allow(clippy::manual_clamp)]
        let timeout_us = timeout_us.max(IWDG_MIN_TIMEOUT_US).min(IWDG_MAX_TIMEOUT_US);
        let mut w = IndependentWatchdog::new(peri, timeout_us);
        w.unleash();
        self.wdg = Some(w);
        true
    }

    pub fn feed(&mut self) {
        if let Some(w) = self.wdg.as_mut() {
            w.pet();
        }
    }
}

pub fn init() -> Board {
    let reset_cause = take_reset_cause();
    let mut config = embassy_stm32::Config::default();
    config.rcc = rcc_config();
    let p = embassy_stm32::init(config);

    let acr = enable_flash_accelerator();
    defmt::info!(
        "FLASH_ACR = {=u32:#010x}: latency {=u32} WS, prefetch {=bool}, I-cache {=bool}, D-cache {=bool}",
        acr,
        acr & 0xF,
        acr & ACR_PRFTEN != 0,
        acr & ACR_ICEN != 0,
        acr & ACR_DCEN != 0
    );

    if let Some(hz) = rcc::clocks(&p.RCC).sys.to_hertz() {
        COST_HZ.store(hz.0, Ordering::Relaxed);
    }

    // The cycle counter: DWT needs trace enabled in DEMCR.
    if let Some(mut cp) = cortex_m::Peripherals::take() {
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
    } else {
        defmt::warn!("core peripherals already taken: cost counter may not run");
    }

    let mut ucfg = usart::Config::default();
    ucfg.baudrate = LINK_BAUD;
    let (Some(tx_buf), Some(rx_buf)) = (TX_BUF.try_init([0; 1024]), RX_BUF.try_init([0; 1024])) else {
        defmt::error!("board init called twice");
        exit_failure()
    };
    match BufferedUart::new(p.USART2, p.PA3, p.PA2, tx_buf, rx_buf, Irqs, ucfg) {
        Ok(uart) => {
            let (tx, rx) = uart.split();
            Board {
                rx: LinkRx { rx },
                tx: LinkTx { tx },
                watchdog: Watchdog { peri: Some(p.IWDG), wdg: None },
                reset_cause,
            }
        }
        Err(e) => {
            defmt::error!("USART2 config: {}", e);
            exit_failure()
        }
    }
}
