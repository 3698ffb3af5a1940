//! Geomagnetic field on board: WMM2025's spherical-harmonic model truncated to a chosen
//! degree, evaluated in f32 (Chulliat et al., *The US/UK World Magnetic Model for
//! 2025–2030*, NOAA technical report, eqs 2–4 and 10–12, in geocentric spherical
//! coordinates; full reference in docs/references.md).
//!
//! With `ρ = a / r` (a = 6,371,200 m), colatitude θ, longitude λ, Schmidt semi-normalised
//! associated Legendre functions `Pₙᵐ(cos θ)` and Gauss coefficients at the date
//! `g(t) = g + ġ (t − 2025.0)` (likewise h):
//! `B_r = Σ (n+1) ρⁿ⁺² Σ (g cos mλ + h sin mλ) Pₙᵐ`,
//! `B_θ = −Σ ρⁿ⁺² Σ (g cos mλ + h sin mλ) dPₙᵐ/dθ`,
//! `B_λ = (1 / sin θ) Σ ρⁿ⁺² Σ m (g sin mλ − h cos mλ) Pₙᵐ`,
//! then rotated to ECEF. `Pₙᵐ` by the standard recursions (diagonal
//! `Pₙⁿ = √((2n−1)/2n) sin θ Pₙ₋₁ⁿ⁻¹`; `Pₙᵐ = ((2n−1) cos θ Pₙ₋₁ᵐ − √((n−1)²−m²) Pₙ₋₂ᵐ) / √(n²−m²)`),
//! `cos mλ`, `sin mλ` by the angle-addition recurrence. Degree 1 is the tilted, offset-free
//! dipole; the error of each truncation against the full model is measured by
//! `sim-host/core/tests/onboard_models.rs` and stated in docs/verification.md. Loops are bounded by
//! [`MAX_DEGREE`]. Near the poles `sin θ` is floored at 1e-6 (within 6 m of the axis).

use super::wmm2025::{G_DOT_NT_YR, G_NT, H_DOT_NT_YR, H_NT, WMM_EPOCH_YEAR, WMM_MAX_DEGREE};
use crate::math::Vec3;
use crate::math::f32m::{atan2, sqrt};

/// Highest degree evaluated.
pub const MAX_DEGREE: usize = WMM_MAX_DEGREE;
/// Geomagnetic reference radius, m.
pub const WMM_RADIUS_M: f32 = 6_371_200.0;
const _: () = assert!(MAX_DEGREE >= 1, "at least the dipole");
const SLOTS: usize = (MAX_DEGREE + 1) * (MAX_DEGREE + 2) / 2;

/// Why no field: position not finite, inside the Earth, or beyond 10 Earth radii.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldError;

/// Index of (n, m) in the 0-based triangular tables including n = 0.
const fn slot(n: usize, m: usize) -> usize {
    // n ≤ MAX_DEGREE: no wrap.
    (n.wrapping_mul(n.wrapping_add(1)) / 2).wrapping_add(m)
}

fn get(a: &[f32; SLOTS], i: usize) -> f32 {
    a.get(i).copied().unwrap_or(0.0)
}

fn coeff(table: &[f32], dot: &[f32], n: usize, m: usize, years: f32) -> f32 {
    // WMM tables start at n = 1: k = n(n+1)/2 + m − 1.
    let k = slot(n, m).wrapping_sub(1);
    table.get(k).copied().unwrap_or(0.0) + dot.get(k).copied().unwrap_or(0.0) * years
}

/// Field in ECEF axes, tesla, at `r_ecef_m` on `decimal_year`, spherical harmonics to
/// degree `degree` (1 … [`MAX_DEGREE`]; clamped into that range).
pub fn field_ecef_t(r_ecef_m: &Vec3, decimal_year: f32, degree: usize) -> Result<Vec3, FieldError> {
    // max/min, not clamp: no bound ordering to trust (clamp panics on min > max).
    #[allow(clippy::manual_clamp)]
    let nmax = degree.max(1).min(MAX_DEGREE);
    let r = sqrt(r_ecef_m.norm_squared());
    if !(r.is_finite() && r > 6.0e6 && r < 6.4e7 && decimal_year.is_finite()) {
        return Err(FieldError);
    }
    let years = decimal_year - WMM_EPOCH_YEAR;
    let p_xy = sqrt(r_ecef_m.x * r_ecef_m.x + r_ecef_m.y * r_ecef_m.y);
    let cos_t = r_ecef_m.z / r;
    let sin_t = (p_xy / r).max(1e-6);
    let lon = atan2(r_ecef_m.y, r_ecef_m.x);
    let (sin_l, cos_l) = crate::math::f32m::sin_cos(lon);
    let (p, dp) = legendre(nmax, sin_t, cos_t);
    let rho = WMM_RADIUS_M / r;
    let (br, bt, bl) = local_components_nt(&p, &dp, nmax, years, rho, (sin_t, sin_l, cos_l));
    // Local (r̂, θ̂, λ̂) → ECEF; nT → T.
    let r_hat = Vec3::new(sin_t * cos_l, sin_t * sin_l, cos_t);
    let t_hat = Vec3::new(cos_t * cos_l, cos_t * sin_l, -sin_t);
    let l_hat = Vec3::new(-sin_l, cos_l, 0.0);
    let b = (r_hat * br + t_hat * bt + l_hat * bl) * 1e-9;
    if b.iter().all(|v| v.is_finite()) { Ok(b) } else { Err(FieldError) }
}

