//! Analytic reference for the stability margins of issue 25: the discrete open-loop
//! response, at the plant (torque) input, of one axis of a rigid body under the flight's
//! quaternion-feedback PD, and margins computed from any response by a method of its own.
//!
//! # Loop
//! Plant `J_p θ̈ = a`, with `a` the applied body torque: the plant input `e` (held over each
//! control period T, zero-order hold), delayed by `Δ = nT + δ` (0 ≤ δ < T) and passed
//! through a first-order lag `τ_a ȧ = e(t - Δ) - a` (τ_a = 0: `a = e(t - Δ)`). `J_p` is the
//! body inertia the plant integrates (the scenario inertia minus the wheel rotors' axial
//! inertia, `plant::Spacecraft::inertia`).
//! Controller (shared/src/control/quaternion_feedback.rs, lockstep SIL: the samples of
//! `t_k` give the command held over `[t_k, t_k + T)`): `u_k = -K q_e,k - D ω_k` with
//! `q_e ≈ θ/2`, so per axis `u_k = -(K/2) θ_k - D ω_k`; with ζ, ωn: `K = 2 ωn² J_c`,
//! `D = 2 ζ ωn J_c` (J_c: the full scenario inertia). Broken at the plant input:
//! `L(z) = -u/e = z^{-n} [K/2, D, 0] (zI - Φ(T))⁻¹ (Γ(T-δ) + Φ(T-δ) Γ(δ) z⁻¹)`.
//!
//! # Closed forms (state `x = (θ, ω, a)`, `β = e^{-s/τ_a}`, `c = τ_a (1 - β)`)
//! Exact solution of the ODE over `s` with `e` constant:
//! `θ⁺ = θ + s ω + (τ_a s - τ_a c) a / J_p + (s²/2 - τ_a s + τ_a c) e / J_p`,
//! `ω⁺ = ω + c a / J_p + (s - c) e / J_p`, `a⁺ = β a + (1 - β) e`: this is `(Φ(s), Γ(s))`.
//! * (a) τ_a = 0, Δ = 0: `Γ(T) = [T²/2, T]/J_p`, i.e. Franklin–Powell–Workman's ZOH double
//!   integrator `θ/e = T²(z+1) / (2 J_p (z-1)²)`, `ω/e = T / (J_p (z-1))`;
//! * (b) Δ = nT: the factor `z^{-n}`;
//! * (c) 0 < δ < T (modified z-transform): within a period the held input of the previous
//!   period acts for δ, then the current one for T - δ: `Γ(T-δ) + Φ(T-δ)Γ(δ) z⁻¹`;
//! * (d) τ_a > 0: the three-state `(Φ, Γ)` above (upper triangular: `(zI - Φ)⁻¹` by back
//!   substitution).
//!
//! # Margins ([`margins`]), from any response `L(ω)` on `[ω_min, ω_max]`
//! Dense logarithmic grid, sign changes refined by bisection on the response itself:
//! crossovers `|L| = 1` (phase margin `180° + ∠L`, the smallest over the crossovers; delay
//! margin `PM/ω_c`), phase crossovers `Im L = 0` with `Re L < 0` (gain margins
//! `-20 log₁₀|L|`: high = smallest positive, low = the negative one closest to 0; the end
//! point counts, e.g. ω = π/T where L is real), `‖S‖∞` and `‖T‖∞` (`S = 1/(1+L)`,
//! `T = L/(1+L)`) refined by golden section, and the balanced (skew σ = 0) disk margin of
//! Seiler, Packard & Gahinet, "An introduction to disk margins", IEEE CSM 2020:
//! `α = 1/‖S + (σ-1)/2‖∞ = 1/‖S - 1/2‖∞ = min_ω 2|1+L|/|1-L|`, disk gain margin
//! `(2+α)/(2-α)` (∞ for α ≥ 2), disk phase margin `2 atan(α/2)`.

use core::ops::{Add, Div, Mul, Sub};

/// A complex number (just what the reference needs; no dependency).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct C {
    pub re: f64,
    pub im: f64,
}

