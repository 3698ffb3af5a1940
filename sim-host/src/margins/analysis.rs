//! Stability margins from a measured 3×3 loop response: pure functions on complex arrays,
//! no simulation (docs/margins.md, "Definitions").
//!
//! The loop is broken at all three inputs at once: `L(ω)` (output axis i, input axis j).
//! Loop-at-a-time margins of axis i use the SISO loop seen at input i with the two other
//! loops closed, `l_i = 1 / S_ii − 1` with `S = (I + L)⁻¹` (closing loop i on `l_i` gives
//! the closed loop whose sensitivity element is `S_ii`; Skogestad & Postlethwaite 2005,
//! §9.4 / Seiler, Packard & Gahinet 2020, "loop-at-a-time"). Classical margins of `l_i`
//! (crossovers, phase crossings, delay margin), the peaks of `s_i = 1/(1 + l_i)` and
//! `t_i = 1 − s_i`, the balanced (skew σ = 0) disk margin `α = 1/‖s − 1/2‖∞` (Seiler et al.
//! 2020, eq. 8 with σ = 0) and the multiloop disk margin `α = 1/max_ω μ_Δ(S − I/2)` for a
//! diagonal complex Δ, with μ bounded from above by D-scaling (`min_D σ̄(D M D⁻¹)`).
//! Crossings are located by linear interpolation in `ln ω` between the two measured
//! frequencies that bracket them (the experiments refine those brackets first).

use nalgebra::{Complex, Matrix3};

pub type C64 = Complex<f64>;
/// A 3×3 complex matrix: `m[i][j]`, output axis i, input axis j.
pub type Cmat = [[C64; 3]; 3];

fn to_na(m: &Cmat) -> Matrix3<C64> {
    Matrix3::from_fn(|i, j| m[i][j])
}

