//! Bounded-variable two-phase primal simplex on fixed-size stack arrays.
//!
//! Solves the standard form of paper 004, eq 11:
//!
//! ```text
//!     min cᵀx   subject to   A x = b,   0 <= x <= h
//! ```
//!
//! with `A` of `rows <= M` by `cols <= N` (const-generic capacities, runtime active
//! sizes). Upper bounds are handled implicitly: a nonbasic variable sits at 0 or at
//! `h_j`, and the ratio test includes the entering variable's own bound ("bound
//! flip") and the basic variables' upper bounds, so no extra rows are added.
//! `h_j = +inf` means "no upper bound"; `h_j = 0` fixes `x_j = 0`.
//!
//! # Algorithm
//! - **Scaling** (exact where possible): column `j` is scaled by `h_j` (so every
//!   finite-bounded variable lives in `[0, 1]`; unbounded columns by a power of two
//!   of their largest entry), then every row by a power of two so its largest entry
//!   is in `[1, 2)`, the cost by a power of two so `max |c| ∈ [1, 2)`. All tolerances
//!   below are in these scaled units. Rows are sign-normalised so `b >= 0`.
//! - **Phase 1**: one artificial variable per row, basis = artificials, cost =
//!   Σ artificials. Artificials never re-enter once they leave. Phase 1 ends
//!   infeasible if Σ artificials > [`FEAS_TOL`]·(1 + max b).
//! - **Phase 2**: the true cost; artificials still basic (redundant or degenerate
//!   rows) get the bounds `[0, 0]`, so the ratio test pivots them out at the first
//!   entering column that touches their row.
//! - **Anti-cycling**: Bland's rule ([`Pricing::Bland`]), or by default
//!   [`Pricing::DantzigBland`]: largest `|d_j|` while pivots make progress, Bland
//!   after any degenerate pivot. Bland's entering variable is the lowest-index
//!   eligible one (at lower with `d_j < -DUAL_TOL`, or at upper with
//!   `d_j > DUAL_TOL`); among ratio-test ties (within [`TIE_TOL`]) the leaving
//!   variable is the lowest index, the bound flip counting as the entering
//!   variable's own index (structural `j` < artificial `N + i`). Everything is
//!   deterministic: same input bits → same output bits.
//! - **Refactorisation**: at the end of each phase the basis inverse is rebuilt from
//!   the scaled data by Gauss-Jordan with partial pivoting, the tableau and basic
//!   values recomputed, and optimality re-checked (drift-induced extra pivots count
//!   towards the cap); not again when no pivot was made since the last one.
//! - **Refinement**: after each refactorisation the basic values get one step of
//!   iterative refinement with a compensated (Dot2) residual, so `x` is accurate to
//!   ~ε rather than `cond(B)·ε` (f32 only, no f64).
//! - **Iteration cap**: every pivot or bound flip is one iteration, both phases
//!   together; default [`default_iteration_cap`] `= 4 (rows + cols)`.
//! - **Warm start** ([`Lp::solve_from`]): phase 2 starts from a given [`Basis`]
//!   (e.g. the optimal basis of a related LP with the same columns) when it is valid
//!   (active, distinct variables; no infinite bound at "upper"), its basis matrix is
//!   not singular and its basic values are within [`FEAS_TOL`] of their bounds
//!   (then clamped onto them); phase 1 is skipped. Otherwise the solve is the cold
//!   two-phase one, bit for bit. Phase 2 from a feasible basis ends at an optimum of
//!   the same LP, so the objective is the cold start's within the tolerances; if the
//!   optimum is not unique (dual degenerate, `dual_margin <= DUAL_TOL`) the vertex
//!   may differ from the cold start's, deterministically (same inputs and basis →
//!   same bits). Cost bound: one refactorisation more than the cold solve (the failed
//!   install), the iteration cap is unchanged.
//!
//! # No panics
//! NaN / ±inf in `A`, `b`, `c`, NaN or `-inf` in `h`, and data whose scaling
//! overflows return [`LpStatus::NonFinite`]; `h_j < 0` returns
//! [`LpStatus::Infeasible`]. All array accesses are checked (`get`) or iterator
//! based; loops are bounded by `M`, `N` and the iteration cap.
//!
//! # Shared numerics
//! The small helpers both solvers of the allocation use live here, below them
//! ([`super::lp`] and the geometric `zonotope` solve): the compensated dot product
//! [`Dot2`], the panic-free [`clampf`] and the 3×3 solve [`solve3`].

/// Pivot tolerance: a scaled tableau entry with `|α| <= PIVOT_TOL` is never pivoted on
/// (its basic variable is not limited by the ratio test; the result is snapped back
/// into its bounds). f32 ε is 1.2e-7; after a few pivots entries carry errors of
/// a few ε, hence ~10 ε.
pub const PIVOT_TOL: f32 = 1e-6;
/// Reduced-cost optimality tolerance (scaled cost, `max |c| ∈ [1, 2)`).
pub const DUAL_TOL: f32 = 1e-6;
/// Phase-1 feasibility tolerance, relative: infeasible iff
/// `Σ artificials > FEAS_TOL · (1 + max_i b_i)` (scaled rows, `max |A_ij| ∈ [1, 2)`).
pub const FEAS_TOL: f32 = 1e-5;
/// Ratio-test tie window (scaled variable units, i.e. fractions of `h_j`).
pub const TIE_TOL: f32 = 1e-7;
/// Basic values within this distance of a bound (scaled) are snapped onto it, so
/// that degenerate ties are exact and Bland's rule sees them.
pub const SNAP_TOL: f32 = 1e-7;
/// A refactorisation pivot below this magnitude means a singular basis; the
/// refactorisation is then skipped (the pivoted tableau is kept).
const SINGULAR_TOL: f32 = 1e-9;

/// Default iteration cap `4 (rows + cols)`, saturating at `u16::MAX`.
pub const fn default_iteration_cap(rows: usize, cols: usize) -> u16 {
    let k = 4usize.saturating_mul(rows.saturating_add(cols));
    // `TryFrom` is not const: the comparison guards the narrowing.
    #[allow(clippy::cast_possible_truncation)]
    if k > u16::MAX as usize { u16::MAX } else { k as u16 }
}

/// Entering-variable rule. Both are deterministic and anti-cycling; the leaving
/// variable is always chosen by Bland's lowest-index rule among ratio ties.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pricing {
    /// Pure Bland: lowest-index eligible variable enters.
    Bland,
    /// Dantzig (largest `|d_j|`, lowest index on ties) while pivots make progress;
    /// Bland's rule after every degenerate pivot, until a non-degenerate step.
    /// Cycling needs an endless run of degenerate pivots, and Bland's rule cannot
    /// cycle from any starting basis, so this terminates; it is typically faster.
    DantzigBland,
}

