//! Cost of attitude determination on the Cortex-M4F, and same bits as the host: runs the
//! fixed workload of `scenario.rs` (MEKF propagate / + tracker / + Sun and field updates,
//! TRIAD, QUEST with 3 vectors) on QEMU mps2-an386, times every call with the FPGAIO
//! 25 MHz counter and prints, on the semihosting console,
//!
//! ```text
//! estimation cost <kind> <calls> <sum_ticks> <max_ticks>
//! estimation fingerprint <hex> rejected <n>
//! ```
//!
//! Under `-icount shift=0` one instruction is 1 ns, so one tick is 40 instructions
//! (docs/firmware.md, "Cost counter"); `scripts/firmware.sh estimation-cost` runs it that
//! way and `tests/tests/estimation_target.rs` checks the fingerprint against the host's
//! and the costs against the issue's budget.
#![no_std]
#![no_main]

mod scenario;

/// FPGAIO COUNTER (free-running, 25 MHz) of the MPS2 FPGA I/O block.
const FPGAIO_COUNTER: usize = 0x4002_8018;

fn counter() -> u32 {
    // SAFETY: an always-readable, side-effect-free MMIO register of the mps2-an386 board.
    unsafe { core::ptr::read_volatile(FPGAIO_COUNTER as *const u32) }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let out = scenario::run(counter);
    for kind in scenario::KINDS {
        if let Some(c) = out.costs.get(kind as usize) {
            semihosting::println!("estimation cost {} {} {} {}", kind.name(), c.calls, c.sum_ticks, c.max_ticks);
        }
    }
    semihosting::println!("estimation fingerprint {:016x} rejected {}", out.fingerprint, out.rejected);
    semihosting::process::exit(0)
}

/// No interrupt is enabled; cortex-m-rt's `device` feature (on for the QEMU board) still
/// needs a non-empty table.
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
pub static __INTERRUPTS: [unsafe extern "C" fn(); 1] = [unexpected_irq];

extern "C" fn unexpected_irq() {
    semihosting::process::exit(3)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    semihosting::process::exit(2)
}
