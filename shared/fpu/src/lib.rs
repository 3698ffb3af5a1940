//! The Cortex-M4F FPU's square root for the flight code (`acs_flight::math::f32m::sqrt`).
//!
//! Why a crate of its own: `core` has no stable `f32::sqrt` (rustc 1.95: `core_float_math`
//! is unstable) and the workspace forbids `unsafe`, so the software square root in
//! `f32m` (an integer-exact method, ~100 instructions) ran about forty times in a mean
//! control step (~3,900 instructions of ~26,000 on the 3U mission, docs/fdir.md "Cost").
//! The FPU computes the same correctly rounded IEEE-754 result in one instruction
//! (`VSQRT.F32`, ARMv7-M Architecture Reference Manual, A7.7.256; 14 cycles on the
//! Cortex-M4, Cortex-M4 Technical Reference Manual, table 7-1). This crate is the one place
//! the flight path uses `unsafe`: one instruction on registers, no memory.
//!
//! [`sqrt_positive`] exists only where that instruction does (`target_arch = "arm"` with
//! the hard-float ABI: the M4F targets of `firmware/`); every other build (the host, the
//! simulator's in-process flight computer) uses `f32m`'s software method, and both give the
//! same bits for every positive finite input (tests/tests/f32m_target.rs compares a sweep
//! over all bit patterns on QEMU's Cortex-M4 with the host's).
#![no_std]

/// True where [`sqrt_positive`] is the FPU instruction.
pub const HAS_VSQRT: bool = cfg!(all(target_arch = "arm", target_abi = "eabihf"));

/// √x by `VSQRT.F32`, for x > 0 finite (the caller keeps zero, negatives, NaN and infinity
/// out so that their results do not depend on the FPU's NaN propagation: on them it still
/// returns the IEEE-754 result, a NaN or ±0 or +∞, never traps). Correctly rounded
/// (round to nearest even: the FPSCR's reset state, which the firmware never changes).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
pub fn sqrt_positive(x: f32) -> f32 {
    let root_bits: u32;
    // SAFETY: three register instructions (core → S15, VSQRT.F32 S15, S15 → core); S15 is
    // declared clobbered. No memory, no stack, no fault: floating-point exceptions are not
    // trapped on the M4F, they only set FPSCR's cumulative flags, which nothing in the flight
    // code reads (so `preserves_flags` is not claimed). Why through a core register: rustc
    // 1.95 refuses `sreg` operands on thumbv7em-none-eabihf ("requires the `vfp2` target
    // feature", unstable to enable; the M4F's FPU is single-precision VFPv4-D16), but it
    // accepts S15 as a clobber (the LLVM constraint carries `~{s15}`).
    #[allow(unsafe_code)]
    unsafe {
        core::arch::asm!(
            "vmov s15, {x}",
            "vsqrt.f32 s15, s15",
            "vmov {root}, s15",
            x = in(reg) x.to_bits(),
            root = lateout(reg) root_bits,
            out("s15") _,
            options(pure, nomem, nostack),
        );
    }
    f32::from_bits(root_bits)
}
