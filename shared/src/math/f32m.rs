//! Single-precision elementary functions for flight code: no `f64` anywhere.
//!
//! Why: `libm`'s `sinf`/`cosf`/`asinf` (ports of musl) evaluate in `f64`, which on the
//! Cortex-M4F is software (`__aeabi_dmul`, `__adddf3`, ...) and was ~57 % of a CMG step;
//! `libm::sqrtf` is integer software. Everything here uses only f32 `+ - * /`, comparisons
//! and bit reinterpretation (plus a few exact integer operations in [`sqrt`]). Rust never
//! contracts `a * b + c` into an FMA, so every operation is one IEEE-754 rounding on the host
//! and on the M4F FPU alike (round to nearest, no flush-to-zero, which is the M4F reset
//! state): host and target produce the same bits (SIL = PIL).
//!
//! Polynomials are the single-precision ones of the Cephes library (S. L. Moshier,
//! `sinf.c`, `cosf.c`, `expf.c`, `atanf.c`, `asinf.c`, Cephes Math Library 2.2, 1992;
//! also in Moshier, *Methods and Programs for Mathematical Functions*, 1989), with the
//! Cody–Waite range reductions (W. J. Cody, W. Waite, *Software Manual for the Elementary
//! Functions*, 1980) written out below.
//!
//! Error bounds (measured against `f64` std functions rounded to f32 by the tests in this
//! file over a dense sweep — every 2^-12 in the stated ranges — plus special values):
//! - [`sin`], [`cos`], [`sin_cos`]: ≤ 1 ulp for |x| ≤ 2π; for |x| ≤ 8192 ≤ 2 ulp or, near
//!   zeros of the function where an f32 reduction cannot give a relative bound, ≤ 2^-34
//!   absolute; ≤ 2^-17 absolute up to [`SIN_COS_MAX_ARG`] = 2^16, NaN beyond;
//! - [`exp`]: ≤ 1 ulp over the whole normal output range;
//! - [`atan2`]: ≤ 2 ulp; [`asin`]: ≤ 2 ulp;
//! - [`sqrt`]: correctly rounded (0 ulp), as IEEE-754 `sqrt`.
//!
//! No function panics; NaN in → NaN out; the behaviour at infinities is stated per function.

// Coefficients are written as published (Cephes); the compiler rounds them to f32.
#![allow(clippy::excessive_precision)]

use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, LOG2_E, PI};

/// 1.5 · 2^23: adding it to |v| < 2^22 rounds v to the nearest integer (ties to even), and
/// that integer then sits in the low mantissa bits of the sum (two's complement).
const ROUND_MAGIC: f32 = 12_582_912.0;
const ROUND_MAGIC_BITS: i32 = 0x4B40_0000;

/// `round(v)` as a float and as an integer, for |v| < 2^22.
#[inline(always)]
fn round_int(v: f32) -> (f32, i32) {
    let t = v + ROUND_MAGIC;
    (t - ROUND_MAGIC, t.to_bits().cast_signed().wrapping_sub(ROUND_MAGIC_BITS))
}

/// `⌊x⌋` without libm (core has no `f32::floor`): exact for every finite x — |x| ≥ 2^23
/// is already an integer; below, truncate toward zero through i32 (exact there) and step
/// down for negative non-integers. NaN and ±∞ pass through, ±0 keep their sign.
pub fn floor(x: f32) -> f32 {
    if !(x.abs() < 8_388_608.0) || x == 0.0 {
        return x;
    }
    // |x| < 2^23: the truncating cast is exact and in range.
    #[allow(clippy::cast_possible_truncation)]
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else if t == 0.0 && x < 0.0 {
        -1.0
    } else {
        t
    }
}

/// 2^n for n in [-126, 127] (callers guarantee the range), built from its bits.
#[inline(always)]
fn pow2i(n: i32) -> f32 {
    f32::from_bits(n.wrapping_add(127).cast_unsigned().wrapping_shl(23))
}

// ---------------------------------------------------------------------------------------
// sin, cos