/// Outcome of a solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LpStatus {
    /// Optimal within the tolerances above.
    Optimal,
    /// No `x` with `A x = b, 0 <= x <= h` (phase 1 residual too large, or `h_j < 0`).
    Infeasible,
    /// The objective decreases without limit (only possible with `h_j = inf`).
    Unbounded,
    /// The iteration cap was reached first; `x` is the last basic solution
    /// (bounded, but possibly infeasible in phase 1 or suboptimal in phase 2).
    IterationCap,
    /// A non-finite input, or scaling / objective overflow.
    NonFinite,
    /// A logic error inside the solver (an index out of range): detected, `x = 0`.
    InternalError,
}

/// Solution of [`Lp::solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LpSolution<const N: usize> {
    /// Primal solution (original units), always inside `[0, h]` (zero on `NonFinite`).
    pub x: [f32; N],
    /// `cᵀx` (original units).
    pub objective: f32,
    /// Pivots + bound flips, both phases.
    pub iterations: u16,
    pub status: LpStatus,
    /// At the optimum: min `|d_j|` over movable nonbasic structurals (scaled cost).
    /// `> DUAL_TOL` ⇒ the optimum is unique (dual non-degenerate). `inf` if none.
    pub dual_margin: f32,
    /// At the optimum: min distance of a basic structural from its bounds (scaled).
    /// `> 0` ⇒ primal non-degenerate. `inf` if none.
    pub primal_margin: f32,
}

impl<const N: usize> LpSolution<N> {
    fn failed(status: LpStatus, iterations: u16) -> Self {
        Self { x: [0.0; N], objective: 0.0, iterations, status, dual_margin: 0.0, primal_margin: 0.0 }
    }
}

/// A simplex basis, for warm starts ([`Lp::solve_from`]): the basic variable of each
/// row (`j < N` structural, `N + i` the artificial of row `i`) and which nonbasic
/// structurals sit at their upper bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Basis<const M: usize, const N: usize> {
    pub vars: [usize; M],
    pub upper: [bool; N],
}

impl<const M: usize, const N: usize> Default for Basis<M, N> {
    /// The artificial basis (the cold start's).
    fn default() -> Self {
        let mut vars = [0usize; M];
        for (i, v) in vars.iter_mut().enumerate() {
            *v = N.saturating_add(i);
        }
        Self { vars, upper: [false; N] }
    }
}

/// `min cᵀx, A x = b, 0 <= x <= h`, first `rows` rows and `cols` columns active.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lp<const M: usize, const N: usize> {
    pub a: [[f32; N]; M],
    pub b: [f32; M],
    pub c: [f32; N],
    pub h: [f32; N],
    /// Active rows (`> M` is clamped to `M`).
    pub rows: usize,
    /// Active columns (`> N` is clamped to `N`).
    pub cols: usize,
    /// Entering rule (default [`Pricing::DantzigBland`]).
    pub pricing: Pricing,
}

impl<const M: usize, const N: usize> Default for Lp<M, N> {
    fn default() -> Self {
        Self::zeroed(M, N)
    }
}

/// An index outside its array inside the solver: a logic error, reported as
/// [`LpStatus::InternalError`] (never a silent 0 or a dropped write).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fault;

impl From<Fault> for LpStatus {
    fn from(_: Fault) -> Self {
        LpStatus::InternalError
    }
}

/// `v[i]`, or [`Fault`].
#[inline(always)]
pub(crate) fn at<T: Copy, const K: usize>(v: &[T; K], i: usize) -> Result<T, Fault> {
    v.get(i).copied().ok_or(Fault)
}

/// `v[i] = x`, or [`Fault`].
#[inline(always)]
fn put<T, const K: usize>(v: &mut [T; K], i: usize, x: T) -> Result<(), Fault> {
    *v.get_mut(i).ok_or(Fault)? = x;
    Ok(())
}

/// `max(x, 0)` with libm `fmaxf`'s result for every input (NaN → 0, `-0` → `-0`),
/// inline: `f32::max` is a library call on the MCU.
#[inline(always)]
fn max0(x: f32) -> f32 {
    if x >= 0.0 { x } else { 0.0 }
}

/// `2^-e` for `v = m 2^e`, `m ∈ [1, 2)`: an exact power-of-two reciprocal scale.
/// Returns 1 for zero, subnormal or non-finite `v`.
fn pow2_recip(v: f32) -> f32 {
    let field = (v.to_bits() >> 23) & 0xff;
    if !(v > 0.0) || field == 0 || field == 0xff {
        return 1.0;
    }
    // 2^-(field-127) has exponent field 254 - field; keep it a normal number. `field` is
    // in 1..=254 here, so 254 - field <= 253: only the lower bound can bind.
    let nf = 254u32.saturating_sub(field).max(1);
    f32::from_bits(nf << 23)
}

impl<const M: usize, const N: usize> Lp<M, N> {
    /// All-zero problem with the given active size (`h = 0`).
    pub const fn zeroed(rows: usize, cols: usize) -> Self {
        Self { a: [[0.0; N]; M], b: [0.0; M], c: [0.0; N], h: [0.0; N], rows, cols, pricing: Pricing::DantzigBland }
    }

    /// Solve with the default cap `4 (rows + cols)`.
    pub fn solve(&self) -> LpSolution<N> {
        let m = if self.rows < M { self.rows } else { M };
        let n = if self.cols < N { self.cols } else { N };
        self.solve_with_cap(default_iteration_cap(m, n))
    }

    /// Bound validation: `Err(NonFinite)` on a NaN or `-inf` bound, else whether a
    /// bound is negative (infeasible). Non-finite `A`, `b`, `c` are caught after
    /// scaling ([`Self::scale_into`]): every scale factor is a finite nonzero number,
    /// so a non-finite input gives a non-finite scaled entry. The statuses are those
    /// of checking `A, b`, then `c, h`, then `h < 0` up front: `NonFinite` first.
    fn check_bounds(&self, n: usize) -> Result<bool, LpStatus> {
        let mut neg = false;
        for hj in self.h.iter().take(n) {
            if hj.is_nan() || *hj == f32::NEG_INFINITY {
                return Err(LpStatus::NonFinite);
            }
            neg |= *hj < 0.0;
        }
        Ok(neg)
    }

    /// Solve with an explicit iteration cap (pivots + bound flips, both phases).
    pub fn solve_with_cap(&self, cap: u16) -> LpSolution<N> {
        self.solve_from(cap, None, None)
    }