/// Schmidt semi-normalised associated Legendre functions `P_n^m(cos θ)` and their
/// θ-derivatives, n = 0 … `nmax`, by the standard recursions (slot order of [`slot`]).
// Inlined (as `local_components_nt`): the tables stay in the caller, not copied out.
#[inline(always)]
fn legendre(nmax: usize, sin_t: f32, cos_t: f32) -> ([f32; SLOTS], [f32; SLOTS]) {
    let mut p = [0.0_f32; SLOTS];
    let mut dp = [0.0_f32; SLOTS];
    if let Some(x) = p.get_mut(0) {
        *x = 1.0;
    }
    for n in 1..=nmax {
        let nf = n as f32;
        for m in 0..=n {
            let mf = m as f32;
            let (v, dv) = if m == n {
                let (pp, dpp) = (
                    get(&p, slot(n.wrapping_sub(1), n.wrapping_sub(1))),
                    get(&dp, slot(n.wrapping_sub(1), n.wrapping_sub(1))),
                );
                let k = if n == 1 { 1.0 } else { sqrt((2.0 * nf - 1.0) / (2.0 * nf)) };
                (k * sin_t * pp, k * (sin_t * dpp + cos_t * pp))
            } else {
                let (p1, dp1) = (get(&p, slot(n.wrapping_sub(1), m)), get(&dp, slot(n.wrapping_sub(1), m)));
                let (p2, dp2) = if m.wrapping_add(2) <= n {
                    (get(&p, slot(n.wrapping_sub(2), m)), get(&dp, slot(n.wrapping_sub(2), m)))
                } else {
                    (0.0, 0.0)
                };
                let k2 = sqrt(((nf - 1.0) * (nf - 1.0) - mf * mf).max(0.0));
                let d = sqrt(nf * nf - mf * mf);
                (
                    ((2.0 * nf - 1.0) * cos_t * p1 - k2 * p2) / d,
                    ((2.0 * nf - 1.0) * (cos_t * dp1 - sin_t * p1) - k2 * dp2) / d,
                )
            };
            if let Some(x) = p.get_mut(slot(n, m)) {
                *x = v;
            }
            if let Some(x) = dp.get_mut(slot(n, m)) {
                *x = dv;
            }
        }
    }
    (p, dp)
}

/// The field's local components `(B_r, B_θ, B_λ)`, nT: the spherical-harmonic sums to
/// degree `nmax` with the coefficients at `years` past the epoch, `rho = a / r`, and
/// `(sin θ, sin λ, cos λ)` of the point.
#[inline(always)]
fn local_components_nt(
    p: &[f32; SLOTS],
    dp: &[f32; SLOTS],
    nmax: usize,
    years: f32,
    rho: f32,
    (sin_t, sin_l, cos_l): (f32, f32, f32),
) -> (f32, f32, f32) {
    let mut rho_n2 = rho * rho * rho; // ρ^(n+2) for n = 1
    let (mut br, mut bt, mut bl) = (0.0_f32, 0.0_f32, 0.0_f32);
    for n in 1..=nmax {
        let nf = n as f32;
        let (mut cm, mut sm) = (1.0_f32, 0.0_f32); // cos mλ, sin mλ
        let (mut sr, mut st, mut sl) = (0.0_f32, 0.0_f32, 0.0_f32);
        for m in 0..=n {
            let g = coeff(&G_NT, &G_DOT_NT_YR, n, m, years);
            let h = coeff(&H_NT, &H_DOT_NT_YR, n, m, years);
            let (pv, dpv) = (get(p, slot(n, m)), get(dp, slot(n, m)));
            let a = g * cm + h * sm;
            sr += a * pv;
            st += a * dpv;
            sl += m as f32 * (g * sm - h * cm) * pv;
            let (c2, s2) = (cm * cos_l - sm * sin_l, sm * cos_l + cm * sin_l);
            cm = c2;
            sm = s2;
        }
        br += (nf + 1.0) * rho_n2 * sr;
        bt -= rho_n2 * st;
        bl += rho_n2 * sl / sin_t;
        rho_n2 *= rho;
    }
    (br, bt, bl)
}