/// π/2 in three parts (Cephes `sinf.c` DP1..DP3 doubled): PIO2_1 has 8 significant bits
/// and PIO2_2 11, so `k · PIO2_1` and `k · PIO2_2` are exact for |k| < 2^13; PIO2_3 carries
/// the rest. Residual |π/2 − ΣPIO2_i| < 2^-48.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_512_969_970_703_125e-4;
const PIO2_3: f32 = 7.549_789_954_891_882_16e-8;

/// Largest |x| accepted by [`sin`]/[`cos`]/[`sin_cos`]: 2^16 (so |k| < 2^16 and
/// `k · PIO2_1` stays exact). Up to 8192 the bounds of the module docs hold; beyond,
/// `k · PIO2_2` rounds and the absolute error grows (measured ≤ 2^-20, bound 2^-17) (where
/// consecutive f32 arguments are already 2^-7 rad apart). Beyond 2^16 the result is NaN:
/// a caller's finiteness check then sees a runaway angle instead of a wrong value.
pub const SIN_COS_MAX_ARG: f32 = 65_536.0;

/// Cephes `sinf.c` minimax coefficients for sin on [-π/4, π/4].
const S1: f32 = -1.951_529_589_1e-4;
const S2: f32 = 8.332_160_873_6e-3;
const S3: f32 = -1.666_665_461_1e-1;
/// Cephes `cosf.c` (`sinf.c` cos branch) coefficients for cos on [-π/4, π/4].
const C1: f32 = 2.443_315_711_809_948e-5;
const C2: f32 = -1.388_731_625_493_765e-3;
const C3: f32 = 4.166_664_568_298_827e-2;

/// x = k·π/2 + r, |r| ≤ π/4 (slightly more at rounding ties); returns (r, k mod 4), or
/// `None` for a non-finite or too large x.
#[inline(always)]
fn reduce_pio2(x: f32) -> Option<(f32, u32)> {
    // `!(a <= b)` is also true for NaN.
    if !(x.abs() <= SIN_COS_MAX_ARG) {
        return None;
    }
    let (kf, k) = round_int(x * core::f32::consts::FRAC_2_PI);
    let r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    Some((r, k.cast_unsigned() & 3))
}

#[inline(always)]
fn sin_poly(r: f32) -> f32 {
    let z = r * r;
    ((S1 * z + S2) * z + S3) * z * r + r
}

#[inline(always)]
fn cos_poly(r: f32) -> f32 {
    let z = r * r;
    ((C1 * z + C2) * z + C3) * z * z - 0.5 * z + 1.0
}

/// `(sin x, cos x)`; NaN for NaN, ±inf and |x| > [`SIN_COS_MAX_ARG`]. Bounds: module docs.
pub fn sin_cos(x: f32) -> (f32, f32) {
    if x == 0.0 {
        return (x, 1.0); // keeps the sign of zero, which the polynomial would lose
    }
    let Some((r, q)) = reduce_pio2(x) else {
        return (f32::NAN, f32::NAN);
    };
    let (s, c) = (sin_poly(r), cos_poly(r));
    // Quadrant q: (s, c), (c, −s), (−s, −c), (−c, s) — as selects and exact negations, not
    // a `match`: LLVM may lower a 4-way match to a computed jump (`mov pc, rN`), an
    // indirect branch the firmware's static check cannot bound.
    let odd = q & 1 == 1;
    let (sin_abs, cos_abs) = if odd { (c, s) } else { (s, c) };
    let sin = if q & 2 == 2 { -sin_abs } else { sin_abs };
    let cos = if q == 1 || q == 2 { -cos_abs } else { cos_abs };
    (sin, cos)
}

/// sin x; NaN for NaN, ±inf and |x| > [`SIN_COS_MAX_ARG`]. sin(±0) = ±0.
pub fn sin(x: f32) -> f32 {
    if x == 0.0 {
        return x; // keeps the sign of zero, which the polynomial would lose
    }
    let Some((r, q)) = reduce_pio2(x) else {
        return f32::NAN;
    };
    match q {
        0 => sin_poly(r),
        1 => cos_poly(r),
        2 => -sin_poly(r),
        _ => -cos_poly(r),
    }
}