    /// [`Self::solve_with_cap`], warm-started from `warm` if it is usable (module
    /// docs), and writing the final basis into `out` (left unchanged if the inputs
    /// are rejected before the simplex runs).
    pub fn solve_from(&self, cap: u16, warm: Option<&Basis<M, N>>, out: Option<&mut Basis<M, N>>) -> LpSolution<N> {
        self.solve_impl(cap, warm, out, true)
    }

    /// [`Self::solve_from`] without the dual margin (reported as 0, "not known to be
    /// unique"): it costs one more pricing pass, and the allocator does not use it.
    /// Every other field has the bits of [`Self::solve_from`]'s.
    pub(crate) fn solve_lean(
        &self,
        cap: u16,
        warm: Option<&Basis<M, N>>,
        out: Option<&mut Basis<M, N>>,
    ) -> LpSolution<N> {
        self.solve_impl(cap, warm, out, false)
    }

    fn solve_impl(
        &self,
        cap: u16,
        warm: Option<&Basis<M, N>>,
        out: Option<&mut Basis<M, N>>,
        margins: bool,
    ) -> LpSolution<N> {
        let m = if self.rows < M { self.rows } else { M };
        let n = if self.cols < N { self.cols } else { N };
        let negative_bound = match self.check_bounds(n) {
            Ok(neg) => neg,
            Err(e) => return LpSolution::failed(e, 0),
        };
        // Built in place and filled by reference: the solver is ~0.5 kB, and moving it
        // through a return value costs a memcpy per solve on the MCU.
        let mut sv = Solver::<M, N>::new(m, n, cap);
        let bmax = match self.scale_into(&mut sv, m, n) {
            Ok(x) => x,
            Err(e) => return LpSolution::failed(e, 0),
        };
        if negative_bound {
            return LpSolution::failed(LpStatus::Infeasible, 0);
        }
        let status = Self::run(&mut sv, bmax, warm);
        if let Some(o) = out {
            o.vars = sv.basis;
            o.upper = sv.upper;
        }
        sv.extract(status, self, margins)
    }

    /// Both phases (or phase 2 alone from a usable warm basis): the final status.
    fn run(sv: &mut Solver<M, N>, bmax: f32, warm: Option<&Basis<M, N>>) -> LpStatus {
        if let Some(w) = warm {
            match sv.install(w) {
                Ok(true) => {
                    return match sv.run_phase() {
                        Ok(()) => LpStatus::Optimal,
                        Err(e) => e,
                    };
                }
                Ok(false) => sv.reset_cold(),
                Err(e) => return e.into(),
            }
        }
        let m = sv.m;
        // ---- phase 1 ---------------------------------------------------------
        // Not skipped even when b = 0 (artificial basis already feasible): phase 2
        // cannot hold a basic artificial at 0 in a row whose entering-column entry is
        // below PIVOT_TOL (it drifts), while phase 1 pivots it out on its own cost.
        sv.phase1 = true;
        if let Err(e) = sv.run_phase() {
            return e;
        }
        let mut infeas = 0.0f32;
        for (var, xb) in sv.basis.iter().zip(sv.xb.iter()).take(m) {
            if *var >= N {
                infeas += *xb;
            }
        }
        if !(infeas <= FEAS_TOL * (1.0 + bmax)) {
            return LpStatus::Infeasible;
        }

        // ---- phase 2 ---------------------------------------------------------
        sv.phase1 = false;
        for (var, xb) in sv.basis.iter().zip(sv.xb.iter_mut()).take(m) {
            if *var >= N {
                *xb = 0.0;
            }
        }
        match sv.run_phase() {
            Ok(()) => LpStatus::Optimal,
            Err(e) => e,
        }
    }

    /// The scaled problem (see the module docs) into the fresh solver `sv`, with the
    /// artificial basis (column scales into `sv.s`): the max scaled `b`.
    fn scale_into(&self, sv: &mut Solver<M, N>, m: usize, n: usize) -> Result<f32, LpStatus> {
        // Scaled upper bounds into `sv.h` (zero-initialised): 0, 1 or inf.
        for (j, ((sj, hsj), &hj)) in sv.s.iter_mut().zip(sv.h.iter_mut()).zip(self.h.iter()).enumerate().take(n) {
            if hj == f32::INFINITY {
                let mut colmax = 0.0f32;
                for row in self.a.iter().take(m) {
                    let v = at(row, j)?;
                    if v.abs() > colmax {
                        colmax = v.abs();
                    }
                }
                *sj = pow2_recip(colmax);
                *hsj = f32::INFINITY;
            } else if hj > 0.0 {
                *sj = hj;
                *hsj = 1.0;
            } else {
                *sj = 1.0;
                *hsj = 0.0;
            }
        }
        sv.dantzig = self.pricing == Pricing::DantzigBland;
        // All finite iff z = Σ 0·v stays 0 over every scaled entry (0·inf and 0·NaN are
        // NaN): one multiply-add per entry, folded into the scaling loops.
        let mut z = 0.0f32;
        for sj in sv.s.iter().take(n) {
            z += 0.0 * sj;
        }
        let mut bmax = 0.0f32;
        // The scaled rows go into `a` and, as the artificial basis's tableau, into `t`
        // (cheaper than copying the whole capacity-sized array afterwards).
        for (((srow, trow), sb), (row, bi)) in
            sv.a.iter_mut().zip(sv.t.iter_mut()).zip(sv.b.iter_mut()).zip(self.a.iter().zip(self.b.iter())).take(m)
        {
            let mut rmax = 0.0f32;
            for ((dst, src), sj) in srow.iter_mut().zip(row.iter()).zip(sv.s.iter()).take(n) {
                *dst = src * sj;
                if dst.abs() > rmax {
                    rmax = dst.abs();
                }
            }
            let r = if rmax > 1e-30 { pow2_recip(rmax) } else { 1.0 };
            let mut bs = bi * r;
            let sign = if bs < 0.0 { -1.0 } else { 1.0 };
            bs *= sign;
            let rs = r * sign;
            for (dst, tdst) in srow.iter_mut().zip(trow.iter_mut()).take(n) {
                *dst *= rs;
                *tdst = *dst;
                z += 0.0 * *dst;
            }
            z += 0.0 * bs;
            *sb = bs;
            if bs > bmax {
                bmax = bs;
            }
        }
        let mut cmax = 0.0f32;
        for ((dst, cj), sj) in sv.c.iter_mut().zip(self.c.iter()).zip(sv.s.iter()).take(n) {
            *dst = cj * sj;
            if dst.abs() > cmax {
                cmax = dst.abs();
            }
        }
        let cs = if cmax > 1e-30 { pow2_recip(cmax) } else { 1.0 };
        for dst in sv.c.iter_mut().take(n) {
            *dst *= cs;
            z += 0.0 * *dst;
        }
        // Inactive entries are 0 (s: 1), finite.
        if z != 0.0 {
            return Err(LpStatus::NonFinite);
        }
        sv.init_basis_vars();
        Ok(bmax)
    }
}

