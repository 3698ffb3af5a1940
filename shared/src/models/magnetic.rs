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
//!
//! The evaluation is resumable ([`FieldEvaluation`]): term by term `(n, m)`, each term
//! computing its Legendre values and its part of the sums, so the flight code can spread
//! one degree-12 evaluation (≈ 31,600 instructions on the Cortex-M4F) over several control
//! steps (`crate::estimation::references`). [`field_ecef_t`] is one evaluation run to the
//! end; both give the same bits.

use super::wmm2025::{G_DOT_NT_YR, G_NT, H_DOT_NT_YR, H_NT, WMM_EPOCH_YEAR, WMM_MAX_DEGREE};
use crate::math::Vec3;
use crate::math::f32m::{atan2, sqrt};

/// Highest degree evaluated.
pub const MAX_DEGREE: usize = WMM_MAX_DEGREE;
/// Geomagnetic reference radius, m.
pub const WMM_RADIUS_M: f32 = 6_371_200.0;
const _: () = assert!(MAX_DEGREE >= 1, "at least the dipole");

/// Why no field: position not finite, inside the Earth, or beyond 10 Earth radii.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldError;

/// Index of (n, m) in the 0-based triangular tables including n = 0.
const fn slot(n: usize, m: usize) -> usize {
    // n ≤ MAX_DEGREE: no wrap.
    (n.wrapping_mul(n.wrapping_add(1)) / 2).wrapping_add(m)
}

fn coeff(table: &[f32], dot: &[f32], n: usize, m: usize, years: f32) -> f32 {
    // WMM tables start at n = 1: k = n(n+1)/2 + m − 1.
    let k = slot(n, m).wrapping_sub(1);
    table.get(k).copied().unwrap_or(0.0) + dot.get(k).copied().unwrap_or(0.0) * years
}

/// Field in ECEF axes, tesla, at `r_ecef_m` on `decimal_year`, spherical harmonics to
/// degree `degree` (1 … [`MAX_DEGREE`]; clamped into that range): a [`FieldEvaluation`]
/// run to the end in one call.
pub fn field_ecef_t(r_ecef_m: &Vec3, decimal_year: f32, degree: usize) -> Result<Vec3, FieldError> {
    let mut e = FieldEvaluation::start(r_ecef_m, decimal_year, degree)?;
    e.advance(usize::MAX);
    e.field_ecef_t().unwrap_or(Err(FieldError))
}

/// Terms `(n, m)` of an evaluation to degree `degree` (clamped like [`field_ecef_t`]):
/// `Σₙ (n + 1)` for n = 1 … degree (90 at degree 12).
pub const fn field_terms(degree: usize) -> usize {
    let nmax = if degree < 1 {
        1
    } else if degree > MAX_DEGREE {
        MAX_DEGREE
    } else {
        degree
    };
    terms_through(nmax)
}

/// `Σₖ (k + 1)` for k = 1 … n (n ≤ [`MAX_DEGREE`] + 1: no overflow).
const fn terms_through(n: usize) -> usize {
    n.wrapping_mul(n.wrapping_add(3)) / 2
}

/// Length of one row `m = 0 … n` of the Legendre tables.
const ROW: usize = MAX_DEGREE + 1;

/// One evaluation of the field, resumable term by term so that its cost can be spread over
/// several control steps ([`FieldEvaluation::advance`]); the same operations in the same
/// order as a single call, so the result is bit-identical to [`field_ecef_t`].
///
/// One term is one `(n, m)`: the Legendre recursions for `Pₙᵐ`, `dPₙᵐ/dθ` (rows n − 1 and
/// n − 2 kept; a degree needs no more) and its contribution to the three sums. Terms run
/// n = 1 … nmax, m = 0 … n; a degree's sums are added to the components when its last
/// term is done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldEvaluation {
    nmax: usize,
    years: f32,
    rho: f32,
    sin_t: f32,
    cos_t: f32,
    sin_l: f32,
    cos_l: f32,
    /// The next term.
    n: usize,
    m: usize,
    /// `Pₙᵐ` and `dPₙᵐ/dθ` of rows n − 2, n − 1 and n (being built), indexed by m.
    p_prev2: [f32; ROW],
    p_prev: [f32; ROW],
    p_cur: [f32; ROW],
    dp_prev2: [f32; ROW],
    dp_prev: [f32; ROW],
    dp_cur: [f32; ROW],
    /// `cos mλ`, `sin mλ` of the next term and degree n's partial sums.
    cm: f32,
    sm: f32,
    sr: f32,
    st: f32,
    sl: f32,
    /// `ρⁿ⁺²` and the components so far, nT.
    rho_n2: f32,
    br: f32,
    bt: f32,
    bl: f32,
}