/// cos x; NaN for NaN, ±inf and |x| > [`SIN_COS_MAX_ARG`].
pub fn cos(x: f32) -> f32 {
    let Some((r, q)) = reduce_pio2(x) else {
        return f32::NAN;
    };
    match q {
        0 => cos_poly(r),
        1 => -sin_poly(r),
        2 => -cos_poly(r),
        _ => sin_poly(r),
    }
}

// ---------------------------------------------------------------------------------------
// exp

/// ln 2 in two parts (Cephes `expf.c`): EXP_C1 has 9 significant bits, so `n · EXP_C1`
/// is exact for the |n| ≤ 150 used here.
const EXP_C1: f32 = 0.693_359_375;
const EXP_C2: f32 = -2.121_944_4e-4;
/// Cephes `expf.c` coefficients: exp(r) ≈ 1 + r + r² P(r) on [-ln2/2, ln2/2].
const EXP_P: [f32; 6] = [
    1.987_569_15e-4,
    1.398_199_950_7e-3,
    8.333_451_907_3e-3,
    4.166_579_589_4e-2,
    1.666_666_545_9e-1,
    5.000_000_120_1e-1,
];

/// e^x. NaN → NaN; +inf (and every x whose result overflows) → +inf; -inf and x < -104
/// → +0; subnormal results are rounded once (correct gradual underflow up to the
/// polynomial error). ≤ 1 ulp for normal results.
pub fn exp(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x > 89.0 {
        return f32::INFINITY;
    }
    if x < -104.0 {
        return 0.0;
    }
    // x = n ln2 + r, |n| ≤ 151.
    let (nf, n) = round_int(x * LOG2_E);
    let r = (x - nf * EXP_C1) - nf * EXP_C2;
    let z = r * r;
    let [p0, p1, p2, p3, p4, p5] = EXP_P;
    let p = (((((p0 * r + p1) * r + p2) * r + p3) * r + p4) * r + p5) * z + r + 1.0;
    // 2^n in two factors (each a normal float): the first product is exact, the second
    // rounds once, so overflow and gradual underflow round correctly.
    let n1 = n >> 1;
    let n2 = n.wrapping_sub(n1);
    p * pow2i(n1) * pow2i(n2)
}

// ---------------------------------------------------------------------------------------
// atan2, asin

/// tan(3π/8) and tan(π/8) (Cephes `atanf.c` range split).
const TAN_3PI_8: f32 = 2.414_213_562_373_095;
const TAN_PI_8: f32 = 0.414_213_562_373_095;
/// π = PI_HI + PI_LO (PI_LO = π − f32(π)), π/2 likewise.
const PI_LO: f32 = -8.742_278e-8;
const PIO2_LO: f32 = -4.371_139e-8;

/// atan t for t ≥ 0 (t = +inf gives π/2). Cephes `atanf.c`.
#[inline(always)]
fn atan_pos(t: f32) -> f32 {
    let (base, lo, x) = if t > TAN_3PI_8 {
        (FRAC_PI_2, PIO2_LO, -1.0 / t)
    } else if t > TAN_PI_8 {
        (FRAC_PI_4, 0.5 * PIO2_LO, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, 0.0, t)
    };
    let z = x * x;
    let p =
        (((8.053_744_495_38e-2 * z - 1.387_768_560_32e-1) * z + 1.997_771_064_78e-1) * z - 3.333_294_915_39e-1) * z * x
            + x;
    base + (p + lo)
}