/// Working state. Basis entries: `j < N` structural, `N + i` artificial of row `i`.
struct Solver<const M: usize, const N: usize> {
    /// Column scales (module docs): `x_j = s_j y_j`. Kept here rather than returned
    /// by [`Lp::scale_into`]: moving the array out costs a memcpy on the MCU.
    s: [f32; N],
    a: [[f32; N]; M],
    b: [f32; M],
    c: [f32; N],
    h: [f32; N],
    /// Tableau `B⁻¹ A`.
    t: [[f32; N]; M],
    xb: [f32; M],
    basis: [usize; M],
    basic: [bool; N],
    upper: [bool; N],
    m: usize,
    n: usize,
    iters: u16,
    cap: u16,
    phase1: bool,
    /// Dantzig pricing allowed (Pricing::DantzigBland).
    dantzig: bool,
    /// Last pivot was degenerate: Bland's rule in force.
    bland_now: bool,
    /// The tableau and basic values were rebuilt by [`Self::refactor`] and no pivot
    /// has been made since: a further refactorisation would recompute the same state.
    fresh: bool,
}

impl<const M: usize, const N: usize> Solver<M, N> {
    fn new(m: usize, n: usize, cap: u16) -> Self {
        Self {
            s: [1.0; N],
            a: [[0.0; N]; M],
            b: [0.0; M],
            c: [0.0; N],
            h: [0.0; N],
            t: [[0.0; N]; M],
            xb: [0.0; M],
            basis: [0; M],
            basic: [false; N],
            upper: [false; N],
            m,
            n,
            iters: 0,
            cap,
            phase1: true,
            dantzig: false,
            bland_now: false,
            fresh: false,
        }
    }

    fn init_basis(&mut self) {
        self.t = self.a;
        self.init_basis_vars();
    }

    /// [`Self::init_basis`] but the tableau (already `a`).
    fn init_basis_vars(&mut self) {
        for (i, (var, (xb, bi))) in self.basis.iter_mut().zip(self.xb.iter_mut().zip(self.b.iter())).enumerate() {
            *var = N.saturating_add(i);
            *xb = *bi;
        }
    }

    /// Back to the cold start's state after a rejected warm basis (no pivots were
    /// made: `iters` is still 0).
    fn reset_cold(&mut self) {
        self.init_basis();
        self.basic = [false; N];
        self.upper = [false; N];
        self.phase1 = true;
        self.bland_now = false;
        self.fresh = false;
    }

    /// Install the warm basis `w` for phase 2: `Ok(true)` if it is valid, its basis
    /// matrix regular and its basic values within [`FEAS_TOL`] (scaled) of their
    /// phase-2 bounds (artificials: `[0, 0]`), then clamped onto them; `Ok(false)`
    /// otherwise (the caller then resets to the cold start).
    fn install(&mut self, w: &Basis<M, N>) -> Result<bool, Fault> {
        let (m, n) = (self.m, self.n);
        let mut basic = [false; N];
        let mut art = [false; M];
        for var in w.vars.iter().take(m) {
            let slot = if *var < n {
                basic.get_mut(*var)
            } else {
                match var.checked_sub(N) {
                    Some(i) if i < m => art.get_mut(i),
                    _ => return Ok(false), // inactive column or out of range
                }
            };
            let Some(used) = slot else { return Ok(false) };
            if *used {
                return Ok(false); // duplicate
            }
            *used = true;
        }
        let mut upper = [false; N];
        for (u, ((wu, b), h)) in upper.iter_mut().zip(w.upper.iter().zip(basic.iter()).zip(self.h.iter())).take(n) {
            if *wu && !*b {
                if !h.is_finite() {
                    return Ok(false);
                }
                *u = true;
            }
        }
        for (dst, src) in self.basis.iter_mut().zip(w.vars.iter()).take(m) {
            *dst = *src;
        }
        self.basic = basic;
        self.upper = upper;
        self.phase1 = false;
        // Unsnapped: snapping would move a slightly negative (or, for an artificial,
        // any positive) value onto its bound and hide the infeasibility.
        if !self.refactor_unsnapped()? {
            return Ok(false);
        }
        self.fresh = true;
        for (var, x) in self.basis.iter().zip(self.xb.iter_mut()).take(m) {
            let ub = Self::upper_of_in(false, &self.h, *var)?;
            if !(*x >= -FEAS_TOL && *x <= ub + FEAS_TOL) {
                return Ok(false);
            }
            *x = if *x < 0.0 {
                0.0
            } else if *x > ub {
                ub
            } else {
                *x
            };
        }
        Ok(true)
    }

    /// Cost of a basic variable in the current phase.
    #[inline]
    fn cost_of(&self, var: usize) -> Result<f32, Fault> {
        Ok(if var < N {
            if self.phase1 { 0.0 } else { at(&self.c, var)? }
        } else if self.phase1 {
            1.0
        } else {
            0.0
        })
    }

    /// Upper bound of a basic variable in the current phase.
    #[inline]
    fn upper_of(&self, var: usize) -> Result<f32, Fault> {
        Self::upper_of_in(self.phase1, &self.h, var)
    }

    /// [`Self::upper_of`] from the parts (for loops that borrow other fields mutably).
    #[inline]
    fn upper_of_in(phase1: bool, h: &[f32; N], var: usize) -> Result<f32, Fault> {
        Ok(if var < N {
            at(h, var)?
        } else if phase1 {
            f32::INFINITY
        } else {
            0.0
        })
    }

    /// Costs of the basic variables, row by row, in the current phase.
    #[inline]
    fn basic_costs(&self) -> Result<[f32; M], Fault> {
        let mut cb = [0.0f32; M];
        for (c, var) in cb.iter_mut().zip(self.basis.iter()).take(self.m) {
            *c = self.cost_of(*var)?;
        }
        Ok(cb)
    }

    /// Reduced cost of column `j` given the basic costs `cb`: `c_j - Σ_i cb_i t_ij`
    /// (rows summed in order).
    #[inline]
    fn reduced_cost_with(&self, cb: &[f32; M], j: usize) -> Result<f32, Fault> {
        let cj = if self.phase1 { 0.0 } else { at(&self.c, j)? };
        let mut z = 0.0f32;
        for (row, cbi) in self.t.iter().zip(cb.iter()).take(self.m) {
            z += cbi * at(row, j)?;
        }
        Ok(cj - z)
    }

