//! Host-vs-target check of `acs_flight::math::f32m`: prints the sweep fingerprint on the
//! semihosting console and exits. Built and run by `scripts/firmware.sh math-fingerprint`
//! (QEMU mps2-an386); `tests/tests/f32m_target.rs` compares the printed value with the
//! host's `sweep_fingerprint`. Same points as that test (SWEEP_POINTS below).
#![no_std]
#![no_main]

/// Arguments per function; the host test uses the same number.
const SWEEP_POINTS: u32 = 1 << 16;

#[cortex_m_rt::entry]
fn main() -> ! {
    let h = acs_flight::math::f32m::sweep_fingerprint(SWEEP_POINTS);
    semihosting::println!("f32m fingerprint {SWEEP_POINTS} {h:016x}");
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