/// atan2(y, x) in [-π, π]. Any NaN → NaN; both infinite → NaN (documented departure
/// from IEEE, which gives ±π/4 or ±3π/4); otherwise the IEEE special cases: one infinite
/// argument gives the limit (0, ±π/2 or ±π), atan2(±0, +0) = ±0, atan2(±0, −0) = ±π.
pub fn atan2(y: f32, x: f32) -> f32 {
    if x.is_nan() || y.is_nan() {
        return f32::NAN;
    }
    // y = 0 (any x, including 0): the angle is 0 or π; otherwise |y|/|x| may be +inf
    // (x = 0 or overflow, giving π/2) or 0 (underflow), or NaN if both are infinite.
    let a = if y == 0.0 {
        if x.is_sign_negative() { PI } else { 0.0 }
    } else if x == 0.0 {
        FRAC_PI_2
    } else {
        let a = atan_pos(y.abs() / x.abs());
        if x < 0.0 { (PI - a) + PI_LO } else { a }
    };
    a.copysign(y)
}

/// asin x in [-π/2, π/2]; NaN for NaN and |x| > 1. Cephes `asinf.c`; the branch for
/// |x| > 0.5 uses asin x = π/2 − 2 asin √((1−|x|)/2) with this module's exact [`sqrt`].
pub fn asin(x: f32) -> f32 {
    let a = x.abs();
    if !(a <= 1.0) {
        return f32::NAN;
    }
    let big = a > 0.5;
    let (z, t) = if big {
        let z = 0.5 * (1.0 - a);
        (z, sqrt(z))
    } else {
        (a * a, a)
    };
    let p = ((((4.216_319_904_8e-2 * z + 2.418_131_104_9e-2) * z + 4.547_002_599_8e-2) * z + 7.495_300_268_6e-2) * z
        + 1.666_675_242_2e-1)
        * z
        * t
        + t;
    let r = if big { FRAC_PI_2 - ((p + p) - PIO2_LO) } else { p };
    r.copysign(x)
}

// ---------------------------------------------------------------------------------------
// sqrt

/// Correctly rounded √x (bit-identical to IEEE-754 `sqrt`, i.e. to the M4F `vsqrt.f32`
/// and to std's `f32::sqrt`). √(±0) = ±0, √(+inf) = +inf, NaN and x < 0 → NaN.
///
/// On the Cortex-M4F (`acs_fpu::HAS_VSQRT`) the root of a positive finite x is the FPU's
/// `VSQRT.F32` (`acs_fpu::sqrt_positive`, one instruction instead of ~100); elsewhere it is
/// [`sqrt_software`]. Both are correctly rounded, so they give the same bits; zero,
/// negatives, NaN and infinity are answered here on every target (a NaN result is always
/// the canonical `f32::NAN`, whatever the input's payload).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    if !(x > 0.0) {
        // ±0 → ±0; negative or NaN → NaN.
        return if x == 0.0 { x } else { f32::NAN };
    }
    if x == f32::INFINITY {
        return x;
    }
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        acs_fpu::sqrt_positive(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        sqrt_software(x)
    }
}