    /// Entering variable: Bland (lowest eligible index) or Dantzig (largest gain,
    /// lowest index on ties), see [`Pricing`]. The gain of a column is its
    /// improvement rate (> DUAL_TOL ⇒ eligible); basic or fixed columns are skipped.
    fn price(&self) -> Result<Option<usize>, Fault> {
        let cb = self.basic_costs()?;
        let bland = !self.dantzig || self.bland_now;
        let mut best: Option<(usize, f32)> = None;
        let cols = self.basic.iter().zip(self.h.iter()).zip(self.upper.iter());
        for (j, ((&basic, &hj), &upper)) in cols.enumerate().take(self.n) {
            if basic || !(hj > 0.0) {
                continue;
            }
            let d = self.reduced_cost_with(&cb, j)?;
            let gj = if upper { d } else { -d };
            if gj > DUAL_TOL {
                if bland {
                    return Ok(Some(j));
                }
                if best.is_none_or(|(_, gb)| gj > gb) {
                    best = Some((j, gj));
                }
            }
        }
        Ok(best.map(|(j, _)| j))
    }

    /// Ratio-test limit of a row with entering-column entry `t_ij`, basic value `x`
    /// and basic variable `var`, for the entering column moving in direction `s`:
    /// `(step, hits_upper)`.
    #[inline]
    fn row_limit(&self, tij: f32, x: f32, var: usize, s: f32) -> Result<Option<(f32, bool)>, Fault> {
        let alpha = s * tij;
        Ok(if alpha > PIVOT_TOL {
            Some((max0(x) / alpha, false))
        } else if alpha < -PIVOT_TOL {
            let ub = self.upper_of(var)?;
            if ub.is_finite() { Some((max0(ub - x) / -alpha, true)) } else { None }
        } else {
            None
        })
    }

    /// Column `j` of the tableau (active rows; 0 below).
    #[inline]
    fn column(&self, j: usize) -> Result<[f32; M], Fault> {
        let mut col = [0.0f32; M];
        for (dst, row) in col.iter_mut().zip(self.t.iter()).take(self.m) {
            *dst = at(row, j)?;
        }
        Ok(col)
    }

    /// One iteration. `Ok(true)`: pivoted/flipped; `Ok(false)`: optimal.
    fn iterate(&mut self) -> Result<bool, LpStatus> {
        let Some(j) = self.price()? else {
            return Ok(false);
        };
        if self.iters >= self.cap {
            return Err(LpStatus::IterationCap);
        }
        self.iters = self.iters.saturating_add(1);
        let at_upper = at(&self.upper, j)?;
        let s = if at_upper { -1.0f32 } else { 1.0 };
        let hj = at(&self.h, j)?;
        let col = self.column(j)?;
        let m = self.m;

        // Pass 1: the limit of every row, and the minimum ratio (bound flip included).
        let mut lims: [Option<(f32, bool)>; M] = [None; M];
        let mut tmin = hj;
        for (lim_i, (tij, (x, var))) in
            lims.iter_mut().zip(col.iter().zip(self.xb.iter().zip(self.basis.iter()))).take(m)
        {
            *lim_i = self.row_limit(*tij, *x, *var, s)?;
            if let Some((lim, _)) = *lim_i
                && lim < tmin
            {
                tmin = lim;
            }
        }
        if !tmin.is_finite() {
            return Err(LpStatus::Unbounded);
        }
        // Pass 2: Bland among ties — lowest variable index leaves.
        let window = tmin + TIE_TOL;
        let mut choice: Option<(usize, f32, bool)> = None; // (row, step, hits_upper)
        let mut choice_var = usize::MAX;
        let mut flip = false;
        if hj <= window {
            choice_var = j;
            flip = true;
        }
        for (i, (lim_i, &var)) in lims.iter().zip(self.basis.iter()).enumerate().take(m) {
            if let Some((lim, up)) = *lim_i
                && lim <= window
                && var < choice_var
            {
                choice = Some((i, lim, up));
                choice_var = var;
                flip = false;
            }
        }

        if flip {
            self.bland_now = false; // a flip moves by h_j > 0: never degenerate
            for (tij, xb) in col.iter().zip(self.xb.iter_mut()).take(m) {
                *xb -= s * hj * tij;
            }
            put(&mut self.upper, j, !at_upper)?;
            self.snap()?;
            return Ok(true);
        }
        let Some((r, theta, hits_upper)) = choice else {
            // Unreachable: tmin is attained by the flip or by a row.
            return Err(LpStatus::Unbounded);
        };
        self.bland_now = !(theta > 0.0);
        for (tij, xb) in col.iter().zip(self.xb.iter_mut()).take(m) {
            *xb -= s * theta * tij;
        }
        put(&mut self.xb, r, if at_upper { hj } else { 0.0 } + s * theta)?;
        let leaving = at(&self.basis, r)?;
        self.pivot(r, j)?;
        if leaving < N {
            put(&mut self.basic, leaving, false)?;
            put(&mut self.upper, leaving, hits_upper)?;
        }
        put(&mut self.basis, r, j)?;
        put(&mut self.basic, j, true)?;
        put(&mut self.upper, j, false)?;
        self.snap()?;
        Ok(true)
    }

    /// Gauss-Jordan pivot of the tableau on row `r`, column `j` (active columns only:
    /// the inactive ones are zero and stay zero). `B⁻¹` is not kept: [`Self::refactor`]
    /// rebuilds it from the basis when a phase ends.
    fn pivot(&mut self, r: usize, j: usize) -> Result<(), Fault> {
        let n = self.n;
        let prow = at(&self.t, r)?;
        let piv = at(&prow, j)?;
        if piv == 0.0 {
            // Unreachable: the ratio test only pivots on |α| > PIVOT_TOL.
            return Ok(());
        }
        let inv = 1.0 / piv;
        let mut prow_n = prow;
        prow_n.iter_mut().take(n).for_each(|v| *v *= inv);
        put(&mut prow_n, j, 1.0)?;
        for (i, row) in self.t.iter_mut().enumerate().take(self.m) {
            if i == r {
                *row = prow_n;
                continue;
            }
            let f = at(row, j)?;
            if f != 0.0 {
                for (v, p) in row.iter_mut().zip(prow_n.iter()).take(n) {
                    *v -= f * p;
                }
            }
            put(row, j, 0.0)?;
        }
        Ok(())
    }