impl C {
    pub const fn new(re: f64, im: f64) -> Self {
        C { re, im }
    }
    pub fn from_polar(r: f64, theta: f64) -> Self {
        C::new(r * theta.cos(), r * theta.sin())
    }
    pub fn norm(self) -> f64 {
        self.re.hypot(self.im)
    }
    pub fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
    pub fn inv(self) -> Self {
        let d = self.re * self.re + self.im * self.im;
        C::new(self.re / d, -self.im / d)
    }
    pub fn powu(self, n: u32) -> Self {
        (0..n).fold(C::new(1.0, 0.0), |acc, _| acc * self)
    }
}

impl Add for C {
    type Output = C;
    fn add(self, o: C) -> C {
        C::new(self.re + o.re, self.im + o.im)
    }
}
impl Sub for C {
    type Output = C;
    fn sub(self, o: C) -> C {
        C::new(self.re - o.re, self.im - o.im)
    }
}
impl Mul for C {
    type Output = C;
    fn mul(self, o: C) -> C {
        C::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
}
impl Div for C {
    type Output = C;
    #[allow(clippy::suspicious_arithmetic_impl)] // division as multiplication by the inverse
    fn div(self, o: C) -> C {
        self * o.inv()
    }
}
impl Add<f64> for C {
    type Output = C;
    fn add(self, o: f64) -> C {
        C::new(self.re + o, self.im)
    }
}
impl Sub<f64> for C {
    type Output = C;
    fn sub(self, o: f64) -> C {
        C::new(self.re - o, self.im)
    }
}
impl Mul<f64> for C {
    type Output = C;
    fn mul(self, o: f64) -> C {
        C::new(self.re * o, self.im * o)
    }
}
impl Div<f64> for C {
    type Output = C;
    fn div(self, o: f64) -> C {
        C::new(self.re / o, self.im / o)
    }
}

/// `n × n` matrix product.
fn matmul(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    (0..n).map(|i| (0..n).map(|j| (0..n).map(|k| a[i][k] * b[k][j]).sum()).collect()).collect()
}

/// Spectral radius as `lim ‖Aᴺ‖^{1/N}`, N = 2⁴⁰ by repeated squaring (rescaled at each
/// squaring; the polynomial factor of a defective eigenvalue costs ≈ ln(N)/N ≈ 3e-11).
fn spectral_radius(a: &[Vec<f64>]) -> f64 {
    let mut b = a.to_vec();
    let mut log_scale = 0.0; // ln of the factor taken out of A^(2^k)
    let squarings = 40;
    for _ in 0..squarings {
        b = matmul(&b, &b);
        log_scale *= 2.0;
        let s = b.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        if s == 0.0 {
            return 0.0;
        }
        b.iter_mut().flatten().for_each(|x| *x /= s);
        log_scale += s.ln();
    }
    let rest = b.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    ((log_scale + rest.ln()) / 2f64.powi(squarings)).exp()
}

/// One axis of the loop (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLoop {
    /// `J_p`, the plant's inertia about the axis, kg m².
    pub plant_inertia_kgm2: f64,
    /// `K` of `u = -K q_e - D ω`, N m (per unit of `q_e`).
    pub k_nm: f64,
    /// `D`, N m s.
    pub d_nms: f64,
    /// `T`, the control period, s.
    pub period_s: f64,
    /// `Δ`, pure delay of the plant input, s.
    pub delay_s: f64,
    /// `τ_a`, first-order lag of the plant input, s (0: none).
    pub lag_s: f64,
}

impl AxisLoop {
    /// The paper-000 tuning `K = 2 ωn² J_c`, `D = 2 ζ ωn J_c`, no delay, no lag.
    pub fn quaternion_feedback(controller_inertia: f64, plant_inertia: f64, wn: f64, zeta: f64, period_s: f64) -> Self {
        AxisLoop {
            plant_inertia_kgm2: plant_inertia,
            k_nm: 2.0 * wn * wn * controller_inertia,
            d_nms: 2.0 * zeta * wn * controller_inertia,
            period_s,
            delay_s: 0.0,
            lag_s: 0.0,
        }
    }