/// The software √x of [`sqrt`] (every target but the M4F's), correctly rounded; kept public
/// so that the host can check it against the FPU's on the target (tests/tests/f32m_target.rs).
///
/// Why software: `core` has no stable `f32::sqrt` on rustc 1.95 (`core_float_math` is
/// unstable) and `libm` has no ARM `arch` path. Method: x = M · 2^(2j) with the integer M ∈ [2^46, 2^48); the
/// result is R · 2^j with R = round(√M) ∈ [2^23, 2^24] (24 bits: the f32 significand
/// grid). An f32 estimate of √M (a·(1/√a), three division-free Newton steps for 1/√a
/// from a bit-trick seed, relative error a few 2^-24) gives R within ±2; exact 64-bit integer comparisons then fix
/// R = ⌊√M⌋ (at most 4 steps each way, a documented cap never reached) and round:
/// √M > R + ½ ⇔ M − R² > R (M integer, no ties possible).
pub fn sqrt_software(x: f32) -> f32 {
    if !(x > 0.0) {
        // ±0 → ±0; negative or NaN → NaN.
        return if x == 0.0 { x } else { f32::NAN };
    }
    if x == f32::INFINITY {
        return x;
    }
    // Subnormal: scale by 2^24 (exact), unscale the root by 2^-12 (exact: it is normal).
    let (xn, unscale) = if x < f32::MIN_POSITIVE { (x * 16_777_216.0, 1.0 / 4096.0) } else { (x, 1.0) };
    let bits = xn.to_bits();
    let e = bits >> 23; // biased exponent, 1..=254: xn = m · 2^(e − 150)
    let frac = bits & 0x007F_FFFF;
    // M = m · 2^s with s ∈ {23, 24} so that e − 150 − s is even: s = 24 − (e & 1).
    let odd = e & 1;
    let s = 24u32.wrapping_sub(odd);
    let m = u64::from(frac | 0x0080_0000).wrapping_shl(s);
    // a = M / 2^46 ∈ [1, 4) as a float (same significand, exponent 0 or 1).
    let a = f32::from_bits(frac | (127u32.wrapping_add(1).wrapping_sub(odd)).wrapping_shl(23));
    // 1/√a by Newton's iteration y ← y (3 − a y²)/2 from the bit-trick seed (≤ 3.5 %
    // error; relative error squares each time: 2e-3, 6e-6, then f32 rounding), then
    // √a ≈ a·y. Multiplications only: a VDIV costs 14 cycles on the M4F, a VMUL 1.
    let mut y = f32::from_bits(0x5F37_59DFu32.wrapping_sub(a.to_bits() >> 1));
    let half_a = 0.5 * a;
    y = y * (1.5 - half_a * y * y);
    y = y * (1.5 - half_a * y * y);
    y = y * (1.5 - half_a * y * y);
    let g = a * y;
    // R0 = g · 2^23, kept within [2^23, 2^24].
    let mut r: u64 = if !(g >= 1.0) {
        1 << 23
    } else if g >= 2.0 {
        1 << 24
    } else {
        u64::from((g.to_bits() & 0x007F_FFFF) | 0x0080_0000)
    };
    let mut steps = 0u32;
    while r.wrapping_mul(r) > m && steps < 4 {
        r = r.wrapping_sub(1);
        steps = steps.wrapping_add(1);
    }
    let mut steps = 0u32;
    while r.wrapping_add(1).wrapping_mul(r.wrapping_add(1)) <= m && steps < 4 {
        r = r.wrapping_add(1);
        steps = steps.wrapping_add(1);
    }
    if m.wrapping_sub(r.wrapping_mul(r)) > r {
        r = r.wrapping_add(1);
    }
    // Result = R · 2^j, j = (e − 150 − s)/2 ∈ [-86, 40]; as bits: biased exponent of
    // R · 2^j is j + 127 + 23 (+1 if R = 2^24), significand R without its leading bit.
    let jb = e.wrapping_add(104).wrapping_sub(s) >> 1; // j + 127
    let out = if r >= 1 << 24 {
        jb.wrapping_add(24).wrapping_shl(23)
    } else {
        let frac_r = u32::try_from(r & 0x007F_FFFF).unwrap_or(0);
        jb.wrapping_add(23).wrapping_shl(23) | frac_r
    };
    f32::from_bits(out) * unscale
}