    /// Snap basic values onto their bounds (clears f32 drift; exact degenerate ties).
    fn snap(&mut self) -> Result<(), Fault> {
        for (var, x) in self.basis.iter().zip(self.xb.iter_mut()).take(self.m) {
            let ub = Self::upper_of_in(self.phase1, &self.h, *var)?;
            if *x < SNAP_TOL {
                *x = 0.0;
            } else if ub.is_finite() && *x > ub - SNAP_TOL {
                *x = ub;
            }
        }
        Ok(())
    }

    /// `B⁻¹` of the current basis by Gauss-Jordan with partial pivoting; `None` if
    /// numerically singular or not finite.
    fn basis_inverse(&self) -> Result<Option<[[f32; M]; M]>, Fault> {
        let m = self.m;
        // Basis matrix, column k = column of basis[k].
        let mut bm = [[0.0f32; M]; M];
        for (k, var) in self.basis.iter().enumerate().take(m) {
            for (i, row) in bm.iter_mut().enumerate().take(m) {
                let v = if *var < N {
                    at(self.a.get(i).ok_or(Fault)?, *var)?
                } else if var.checked_sub(N) == Some(i) {
                    1.0
                } else {
                    0.0
                };
                put(row, k, v)?;
            }
        }
        let mut inv = [[0.0f32; M]; M];
        for (i, row) in inv.iter_mut().enumerate() {
            put(row, i, 1.0)?;
        }
        for col in 0..m {
            // partial pivoting
            let mut p = col;
            let mut best = 0.0f32;
            for (i, row) in bm.iter().enumerate().take(m).skip(col) {
                let v = at(row, col)?.abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > SINGULAR_TOL) {
                return Ok(None);
            }
            if p != col {
                // `slice::swap` panics out of range; `p, col < m <= M` holds but is not
                // visible to the optimiser (tools/elf-check found the panic path).
                if p >= M || col >= M {
                    return Err(Fault);
                }
                bm.swap(p, col);
                inv.swap(p, col);
            }
            let (mut pr, mut pi) = (at(&bm, col)?, at(&inv, col)?);
            let d = 1.0 / at(&pr, col)?;
            pr.iter_mut().for_each(|v| *v *= d);
            pi.iter_mut().for_each(|v| *v *= d);
            for (i, (row, irow)) in bm.iter_mut().zip(inv.iter_mut()).enumerate().take(m) {
                if i == col {
                    *row = pr;
                    *irow = pi;
                    continue;
                }
                let f = at(row, col)?;
                if f != 0.0 {
                    for (v, p) in row.iter_mut().zip(pr.iter()) {
                        *v -= f * p;
                    }
                    for (v, p) in irow.iter_mut().zip(pi.iter()) {
                        *v -= f * p;
                    }
                }
            }
        }
        if !inv.iter().all(|r| r.iter().all(|v| v.is_finite())) {
            return Ok(None);
        }
        Ok(Some(inv))
    }

    /// Rebuild the tableau and the basic values from the scaled data and a fresh `B⁻¹`.
    /// Returns false (and changes nothing) if the basis matrix is numerically singular.
    fn refactor(&mut self) -> Result<bool, Fault> {
        if !self.refactor_unsnapped()? {
            return Ok(false);
        }
        self.snap()?;
        Ok(true)
    }

    /// [`Self::refactor`] without the final [`Self::snap`].
    fn refactor_unsnapped(&mut self) -> Result<bool, Fault> {
        let m = self.m;
        let Some(inv) = self.basis_inverse()? else {
            return Ok(false);
        };
        // rhs = b - Σ_{nonbasic at upper} a_j h_j
        let mut rhs = self.b;
        for (ri, row) in rhs.iter_mut().zip(self.a.iter()).take(m) {
            for (aij, ((basic, upper), hj)) in
                row.iter().zip(self.basic.iter().zip(self.upper.iter()).zip(self.h.iter())).take(self.n)
            {
                if !basic && *upper {
                    *ri -= aij * hj;
                }
            }
        }
        for (i, (trow, (irow, xb))) in self.t.iter_mut().zip(inv.iter().zip(self.xb.iter_mut())).enumerate().take(m) {
            let _ = i;
            for (j, tv) in trow.iter_mut().enumerate().take(self.n) {
                let mut acc = 0.0f32;
                for (ik, arow) in irow.iter().zip(self.a.iter()).take(m) {
                    acc += ik * at(arow, j)?;
                }
                *tv = acc;
            }
            let mut acc = 0.0f32;
            for (ik, r) in irow.iter().zip(rhs.iter()).take(m) {
                acc += ik * r;
            }
            *xb = acc;
        }
        self.refine(&inv)?;
        // Exact unit columns for the basic structurals.
        for (k, var) in self.basis.iter().enumerate().take(m) {
            if *var < N {
                for (i, trow) in self.t.iter_mut().enumerate().take(m) {
                    put(trow, *var, if i == k { 1.0 } else { 0.0 })?;
                }
            }
        }
        Ok(true)
    }

    /// One step of iterative refinement of the basic values with a compensated
    /// residual (Ogita-Rump-Oishi Dot2: TwoSum + Dekker TwoProduct, f32 only):
    /// `r = b - Σ_{nonbasic at upper} a_j h_j - B x_B` is evaluated as if in twice the
    /// working precision, then `x_B += B⁻¹ r`. This brings the basic solution (and so
    /// λ) from `cond(B)·ε` to ~`ε` accuracy for `cond(B) << 1/ε`. Skipped if anything
    /// is non-finite (huge data).
    fn refine(&mut self, inv: &[[f32; M]; M]) -> Result<(), Fault> {
        let m = self.m;
        let mut r = [0.0f32; M];
        for (i, (ri, (arow, bi))) in r.iter_mut().zip(self.a.iter().zip(self.b.iter())).enumerate().take(m) {
            let mut acc = Dot2::new(*bi);
            for (aij, ((basic, upper), hj)) in
                arow.iter().zip(self.basic.iter().zip(self.upper.iter()).zip(self.h.iter())).take(self.n)
            {
                if !basic && *upper {
                    acc.add_prod(-*aij, *hj);
                }
            }
            for (var, xb) in self.basis.iter().zip(self.xb.iter()).take(m) {
                let coef = if *var < N {
                    at(arow, *var)?
                } else if var.checked_sub(N) == Some(i) {
                    1.0
                } else {
                    0.0
                };
                acc.add_prod(-coef, *xb);
            }
            *ri = acc.value();
        }
        if !r.iter().all(|v| v.is_finite()) {
            return Ok(());
        }
        let mut upd = [0.0f32; M];
        for (u, irow) in upd.iter_mut().zip(inv.iter()).take(m) {
            *u = irow.iter().zip(r.iter()).take(m).map(|(a, b)| a * b).sum();
        }
        if upd.iter().all(|v| v.is_finite()) {
            for (x, u) in self.xb.iter_mut().zip(upd.iter()).take(m) {
                *x += u;
            }
        }
        Ok(())
    }