fn from_na(m: &Matrix3<C64>) -> Cmat {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// `S = (I + L)⁻¹`; `None` when `I + L` is singular (a closed-loop pole on the unit circle
/// at this frequency).
pub fn sensitivity(l: &Cmat) -> Option<Cmat> {
    (Matrix3::identity() + to_na(l)).try_inverse().map(|s| from_na(&s))
}

/// `L = −U E⁻¹` from the loop outputs `U` and total inputs `E` of three experiments (column
/// j: the experiment that excites axis j); `None` when `E` is singular.
pub fn loop_from_columns(u: &Cmat, e: &Cmat) -> Option<Cmat> {
    to_na(e).try_inverse().map(|ei| from_na(&(-(to_na(u) * ei))))
}

/// Loop-at-a-time loop of axis i: `l_i = 1/S_ii − 1`.
pub fn loop_at_a_time(s: &Cmat, i: usize) -> C64 {
    C64::new(1.0, 0.0) / s[i][i] - C64::new(1.0, 0.0)
}

/// Largest singular value of a 3×3 complex matrix.
pub fn max_singular_value(m: &Cmat) -> f64 {
    to_na(m).singular_values().max()
}

/// Upper bound of the structured singular value of `m` for a diagonal complex uncertainty:
/// `min over D = diag(1, d2, d3) > 0 of σ̄(D m D⁻¹)` (Skogestad & Postlethwaite 2005, §8.8.3;
/// exact for 3 blocks or fewer is not guaranteed, it is an upper bound). The minimum is
/// searched by cyclic golden-section steps on `ln d2`, `ln d3` (σ̄ of `D m D⁻¹` is
/// quasi-convex in `ln D`). Returns (bound, d2, d3).
pub fn mu_upper_bound(m: &Cmat) -> (f64, f64, f64) {
    let scaled = |ld: [f64; 2]| {
        let d = [1.0, ld[0].exp(), ld[1].exp()];
        let dm: Cmat = std::array::from_fn(|i| std::array::from_fn(|j| m[i][j] * (d[i] / d[j])));
        max_singular_value(&dm)
    };
    let mut ld = [0.0f64; 2];
    let mut best = scaled(ld);
    for _sweep in 0..12 {
        let before = best;
        for c in 0..2 {
            let (lo, hi) = (ld[c] - 8.0, ld[c] + 8.0);
            let x = golden_min(lo, hi, 60, |x| {
                let mut t = ld;
                t[c] = x;
                scaled(t)
            });
            let mut t = ld;
            t[c] = x;
            let v = scaled(t);
            if v < best {
                best = v;
                ld = t;
            }
        }
        if before - best <= 1e-12 * before {
            break;
        }
    }
    (best, ld[0].exp(), ld[1].exp())
}

/// The minimiser of a unimodal `f` on `[a, b]` by golden-section search.
fn golden_min(mut a: f64, mut b: f64, iters: usize, f: impl Fn(f64) -> f64) -> f64 {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iters {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// Principal phase in degrees, (−180, 180].
fn phase_deg(z: C64) -> f64 {
    z.arg().to_degrees()
}

/// Wraps an angle in degrees into (−180, 180].
fn wrap_deg(a: f64) -> f64 {
    let w = a.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// A point between measured frequencies `k` and `k + 1`: fraction `f` of the way in `ln ω`.
fn interpolate(w: &[f64], l: &[C64], k: usize, f: f64) -> (f64, C64) {
    let lw = w[k].ln() + f * (w[k + 1].ln() - w[k].ln());
    (lw.exp(), l[k] + (l[k + 1] - l[k]) * f)
}

/// Where a sampled function crosses zero between consecutive samples: (index k, fraction
/// in [0, 1]) of each sign change.
pub fn zero_crossings(g: &[f64]) -> Vec<(usize, f64)> {
    let mut out = Vec::new();
    for k in 0..g.len().saturating_sub(1) {
        let (a, b) = (g[k], g[k + 1]);
        if !(a.is_finite() && b.is_finite()) {
            continue;
        }
        if a == 0.0 {
            out.push((k, 0.0));
        } else if a * b < 0.0 {
            out.push((k, a / (a - b)));
        }
    }
    if let Some(&last) = g.last()
        && last == 0.0
        && g.len() >= 2
    {
        out.push((g.len() - 2, 1.0));
    }
    out
}

/// A gain crossover of one loop: `|l| = 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossover {
    pub frequency_rad_s: f64,
    /// `180° + arg l(ωc)`, wrapped into (−180°, 180°].
    pub phase_margin_deg: f64,
}

/// A phase crossing of one loop: `arg l = −180°`, with its gain margin `−20 log10 |l|`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseCrossing {
    pub frequency_rad_s: f64,
    pub gain_margin_db: f64,
}

/// Gain crossovers of a sampled SISO loop (`|l| − 1` changes sign, located in `ln |l|`).
pub fn crossovers(w: &[f64], l: &[C64]) -> Vec<Crossover> {
    let g: Vec<f64> = l.iter().map(|z| z.norm().ln()).collect();
    zero_crossings(&g)
        .into_iter()
        .map(|(k, f)| {
            let (wc, lc) = interpolate(w, l, k, f);
            Crossover { frequency_rad_s: wc, phase_margin_deg: wrap_deg(phase_deg(lc) + 180.0) }
        })
        .collect()
}

/// Phase crossings of a sampled SISO loop: `Im l` changes sign where `Re l < 0`. A
/// discrete-time loop is real at the Nyquist frequency `nyquist_rad_s`: when the last
/// sample is there with `Re l < 0`, that is a phase crossing too (the Nyquist curve and its
/// mirror image meet on the negative real axis).
pub fn phase_crossings(w: &[f64], l: &[C64], nyquist_rad_s: f64) -> Vec<PhaseCrossing> {
    // Sign of the phase's sine, normalised so that a large |l| does not dominate.
    let g: Vec<f64> = l.iter().map(|z| z.im / z.norm()).collect();
    let crossing = |wp: f64, lp: C64| PhaseCrossing { frequency_rad_s: wp, gain_margin_db: -20.0 * lp.norm().log10() };
    let mut out: Vec<PhaseCrossing> = zero_crossings(&g)
        .into_iter()
        .filter_map(|(k, f)| {
            let (wp, lp) = interpolate(w, l, k, f);
            (lp.re < 0.0).then(|| crossing(wp, lp))
        })
        .collect();
    if let (Some(&wn), Some(&ln)) = (w.last(), l.last())
        && (wn / nyquist_rad_s - 1.0).abs() < 1e-9
        && ln.re < 0.0
        && out.last().is_none_or(|p| (p.frequency_rad_s / wn - 1.0).abs() > 1e-3)
    {
        out.push(crossing(wn, C64::new(ln.re, 0.0)));
    }
    out
}

/// A disk margin (balanced, σ = 0): `α`, the gain and phase variations it covers, and where
/// the peak occurs.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DiskMargin {
    pub alpha: f64,
    /// `20 log10((2 + α)/(2 − α))`; `None` (infinite) when α ≥ 2.
    pub gain_margin_db: Option<f64>,
    /// `2 atan(α/2)`, degrees.
    pub phase_margin_deg: f64,
    pub frequency_rad_s: f64,
}

impl DiskMargin {
    /// The disk margin of `α` (Seiler, Packard & Gahinet 2020, eqs. 9-10 with σ = 0).
    pub fn from_alpha(alpha: f64, frequency_rad_s: f64) -> Self {
        let gain = (alpha < 2.0).then(|| 20.0 * ((2.0 + alpha) / (2.0 - alpha)).log10());
        Self { alpha, gain_margin_db: gain, phase_margin_deg: 2.0 * (alpha / 2.0).atan().to_degrees(), frequency_rad_s }
    }
}

/// The peak of `y` over the samples: (value, frequency); NaN samples ignored.
fn peak(w: &[f64], y: impl Iterator<Item = f64>) -> (f64, f64) {
    w.iter()
        .zip(y)
        .filter(|(_, v)| v.is_finite())
        .fold((f64::NAN, f64::NAN), |(bv, bw), (w, v)| if bv.is_nan() || v > bv { (v, *w) } else { (bv, bw) })
}

/// Every figure of one axis (loop at a time).
#[derive(Clone, Debug, PartialEq)]
pub struct AxisMargins {
    pub crossovers: Vec<Crossover>,
    pub phase_crossings: Vec<PhaseCrossing>,
    /// `max |s|`, dB, and its frequency.
    pub sensitivity_peak: (f64, f64),
    /// `max |t|`, dB, and its frequency.
    pub complementary_peak: (f64, f64),
    pub disk: DiskMargin,
}

impl AxisMargins {
    /// The crossover with the smallest phase margin.
    pub fn critical_crossover(&self) -> Option<Crossover> {
        self.crossovers.iter().copied().min_by(|a, b| a.phase_margin_deg.total_cmp(&b.phase_margin_deg))
    }

    /// The smallest delay margin over the crossovers, `PM / ωc` (s): the pure delay that
    /// brings the phase margin to zero at that crossover.
    pub fn delay_margin_s(&self) -> Option<f64> {
        self.crossovers
            .iter()
            .map(|c| c.phase_margin_deg.to_radians() / c.frequency_rad_s)
            .min_by(|a, b| a.total_cmp(b))
    }

    /// The largest gain reduction the loop tolerates (dB, < 0): the phase crossing with
    /// `|l| > 1` closest to 0 dB.
    pub fn gain_margin_low_db(&self) -> Option<f64> {
        self.phase_crossings.iter().map(|p| p.gain_margin_db).filter(|g| *g < 0.0).max_by(|a, b| a.total_cmp(b))
    }

    /// The largest gain increase the loop tolerates (dB, > 0).
    pub fn gain_margin_high_db(&self) -> Option<f64> {
        self.phase_crossings.iter().map(|p| p.gain_margin_db).filter(|g| *g >= 0.0).min_by(|a, b| a.total_cmp(b))
    }
}

/// Margins of axis i from the sampled sensitivities `s[k] = S(ω_k)`.
pub fn axis_margins(w: &[f64], s: &[Cmat], i: usize, nyquist_rad_s: f64) -> AxisMargins {
    let one = C64::new(1.0, 0.0);
    let si: Vec<C64> = s.iter().map(|m| m[i][i]).collect();
    let l: Vec<C64> = s.iter().map(|m| loop_at_a_time(m, i)).collect();
    let db = |x: f64| 20.0 * x.log10();
    let (sp, sw) = peak(w, si.iter().map(|z| z.norm()));
    let (tp, tw) = peak(w, si.iter().map(|z| (one - z).norm()));
    let (dp, dw) = peak(w, si.iter().map(|z| (z - 0.5).norm()));
    AxisMargins {
        crossovers: crossovers(w, &l),
        phase_crossings: phase_crossings(w, &l, nyquist_rad_s),
        sensitivity_peak: (db(sp), sw),
        complementary_peak: (db(tp), tw),
        disk: DiskMargin::from_alpha(1.0 / dp, dw),
    }
}

/// `S − I/2`, the matrix whose structured singular value gives the balanced multiloop disk
/// margin.
pub fn disk_matrix(s: &Cmat) -> Cmat {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| s[i][j] - if i == j { C64::new(0.5, 0.0) } else { C64::new(0.0, 0.0) })
    })
}