/// FNV-1a fingerprint of every function of this module over a fixed sweep of `points`
/// arguments per function (plus special values), for the host-vs-target comparison:
/// `firmware/examples/f32m_fingerprint.rs` prints it under QEMU and
/// `tests/tests/f32m_target.rs` compares it with the host's. NaN results are hashed as
/// one canonical NaN: payloads differ between ISAs (x86 produces a negative quiet NaN for
/// 0/0, ARM a positive one) and are not part of the contract.
pub fn sweep_fingerprint(points: u32) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    let mut mix = |v: f32| {
        let b = if v.is_nan() { 0x7FC0_0000 } else { v.to_bits() };
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3);
    };
    let n = points as f32;
    for i in 0..points {
        let u = i as f32 / n; // [0, 1)
        let x = (u - 0.5) * (32.0 * PI); // sin/cos: [-16π, 16π)
        mix(sin(x));
        mix(cos(x));
        let (s, c) = sin_cos(x * 1024.0); // reduction up to 2^14·π
        mix(s);
        mix(c);
        mix(exp(u * 193.0 - 104.0)); // [-104, 89): underflow to overflow
        mix(sqrt(f32::from_bits(i.wrapping_mul(0x9E37_79B9)))); // all bit patterns
        mix(atan2(x, 3.0 - 7.0 * u)); // all quadrants
        mix(asin(u * 2.2 - 1.1)); // including |x| > 1
    }
    let specials = [
        0.0,
        -0.0,
        f32::from_bits(1),
        f32::MIN_POSITIVE,
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e5,
        -70_000.0,
    ];
    for x in specials {
        for y in specials {
            mix(atan2(y, x));
        }
        let (s, c) = sin_cos(x);
        for v in [sin(x), cos(x), s, c, exp(x), exp(-x), sqrt(x), sqrt(-x), asin(x)] {
            mix(v);
        }
    }
    h
}

#[cfg(test)]
mod tests {
    //! Accuracy against an independent reference: std's f64 functions (the host libm,
    //! correctly rounded or within 1 ulp of f64, i.e. ~2^-29 f32 ulp) rounded to f32.
    use super::*;

