//! Algebraic Riccati equations and LQR gains.
//!
//! - CARE `AᵀX + XA − X G X + Q = 0`, `G = B R⁻¹ Bᵀ`; LQR gain `K = R⁻¹ BᵀX`, `u = −K x`
//!   (paper 002 eq 12, paper 003 eqs 24-25).
//! - DARE `X = AᵀXA − AᵀXB (R + BᵀXB)⁻¹ BᵀXA + Q`; gain `K = (R + BᵀXB)⁻¹ BᵀXA`.
//!
//! # Method: structure-preserving doubling (SDA) for both
//! DARE (Chu, Fan, Lin & Wang, Int. J. Control 77(8), 2004): with `E₀ = A`, `G₀ = G`,
//! `H₀ = Q` and `W = I + G_k H_k`,
//! `E ← E W⁻¹ E`, `G ← G + E W⁻¹ G Eᵀ`, `H ← H + Eᵀ H W⁻¹ E`.
//! `H_k` increases monotonically to the stabilising `X` with error `O(ρ^(2^k))`, ρ the
//! spectral radius of the optimal closed loop. `G_k`, `H_k` stay symmetric positive
//! semidefinite, `W` is always invertible (`GH` has real eigenvalues ≥ 0), and `A` may be
//! singular.
//!
//! CARE (Chu, Fan & Lin, Linear Algebra Appl. 396, 2005): the Cayley transform
//! `(𝓗 − γI)⁻¹(𝓗 + γI)` of the Hamiltonian `𝓗 = [[A, −G], [−Q, −Aᵀ]]` maps each stable
//! eigenvalue λ to `(λ+γ)/(λ−γ)`, inside the unit disc, and its standard symplectic form
//! (found by writing `M = P(𝓗+γI)`, `L = P(𝓗−γI)` with `M = [[E,0],[−H,I]]`,
//! `L = [[I,G],[0,Eᵀ]]`) gives, with `A_γ = A − γI`, `W_γ = A_γ + G A_γ⁻ᵀ Q`:
//! `E₀ = I + 2γ W_γ⁻¹`, `G₀ = 2γ W_γ⁻¹ G A_γ⁻ᵀ`, `H₀ = 2γ W_γ⁻ᵀ Q A_γ⁻¹`,
//! then the same doubling. γ is the geometric mean of the smallest and largest modulus of
//! the Hamiltonian's eigenvalues, which minimises `max |(λ+γ)/(λ−γ)|` for a real spectrum.
//!
//! Why SDA rather than the matrix-sign function or Newton–Kleinman: one kernel serves
//! CARE and DARE; it needs only n×n solves (the sign function inverts 2n×2n matrices and
//! then extracts X by least squares, losing accuracy when 𝓗 is badly scaled, as in the
//! paper-003 rig with weights 1e5..2e8); it needs no stabilising initial gain
//! (Newton–Kleinman does); it preserves symmetry and definiteness of the iterates; and it
//! converges quadratically from the start, so even a stiff spectrum (closed-loop poles
//! from 1e-2 to 5e2 rad/s on the rig) costs ~15 iterations. Each solve ends with at most
//! `newton_steps` Newton (defect-correction) steps on the Riccati residual, accepted only
//! when they reduce it.

use nalgebra::{Complex, DMatrix, SVD, Schur};
use std::fmt;

/// Which Riccati equation / stability region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Time {
    /// Stable means `Re λ < 0`.
    Continuous,
    /// Stable means `|λ| < 1`.
    Discrete,
}

