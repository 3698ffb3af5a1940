//! STM32F405RG board support (embassy-stm32).
//!
//! - Clocks: HSI 16 MHz → PLL → 168 MHz core (AHB 168, APB1 42, APB2 84 MHz). No crystal is
//!   assumed; boards with an 8 MHz HSE can switch `rcc_config` to it.
//! - Host link: USART2, PA2 = TX, PA3 = RX, 921 600 Bd 8N1, interrupt-driven buffered UART.
//! - Time driver: embassy-stm32's (`time-driver-any`), 1 MHz ticks.
//! - Cost counter: DWT CYCCNT at the core clock.
//! - defmt over RTT (probe-rs), panics via panic-probe (logs, then a breakpoint the probe
//!   reports).

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_stm32::usart::{self, BufferedUart, BufferedUartRx, BufferedUartTx};
use embassy_stm32::{bind_interrupts, peripherals, rcc};
use embedded_io_async::{Read as _, Write as _};
use static_cell::StaticCell;

use defmt_rtt as _;
use panic_probe as _;

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

pub fn init() -> (LinkRx, LinkTx) {
    let mut config = embassy_stm32::Config::default();
    config.rcc = rcc_config();
    let p = embassy_stm32::init(config);

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
            (LinkRx { rx }, LinkTx { tx })
        }
        Err(e) => {
            defmt::error!("USART2 config: {}", e);
            exit_failure()
        }
    }
}