    #[test]
    fn floor_matches_std_everywhere() {
        // Every 37th float bit pattern, both signs: exact agreement (std is the reference).
        let mut bits = 0u32;
        while bits < 0x7F80_0000 {
            for x in [f32::from_bits(bits), -f32::from_bits(bits)] {
                assert_eq!(floor(x).to_bits(), std::primitive::f32::floor(x).to_bits(), "{x}");
            }
            bits += 37;
        }
        assert!(floor(f32::NAN).is_nan());
        assert_eq!(floor(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(floor(-0.5), -1.0);
        assert_eq!(floor(2.999_999_8), 2.0);
    }

    /// Distance in ulps between two finite f32 of any sign (monotone bit ordering).
    fn ulps(a: f32, b: f32) -> u64 {
        let key = |v: f32| {
            let b = v.to_bits() as i64;
            if b & 0x8000_0000 != 0 { 0x8000_0000 - b } else { b }
        };
        (key(a) - key(b)).unsigned_abs()
    }

    /// Max ulp error and max absolute error of `f` against `reference` over `xs`.
    fn sweep(xs: impl Iterator<Item = f32>, f: impl Fn(f32) -> f32, reference: impl Fn(f64) -> f64) -> (u64, f64) {
        let (mut worst_ulp, mut worst_abs) = (0u64, 0f64);
        for x in xs {
            let want = reference(x as f64);
            let got = f(x);
            assert!(got.is_finite() == want.is_finite() || (want as f32).is_infinite(), "x={x} got {got} want {want}");
            if want.is_finite() && got.is_finite() {
                worst_ulp = worst_ulp.max(ulps(got, want as f32));
                worst_abs = worst_abs.max((got as f64 - want).abs());
            }
        }
        (worst_ulp, worst_abs)
    }

    /// Every 2^-12 in [lo, hi].
    fn grid(lo: f32, hi: f32) -> impl Iterator<Item = f32> {
        let n = ((hi - lo) * 4096.0) as i64;
        (0..=n).map(move |i| lo + i as f32 / 4096.0)
    }

    /// `n` pseudo-random f32 spread over [lo, hi] (fixed LCG: reproducible).
    fn scattered(lo: f32, hi: f32, n: usize) -> impl Iterator<Item = f32> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        (0..n).map(move |_| {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            lo + (hi - lo) * ((s >> 40) as f32 / (1u64 << 24) as f32)
        })
    }

    const TWO_PI: f32 = 2.0 * PI;

    #[test]
    fn sin_cos_within_1_ulp_on_two_turns() {
        let (us, _) = sweep(grid(-TWO_PI, TWO_PI), sin, f64::sin);
        let (uc, _) = sweep(grid(-TWO_PI, TWO_PI), cos, f64::cos);
        println!("sin {us} ulp, cos {uc} ulp on |x| <= 2pi");
        assert!(us <= 1 && uc <= 1, "sin {us} cos {uc}");
        // sin_cos is exactly sin and cos.
        for x in grid(-TWO_PI, TWO_PI).step_by(7) {
            let (s, c) = sin_cos(x);
            assert_eq!((s.to_bits(), c.to_bits()), (sin(x).to_bits(), cos(x).to_bits()));
        }
    }

    #[test]
    fn sin_cos_on_the_exact_reduction_range() {
        // |x| <= 8192: every 2^-6 (about 10^6 points) plus scattered arguments; near the
        // zeros of sin/cos the ulp error of an f32 argument reduction is unbounded in
        // principle, so the bound is 2 ulp or 2^-34 absolute.
        let xs = || grid(-8192.0, 8192.0).step_by(64).chain(scattered(-8192.0, 8192.0, 200_000));
        for (name, f, r) in [("sin", sin as fn(f32) -> f32, f64::sin as fn(f64) -> f64), ("cos", cos, f64::cos)] {
            let mut worst = 0f64;
            for x in xs() {
                let want = r(x as f64);
                let got = f(x);
                let u = ulps(got, want as f32);
                let abs = (got as f64 - want).abs();
                if u > 2 {
                    worst = worst.max(abs);
                }
            }
            println!("{name}: worst absolute error where > 2 ulp: {worst:e}");
            assert!(worst <= 2f64.powi(-34), "{name} {worst:e}");
        }
    }

    #[test]
    fn sin_cos_beyond_8192_degrade_gracefully_and_stop_at_the_limit() {
        let (_, a) = sweep(scattered(8192.0, SIN_COS_MAX_ARG, 100_000), sin, f64::sin);
        let (_, b) = sweep(scattered(-SIN_COS_MAX_ARG, -8192.0, 100_000), cos, f64::cos);
        println!("beyond 8192: abs error sin {a:e} cos {b:e}");
        assert!(a <= 2f64.powi(-17) && b <= 2f64.powi(-17));
        let big = f32::from_bits(SIN_COS_MAX_ARG.to_bits() + 1);
        for x in [big, -big, f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert!(sin(x).is_nan() && cos(x).is_nan() && sin_cos(x).0.is_nan() && sin_cos(x).1.is_nan(), "{x}");
        }
        assert!(sin(SIN_COS_MAX_ARG).is_finite());
    }

    #[test]
    fn sin_cos_small_and_signed_zero() {
        assert_eq!(sin(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sin(0.0).to_bits(), 0);
        assert_eq!(sin_cos(-0.0), (-0.0, 1.0));
        assert_eq!(cos(-0.0), 1.0);
        // Subnormal and tiny arguments: sin x = x, cos x = 1 exactly.
        for x in [f32::from_bits(1), -f32::from_bits(1), f32::from_bits(0x0040_0000), 1e-30, -1e-20, 1e-5] {
            assert_eq!(sin(x), (x as f64).sin() as f32, "{x}");
            assert_eq!(cos(x), 1.0, "{x}");
        }
    }

    #[test]
    fn exp_within_1_ulp() {
        let (u, _) = sweep(grid(-87.0, 88.0).step_by(3), exp, f64::exp);
        let (u2, _) = sweep(grid(-1.0, 1.0), exp, f64::exp);
        println!("exp {u} ulp on [-87, 88], {u2} on [-1, 1]");
        assert!(u <= 1 && u2 <= 1);
        // Overflow, underflow (gradual: subnormal results within 1 ulp), specials.
        assert_eq!(exp(88.72283), (88.72283f32 as f64).exp() as f32);
        assert_eq!(exp(88.7229), f32::INFINITY);
        assert_eq!(exp(100.0), f32::INFINITY);
        assert_eq!(exp(f32::INFINITY), f32::INFINITY);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert_eq!(exp(-200.0), 0.0);
        assert!(exp(f32::NAN).is_nan());
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-0.0), 1.0);
        for x in [-88.0f32, -95.0, -100.0, -103.0, -103.9] {
            assert!(ulps(exp(x), (x as f64).exp() as f32) <= 1, "{x}: {} vs {}", exp(x), (x as f64).exp());
        }
    }

