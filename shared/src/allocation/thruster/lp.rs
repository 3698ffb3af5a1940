//! Thruster control allocation by linear programming (paper 004).
//!
//! Problem (eqs 1-10): find thrust levels `u` with `B u = m_d` and
//! `u_lo <= u <= u_hi`, where the bounds fold position limits, rate limits (eq 9)
//! and failures ([`Allocator::bounds`]).
//!
//! Two methods, one result type ([`AllocResult`]):
//!
//! 1. [`Allocator::direction_preserving`] — the paper's LP, eqs 12-18:
//!    `max λ` s.t. `B u = λ m_d`, `u_lo <= u <= u_hi`, `0 <= λ <= 1`, solved as
//!    `min cᵀx, A x = b, 0 <= x <= h` with `x = [u - u_lo; λ]`, `A = [B, -m_d]`,
//!    `b = -B u_lo`, `h = [u_hi - u_lo; 1]`, `c = [0 … 0, -1]` (eqs 13-17).
//!    If `λ` reaches 1 the demand is attainable and a second LP (the "remaining
//!    freedom" of the paper) minimises propellant `Σ w_i u_i` (`w_i = 1` for
//!    thrusters with `u_min = 0`, else 0) subject to `B u = m_d` exactly. If
//!    `λ < 1` the direction is kept and the magnitude scaled (status `Scaled`).
//!    Solved exactly without pivoting by [`super::zonotope`] (λ from the facets of
//!    the attainable set, the fuel optimum from the lower facets of the 4-D zonotope
//!    `{(B u, wᵀu)}`; fuel ties broken towards lower thruster indices): a fixed cost
//!    and no iteration count (`iterations = 0`). The simplex (stage 1, then the fuel
//!    LP warm-started from its basis, [`Allocator::direction_preserving_lp`]) runs
//!    only where the geometric solve declines (degenerate or rank-deficient attainable
//!    set, `u = 0` not admissible; see its module docs).
//!
//! 2. [`Allocator::bodson`] — Bodson's direction-preserving method as evaluated in
//!    Bodson (2002, JGCA 25(4)) and written up as "DPscaled" in Durham, Bordignon &
//!    Beck, *Aircraft Control Allocation* (2017, §A.5.3) — the paper's ref \[26\].
//!    `λ` is eliminated: with `k = argmax |m_i|`, the `2` rows
//!    `m_j (B u)_k - m_k (B u)_j = 0` (`j ≠ k`) force `B u ∥ m_d`, and the objective
//!    `max m_dᵀ B u` drives `B u` to the boundary of the attainable set along
//!    `m_d` **without the cap λ <= 1**. Then, with `λ* = m_dᵀBu*/|m_d|²`:
//!    `λ* < 1` → `u = u*` (scaled, same as method 1); `λ* >= 1` → the boundary
//!    solution is scaled back towards the zero-command point, `u = u*/λ*`
//!    (Durham's direct-allocation solution). If rate limits or a stuck-on thruster
//!    exclude `u = 0`, the anchor is instead the solution `u⁻` of the same LP
//!    minimising `m_dᵀ B u` (at `λ⁻`), and `u = u⁻ + (1-λ⁻)/(λ*-λ⁻)·(u* - u⁻)`.
//!    Difference from method 1: for attainable demands method 1 returns a vertex
//!    (then the fuel optimum) with many thrusters off; Bodson's returns a scaled
//!    boundary point — a continuous, ray-homogeneous map `m_d ↦ u` that fires
//!    opposing thrusters together, at the cost of more propellant and of always
//!    pivoting to the boundary (more iterations). This matches the paper's
//!    ranking (table 5: more fuel and processing time, smaller tracking error).
//!
//! Why this variant: the paper only says Bodson "optimised the direction-preserving
//! approach for control error" and cites \[26\]; of the LP allocators of Bodson 2002 /
//! \[26\] this is the one that (a) still preserves direction for unattainable demands
//! (the paper lists both methods as answers to unattainable demands) and (b) differs
//! on attainable ones. Bodson's *mixed-optimisation* LP (`min ‖Bu - m‖₁ + ε‖u‖₁`)
//! does not preserve direction when saturated, so it is not the method compared.
//!
//! # Numerics (f32)
//! - `λ >= 1 - LAMBDA_TOL` (1e-5) counts as attained (then status `Ok`, `λ = 1`).
//! - LP tolerances: see [`super::simplex`] (pivot 1e-6, reduced cost 1e-6, phase-1
//!   feasibility 1e-5 relative, all in scaled units); the final basic solution is
//!   refined with a compensated residual, so λ of method 1 is accurate to ~1e-7.
//! - `B u` (realised moment, Bodson's λ) uses compensated dot products; Bodson's
//!   boundary vertex is re-solved on its active set against the unrounded `m_d`
//!   ([`Allocator::bodson`] docs), because the reduced rows are rounded in f32.
//!
//! # Safe fallback
//! On `Infeasible`, `NonFinite` or `IterationCap` the command is
//! `u_i = clamp(0, u_lo_i, u_hi_i)`: every thruster off, except where consistent
//! finite bounds exclude 0 (stuck-on thruster, or a rate limit that forbids an
//! instant cut-off) where the bound nearest 0 is used; `u_i = 0` if that thruster's
//! bounds are non-finite or inverted. `λ = 0`; `realised = B u` and
//! `shortfall = m_d - realised` (components set to 0 where non-finite).