#[derive(Clone, Debug, PartialEq)]
pub enum RiccatiError {
    /// Inconsistent matrix shapes; the text names the offending argument.
    Dimension(&'static str),
    /// An input contains NaN or ±inf.
    NonFinite,
    /// `R` is not symmetric positive definite (Cholesky failed).
    SingularR,
    /// `Q` is not symmetric positive semidefinite.
    QNotPsd,
    /// PBH test: `rank [A − λI, B] < n` for this eigenvalue `(re, im)` of A outside the
    /// open stability region.
    NotStabilisable { eigenvalue: (f64, f64) },
    /// A mode of A on the stability boundary is unobservable through Q: the Hamiltonian
    /// (symplectic) pencil has boundary eigenvalues and no stabilising solution exists.
    NoStabilisingSolution { eigenvalue: (f64, f64) },
    /// No shift γ made the Cayley transform well conditioned (CARE only).
    CayleyIllConditioned,
    /// The doubling did not converge in `max_iter` steps (or produced non-finite values).
    NoConvergence { iterations: usize, rel_change: f64 },
    /// Converged, but the closed loop is not stable (largest Re λ or |λ| given).
    NotStabilising { margin: f64 },
    /// Eigenvalue / SVD routine failed to converge.
    EigenFailure,
}

impl fmt::Display for RiccatiError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self:?}")
    }
}
impl std::error::Error for RiccatiError {}

pub type Result<T> = std::result::Result<T, RiccatiError>;

/// Solver settings.
#[derive(Clone, Copy, Debug)]
pub struct SdaOptions {
    /// Stop when `‖H_{k+1} − H_k‖_F ≤ tol ‖H_{k+1}‖_F` (or when that change, already
    /// below 1e-8, stops decreasing: rounding floor).
    pub tol: f64,
    /// Doubling steps allowed (2^64 Cayley/Stein steps: never the limit for a solvable
    /// problem; hit only when it is not).
    pub max_iter: usize,
    /// Newton refinement steps after the doubling (0 to disable).
    pub newton_steps: usize,
}

impl Default for SdaOptions {
    fn default() -> Self {
        Self { tol: 1e-14, max_iter: 64, newton_steps: 2 }
    }
}

/// Solution and diagnostics.
#[derive(Clone, Debug)]
pub struct RiccatiSolution {
    /// Stabilising, symmetric, positive semidefinite solution.
    pub x: DMatrix<f64>,
    /// Doubling steps used.
    pub iterations: usize,
    /// Cayley shift (CARE), 0 for DARE.
    pub gamma: f64,
    /// Newton steps accepted.
    pub newton_steps: usize,
    /// [`care_residual_rel`] / [`dare_residual_rel`] of `x`.
    pub residual_rel: f64,
    /// Largest Re λ (continuous) or |λ| (discrete) of the closed loop.
    pub closed_loop_margin: f64,
}

/// CARE solution with default options.
pub fn care(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    care_with(a, b, q, r, &SdaOptions::default()).map(|s| s.x)
}

/// DARE solution with default options.
pub fn dare(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    dare_with(a, b, q, r, &SdaOptions::default()).map(|s| s.x)
}

/// Continuous LQR: `(K, X)` with `K = R⁻¹BᵀX`.
pub fn lqr(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let x = care(a, b, q, r)?;
    Ok((lqr_gain(b, r, &x)?, x))
}

/// Discrete LQR: `(K, X)` with `K = (R + BᵀXB)⁻¹BᵀXA`.
pub fn dlqr(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let x = dare(a, b, q, r)?;
    Ok((dlqr_gain(a, b, r, &x)?, x))
}

/// `K = R⁻¹ BᵀX` (Cholesky solve).
pub fn lqr_gain(b: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let ch = r.clone().cholesky().ok_or(RiccatiError::SingularR)?;
    Ok(ch.solve(&(b.transpose() * x)))
}

/// `K = (R + BᵀXB)⁻¹ BᵀXA` (Cholesky solve).
pub fn dlqr_gain(a: &DMatrix<f64>, b: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let bx = b.transpose() * x;
    let s = sym(&(r + &bx * b));
    let ch = s.cholesky().ok_or(RiccatiError::SingularR)?;
    Ok(ch.solve(&(bx * a)))
}

/// CARE residual `AᵀX + XA − X G X + Q`.
pub fn care_residual(a: &DMatrix<f64>, g: &DMatrix<f64>, q: &DMatrix<f64>, x: &DMatrix<f64>) -> DMatrix<f64> {
    let atx = a.transpose() * x;
    &atx + atx.transpose() - x * g * x + q
}