    /// `Δ = nT + δ`: `(n, δ)` (a δ within 1e-12 T of a whole period counts as 0).
    pub fn delay_split(&self) -> (usize, f64) {
        let t = self.period_s;
        let r = self.delay_s / t;
        let n = (r + 1e-12).floor().max(0.0);
        let delta = ((r - n) * t).max(0.0);
        (n as usize, if delta < 1e-12 * t { 0.0 } else { delta })
    }

    /// `(Φ(s), Γ(s))`: exact transition over `s` of `x = (θ, ω, a)` with the input held.
    pub fn transition(&self, s: f64) -> ([[f64; 3]; 3], [f64; 3]) {
        let (j, tau) = (self.plant_inertia_kgm2, self.lag_s);
        let beta = if tau > 0.0 { (-s / tau).exp() } else { 0.0 };
        let c = tau * (1.0 - beta);
        let phi = [[1.0, s, (tau * s - tau * c) / j], [0.0, 1.0, c / j], [0.0, 0.0, beta]];
        let gamma = [(0.5 * s * s - tau * s + tau * c) / j, (s - c) / j, 1.0 - beta];
        (phi, gamma)
    }

    /// The input matrices of the period: `Γ1 = Γ(T-δ)` (current input), `Γ0 = Φ(T-δ)Γ(δ)`
    /// (previous input).
    fn input_matrices(&self, delta: f64) -> ([f64; 3], [f64; 3]) {
        let (phi_r, gamma1) = self.transition(self.period_s - delta);
        let (_, g_d) = self.transition(delta);
        let mut gamma0 = [0.0; 3];
        for (i, g) in gamma0.iter_mut().enumerate() {
            *g = (0..3).map(|k| phi_r[i][k] * g_d[k]).sum();
        }
        (gamma1, gamma0)
    }

    /// `L(e^{jωT})` (module doc).
    pub fn response(&self, w: f64) -> C {
        let t = self.period_s;
        let z = C::from_polar(1.0, w * t);
        let zinv = z.inv();
        let (n, delta) = self.delay_split();
        let (phi, _) = self.transition(t);
        let (g1, g0) = self.input_matrices(delta);
        let g: Vec<C> = (0..3).map(|i| C::new(g1[i], 0.0) + zinv * g0[i]).collect();
        // (zI - Φ) x = g, Φ upper triangular with diagonal (1, 1, β).
        let x3 = g[2] / (z - phi[2][2]);
        let x2 = (g[1] + x3 * phi[1][2]) / (z - 1.0);
        let x1 = (g[0] + x2 * phi[0][1] + x3 * phi[0][2]) / (z - 1.0);
        (x1 * (0.5 * self.k_nm) + x2 * self.d_nms) * zinv.powu(n as u32)
    }

    /// Continuous-time loop without sampling: `e^{-sΔ} (K/2 + D s) / (J_p s² (1 + τ_a s))`.
    pub fn continuous_response(&self, w: f64) -> C {
        let s = C::new(0.0, w);
        let num = C::new(0.5 * self.k_nm, self.d_nms * w);
        let den = s * s * self.plant_inertia_kgm2 * (s * self.lag_s + 1.0);
        num / den * C::from_polar(1.0, -w * self.delay_s)
    }

    /// Spectral radius of the closed loop `e_k = u_k` (state `x` and the delayed inputs):
    /// below 1 iff the sampled loop is stable.
    pub fn closed_loop_spectral_radius(&self) -> f64 {
        let (n, delta) = self.delay_split();
        let (phi, _) = self.transition(self.period_s);
        let (g1, g0) = self.input_matrices(delta);
        let m = n + usize::from(delta > 0.0); // past inputs held: e_{k-1} … e_{k-m}
        let dim = 3 + m;
        let c = [0.5 * self.k_nm, self.d_nms, 0.0];
        // Row vector (over the state) of the input e_{k-i} (zero past the buffer: unused).
        let input = |i: usize| {
            let mut r = vec![0.0; dim];
            if i == 0 {
                r[..3].iter_mut().zip(c).for_each(|(r, c)| *r = -c);
            } else if 3 + i - 1 < dim {
                r[3 + i - 1] = 1.0;
            }
            r
        };
        let mut a = vec![vec![0.0; dim]; dim];
        let (e_now, e_prev) = (input(n), input(n + 1));
        for i in 0..3 {
            for k in 0..3 {
                a[i][k] += phi[i][k];
            }
            for k in 0..dim {
                a[i][k] += g1[i] * e_now[k] + if delta > 0.0 { g0[i] * e_prev[k] } else { 0.0 };
            }
        }
        for b in 0..m {
            a[3 + b] = input(b);
        }
        spectral_radius(&a)
    }
}