/// The multiloop disk margin: `α = 1 / max_ω μ(S − I/2)` with μ's D-scaled upper bound
/// (a guaranteed, possibly conservative, margin), and the unscaled `1 / max_ω σ̄(S − I/2)`.
pub fn multiloop_disk_margin(w: &[f64], s: &[Cmat]) -> (DiskMargin, DiskMargin) {
    let mu = peak(w, s.iter().map(|m| mu_upper_bound(&disk_matrix(m)).0));
    let sv = peak(w, s.iter().map(|m| max_singular_value(&disk_matrix(m))));
    (DiskMargin::from_alpha(1.0 / mu.0, mu.1), DiskMargin::from_alpha(1.0 / sv.0, sv.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> C64 {
        C64::new(re, im)
    }

    /// `L(s) = k e^{-sτ} / s` sampled: crossover at ω = k, phase margin 90° − kτ, phase
    /// crossing at ω = π/(2τ) with gain margin `20 log10(π/(2 k τ))`.
    fn integrator_with_delay(k: f64, tau: f64, w: &[f64]) -> Vec<C64> {
        w.iter().map(|&w| k * C64::new(0.0, -w * tau).exp() / C64::new(0.0, w)).collect()
    }

    fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64)).collect()
    }

    #[test]
    fn integrator_with_delay_gives_the_closed_form_margins() {
        let (k, tau) = (2.0, 0.1);
        let w = log_grid(0.01, 100.0, 4001);
        let l = integrator_with_delay(k, tau, &w);
        let xo = crossovers(&w, &l);
        assert_eq!(xo.len(), 1);
        assert!((xo[0].frequency_rad_s / k - 1.0).abs() < 1e-6, "{xo:?}");
        let pm = 90.0 - (k * tau).to_degrees();
        assert!((xo[0].phase_margin_deg - pm).abs() < 1e-3, "{xo:?} vs {pm}");
        let pc = phase_crossings(&w, &l, f64::INFINITY);
        let wp = std::f64::consts::FRAC_PI_2 / tau;
        let gm = 20.0 * (wp / k).log10();
        assert!((pc[0].frequency_rad_s / wp - 1.0).abs() < 1e-4, "{pc:?}");
        assert!((pc[0].gain_margin_db - gm).abs() < 1e-3, "{pc:?} vs {gm}");
    }

    #[test]
    fn disk_margin_of_a_first_order_loop_is_the_closed_form() {
        // l = k/s: s - 1/2 = (s - k)/(2(s + k)) has |.| = 1/2 at every ω, so α = 2
        // (infinite gain margin, 90° of disk phase margin).
        let w = log_grid(0.01, 100.0, 201);
        let s: Vec<Cmat> = w
            .iter()
            .map(|&w| {
                let l = c(0.0, -1.0 / w);
                let mut m = [[c(0.0, 0.0); 3]; 3];
                for i in 0..3 {
                    m[i][i] = c(1.0, 0.0) / (c(1.0, 0.0) + l);
                }
                m
            })
            .collect();
        let a = axis_margins(&w, &s, 0, f64::INFINITY);
        assert!((a.disk.alpha - 2.0).abs() < 1e-9, "{a:?}");
        // α = 2 to round-off: the gain margin is infinite, or nearly.
        assert!(a.disk.gain_margin_db.is_none_or(|g| g > 150.0), "{a:?}");
        assert!((a.disk.phase_margin_deg - 90.0).abs() < 1e-6);
        let (ml, unscaled) = multiloop_disk_margin(&w, &s);
        assert!((ml.alpha - 2.0).abs() < 1e-6 && (unscaled.alpha - 2.0).abs() < 1e-6, "{ml:?} {unscaled:?}");
    }

    #[test]
    fn disk_margin_alpha_maps_to_the_published_gain_and_phase() {
        // Seiler et al. 2020: α = 0.75 covers gains [0.45, 2.2] (6.9 dB) and ±41.1°.
        let d = DiskMargin::from_alpha(0.75, 1.0);
        assert!((d.gain_margin_db.unwrap() - 20.0 * (2.75f64 / 1.25).log10()).abs() < 1e-12);
        assert!((d.phase_margin_deg - 41.11209043).abs() < 1e-6, "{d:?}");
    }

    #[test]
    fn loop_at_a_time_of_a_diagonal_loop_is_its_diagonal_and_l_from_columns_inverts() {
        let l: Cmat = [
            [c(2.0, -1.0), c(0.0, 0.0), c(0.0, 0.0)],
            [c(0.0, 0.0), c(-0.5, 0.3), c(0.0, 0.0)],
            [c(0.0, 0.0), c(0.0, 0.0), c(0.1, 4.0)],
        ];
        let s = sensitivity(&l).unwrap();
        for i in 0..3 {
            assert!((loop_at_a_time(&s, i) - l[i][i]).norm() < 1e-12);
        }
        // U = -L E for any invertible E.
        let e: Cmat = [
            [c(1.0, 0.2), c(0.1, 0.0), c(0.0, -0.3)],
            [c(0.0, 0.1), c(0.9, 0.0), c(0.2, 0.0)],
            [c(0.3, 0.0), c(0.0, 0.0), c(1.1, 0.5)],
        ];
        let u = from_na(&(-(to_na(&l) * to_na(&e))));
        let back = loop_from_columns(&u, &e).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((back[i][j] - l[i][j]).norm() < 1e-12);
            }
        }
    }

    #[test]
    fn d_scaling_bounds_mu_of_a_badly_scaled_matrix_by_its_spectral_radius() {
        // A rank-one, badly scaled M = x yᴴ: μ for diagonal complex Δ equals Σ|x_i y_i|,
        // which D-scaling attains; the unscaled σ̄ = |x||y| is far larger.
        let x = [c(100.0, 0.0), c(0.01, 0.0), c(1.0, 0.0)];
        let y = [c(0.01, 0.0), c(100.0, 0.0), c(1.0, 0.0)];
        let m: Cmat = std::array::from_fn(|i| std::array::from_fn(|j| x[i] * y[j].conj()));
        let (mu, _, _) = mu_upper_bound(&m);
        let exact: f64 = (0..3).map(|i| (x[i] * y[i]).norm()).sum();
        assert!((mu / exact - 1.0).abs() < 1e-6, "{mu} vs {exact}");
        assert!(max_singular_value(&m) > 100.0 * mu);
    }

    #[test]
    fn an_unstable_loop_has_a_negative_phase_margin() {
        // k e^{-sτ}/s with kτ > π/2: the phase is below -180° at crossover.
        let w = log_grid(0.01, 100.0, 2001);
        let l = integrator_with_delay(20.0, 0.1, &w);
        let xo = crossovers(&w, &l);
        assert!(xo[0].phase_margin_deg < 0.0, "{xo:?}");
        let pc = phase_crossings(&w, &l, f64::INFINITY);
        assert!(pc[0].gain_margin_db < 0.0, "{pc:?}");
    }
}