/// Relative CARE residual `‖Res‖_F / (‖Q‖_F + 2‖AᵀX‖_F + ‖X G X‖_F)`: the residual
/// measured against the size of the terms that cancel in it (a backward-error-like
/// measure that stays meaningful when ‖X‖ is large, as for the rig's weights).
pub fn care_residual_rel(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Result<f64> {
    let g = gram(b, r)?;
    let res = care_residual(a, &g, q, x).norm();
    let den = q.norm() + 2.0 * (a.transpose() * x).norm() + (x * &g * x).norm();
    Ok(if den > 0.0 { res / den } else { res })
}

/// DARE residual `AᵀXA − X − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q` and the norms of its terms.
fn dare_residual_parts(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, f64)> {
    let bxa = b.transpose() * x * a;
    let s = sym(&(r + b.transpose() * x * b));
    let ch = s.cholesky().ok_or(RiccatiError::SingularR)?;
    let corr = bxa.transpose() * ch.solve(&bxa);
    let axa = a.transpose() * x * a;
    let den = q.norm() + x.norm() + axa.norm() + corr.norm();
    Ok((&axa - x - corr + q, den))
}

/// Relative DARE residual `‖Res‖_F / (‖Q‖_F + ‖X‖_F + ‖AᵀXA‖_F + ‖AᵀXB(R+BᵀXB)⁻¹BᵀXA‖_F)`.
pub fn dare_residual_rel(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Result<f64> {
    let (res, den) = dare_residual_parts(a, b, q, r, x)?;
    Ok(if den > 0.0 { res.norm() / den } else { res.norm() })
}

/// CARE by Cayley-transformed SDA (see module doc).
pub fn care_with(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    opt: &SdaOptions,
) -> Result<RiccatiSolution> {
    let g = checked_gram(a, b, q, r, Time::Continuous)?;
    let n = a.nrows();
    let eye = DMatrix::<f64>::identity(n, n);

    let mut gamma = choose_gamma(a, &g, q);
    let mut start = None;
    for _ in 0..8 {
        if let Some(s) = cayley_start(a, &g, q, gamma, &eye) {
            start = Some(s);
            break;
        }
        gamma *= 1.618; // γ hit (near) an eigenvalue of A or made W_γ singular: move it
    }
    let (e0, g0, h0) = start.ok_or(RiccatiError::CayleyIllConditioned)?;
    let (x, iterations) = doubling(e0, g0, h0, opt)?;

    // Newton refinement: (A − GX)ᵀΔ + Δ(A − GX) = −Res(X).
    let (x, res, accepted) = newton_refine(
        x,
        opt.newton_steps,
        |x| care_residual_rel(a, b, q, r, x),
        |x| {
            let phi = a - &g * x;
            let rhs = care_residual(a, &g, q, x);
            let op = eye.kronecker(&phi.transpose()) + phi.transpose().kronecker(&eye);
            Ok((op, rhs))
        },
    )?;

    let margin = spectral_margin(&(a - &g * &x), Time::Continuous)?;
    if margin >= 0.0 {
        return Err(RiccatiError::NotStabilising { margin });
    }
    Ok(RiccatiSolution { x, iterations, gamma, newton_steps: accepted, residual_rel: res, closed_loop_margin: margin })
}

/// DARE by SDA (see module doc).
pub fn dare_with(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    opt: &SdaOptions,
) -> Result<RiccatiSolution> {
    let g = checked_gram(a, b, q, r, Time::Discrete)?;
    let n = a.nrows();
    let (x, iterations) = doubling(a.clone(), g, q.clone(), opt)?;

    // Newton (Hewer) refinement: ΦᵀΔΦ − Δ = −Res(X), Φ = A − BK(X).
    let (x, res, accepted) = newton_refine(
        x,
        opt.newton_steps,
        |x| dare_residual_rel(a, b, q, r, x),
        |x| {
            let k = dlqr_gain(a, b, r, x)?;
            let phi = a - b * k;
            let (rhs, _) = dare_residual_parts(a, b, q, r, x)?;
            let op = phi.transpose().kronecker(&phi.transpose()) - DMatrix::<f64>::identity(n * n, n * n);
            Ok((op, rhs))
        },
    )?;
    let k = dlqr_gain(a, b, r, &x)?;
    let margin = spectral_margin(&(a - b * k), Time::Discrete)?;
    if margin >= 1.0 {
        return Err(RiccatiError::NotStabilising { margin });
    }
    Ok(RiccatiSolution {
        x,
        iterations,
        gamma: 0.0,
        newton_steps: accepted,
        residual_rel: res,
        closed_loop_margin: margin,
    })
}

/// The checks both solvers start with (shapes, finiteness, symmetry and definiteness, then the PBH
/// stabilisability/detectability test for `time`), and `G = B R⁻¹ Bᵀ`.
fn checked_gram(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    time: Time,
) -> Result<DMatrix<f64>> {
    check_inputs(a, b, q, r)?;
    check_pbh(a, b, q, time)?;
    gram(b, r)
}

/// Newton (defect-correction) refinement shared by CARE and DARE (module doc): up to
/// `steps` steps `X ← sym(X + Δ)`, `Δ` solving `op(X) vec Δ = vec Res(X)` where
/// `linearise(X)` returns `(op, Res)`; a step is accepted only if the relative residual
/// `residual_rel` falls (and stays finite), and the refinement stops at the first step
/// refused, unsolvable, or once the residual is below 1e-15. Returns `(X, residual,
/// steps accepted)`.
fn newton_refine(
    mut x: DMatrix<f64>,
    steps: usize,
    residual_rel: impl Fn(&DMatrix<f64>) -> Result<f64>,
    linearise: impl Fn(&DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)>,
) -> Result<(DMatrix<f64>, f64, usize)> {
    let mut res = residual_rel(&x)?;
    let mut accepted = 0;
    for _ in 0..steps {
        if res < 1e-15 {
            break;
        }
        let (op, rhs) = linearise(&x)?;
        let Some(d) = solve_vec(&op, &rhs) else { break };
        let xn = sym(&(&x + d));
        let rn = residual_rel(&xn)?;
        if rn.is_finite() && rn < res {
            x = xn;
            res = rn;
            accepted += 1;
        } else {
            break;
        }
    }
    Ok((x, res, accepted))
}

/// The SDA kernel; returns `(H_∞ = X, steps)`.
fn doubling(
    mut e: DMatrix<f64>,
    mut g: DMatrix<f64>,
    mut h: DMatrix<f64>,
    opt: &SdaOptions,
) -> Result<(DMatrix<f64>, usize)> {
    let n = e.nrows();
    let eye = DMatrix::<f64>::identity(n, n);
    let mut rel_change = f64::INFINITY;
    for k in 1..=opt.max_iter {
        let lu = (&eye + &g * &h).lu();
        let (Some(w_e), Some(w_g)) = (lu.solve(&e), lu.solve(&g)) else {
            return Err(RiccatiError::NoConvergence { iterations: k, rel_change });
        };
        let h_new = sym(&(&h + e.transpose() * &h * &w_e));
        g = sym(&(&g + &e * w_g * e.transpose()));
        e = &e * w_e;
        let dh = (&h_new - &h).norm();
        let hn = h_new.norm();
        h = h_new;
        let prev = rel_change;
        rel_change = if hn > 0.0 { dh / hn } else { dh };
        if !rel_change.is_finite() || !e.iter().all(|v| v.is_finite()) {
            return Err(RiccatiError::NoConvergence { iterations: k, rel_change });
        }
        // Converged, or stagnating at the rounding floor (the change stopped shrinking
        // quadratically once already below 1e-8): accept; the residual is reported.
        if dh <= opt.tol * hn || hn == 0.0 && dh == 0.0 || rel_change < 1e-8 && rel_change >= prev {
            return Ok((h, k));
        }
    }
    Err(RiccatiError::NoConvergence { iterations: opt.max_iter, rel_change })
}

/// `(E₀, G₀, H₀)` of the Cayley-transformed pencil, or `None` when `A_γ` or `W_γ` is
/// numerically singular (reciprocal condition below 1e-10).
fn cayley_start(
    a: &DMatrix<f64>,
    g: &DMatrix<f64>,
    q: &DMatrix<f64>,
    gamma: f64,
    eye: &DMatrix<f64>,
) -> Option<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
    let ag = a - eye * gamma;
    if rcond(&ag)? < 1e-10 {
        return None;
    }
    let ag_inv = ag.clone().try_inverse()?;
    let w = &ag + g * ag_inv.transpose() * q;
    if rcond(&w)? < 1e-10 {
        return None;
    }
    let w_inv = w.try_inverse()?;
    let two_g = 2.0 * gamma;
    let e0 = eye + &w_inv * two_g;
    let g0 = sym(&(&w_inv * g * ag_inv.transpose() * two_g));
    let h0 = sym(&(w_inv.transpose() * q * &ag_inv * two_g));
    Some((e0, g0, h0))
}

/// γ = √(min|λ| · max|λ|) over the Hamiltonian's eigenvalues (moduli below 1e-12 of the
/// largest ignored); falls back to a norm estimate if the eigenvalues are unavailable.
fn choose_gamma(a: &DMatrix<f64>, g: &DMatrix<f64>, q: &DMatrix<f64>) -> f64 {
    let n = a.nrows();
    let mut ham = DMatrix::<f64>::zeros(2 * n, 2 * n);
    ham.view_mut((0, 0), (n, n)).copy_from(a);
    ham.view_mut((0, n), (n, n)).copy_from(&(-g));
    ham.view_mut((n, 0), (n, n)).copy_from(&(-q));
    ham.view_mut((n, n), (n, n)).copy_from(&(-a.transpose()));
    let fallback = (a.norm() + (g.norm() * q.norm()).sqrt()).max(1e-12) / (n as f64).sqrt();
    let Some(ev) = eigenvalues(&ham) else {
        return fallback;
    };
    let mods: Vec<f64> = ev.iter().map(|l| l.norm()).collect();
    let max = mods.iter().cloned().fold(0.0, f64::max);
    let min = mods.iter().cloned().filter(|&m| m > 1e-12 * max).fold(f64::INFINITY, f64::min);
    if max > 0.0 && min.is_finite() { (min * max).sqrt() } else { fallback }
}

/// Shapes, finiteness, symmetry and definiteness of the data.
fn check_inputs(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<()> {
    let n = a.nrows();
    if a.ncols() != n || n == 0 {
        return Err(RiccatiError::Dimension("A must be square"));
    }
    if b.nrows() != n || b.ncols() == 0 {
        return Err(RiccatiError::Dimension("B must have n rows"));
    }
    if q.shape() != (n, n) {
        return Err(RiccatiError::Dimension("Q must be n×n"));
    }
    if r.shape() != (b.ncols(), b.ncols()) {
        return Err(RiccatiError::Dimension("R must be m×m"));
    }
    if ![a, b, q, r].iter().all(|m| m.iter().all(|v| v.is_finite())) {
        return Err(RiccatiError::NonFinite);
    }
    if (r - r.transpose()).norm() > 1e-12 * r.norm() {
        return Err(RiccatiError::SingularR);
    }
    r.clone().cholesky().ok_or(RiccatiError::SingularR)?;
    if (q - q.transpose()).norm() > 1e-12 * q.norm() {
        return Err(RiccatiError::QNotPsd);
    }
    let qmin = sym(q).symmetric_eigenvalues().min();
    if qmin < -1e-12 * q.norm().max(f64::MIN_POSITIVE) {
        return Err(RiccatiError::QNotPsd);
    }
    Ok(())
}

/// PBH tests on the eigenvalues of A outside the open stability region: stabilisability
/// (`rank [A − λI, βB] = n`) and, on the boundary, observability through Q
/// (`rank [A − λI; αQ] = n`). The blocks are scaled to the norm of A (β = ‖A‖/‖B‖,
/// α = ‖A‖/‖Q‖; rank is invariant to that) so the relative rank tolerance 1e-10 does not
/// depend on the units of B and Q (e.g. a process noise Q_d ~ 1e-13 in the dual DARE).
fn check_pbh(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, time: Time) -> Result<()> {
    let n = a.nrows();
    let scale = a.norm().max(1.0);
    let tol_l = 1e-8 * scale;
    let bs = if b.norm() > 0.0 { b * (scale / b.norm()) } else { b.clone() };
    let qs = if q.norm() > 0.0 { q * (scale / q.norm()) } else { q.clone() };
    let ev = eigenvalues(a).ok_or(RiccatiError::EigenFailure)?;
    for l in ev {
        let (outside, boundary) = match time {
            Time::Continuous => (l.re >= -tol_l, l.re.abs() <= tol_l),
            Time::Discrete => (l.norm() >= 1.0 - 1e-8, (l.norm() - 1.0).abs() <= 1e-8),
        };
        if !outside {
            continue;
        }
        let al = a.map(Complex::from) - DMatrix::<Complex<f64>>::identity(n, n) * l;
        let mut m = DMatrix::<Complex<f64>>::zeros(n, n + b.ncols());
        m.view_mut((0, 0), (n, n)).copy_from(&al);
        m.view_mut((0, n), (n, b.ncols())).copy_from(&bs.map(Complex::from));
        if min_singular(m)? <= 1e-10 * scale {
            return Err(RiccatiError::NotStabilisable { eigenvalue: (l.re, l.im) });
        }
        if boundary {
            let mut m = DMatrix::<Complex<f64>>::zeros(2 * n, n);
            m.view_mut((0, 0), (n, n)).copy_from(&al);
            m.view_mut((n, 0), (n, n)).copy_from(&qs.map(Complex::from));
            if min_singular(m)? <= 1e-10 * scale {
                return Err(RiccatiError::NoStabilisingSolution { eigenvalue: (l.re, l.im) });
            }
        }
    }
    Ok(())
}

fn min_singular(m: DMatrix<Complex<f64>>) -> Result<f64> {
    let svd = SVD::try_new(m, false, false, f64::EPSILON, 10_000).ok_or(RiccatiError::EigenFailure)?;
    Ok(svd.singular_values.iter().cloned().fold(f64::INFINITY, f64::min))
}

/// Eigenvalues of a real square matrix (Schur form, bounded iterations).
pub fn eigenvalues(m: &DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    let schur = Schur::try_new(m.clone(), f64::EPSILON, 100_000)?;
    Some(schur.complex_eigenvalues().iter().cloned().collect())
}

/// Largest Re λ (continuous) or |λ| (discrete) of `m`.
pub fn spectral_margin(m: &DMatrix<f64>, time: Time) -> Result<f64> {
    let ev = eigenvalues(m).ok_or(RiccatiError::EigenFailure)?;
    Ok(ev
        .iter()
        .map(|l| match time {
            Time::Continuous => l.re,
            Time::Discrete => l.norm(),
        })
        .fold(f64::NEG_INFINITY, f64::max))
}

/// `B R⁻¹ Bᵀ` as `FᵀF`, `F = L⁻¹Bᵀ`, `R = LLᵀ`: symmetric PSD by construction.
pub fn gram(b: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let ch = r.clone().cholesky().ok_or(RiccatiError::SingularR)?;
    let f = ch.l().solve_lower_triangular(&b.transpose()).ok_or(RiccatiError::SingularR)?;
    Ok(f.transpose() * f)
}

/// Solve `op · vec(D) = −vec(rhs)` (column-major vec) for the n×n matrix D.
fn solve_vec(op: &DMatrix<f64>, rhs: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = rhs.nrows();
    let v = nalgebra::DVector::from_column_slice(rhs.as_slice());
    let d = op.clone().lu().solve(&(-v))?;
    d.iter().all(|x| x.is_finite()).then(|| DMatrix::from_column_slice(n, n, d.as_slice()))
}

/// Reciprocal 2-norm condition number (σ_min/σ_max); `None` if the SVD fails.
fn rcond(m: &DMatrix<f64>) -> Option<f64> {
    let svd = SVD::try_new(m.clone(), false, false, f64::EPSILON, 10_000)?;
    let s = &svd.singular_values;
    let max = s.max();
    Some(if max > 0.0 { s.min() / max } else { 0.0 })
}

/// `(M + Mᵀ)/2`.
pub fn sym(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}