    #[test]
    fn atan2_within_2_ulp_all_quadrants() {
        let mut worst = 0;
        // Angles every 2^-12 on the circle at several radii (all quadrants and octants).
        for r in [1e-30f32, 1e-3, 1.0, 7.5, 1e20] {
            for th in grid(-PI, PI) {
                let (y, x) = ((th as f64).sin() as f32 * r, (th as f64).cos() as f32 * r);
                let want = (y as f64).atan2(x as f64) as f32;
                worst = worst.max(ulps(atan2(y, x), want));
            }
        }
        println!("atan2 {worst} ulp");
        assert!(worst <= 2, "{worst}");
        // IEEE zeros and infinities; NaN; the documented inf/inf departure.
        assert_eq!(atan2(0.0, 1.0).to_bits(), 0);
        assert_eq!(atan2(-0.0, 1.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(atan2(0.0, 0.0).to_bits(), 0);
        assert_eq!(atan2(-0.0, 0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(atan2(0.0, -0.0), PI);
        assert_eq!(atan2(-0.0, -0.0), -PI);
        assert_eq!(atan2(0.0, -1.0), PI);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, -0.0), -FRAC_PI_2);
        assert_eq!(atan2(1.0, f32::INFINITY), 0.0);
        assert_eq!(atan2(1.0, f32::NEG_INFINITY), PI);
        assert_eq!(atan2(f32::NEG_INFINITY, 3.0), -FRAC_PI_2);
        assert_eq!(atan2(f32::MAX, f32::MIN_POSITIVE), FRAC_PI_2);
        assert!(atan2(f32::INFINITY, f32::INFINITY).is_nan());
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }

    #[test]
    fn asin_within_2_ulp() {
        let (u, _) = sweep(grid(-1.0, 1.0), asin, f64::asin);
        let (u2, _) = sweep(scattered(-1.0, 1.0, 300_000), asin, f64::asin);
        println!("asin {u} ulp (grid), {u2} (scattered)");
        assert!(u <= 2 && u2 <= 2);
        assert_eq!(asin(1.0), FRAC_PI_2);
        assert_eq!(asin(-1.0), -FRAC_PI_2);
        assert_eq!(asin(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(asin(1e-30), 1e-30);
        for x in [1.000_000_1f32, -2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert!(asin(x).is_nan(), "{x}");
        }
    }

    #[test]
    fn sqrt_is_correctly_rounded() {
        let check = |x: f32| {
            let want = (x as f64).sqrt() as f32; // f64 → f32 double rounding is exact for sqrt
            assert_eq!(sqrt(x).to_bits(), want.to_bits(), "sqrt({x:e}) = {:e}, want {want:e}", sqrt(x));
            assert_eq!(sqrt(x).to_bits(), x.sqrt().to_bits());
        };
        // Every f32 in [1, 4): every significand with both exponent parities.
        for b in 1.0f32.to_bits()..4.0f32.to_bits() {
            check(f32::from_bits(b));
        }
        // Every 4099th bit pattern over all positive floats (subnormals, extremes).
        for b in (1..0x7F80_0000u32).step_by(4099) {
            check(f32::from_bits(b));
        }
        for x in [f32::from_bits(1), f32::MIN_POSITIVE, f32::MAX, 1.0, 4.0, 0.25, 2.0, 1e-40] {
            check(x);
        }
        assert_eq!(sqrt(0.0).to_bits(), 0);
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        for x in [-1.0f32, -f32::from_bits(1), f32::NEG_INFINITY, f32::NAN] {
            assert!(sqrt(x).is_nan(), "{x}");
        }
    }
}