use super::Bounds;
use super::simplex::{Basis, Dot2, Fault, Lp, LpSolution, LpStatus, at, clampf, default_iteration_cap, solve3};
use super::zonotope::{self, Geo};
use crate::allocation::{AXES, AllocOutcome, AllocResult, AllocStatus};

/// `λ >= 1 - LAMBDA_TOL` counts as "demand attained".
pub const LAMBDA_TOL: f32 = 1e-5;
/// A thruster is flagged saturated when within `SAT_TOL · (u_hi - u_lo)` of a bound
/// (a failed thruster, `u_lo = u_hi`, is flagged at both).
pub const SAT_TOL: f32 = 1e-5;

/// Rate limits (eqs 6-7): `rho_min <= u̇ <= rho_max`, previous command `u_prev`,
/// sample time `dt` (the paper's `T`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateLimit<const N: usize> {
    pub u_prev: [f32; N],
    pub rho_min: [f32; N],
    pub rho_max: [f32; N],
    pub dt: f32,
}

/// Failure mask (bit `i` = thruster `i`, 0-based). A failed thruster is locked:
/// at 0 (failed off) or, if its `stuck_on` bit is set too, at `u_max` (stuck on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Failures {
    pub failed: u32,
    pub stuck_on: u32,
}

/// Bit `i` of a `u32` actuator mask (0 for `i >= 32`: no such actuator, no bit).
pub fn bit_of(i: usize) -> u32 {
    u32::try_from(i).ok().and_then(|s| 1u32.checked_shl(s)).unwrap_or(0)
}

impl Failures {
    pub const NONE: Self = Self { failed: 0, stuck_on: 0 };
    /// Failed-off thrusters from 1-based indices (as in the paper's text).
    pub fn off_1based(ids: &[usize]) -> Self {
        let mut failed = 0u32;
        for id in ids {
            if (1..=32).contains(id) {
                failed |= 1u32.checked_shl(u32::try_from(id.saturating_sub(1)).unwrap_or(u32::MAX)).unwrap_or(0);
            }
        }
        Self { failed, stuck_on: 0 }
    }
}

/// `k = argmax |m_i|` (first on ties), `|m_k|` and `m̂ = m_d / |m_k|`.
fn normalised_demand(m_d: &[f32; AXES]) -> (usize, f32, [f32; AXES]) {
    let mut k = 0usize;
    let mut mk = 0.0f32;
    for (i, v) in m_d.iter().enumerate() {
        if v.abs() > mk {
            mk = v.abs();
            k = i;
        }
    }
    let mut m_hat = [0.0f32; AXES];
    for (h, v) in m_hat.iter_mut().zip(m_d.iter()) {
        *h = v / mk;
    }
    (k, mk, m_hat)
}

/// The allocator: effectiveness matrix `B` (3 × N, moment per unit command) and
/// nominal limits. `NV` must equal `N + 1` (the λ column of eq 16); this is checked
/// at compile time. `N <= 32` (bitmasks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Allocator<const N: usize, const NV: usize> {
    b: [[f32; N]; AXES],
    u_min: [f32; N],
    u_max: [f32; N],
    fuel_w: [f32; N],
    /// Iteration cap per LP solve (default `4 (rows + cols)` = 48 for N = 8).
    pub lp_iteration_cap: u16,
}

impl<const N: usize, const NV: usize> Allocator<N, NV> {
    const DIMS_OK: () =
        assert!(NV == N + 1 && N >= 1 && N <= 32, "Allocator<N, NV>: NV must be N + 1 and 1 <= N <= 32");