/// A gain margin at a phase crossover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainCrossing {
    pub frequency_rad_s: f64,
    /// `-20 log₁₀|L|` there.
    pub gain_margin_db: f64,
}

/// Balanced disk margin (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskMargin {
    pub alpha: f64,
    /// `20 log₁₀((2+α)/(2-α))`, infinite for α ≥ 2.
    pub gain_margin_db: f64,
    pub phase_margin_deg: f64,
    pub frequency_rad_s: f64,
}

/// Margins of one loop (module doc); `None` where one does not exist.
#[derive(Clone, Debug, PartialEq)]
pub struct Margins {
    pub crossover_rad_s: Option<f64>,
    pub phase_margin_deg: Option<f64>,
    pub delay_margin_s: Option<f64>,
    pub gain_crossings: Vec<GainCrossing>,
    pub gain_margin_low_db: Option<f64>,
    pub gain_margin_high_db: Option<f64>,
    pub sensitivity_peak_db: f64,
    pub sensitivity_peak_rad_s: f64,
    pub complementary_peak_db: f64,
    pub complementary_peak_rad_s: f64,
    pub disk: DiskMargin,
}

/// Logarithmic grid of `n ≥ 2` points from `a` to `b`, both included.
pub fn log_grid(a: f64, b: f64, n: usize) -> Vec<f64> {
    let (la, lb) = (a.ln(), b.ln());
    (0..n).map(|i| if i + 1 == n { b } else { (la + (lb - la) * i as f64 / (n - 1) as f64).exp() }).collect()
}