    fn run_phase(&mut self) -> Result<(), LpStatus> {
        // Each pass either pivots (bounded by the cap) or ends the phase; the outer
        // loop runs at most cap + 1 times.
        //
        // No refactorisation when nothing was pivoted since the last one (warm start
        // already optimal, or phase 2 making no pivot after phase 1's).
        loop {
            match self.iterate() {
                Ok(true) => {
                    self.fresh = false;
                    continue;
                }
                Ok(false) => {
                    if self.fresh {
                        return Ok(());
                    }
                    if self.refactor()? {
                        self.fresh = true;
                        if self.price()?.is_some() {
                            continue;
                        }
                    }
                    return Ok(());
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn extract(&self, status: LpStatus, lp: &Lp<M, N>, margins: bool) -> LpSolution<N> {
        if status == LpStatus::InternalError {
            return LpSolution::failed(status, self.iters);
        }
        self.try_extract(status, lp, margins).unwrap_or(LpSolution::failed(LpStatus::InternalError, self.iters))
    }

    fn try_extract(&self, status: LpStatus, lp: &Lp<M, N>, margins: bool) -> Result<LpSolution<N>, Fault> {
        let mut y = [0.0f32; N];
        for (yj, ((basic, upper), hj)) in
            y.iter_mut().zip(self.basic.iter().zip(self.upper.iter()).zip(self.h.iter())).take(self.n)
        {
            if !basic && *upper {
                *yj = *hj;
            }
        }
        let mut primal_margin = f32::INFINITY;
        for (var, xb) in self.basis.iter().zip(self.xb.iter()).take(self.m) {
            if *var < N {
                put(&mut y, *var, *xb)?;
                let ub = at(&self.h, *var)?;
                let gap = if ub.is_finite() { xb.min(ub - xb) } else { *xb };
                if gap < primal_margin {
                    primal_margin = gap;
                }
            }
        }
        let mut dual_margin = 0.0f32;
        if status == LpStatus::Optimal && margins {
            dual_margin = f32::INFINITY;
            let cb = self.basic_costs()?;
            for (j, (basic, hj)) in self.basic.iter().zip(self.h.iter()).enumerate().take(self.n) {
                if !basic && *hj > 0.0 {
                    let d = self.reduced_cost_with(&cb, j)?.abs();
                    if d < dual_margin {
                        dual_margin = d;
                    }
                }
            }
        }
        let mut x = [0.0f32; N];
        let mut obj = 0.0f32;
        for (((xj, yj), sj), (hj, cj)) in
            x.iter_mut().zip(y.iter()).zip(self.s.iter()).zip(lp.h.iter().zip(lp.c.iter())).take(self.n)
        {
            let v = max0(yj * sj);
            *xj = if v > *hj { *hj } else { v };
            obj += cj * *xj;
        }
        if !(obj.is_finite() && x.iter().all(|v| v.is_finite())) {
            // overflow of finite-but-huge data: report it, never return inf/NaN
            return Ok(LpSolution::failed(LpStatus::NonFinite, self.iters));
        }
        Ok(LpSolution { x, objective: obj, iterations: self.iters, status, dual_margin, primal_margin })
    }
}

/// Compensated dot-product accumulator (Dot2, Ogita-Rump-Oishi 2005) in f32:
/// error-free TwoSum and Dekker's TwoProduct (Veltkamp split by 2^12 + 1).
pub(crate) struct Dot2 {
    s: f32,
    c: f32,
}

impl Dot2 {
    #[inline]
    pub(crate) fn new(x: f32) -> Self {
        Self { s: x, c: 0.0 }
    }
    #[inline]
    fn split(a: f32) -> (f32, f32) {
        let t = 4097.0 * a;
        let hi = t - (t - a);
        (hi, a - hi)
    }
    #[inline]
    pub(crate) fn add_prod(&mut self, a: f32, b: f32) {
        let p = a * b;
        let (ah, al) = Self::split(a);
        let (bh, bl) = Self::split(b);
        let ep = al * bl - (((p - ah * bh) - al * bh) - ah * bl);
        let s = self.s + p;
        let z = s - self.s;
        let es = (self.s - (s - z)) + (p - z);
        self.s = s;
        self.c += ep + es;
    }
    #[inline]
    pub(crate) fn value(&self) -> f32 {
        self.s + self.c
    }
}

/// Panic-free clamp (`f32::clamp` asserts `lo <= hi`): `lo` wins if `lo > hi`,
/// NaN `x` gives `lo`.
#[inline(always)]
pub(crate) fn clampf(x: f32, lo: f32, hi: f32) -> f32 {
    if !(x >= lo) {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// Solve the 3×3 system `a z = r` by Gaussian elimination with partial pivoting,
/// plus one step of iterative refinement with a compensated residual ([`Dot2`]).
/// `Ok(None)` if singular (pivot < 1e-12 · max |a|) or non-finite.
pub(crate) fn solve3(a: &[[f32; 3]; 3], r: &[f32; 3]) -> Result<Option<[f32; 3]>, Fault> {
    let amax = a.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
    if !(amax > 0.0) || !amax.is_finite() {
        return Ok(None);
    }
    let elim = |rhs: &[f32; 3]| -> Result<Option<[f32; 3]>, Fault> {
        let mut m = *a;
        let mut v = *rhs;
        // column 0..2 pivoting, written out (no runtime indexing)
        let piv = |m: &mut [[f32; 3]; 3], v: &mut [f32; 3], c: usize| -> Result<f32, Fault> {
            let mut best = c;
            let mut bv = 0.0f32;
            for (i, row) in m.iter().enumerate().skip(c) {
                let x = at(row, c)?.abs();
                if x > bv {
                    bv = x;
                    best = i;
                }
            }
            m.swap(c.min(2), best.min(2));
            v.swap(c.min(2), best.min(2));
            Ok(bv)
        };
        for c in 0..3usize {
            if !(piv(&mut m, &mut v, c)? > 1e-12 * amax) {
                return Ok(None);
            }
            let (prow, pv) = (at(&m, c)?, at(&v, c)?);
            let p = at(&prow, c)?;
            for (row, vi) in m.iter_mut().zip(v.iter_mut()).skip(c.saturating_add(1)) {
                let f = at(row, c)? / p;
                for (x, y) in row.iter_mut().zip(prow.iter()) {
                    *x -= f * y;
                }
                *vi -= f * pv;
            }
        }
        let mut z = [0.0f32; 3];
        for c in (0..3usize).rev() {
            let row = at(&m, c)?;
            let mut acc = at(&v, c)?;
            for (k, zk) in z.iter().enumerate().skip(c.saturating_add(1)) {
                acc -= at(&row, k)? * zk;
            }
            *z.get_mut(c).ok_or(Fault)? = acc / at(&row, c)?;
        }
        Ok(if z.iter().all(|x| x.is_finite()) { Some(z) } else { None })
    };
    let Some(z) = elim(r)? else {
        return Ok(None);
    };
    let mut res = [0.0f32; 3];
    for ((ri, row), rhs) in res.iter_mut().zip(a.iter()).zip(r.iter()) {
        let mut acc = Dot2::new(*rhs);
        for (aij, zj) in row.iter().zip(z.iter()) {
            acc.add_prod(-*aij, *zj);
        }
        *ri = acc.value();
    }
    Ok(match elim(&res)? {
        Some(dz) => {
            let mut out = z;
            for (o, d) in out.iter_mut().zip(dz.iter()) {
                *o += d;
            }
            Some(out)
        }
        None => Some(z),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2() {
        assert_eq!(pow2_recip(1.0), 1.0);
        assert_eq!(pow2_recip(3.0), 0.5);
        assert_eq!(pow2_recip(0.3), 4.0);
        assert_eq!(pow2_recip(0.0), 1.0);
        assert_eq!(pow2_recip(f32::NAN), 1.0);
        assert!(pow2_recip(f32::MAX) > 0.0);
    }

    #[test]
    fn small_lp() {
        // min -x0 - 2 x1, x0 + x1 = 1, x in [0, 1]^2 plus slack: x0 + x1 + s = 1.5
        let mut lp = Lp::<1, 3>::zeroed(1, 3);
        lp.a = [[1.0, 1.0, 1.0]];
        lp.b = [1.5];
        lp.c = [-1.0, -2.0, 0.0];
        lp.h = [1.0, 1.0, f32::INFINITY];
        let s = lp.solve();
        assert_eq!(s.status, LpStatus::Optimal);
        assert!((s.objective + 2.5).abs() < 1e-6, "{s:?}");
    }

    #[test]
    fn infeasible_and_unbounded() {
        let mut lp = Lp::<1, 2>::zeroed(1, 2);
        lp.a = [[1.0, 1.0]];
        lp.b = [3.0];
        lp.h = [1.0, 1.0];
        assert_eq!(lp.solve().status, LpStatus::Infeasible);
        lp.h = [f32::INFINITY, f32::INFINITY];
        lp.c = [-1.0, 0.0];
        lp.a = [[1.0, -1.0]];
        lp.b = [0.5];
        assert_eq!(lp.solve().status, LpStatus::Unbounded);
        lp.b = [f32::NAN];
        assert_eq!(lp.solve().status, LpStatus::NonFinite);
    }
}

#[cfg(test)]
mod validation_tests {
    use super::*;

    /// `x0 + x1 = 1`, `x in [0, 1]^2`, `min -x0`: optimum `x = (1, 0)`.
    fn base() -> Lp<1, 2> {
        let mut lp = Lp::<1, 2>::zeroed(1, 2);
        lp.a = [[1.0, 1.0]];
        lp.b = [1.0];
        lp.c = [-1.0, 0.0];
        lp.h = [1.0, 1.0];
        lp
    }

    #[test]
    fn every_non_finite_input_is_reported_before_a_negative_bound() {
        assert_eq!(base().solve().status, LpStatus::Optimal);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut cases = [base(), base(), base(), base()];
            cases[0].a[0][1] = bad;
            cases[1].b[0] = bad;
            cases[2].c[1] = bad;
            cases[3].h[0] = if bad == f32::INFINITY { f32::NAN } else { bad };
            for (k, mut lp) in cases.into_iter().enumerate() {
                assert_eq!(lp.solve().status, LpStatus::NonFinite, "case {k}, {bad}");
                // NonFinite wins over the infeasibility of a negative bound.
                lp.h[1] = -1.0;
                assert_eq!(lp.solve().status, LpStatus::NonFinite, "case {k}, {bad}, h < 0");
            }
        }
        let mut lp = base();
        lp.h[1] = -1.0;
        assert_eq!(lp.solve().status, LpStatus::Infeasible);
        // An inactive column may hold anything: it is not part of the problem.
        let mut lp = base();
        lp.cols = 1;
        lp.a[0][1] = f32::NAN;
        lp.h[1] = -1.0;
        let s = lp.solve();
        assert_eq!((s.status, s.x), (LpStatus::Optimal, [1.0, 0.0]));
    }

    #[test]
    fn the_lean_solve_differs_only_by_the_unreported_dual_margin() {
        let mut lp = Lp::<2, 4>::zeroed(2, 4);
        lp.a = [[1.0, 2.0, -1.0, 0.5], [0.0, 1.0, 1.0, -2.0]];
        lp.b = [1.0, 0.5];
        lp.c = [1.0, -1.0, 0.5, 0.25];
        lp.h = [1.0, 1.0, 2.0, f32::INFINITY];
        let full = lp.solve();
        assert_eq!(full.status, LpStatus::Optimal);
        assert!(full.dual_margin > 0.0 && full.dual_margin.is_finite());
        let lean = lp.solve_lean(default_iteration_cap(2, 4), None, None);
        assert_eq!(lean.dual_margin, 0.0);
        assert_eq!(LpSolution { dual_margin: full.dual_margin, ..lean }, full);
    }
}

#[cfg(test)]
mod internal_error_tests {
    use super::*;
    use crate::allocation::AllocStatus;

    #[test]
    fn an_index_out_of_range_is_an_internal_error_not_a_plausible_number() {
        assert_eq!(at(&[1.0f32; 2], 2), Err(Fault));
        let mut v = [0.0f32; 2];
        assert_eq!(put(&mut v, 5, 1.0), Err(Fault));
        assert_eq!(v, [0.0; 2]);
        assert_eq!(LpStatus::from(Fault), LpStatus::InternalError);
        let al = crate::allocation::thruster::paper::paper_allocator(1.0);
        assert_eq!(al.bodson_lp(&[1.0, 0.0, 0.0], 3, &al.nominal_bounds(), true).err(), Some(Fault));
        assert_eq!(crate::fsw::report::alloc_status(AllocStatus::InternalError), crate::types::Status::ALLOC_FALLBACK);
    }
}