    /// `B` (3 × N), nominal `u_min`, `u_max` (eq 5). Non-finite data are accepted
    /// here and reported as `NonFinite` by every allocation call.
    pub fn new(b: [[f32; N]; AXES], u_min: [f32; N], u_max: [f32; N]) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::DIMS_OK;
        let mut fuel_w = [0.0f32; N];
        for (w, lo) in fuel_w.iter_mut().zip(u_min.iter()) {
            *w = if *lo == 0.0 { 1.0 } else { 0.0 };
        }
        Self { b, u_min, u_max, fuel_w, lp_iteration_cap: default_iteration_cap(AXES, NV) }
    }

    /// Replace the propellant weights of the fuel stage (default: 1 for thrusters
    /// with `u_min = 0`, else 0). Non-finite weights make the fuel stage fail
    /// (stage-1 solution kept). Tip: weights `1 + 1e-4·i` break the exact fuel ties
    /// of symmetric layouts, making the attainable-demand allocation unique and so
    /// continuous in `m_d` (at a fuel cost ≤ 1e-4·Σu·N).
    pub fn with_fuel_weights(mut self, w: [f32; N]) -> Self {
        self.fuel_w = w;
        self
    }

    pub fn b(&self) -> &[[f32; N]; AXES] {
        &self.b
    }

    /// Nominal bounds (no rate limit, no failure).
    pub fn nominal_bounds(&self) -> Bounds<N> {
        Bounds { lo: self.u_min, hi: self.u_max }
    }

    /// Per-call bounds: eq 9 rate folding, then failures.
    ///
    /// `lo = max(u_min, u_prev + T ρ_min)`, `hi = min(u_max, u_prev + T ρ_max)`.
    /// If these cross (`u_prev` outside `[u_min, u_max]` by more than one rate step)
    /// position limits win and the thruster is pinned at the position limit nearest
    /// `u_prev`. A failed thruster gets `lo = hi = 0` (off) or `u_max` (stuck on),
    /// overriding everything. Non-finite rate data make that thruster's bounds NaN,
    /// so the allocation call reports `NonFinite`.
    pub fn bounds(&self, rate: Option<&RateLimit<N>>, failures: Failures) -> Bounds<N> {
        let mut out = self.nominal_bounds();
        if let Some(rl) = rate {
            let limits = self.u_min.iter().zip(self.u_max.iter());
            let rates = rl.u_prev.iter().zip(rl.rho_min.iter()).zip(rl.rho_max.iter());
            for ((lo, hi), ((&umin, &umax), ((&up, &rmin), &rmax))) in
                out.lo.iter_mut().zip(out.hi.iter_mut()).zip(limits.zip(rates))
            {
                let a = up + rl.dt * rmin;
                let bb = up + rl.dt * rmax;
                if !(a.is_finite() && bb.is_finite()) {
                    *lo = f32::NAN;
                    *hi = f32::NAN;
                    continue;
                }
                let l = if a > umin { a } else { umin };
                let h = if bb < umax { bb } else { umax };
                if l <= h {
                    *lo = l;
                    *hi = h;
                } else {
                    let pin = if up >= umax { umax } else { umin };
                    *lo = pin;
                    *hi = pin;
                }
            }
        }
        for (i, ((lo, hi), &umax)) in out.lo.iter_mut().zip(out.hi.iter_mut()).zip(self.u_max.iter()).enumerate() {
            let bit = bit_of(i);
            if failures.failed & bit != 0 {
                let v = if failures.stuck_on & bit != 0 { umax } else { 0.0 };
                *lo = v;
                *hi = v;
            }
        }
        out
    }

    fn inputs_finite(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> bool {
        m_d.iter().all(|v| v.is_finite())
            && self.b.iter().all(|r| r.iter().all(|v| v.is_finite()))
            && bd.lo.iter().chain(bd.hi.iter()).all(|v| v.is_finite())
            && self.u_min.iter().chain(self.u_max.iter()).all(|v| v.is_finite())
    }

    fn bounds_consistent(bd: &Bounds<N>) -> bool {
        bd.lo.iter().zip(bd.hi.iter()).all(|(l, h)| l <= h)
    }

    fn zero_admissible(bd: &Bounds<N>) -> bool {
        bd.lo.iter().zip(bd.hi.iter()).all(|(l, h)| *l <= 0.0 && *h >= 0.0)
    }

    /// `B u` with compensated dot products ([`Dot2`]): moments near zero are sums of
    /// O(1) terms that cancel, and both `realised` and Bodson's `λ` are read from it.
    fn moment(&self, u: &[f32; N]) -> [f32; AXES] {
        let mut out = [0.0f32; AXES];
        for (o, row) in out.iter_mut().zip(self.b.iter()) {
            let mut acc = Dot2::new(0.0);
            for (b, x) in row.iter().zip(u.iter()) {
                // A zero product (thruster off, or not fitted) leaves Dot2's sum and
                // error term unchanged: skipped.
                if *b != 0.0 && *x != 0.0 {
                    acc.add_prod(*b, *x);
                }
            }
            *o = acc.value();
        }
        out
    }

    /// Build the result: clamp into bounds, realised / shortfall, saturation masks.
    fn finish(
        &self,
        m_d: &[f32; AXES],
        bd: &Bounds<N>,
        mut u: [f32; N],
        lambda: f32,
        status: AllocStatus,
        iterations: u16,
    ) -> AllocResult<N> {
        let mut sat_low = 0u32;
        let mut sat_high = 0u32;
        for (i, ((x, lo), hi)) in u.iter_mut().zip(bd.lo.iter()).zip(bd.hi.iter()).enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                if !x.is_finite() {
                    *x = 0.0;
                }
                continue;
            }
            if !(*x >= *lo) {
                *x = *lo; // also catches NaN
            }
            if *x > *hi {
                *x = *hi;
            }
            let tol = SAT_TOL * (hi - lo);
            let bit = bit_of(i);
            if *x <= lo + tol {
                sat_low |= bit;
            }
            if *x >= hi - tol {
                sat_high |= bit;
            }
        }
        let mut realised = self.moment(&u);
        let mut shortfall = [0.0f32; AXES];
        for ((s, r), m) in shortfall.iter_mut().zip(realised.iter_mut()).zip(m_d.iter()) {
            if !r.is_finite() {
                *r = 0.0;
            }
            let d = m - *r;
            *s = if d.is_finite() { d } else { 0.0 };
        }
        AllocResult {
            u,
            outcome: AllocOutcome { realised, shortfall, lambda, sat_low, sat_high, iterations, status, unrealised: 0 },
        }
    }

    /// The documented safe fallback (module docs).
    fn fallback(&self, m_d: &[f32; AXES], bd: &Bounds<N>, status: AllocStatus, it: u16) -> AllocResult<N> {
        let mut u = [0.0f32; N];
        for ((x, lo), hi) in u.iter_mut().zip(bd.lo.iter()).zip(bd.hi.iter()) {
            *x = if lo.is_finite() && hi.is_finite() && lo <= hi { clampf(0.0, *lo, *hi) } else { 0.0 };
        }
        self.finish(m_d, bd, u, 0.0, status, it)
    }

    fn lp_fail(s: LpStatus) -> AllocStatus {
        match s {
            LpStatus::IterationCap => AllocStatus::IterationCap,
            LpStatus::NonFinite => AllocStatus::NonFinite,
            LpStatus::InternalError => AllocStatus::InternalError,
            // Unbounded cannot occur (all h finite); treated as infeasible.
            LpStatus::Infeasible | LpStatus::Unbounded | LpStatus::Optimal => AllocStatus::Infeasible,
        }
    }

    /// The LP columns: the thrusters that can move under `bd` (`lo < hi`), in index
    /// order: `(map, nc)`, LP column `k < nc` is thruster `map[k]`. Thrusters fixed at
    /// `lo = hi` (not fitted: `u_min = u_max`; failed; pinned by a rate limit) are left
    /// out of the LP (their `B u_lo` is folded into `b`), so the simplex loops run over
    /// the `nc` movable thrusters instead of the capacity `N`. This changes no pivot:
    /// a fixed column (`h_j = 0`) is never priced, never basic, and the order of the
    /// others (hence Bland's and Dantzig's lowest-index choices) is kept. Only the
    /// power-of-two row scale of the scaled LP can differ, when a removed column
    /// (failed thruster) held a row's largest entry.
    pub fn movable(bd: &Bounds<N>) -> ([usize; N], usize) {
        let mut map = [0usize; N];
        let mut nc = 0usize;
        for (j, (lo, hi)) in bd.lo.iter().zip(bd.hi.iter()).enumerate() {
            if lo < hi
                && let Some(slot) = map.get_mut(nc)
            {
                *slot = j;
                nc = nc.saturating_add(1);
            }
        }
        (map, nc)
    }

    /// Columns of `A` (rows of `B`) for the movable thrusters, and `b = rhs - B u_lo`
    /// over all thrusters (fixed ones included), in the original summation order.
    fn fill_rows(&self, lp: &mut Lp<AXES, NV>, bd: &Bounds<N>, map: &[usize; N], nc: usize, rhs: &[f32; AXES]) {
        for ((arow, bi), (brow, ri)) in lp.a.iter_mut().zip(lp.b.iter_mut()).zip(self.b.iter().zip(rhs.iter())) {
            let mut acc = 0.0f32;
            for (b, lo) in brow.iter().zip(bd.lo.iter()) {
                acc += b * lo;
            }
            for (a, &j) in arow.iter_mut().zip(map.iter()).take(nc) {
                *a = brow.get(j).copied().unwrap_or(0.0);
            }
            *bi = ri - acc;
        }
    }

    /// Stage-1 LP of the direction-preserving method, eq 18 (public for diagnostics).
    /// Columns: the movable thrusters ([`Self::movable`]), then `λ` (column `nc`).
    pub fn dp_lp(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> Lp<AXES, NV> {
        let (map, nc) = Self::movable(bd);
        self.dp_lp_on(m_d, bd, &map, nc)
    }

    /// [`Self::dp_lp`] with the columns `(map, nc)` of [`Self::movable`] given.
    fn dp_lp_on(&self, m_d: &[f32; AXES], bd: &Bounds<N>, map: &[usize; N], nc: usize) -> Lp<AXES, NV> {
        let mut lp = Lp::<AXES, NV>::zeroed(AXES, nc.saturating_add(1));
        self.fill_rows(&mut lp, bd, map, nc, &[0.0; AXES]); // b = -B u_min    (eq 16)
        for (arow, mi) in lp.a.iter_mut().zip(m_d.iter()) {
            if let Some(a) = arow.get_mut(nc) {
                *a = -mi; // A = [B, -m_d]       (eq 16)
            }
        }
        for (h, &j) in lp.h.iter_mut().zip(map.iter()).take(nc) {
            *h = at(&bd.hi, j).unwrap_or(0.0) - at(&bd.lo, j).unwrap_or(0.0); // h = [u_max - u_min; 1] (eq 17)
        }
        if let Some(h) = lp.h.get_mut(nc) {
            *h = 1.0;
        }
        if let Some(c) = lp.c.get_mut(nc) {
            *c = -1.0; // c = [0 … 0, -1]      (eq 15)
        }
        lp
    }

    /// Fuel LP: `min Σ w_i u_i` s.t. `B u = m_d`, `lo <= u <= hi` (x = u - lo),
    /// columns: the movable thrusters ([`Self::movable`]).
    pub fn fuel_lp(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> Lp<AXES, NV> {
        let (map, nc) = Self::movable(bd);
        self.fuel_lp_on(m_d, bd, &map, nc)
    }

    /// [`Self::fuel_lp`] with the columns `(map, nc)` of [`Self::movable`] given.
    fn fuel_lp_on(&self, m_d: &[f32; AXES], bd: &Bounds<N>, map: &[usize; N], nc: usize) -> Lp<AXES, NV> {
        let mut lp = Lp::<AXES, NV>::zeroed(AXES, nc);
        self.fill_rows(&mut lp, bd, map, nc, m_d);
        for ((h, c), &j) in lp.h.iter_mut().zip(lp.c.iter_mut()).zip(map.iter()).take(nc) {
            *h = at(&bd.hi, j).unwrap_or(0.0) - at(&bd.lo, j).unwrap_or(0.0);
            *c = at(&self.fuel_w, j).unwrap_or(0.0);
        }
        lp
    }

    /// Bodson's reduced LP (2 rows): `B u ∥ m̂`, `max` (or `min`) `m̂ᵀ B u`.
    /// `k` is the index of the largest `|m̂|` (`|m̂_k| = 1`).
    /// `Err` if `k >= AXES` (a logic error of the caller).
    pub fn bodson_lp(
        &self,
        m_hat: &[f32; AXES],
        k: usize,
        bd: &Bounds<N>,
        maximise: bool,
    ) -> Result<Lp<AXES, NV>, Fault> {
        let (map, nc) = Self::movable(bd);
        self.bodson_lp_on(m_hat, k, bd, maximise, &map, nc)
    }

    /// [`Self::bodson_lp`] with the columns `(map, nc)` of [`Self::movable`] given.
    fn bodson_lp_on(
        &self,
        m_hat: &[f32; AXES],
        k: usize,
        bd: &Bounds<N>,
        maximise: bool,
        map: &[usize; N],
        nc: usize,
    ) -> Result<Lp<AXES, NV>, Fault> {
        let mut lp = Lp::<AXES, NV>::zeroed(AXES.saturating_sub(1), nc);
        let (bk, mk) = (at(&self.b, k)?, at(m_hat, k)?);
        let mut r = 0usize;
        for (j, (brow, mj)) in self.b.iter().zip(m_hat.iter()).enumerate() {
            if j == k {
                continue;
            }
            let (arow, bi) = (lp.a.get_mut(r).ok_or(Fault)?, lp.b.get_mut(r).ok_or(Fault)?);
            // b over all thrusters (fixed ones included), A over the movable ones.
            let mut acc = 0.0f32;
            for ((bkl, bjl), lo) in bk.iter().zip(brow.iter()).zip(bd.lo.iter()) {
                acc += (mj * bkl - mk * bjl) * lo;
            }
            for (a, &l) in arow.iter_mut().zip(map.iter()).take(nc) {
                *a = mj * at(&bk, l)? - mk * at(brow, l)?;
            }
            *bi = -acc;
            r = r.saturating_add(1);
        }
        let sign = if maximise { -1.0 } else { 1.0 };
        for ((c, h), &l) in lp.c.iter_mut().zip(lp.h.iter_mut()).zip(map.iter()).take(nc) {
            let mut proj = 0.0f32;
            for (brow, mi) in self.b.iter().zip(m_hat.iter()) {
                proj += mi * at(brow, l)?;
            }
            *c = sign * proj;
            *h = at(&bd.hi, l)? - at(&bd.lo, l)?;
        }
        Ok(lp)
    }

    /// Accuracy polish of a Bodson boundary solution: the reduced LP's rows
    /// `m_j B_k - m_k B_j` are rounded in f32, so its vertex satisfies `B u ∥ m`
    /// only to `cond · ε`. With the LP's active set (exactly two thrusters strictly
    /// inside their bounds, the generic case) the original 3×3 system
    /// `[b_f1, b_f2, -m_d] [u_f1, u_f2, λ]ᵀ = -Σ_{j∉F} b_j u_j` is re-solved with
    /// refinement, with the unrounded demand `m_d` (the rounding of `m̂ = m_d/|m_k|`
    /// alone moves λ by `ε ×` the ray/facet grazing factor). Kept only if finite and inside the bounds (± 1e-5 of the span);
    /// otherwise (degenerate vertex) `u` is left unchanged.
    /// `Err` only on an index out of range (a logic error).
    fn polish_bodson(&self, u: &mut [f32; N], m_d: &[f32; AXES], bd: &Bounds<N>) -> Result<(), Fault> {
        let mut free = [usize::MAX; 2];
        let mut nf = 0usize;
        for (j, ((x, lo), hi)) in u.iter().zip(bd.lo.iter()).zip(bd.hi.iter()).enumerate() {
            let tol = 1e-5 * (hi - lo);
            if *x > lo + tol && *x < hi - tol {
                // More than two free thrusters: degenerate for the polish, not an error.
                if let Some(f) = free.get_mut(nf) {
                    *f = j;
                }
                nf = nf.saturating_add(1);
            }
        }
        if nf != 2 {
            return Ok(());
        }
        let [f1, f2] = free;
        let mut a = [[0.0f32; 3]; 3];
        let mut r = [0.0f32; 3];
        for ((arow, ri), (brow, mi)) in a.iter_mut().zip(r.iter_mut()).zip(self.b.iter().zip(m_d.iter())) {
            *arow = [at(brow, f1)?, at(brow, f2)?, -mi];
            let mut acc = Dot2::new(0.0);
            for (j, (bij, x)) in brow.iter().zip(u.iter()).enumerate() {
                if j != f1 && j != f2 {
                    acc.add_prod(-*bij, *x);
                }
            }
            *ri = acc.value();
        }
        let Some(z) = solve3(&a, &r)? else {
            return Ok(());
        };
        let (lo1, hi1, lo2, hi2) = (at(&bd.lo, f1)?, at(&bd.hi, f1)?, at(&bd.lo, f2)?, at(&bd.hi, f2)?);
        let ok = |v: f32, lo: f32, hi: f32| {
            let tol = 1e-5 * (hi - lo);
            v >= lo - tol && v <= hi + tol
        };
        let [z1, z2, _] = z;
        if ok(z1, lo1, hi1) && ok(z2, lo2, hi2) {
            *u.get_mut(f1).ok_or(Fault)? = clampf(z1, lo1, hi1);
            *u.get_mut(f2).ok_or(Fault)? = clampf(z2, lo2, hi2);
        }
        Ok(())
    }

    /// `u = u_lo + x` on the LP columns ([`Self::movable`]), `u = u_lo` elsewhere.
    fn u_from_x(x: &[f32; NV], bd: &Bounds<N>, map: &[usize; N], nc: usize) -> [f32; N] {
        let mut u = bd.lo;
        for (xk, &j) in x.iter().zip(map.iter()).take(nc) {
            if let Some(ui) = u.get_mut(j) {
                *ui += xk;
            }
        }
        u
    }

    fn fuel(&self, u: &[f32; N]) -> f32 {
        u.iter().zip(self.fuel_w.iter()).map(|(x, w)| x * w).sum()
    }

    /// Paper eqs 12-18 + fuel stage. See the module docs.
    pub fn direction_preserving(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> AllocResult<N> {
        if !self.inputs_finite(m_d, bd) {
            return self.fallback(m_d, bd, AllocStatus::NonFinite, 0);
        }
        if !Self::bounds_consistent(bd) {
            return self.fallback(m_d, bd, AllocStatus::Infeasible, 0);
        }
        let (map, nc) = Self::movable(bd);
        // Exact geometric solve (no pivoting, fixed cost); the simplex below only when
        // it declines (degenerate or rank-deficient attainable set, 0 not admissible).
        match zonotope::solve(&self.b, &self.fuel_w, bd, &map, nc, m_d, LAMBDA_TOL) {
            Ok(Some(Geo::Attained { u })) => return self.finish(m_d, bd, u, 1.0, AllocStatus::Ok, 0),
            Ok(Some(Geo::Boundary { u, lambda })) => {
                return if lambda >= 1.0 - LAMBDA_TOL {
                    self.finish(m_d, bd, u, 1.0, AllocStatus::Ok, 0)
                } else {
                    self.finish(m_d, bd, u, lambda, AllocStatus::Scaled, 0)
                };
            }
            Ok(None) => {}
            Err(_) => return self.fallback(m_d, bd, AllocStatus::InternalError, 0),
        }
        self.direction_preserving_simplex(m_d, bd, &map, nc)
    }

    /// The simplex form of [`Self::direction_preserving`] (stage-1 LP, eq 18, then the
    /// fuel LP warm-started from its basis), for the cases the geometric solve declines.
    /// Public (with the same input checks) as a reference for tests and benches.
    pub fn direction_preserving_lp(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> AllocResult<N> {
        if !self.inputs_finite(m_d, bd) {
            return self.fallback(m_d, bd, AllocStatus::NonFinite, 0);
        }
        if !Self::bounds_consistent(bd) {
            return self.fallback(m_d, bd, AllocStatus::Infeasible, 0);
        }
        let (map, nc) = Self::movable(bd);
        self.direction_preserving_simplex(m_d, bd, &map, nc)
    }

    fn direction_preserving_simplex(
        &self,
        m_d: &[f32; AXES],
        bd: &Bounds<N>,
        map: &[usize; N],
        nc: usize,
    ) -> AllocResult<N> {
        let (map, nc) = (*map, nc);
        let mut basis = Basis::<AXES, NV>::default();
        let s1: LpSolution<NV> =
            self.dp_lp_on(m_d, bd, &map, nc).solve_lean(self.lp_iteration_cap, None, Some(&mut basis));
        let mut it = s1.iterations;
        if s1.status != LpStatus::Optimal {
            return self.fallback(m_d, bd, Self::lp_fail(s1.status), it);
        }
        let Ok(lambda) = at(&s1.x, nc) else {
            return self.fallback(m_d, bd, AllocStatus::InternalError, it);
        };
        let u1 = Self::u_from_x(&s1.x, bd, &map, nc);
        if lambda < 1.0 - LAMBDA_TOL {
            return self.finish(m_d, bd, u1, lambda, AllocStatus::Scaled, it);
        }
        // Attainable: stage 2, minimum propellant with B u = m_d, warm-started from the
        // stage-1 basis. With λ nonbasic at its upper bound 1 the stage-1 basis has the
        // same basic thruster columns (same indices: both LPs list the movable
        // thrusters first) and the same right-hand side `m_d - B u_lo`, so it is a
        // feasible basis of the fuel LP: phase 1 is skipped, and when the stage-1
        // vertex is already fuel-optimal (all reduced costs of the fuel objective of
        // the right sign: the LP optimality certificate) stage 2 makes no pivot at all.
        // If λ is basic (value within LAMBDA_TOL of 1) the basis names column `nc`,
        // which the fuel LP does not have: the solver rejects it and cold-starts.
        let s2 = self.fuel_lp_on(m_d, bd, &map, nc).solve_lean(self.lp_iteration_cap, Some(&basis), None);
        it = it.saturating_add(s2.iterations);
        if s2.status == LpStatus::InternalError {
            return self.fallback(m_d, bd, AllocStatus::InternalError, it);
        }
        let u2 = Self::u_from_x(&s2.x, bd, &map, nc);
        let u = if s2.status == LpStatus::Optimal && self.fuel(&u2) <= self.fuel(&u1) {
            u2
        } else {
            u1 // stage 2 failed numerically (λ within tolerance of 1): keep stage 1
        };
        self.finish(m_d, bd, u, 1.0, AllocStatus::Ok, it)
    }

    /// Bodson's direction-preserving method (reduced LP, solution scaled from the
    /// boundary). See the module docs.
    /// Zero (or subnormal) demand: zero command if admissible, else the least-fuel
    /// admissible command with zero moment.
    fn zero_demand(&self, m_d: &[f32; AXES], bd: &Bounds<N>, zero_ok: bool) -> AllocResult<N> {
        if zero_ok {
            return self.finish(m_d, bd, [0.0; N], 1.0, AllocStatus::Ok, 0);
        }
        let (map, nc) = Self::movable(bd);
        let s = self.fuel_lp_on(&[0.0; AXES], bd, &map, nc).solve_lean(self.lp_iteration_cap, None, None);
        if s.status != LpStatus::Optimal {
            return self.fallback(m_d, bd, Self::lp_fail(s.status), s.iterations);
        }
        self.finish(m_d, bd, Self::u_from_x(&s.x, bd, &map, nc), 1.0, AllocStatus::Ok, s.iterations)
    }

    pub fn bodson(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> AllocResult<N> {
        if !self.inputs_finite(m_d, bd) {
            return self.fallback(m_d, bd, AllocStatus::NonFinite, 0);
        }
        if !Self::bounds_consistent(bd) {
            return self.fallback(m_d, bd, AllocStatus::Infeasible, 0);
        }
        let zero_ok = Self::zero_admissible(bd);
        let (_, mk, m_hat) = normalised_demand(m_d);
        let mm: f32 = m_hat.iter().map(|v| v * v).sum();
        let lambda_of = |u: &[f32; N]| -> f32 {
            let bu = self.moment(u);
            let p: f32 = bu.iter().zip(m_hat.iter()).map(|(a, b)| a * b).sum();
            p / mm / mk
        };
        if !(mk > 0.0) || !m_hat.iter().all(|v| v.is_finite()) || !(1.0 / mk).is_finite() {
            return self.zero_demand(m_d, bd, zero_ok);
        }
        let (map, nc) = Self::movable(bd);
        // The boundary point along m̂ from the facets of the attainable set (exact, no
        // pivoting; the reduced LP's vertex, already on the unrounded ray); the LP
        // below only where the geometric solve declines.
        if zero_ok {
            match zonotope::boundary(&self.b, bd, &map, nc, &m_hat) {
                Ok(Some((u_hi, _))) => {
                    let l_hi = lambda_of(&u_hi);
                    if !l_hi.is_finite() || l_hi < -LAMBDA_TOL {
                        return self.fallback(m_d, bd, AllocStatus::Infeasible, 0);
                    }
                    if l_hi < 1.0 - LAMBDA_TOL {
                        return self.finish(m_d, bd, u_hi, l_hi.max(0.0), AllocStatus::Scaled, 0);
                    }
                    let t = if l_hi > LAMBDA_TOL { clampf(1.0 / l_hi, 0.0, 1.0) } else { 1.0 };
                    let mut u = [0.0f32; N];
                    for (x, b) in u.iter_mut().zip(u_hi.iter()) {
                        *x = t * b;
                    }
                    return self.finish(m_d, bd, u, 1.0, AllocStatus::Ok, 0);
                }
                Ok(None) => {}
                Err(_) => return self.fallback(m_d, bd, AllocStatus::InternalError, 0),
            }
        }
        self.bodson_simplex(m_d, bd, &map, nc)
    }

    /// The reduced-LP form of [`Self::bodson`] (public with the same input checks, as a
    /// reference for tests): the simplex for the boundary point(s), then the scaling.
    pub fn bodson_via_lp(&self, m_d: &[f32; AXES], bd: &Bounds<N>) -> AllocResult<N> {
        if !self.inputs_finite(m_d, bd) {
            return self.fallback(m_d, bd, AllocStatus::NonFinite, 0);
        }
        if !Self::bounds_consistent(bd) {
            return self.fallback(m_d, bd, AllocStatus::Infeasible, 0);
        }
        let (_, mk, m_hat) = normalised_demand(m_d);
        if !(mk > 0.0) || !m_hat.iter().all(|v| v.is_finite()) || !(1.0 / mk).is_finite() {
            return self.zero_demand(m_d, bd, Self::zero_admissible(bd));
        }
        let (map, nc) = Self::movable(bd);
        self.bodson_simplex(m_d, bd, &map, nc)
    }

    fn bodson_simplex(&self, m_d: &[f32; AXES], bd: &Bounds<N>, map: &[usize; N], nc: usize) -> AllocResult<N> {
        let (map, nc) = (*map, nc);
        let zero_ok = Self::zero_admissible(bd);
        let (k, mk, m_hat) = normalised_demand(m_d);
        let mm: f32 = m_hat.iter().map(|v| v * v).sum();
        let lambda_of = |u: &[f32; N]| -> f32 {
            let bu = self.moment(u);
            let p: f32 = bu.iter().zip(m_hat.iter()).map(|(a, b)| a * b).sum();
            p / mm / mk
        };
        // Solved in place (by reference): moving the LP out of the `Result` is a memcpy.
        let s_hi = match &self.bodson_lp_on(&m_hat, k, bd, true, &map, nc) {
            Ok(lp) => lp.solve_lean(self.lp_iteration_cap, None, None),
            Err(_) => return self.fallback(m_d, bd, AllocStatus::InternalError, 0),
        };
        let mut it = s_hi.iterations;
        if s_hi.status != LpStatus::Optimal {
            return self.fallback(m_d, bd, Self::lp_fail(s_hi.status), it);
        }
        let mut u_hi = Self::u_from_x(&s_hi.x, bd, &map, nc);
        if self.polish_bodson(&mut u_hi, m_d, bd).is_err() {
            return self.fallback(m_d, bd, AllocStatus::InternalError, it);
        }
        let l_hi = lambda_of(&u_hi);
        if !l_hi.is_finite() || l_hi < -LAMBDA_TOL {
            return self.fallback(m_d, bd, AllocStatus::Infeasible, it);
        }
        if l_hi < 1.0 - LAMBDA_TOL {
            return self.finish(m_d, bd, u_hi, l_hi.max(0.0), AllocStatus::Scaled, it);
        }
        // Attainable: scale back from the boundary towards the anchor.
        let (u_lo, l_lo) = if zero_ok {
            ([0.0f32; N], 0.0f32)
        } else {
            let s_lo = match &self.bodson_lp_on(&m_hat, k, bd, false, &map, nc) {
                Ok(lp) => lp.solve_lean(self.lp_iteration_cap, None, None),
                Err(_) => return self.fallback(m_d, bd, AllocStatus::InternalError, it),
            };
            it = it.saturating_add(s_lo.iterations);
            if s_lo.status != LpStatus::Optimal {
                return self.fallback(m_d, bd, Self::lp_fail(s_lo.status), it);
            }
            let mut u = Self::u_from_x(&s_lo.x, bd, &map, nc);
            if self.polish_bodson(&mut u, m_d, bd).is_err() {
                return self.fallback(m_d, bd, AllocStatus::InternalError, it);
            }
            (u, lambda_of(&u))
        };
        if !l_lo.is_finite() || l_lo > 1.0 + LAMBDA_TOL {
            // Even the smallest admissible output along m_d exceeds the demand.
            return self.fallback(m_d, bd, AllocStatus::Infeasible, it);
        }
        let den = l_hi - l_lo;
        let t = if den > LAMBDA_TOL { clampf((1.0 - l_lo) / den, 0.0, 1.0) } else { 1.0 };
        let mut u = [0.0f32; N];
        for ((x, a), b) in u.iter_mut().zip(u_lo.iter()).zip(u_hi.iter()) {
            *x = a + t * (b - a);
        }
        self.finish(m_d, bd, u, 1.0, AllocStatus::Ok, it)
    }
}