impl FieldEvaluation {
    /// Set up an evaluation at `r_ecef_m` on `decimal_year` to degree `degree` (clamped
    /// into 1 … [`MAX_DEGREE`]); no term is evaluated yet.
    pub fn start(r_ecef_m: &Vec3, decimal_year: f32, degree: usize) -> Result<Self, FieldError> {
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
        let rho = WMM_RADIUS_M / r;
        let mut p_prev = [0.0_f32; ROW];
        if let Some(x) = p_prev.get_mut(0) {
            *x = 1.0; // P₀⁰
        }
        Ok(Self {
            nmax,
            years,
            rho,
            sin_t,
            cos_t,
            sin_l,
            cos_l,
            n: 1,
            m: 0,
            p_prev2: [0.0; ROW],
            p_prev,
            p_cur: [0.0; ROW],
            dp_prev2: [0.0; ROW],
            dp_prev: [0.0; ROW],
            dp_cur: [0.0; ROW],
            cm: 1.0,
            sm: 0.0,
            sr: 0.0,
            st: 0.0,
            sl: 0.0,
            rho_n2: rho * rho * rho, // ρ^(n+2) for n = 1
            br: 0.0,
            bt: 0.0,
            bl: 0.0,
        })
    }

    /// Whether every term has been evaluated.
    pub fn is_done(&self) -> bool {
        self.n > self.nmax
    }

    /// Terms still to evaluate.
    pub fn remaining_terms(&self) -> usize {
        if self.is_done() {
            return 0;
        }
        // n ≥ 1 and m ≤ n ≤ nmax: the terms before (n, m) are fewer than all.
        let before = terms_through(self.n.wrapping_sub(1)).wrapping_add(self.m);
        terms_through(self.nmax).saturating_sub(before)
    }

    /// Evaluate up to `terms` more terms; true when the evaluation is complete.
    pub fn advance(&mut self, terms: usize) -> bool {
        for _ in 0..terms {
            if self.is_done() {
                break;
            }
            self.term();
        }
        self.is_done()
    }

    /// The field in ECEF axes, tesla, once complete (`None` before).
    pub fn field_ecef_t(&self) -> Option<Result<Vec3, FieldError>> {
        if !self.is_done() {
            return None;
        }
        let (sin_t, cos_t, sin_l, cos_l) = (self.sin_t, self.cos_t, self.sin_l, self.cos_l);
        // Local (r̂, θ̂, λ̂) → ECEF; nT → T.
        let r_hat = Vec3::new(sin_t * cos_l, sin_t * sin_l, cos_t);
        let t_hat = Vec3::new(cos_t * cos_l, cos_t * sin_l, -sin_t);
        let l_hat = Vec3::new(-sin_l, cos_l, 0.0);
        let b = (r_hat * self.br + t_hat * self.bt + l_hat * self.bl) * 1e-9;
        Some(if b.iter().all(|v| v.is_finite()) { Ok(b) } else { Err(FieldError) })
    }