/// Root of `f` in `[a, b]` (`f(a)`, `f(b)` of opposite signs), bisection to 1e-13 relative.
fn bisect(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let fa0 = f(a);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if (b - a) <= 1e-13 * m.abs() {
            break;
        }
        if (f(m) > 0.0) == (fa0 > 0.0) {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Largest (`max`) or smallest value of `f` over the grid, refined by golden section between
/// the neighbours of the best grid point: `(ω, f(ω))`.
fn extremum(f: &dyn Fn(f64) -> f64, grid: &[f64], max: bool) -> (f64, f64) {
    let sign = if max { 1.0 } else { -1.0 };
    let g = |w: f64| sign * f(w);
    let i = (0..grid.len()).max_by(|&i, &j| g(grid[i]).total_cmp(&g(grid[j]))).unwrap_or(0);
    let (mut a, mut b) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..100 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if g(c) > g(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let w = if g(0.5 * (a + b)) >= g(grid[i]) { 0.5 * (a + b) } else { grid[i] };
    (w, f(w))
}

/// `180° + ∠L`, wrapped to (-180°, 180°].
fn phase_margin_at(l: C) -> f64 {
    let pm = 180.0 + l.arg().to_degrees();
    if pm > 180.0 { pm - 360.0 } else { pm }
}

/// Every margin of the response `l` over `[w_min, w_max]` on a grid of `points` (module doc).
pub fn margins(l: &dyn Fn(f64) -> C, w_min: f64, w_max: f64, points: usize) -> Margins {
    let grid = log_grid(w_min, w_max, points.max(2));
    let lmag = |w: f64| l(w).norm().ln();
    let im = |w: f64| l(w).im;
    // Crossovers: the one of smallest phase margin.
    let mut best: Option<(f64, f64)> = None;
    let mut crossings = Vec::new();
    for p in grid.windows(2) {
        let (a, b) = (p[0], p[1]);
        if (lmag(a) > 0.0) != (lmag(b) > 0.0) {
            let wc = bisect(&lmag, a, b);
            let pm = phase_margin_at(l(wc));
            if best.is_none_or(|(_, p)| pm < p) {
                best = Some((wc, pm));
            }
        }
        let (la, lb) = (l(a), l(b));
        if (la.im > 0.0) != (lb.im > 0.0) && la.re < 0.0 && lb.re < 0.0 {
            let w = bisect(&im, a, b);
            crossings.push(GainCrossing { frequency_rad_s: w, gain_margin_db: -20.0 * l(w).norm().log10() });
        }
    }
    // The end point: L real and negative there (e.g. the Nyquist frequency).
    let end = l(w_max);
    if end.re < 0.0 && end.im.abs() <= 1e-9 * end.norm() {
        crossings.push(GainCrossing { frequency_rad_s: w_max, gain_margin_db: -20.0 * end.norm().log10() });
    }
    let high = crossings.iter().map(|c| c.gain_margin_db).filter(|g| *g > 0.0).reduce(f64::min);
    let low = crossings.iter().map(|c| c.gain_margin_db).filter(|g| *g < 0.0).reduce(f64::max);
    let s_mag = |w: f64| 1.0 / (l(w) + 1.0).norm();
    let t_mag = |w: f64| l(w).norm() / (l(w) + 1.0).norm();
    let (ws, s_peak) = extremum(&s_mag, &grid, true);
    let (wt, t_peak) = extremum(&t_mag, &grid, true);
    let disk_alpha = |w: f64| 2.0 * (l(w) + 1.0).norm() / (C::new(1.0, 0.0) - l(w)).norm();
    let (wd, alpha) = extremum(&disk_alpha, &grid, false);
    Margins {
        crossover_rad_s: best.map(|b| b.0),
        phase_margin_deg: best.map(|b| b.1),
        delay_margin_s: best.map(|(wc, pm)| pm.to_radians() / wc),
        gain_crossings: crossings,
        gain_margin_low_db: low,
        gain_margin_high_db: high,
        sensitivity_peak_db: 20.0 * s_peak.log10(),
        sensitivity_peak_rad_s: ws,
        complementary_peak_db: 20.0 * t_peak.log10(),
        complementary_peak_rad_s: wt,
        disk: disk_margin(alpha, wd),
    }
}

/// The balanced disk's gain and phase margins for `α` (module doc).
pub fn disk_margin(alpha: f64, frequency_rad_s: f64) -> DiskMargin {
    let gain_margin_db = if alpha < 2.0 { 20.0 * ((2.0 + alpha) / (2.0 - alpha)).log10() } else { f64::INFINITY };
    DiskMargin { alpha, gain_margin_db, phase_margin_deg: 2.0 * (0.5 * alpha).atan().to_degrees(), frequency_rad_s }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WN: f64 = 0.7;
    const ZETA: f64 = 0.47;

    fn paper000(period_s: f64) -> AxisLoop {
        AxisLoop::quaternion_feedback(3.1, 3.1, WN, ZETA, period_s)
    }

    fn nyquist(l: &AxisLoop) -> f64 {
        std::f64::consts::PI / l.period_s
    }

    /// Continuous limit: `J s² + D s + K/2` with `K/2 = ωn² J`, `D = 2ζωn J`:
    /// `|L| = 1` at `ωc² = ωn² (2ζ² + √(4ζ⁴ + 1))`, `PM = atan(2ζ ωc/ωn)`; the ZOH takes
    /// `ωc T/2` more phase at small T.
    #[test]
    fn continuous_limit_of_the_pd_double_integrator() {
        let wc = WN * (2.0 * ZETA.powi(2) + (4.0 * ZETA.powi(4) + 1.0).sqrt()).sqrt();
        let pm = (2.0 * ZETA * wc / WN).atan().to_degrees();
        let l = paper000(1e-4);
        let m = margins(&|w| l.response(w), 1e-3, nyquist(&l), 20_000);
        let (mc, mpm) = (m.crossover_rad_s.unwrap(), m.phase_margin_deg.unwrap());
        let pm_zoh = pm - (0.5 * wc * l.period_s).to_degrees();
        eprintln!("continuous limit: wc {mc} vs {wc}, PM {mpm} vs {pm_zoh} ({pm} without the hold)");
        assert!((mc / wc - 1.0).abs() < 1e-6, "{mc} {wc}");
        assert!((mpm - pm_zoh).abs() < 1e-4, "{mpm} {pm_zoh}");
        assert!((m.delay_margin_s.unwrap() - mpm.to_radians() / mc).abs() < 1e-12);
        // The sampled response tends to the continuous one.
        for w in [0.01, 0.3, 1.0, 10.0] {
            let (d, c) = (l.response(w), l.continuous_response(w));
            assert!(((d - c) / c).norm() < 1e-3 * w.max(1.0), "{w}: {d:?} {c:?}");
        }
    }

    /// (a) Franklin–Powell–Workman: `θ/e = T²(z+1)/(2J(z-1)²)`, `ω/e = T/(J(z-1))`.
    #[test]
    fn zoh_double_integrator_matches_the_textbook_form() {
        let l = paper000(0.1);
        let t = l.period_s;
        for w in [0.05, 0.7, 3.0, 31.0] {
            let z = C::from_polar(1.0, w * t);
            let one = C::new(1.0, 0.0);
            let th = (z + one) * (t * t) / ((z - one) * (z - one) * (2.0 * 3.1));
            let om = C::new(t / 3.1, 0.0) / (z - one);
            let want = th * (0.5 * l.k_nm) + om * l.d_nms;
            assert!(((l.response(w) - want) / want).norm() < 1e-12, "{w}");
        }
        // At Nyquist L = -D T/(2 J_p) (θ/e vanishes): the phase crossover there.
        let m = margins(&|w| l.response(w), 1e-3, nyquist(&l), 5000);
        let last = m.gain_crossings.last().unwrap();
        let gm = -20.0 * (l.d_nms * t / (2.0 * 3.1)).log10();
        assert!((last.gain_margin_db - gm).abs() < 1e-9 && last.frequency_rad_s == nyquist(&l));
        assert!((m.gain_margin_high_db.unwrap() - gm).abs() < 1e-9);
    }

    /// (b) n whole samples of delay: same |L|, phase exactly `-ωTn` more.
    #[test]
    fn whole_sample_delay_adds_minus_omega_t_n() {
        let l0 = paper000(0.1);
        for n in 1..4 {
            let l = AxisLoop { delay_s: n as f64 * 0.1, ..l0 };
            for w in [0.05, 0.7, 3.0, 30.0] {
                let r = l.response(w) / l0.response(w);
                let want = C::from_polar(1.0, -w * 0.1 * n as f64);
                assert!((r - want).norm() < 1e-12, "n {n} w {w}: {r:?}");
            }
        }
    }

    /// (c) the fractional delay is continuous at both ends (δ → 0, δ → T) and, at low
    /// frequency, is the continuous delay `e^{-jωΔ}`.
    #[test]
    fn fractional_delay_is_continuous_and_a_delay() {
        let l0 = paper000(0.1);
        let at = |d: f64| AxisLoop { delay_s: d, ..l0 };
        for w in [0.05, 0.7, 3.0] {
            let near = |a: C, b: C| ((a - b) / b).norm();
            assert!(near(at(1e-9).response(w), l0.response(w)) < 1e-6);
            assert!(near(at(0.1 - 1e-9).response(w), at(0.1).response(w)) < 1e-6);
            assert!(near(at(0.15 - 1e-9).response(w), at(0.15).response(w)) < 1e-6);
        }
        let (l, w) = (at(0.037), 0.01);
        let r = l.response(w) / l0.response(w);
        assert!((r.arg() + w * 0.037).abs() < 1e-6 && (r.norm() - 1.0).abs() < 1e-6, "{r:?}");
    }

    /// (d) the lag's closed-form transition against a fine RK4 integration of the ODE, and
    /// τ_a → 0 gives (a).
    #[test]
    fn lag_transition_matches_the_ode() {
        let l = AxisLoop { lag_s: 0.07, ..paper000(0.1) };
        let (phi, gamma) = l.transition(0.1);
        let f = |x: [f64; 3], e: f64| [x[1], x[2] / 3.1, (e - x[2]) / 0.07];
        let rk4 = |x0: [f64; 3], e: f64| {
            let (mut x, h) = (x0, 0.1 / 2000.0);
            let add = |x: [f64; 3], d: [f64; 3], s: f64| [x[0] + s * d[0], x[1] + s * d[1], x[2] + s * d[2]];
            for _ in 0..2000 {
                let k1 = f(x, e);
                let k2 = f(add(x, k1, h / 2.0), e);
                let k3 = f(add(x, k2, h / 2.0), e);
                let k4 = f(add(x, k3, h), e);
                x = add(add(add(add(x, k1, h / 6.0), k2, h / 3.0), k3, h / 3.0), k4, h / 6.0);
            }
            x
        };
        for (col, x0) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].into_iter().enumerate() {
            let x = rk4(x0, 0.0);
            (0..3).for_each(|i| assert!((x[i] - phi[i][col]).abs() < 1e-12, "Φ[{i}][{col}]"));
        }
        let x = rk4([0.0; 3], 1.0);
        (0..3).for_each(|i| assert!((x[i] - gamma[i]).abs() < 1e-12, "Γ[{i}]"));
        let fast = AxisLoop { lag_s: 1e-9, ..paper000(0.1) };
        assert!(((fast.response(1.0) - paper000(0.1).response(1.0)) / paper000(0.1).response(1.0)).norm() < 1e-6);
    }

    /// Disk margins by hand: a constant `L = -1/2` is destabilised by a gain of exactly 2:
    /// α = 2|1+L|/|1-L| = 2/3, disk gain margin 20 log₁₀ 2; `L = e^{-j120°}` (|L| = 1, PM 60°):
    /// α = 2 cot(60°) = 2 tan(30°), disk phase margin 60°; an integrator `a/s`: α = 2, 90°.
    #[test]
    fn disk_margin_hand_cases() {
        let m = margins(&|_| C::new(-0.5, 0.0), 0.1, 10.0, 50);
        assert!((m.disk.alpha - 2.0 / 3.0).abs() < 1e-12);
        assert!((m.disk.gain_margin_db - 20.0 * 2f64.log10()).abs() < 1e-12);
        let m = margins(&|_| C::from_polar(1.0, -120f64.to_radians()), 0.1, 10.0, 50);
        assert!((m.disk.alpha - 2.0 * 30f64.to_radians().tan()).abs() < 1e-12);
        assert!((m.disk.phase_margin_deg - 60.0).abs() < 1e-9);
        let m = margins(&|w| C::new(0.0, -3.0 / w), 0.1, 10.0, 200);
        assert!((m.disk.alpha - 2.0).abs() < 1e-12 && m.disk.gain_margin_db.is_infinite());
        assert!((m.disk.phase_margin_deg - 90.0).abs() < 1e-9);
        assert!((m.phase_margin_deg.unwrap() - 90.0).abs() < 1e-9 && (m.crossover_rad_s.unwrap() - 3.0).abs() < 1e-9);
    }

    /// Stability: the nominal loop is stable; gains × 10 with a delay are not, and the phase
    /// margin says so (negative).
    #[test]
    fn gains_times_ten_with_a_delay_is_unstable() {
        let l = paper000(0.1);
        assert!(l.closed_loop_spectral_radius() < 1.0);
        let hot = AxisLoop { k_nm: 10.0 * l.k_nm, d_nms: 10.0 * l.d_nms, delay_s: 0.2, ..l };
        assert!(hot.closed_loop_spectral_radius() > 1.0, "{}", hot.closed_loop_spectral_radius());
        let m = margins(&|w| hot.response(w), 1e-3, nyquist(&hot), 5000);
        assert!(m.phase_margin_deg.unwrap() < 0.0, "{m:?}");
        // Δ = T/2 with the lag: closed-loop matrix and Nyquist agree on the boundary: scaling
        // the gains by the gain margin puts a pole on the unit circle.
        let l = AxisLoop { delay_s: 0.05, lag_s: 0.05, ..paper000(0.1) };
        let m = margins(&|w| l.response(w), 1e-3, nyquist(&l), 5000);
        let k = 10f64.powf(m.gain_margin_high_db.unwrap() / 20.0);
        let at = |f: f64| AxisLoop { k_nm: f * l.k_nm, d_nms: f * l.d_nms, ..l }.closed_loop_spectral_radius();
        assert!(at(k * 0.999) < 1.0 && at(k * 1.001) > 1.0, "{} {}", at(k * 0.999), at(k * 1.001));
    }
}