    /// Term `(n, m)`: Schmidt semi-normalised `Pₙᵐ(cos θ)` and its θ-derivative by the
    /// standard recursions, then its part of `B_r`, `B_θ`, `B_λ` with the Gauss
    /// coefficients at the date; the degree's sums close after m = n.
    fn term(&mut self) {
        let (n, m) = (self.n, self.m);
        let (sin_t, cos_t) = (self.sin_t, self.cos_t);
        let nf = n as f32;
        let mf = m as f32;
        let (v, dv) = if m == n {
            let (pp, dpp) = (row(&self.p_prev, n.wrapping_sub(1)), row(&self.dp_prev, n.wrapping_sub(1)));
            let k = if n == 1 { 1.0 } else { sqrt((2.0 * nf - 1.0) / (2.0 * nf)) };
            (k * sin_t * pp, k * (sin_t * dpp + cos_t * pp))
        } else {
            let (p1, dp1) = (row(&self.p_prev, m), row(&self.dp_prev, m));
            let (p2, dp2) =
                if m.wrapping_add(2) <= n { (row(&self.p_prev2, m), row(&self.dp_prev2, m)) } else { (0.0, 0.0) };
            let k2 = sqrt(((nf - 1.0) * (nf - 1.0) - mf * mf).max(0.0));
            let d = sqrt(nf * nf - mf * mf);
            (
                ((2.0 * nf - 1.0) * cos_t * p1 - k2 * p2) / d,
                ((2.0 * nf - 1.0) * (cos_t * dp1 - sin_t * p1) - k2 * dp2) / d,
            )
        };
        if let Some(x) = self.p_cur.get_mut(m) {
            *x = v;
        }
        if let Some(x) = self.dp_cur.get_mut(m) {
            *x = dv;
        }
        let g = coeff(&G_NT, &G_DOT_NT_YR, n, m, self.years);
        let h = coeff(&H_NT, &H_DOT_NT_YR, n, m, self.years);
        let (cm, sm) = (self.cm, self.sm);
        let a = g * cm + h * sm;
        self.sr += a * v;
        self.st += a * dv;
        self.sl += m as f32 * (g * sm - h * cm) * v;
        self.cm = cm * self.cos_l - sm * self.sin_l;
        self.sm = sm * self.cos_l + cm * self.sin_l;
        if m < n {
            self.m = m.wrapping_add(1);
            return;
        }
        // Degree n complete.
        self.br += (nf + 1.0) * self.rho_n2 * self.sr;
        self.bt -= self.rho_n2 * self.st;
        self.bl += self.rho_n2 * self.sl / sin_t;
        self.rho_n2 *= self.rho;
        self.p_prev2 = self.p_prev;
        self.p_prev = self.p_cur;
        self.dp_prev2 = self.dp_prev;
        self.dp_prev = self.dp_cur;
        (self.cm, self.sm, self.sr, self.st, self.sl) = (1.0, 0.0, 0.0, 0.0, 0.0);
        self.n = n.wrapping_add(1);
        self.m = 0;
    }
}

fn row(a: &[f32; ROW], m: usize) -> f32 {
    a.get(m).copied().unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Slices of any size give the bits of one call, and the term count is exact.
    #[test]
    fn an_evaluation_in_slices_gives_the_bits_of_one_call() {
        assert_eq!(field_terms(12), 90);
        assert_eq!(field_terms(0), 2);
        assert_eq!(field_terms(99), 90);
        let points = [Vec3::new(6.9e6, 1.0e5, 2.0e5), Vec3::new(-3.0e6, 4.0e6, -5.1e6), Vec3::new(0.0, 0.0, 6.99e6)];
        for r in &points {
            for degree in 1..=MAX_DEGREE {
                let whole = field_ecef_t(r, 2026.3, degree).unwrap();
                for slice in [1, 2, 7, 9, 13, 90] {
                    let mut e = FieldEvaluation::start(r, 2026.3, degree).unwrap();
                    let mut calls = 0;
                    assert_eq!(e.remaining_terms(), field_terms(degree));
                    while !e.is_done() {
                        assert!(e.field_ecef_t().is_none());
                        let before = e.remaining_terms();
                        e.advance(slice);
                        assert_eq!(e.remaining_terms(), before.saturating_sub(slice));
                        calls += 1;
                    }
                    assert_eq!(calls, field_terms(degree).div_ceil(slice));
                    let b = e.field_ecef_t().unwrap().unwrap();
                    assert_eq!(b.map(f32::to_bits), whole.map(f32::to_bits), "degree {degree} slice {slice}");
                }
            }
        }
        assert_eq!(FieldEvaluation::start(&Vec3::new(1.0, 0.0, 0.0), 2026.0, 12), Err(FieldError));
    }
}
