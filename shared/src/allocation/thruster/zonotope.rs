//! Exact geometric solve of the direction-preserving allocation (paper 004, eqs 12-18,
//! and its fuel stage) for three-axis moments: no pivoting, a fixed number of dot
//! products, then one or two 3×3 solves.
//!
//! # Stage 1: λ (eq 18) from the facets of the attainable set
//! With `x = u - u_lo ∈ [0, s]` (`s = u_hi - u_lo`), the attainable moments form the
//! zonotope `Z = c₀ + Σ_k g_k [0, 1]`, `g_k = s_k b_k`, `c₀ = B u_lo` (fixed thrusters
//! included). A full-dimensional zonotope in R³ has exactly the facet normals
//! `n = g_a × g_b` (pairs of generators) and support `h(n) = n·c₀ + Σ_k max(0, n·g_k)`.
//! When `u = 0` is admissible (`0 ∈ Z`, so `h >= 0`), `λ d ∈ Z` iff `λ n·d <= h(n)`
//! for every facet, hence `λ_max = min_{n·d > 0} h(n) / (n·d)` (each pair checked with
//! the orientation of `n` that has `n·d > 0`). On the minimising facet `(a, b)` the
//! other thrusters sit at the bound given by the sign of `n·g_k` (upper if positive),
//! and `[b_a, b_b, -m_d] [u_a, u_b, λ]ᵀ = -Σ_{k≠a,b} b_k u_k` gives the LP's vertex
//! (the facet point is unique when no other generator lies in the facet's plane).
//!
//! # Stage 2 (λ = 1): minimum propellant from the lower facets of a 4-D zonotope
//! `min Σ w_k u_k, B u = m_d` is the lowest point above `m_d` of the 4-D zonotope
//! `Z₄ = {(B u, wᵀu)}`, generators `G_k = s_k (b_k, w_k)`. Its facet normals `ν` are
//! orthogonal to triples of generators (`ν·G = det[G, G_a, G_b, G_c]`); orienting
//! them downwards (`ν₄ < 0`), the least fuel is `F = max_T (ν_xyz·m_d - h(ν)) / (-ν₄)`
//! (LP duality: the lower boundary of `Z₄` is the maximum of its lower facets' planes).
//! On the maximising facet the other thrusters sit at the bound given by the sign of
//! `ν·G_k` and `B_T u_T = m_d - Σ_{k∉T} b_k u_k` gives the triple's levels: the fuel
//! LP's optimal basis, without pivoting.
//!
//! Fuel ties: when a fourth generator lies in the facet's hyperplane (`ν·G_e ≈ 0`,
//! e.g. the paper layout's pairs `b1 + b5 = b3 + b7`: same moment, same fuel), the
//! optimal commands form a segment `u(t) = u⁰ + t v` (`u_e = u_lo,e + t`, `B v = 0`,
//! `wᵀv = 0`). The simplex returned whichever end its pivoting path reached; here the
//! tie is broken deterministically as by fuel weights `w_i (1 + ε (i + 1))`, `ε → 0⁺`
//! (the documented tie-break tip of [`super::lp::Allocator::with_fuel_weights`] in
//! the limit): the end minimising `Σ (i + 1) u_i`, i.e. lower-index thrusters first.
//!
//! # When it declines (`Ok(None)`: the caller runs the simplex instead)
//! `u = 0` not admissible (stuck-on thruster or rate limits excluding 0), non-finite
//! fuel weights, fewer than 3 movable thrusters, a degenerate minimising facet (another
//! generator within `DEGEN_TOL` of its plane, which also catches a flat, rank-deficient
//! `Z`, e.g. after failures), a grazing ray (`n·d` within `DEGEN_TOL`), more than one
//! generator in the optimal fuel facet, no lower facet (rank-deficient `B`), a singular
//! 3×3 system, or a solution outside its bounds by more than `BOUND_TOL` of the span.
//! Loops: pairs `≤ N²/2`, triples `≤ N³/6`, each over `N` generators: bounded by the
//! capacity `N <= 32`, no iteration depends on the data.

use super::Bounds;
use super::simplex::{Dot2, Fault, at, clampf, solve3};
use crate::allocation::AXES;

/// A generator is "in a facet's plane" when `|n·g| <= DEGEN_TOL · ‖n‖₁ · max|g|`
/// (f32 rounding of these products is ~1e-7 of that scale).
const DEGEN_TOL: f32 = 1e-5;
/// A facet solution may leave its bounds by this fraction of the span (rounding near
/// an edge of the attainable set); it is then clamped onto them.
const BOUND_TOL: f32 = 1e-5;
/// A fuel slope along a tie segment within this fraction of its terms' magnitudes is
/// rounding (f32 ε = 1.2e-7, a 3×3 solve and four products): an exact tie.
const FUEL_TIE: f32 = 1e-6;

/// Result of [`solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Geo<const N: usize> {
    /// `λ < 1` (to within `lambda_tol` it is reported as attained by the caller): the
    /// boundary point along the demand.
    Boundary { u: [f32; N], lambda: f32 },
    /// `λ = 1`: the fuel optimum.
    Attained { u: [f32; N] },
}

/// Movable thrusters' data, compacted to the first `nc` slots (LP column order).
struct Gens<const N: usize> {
    /// `s_k (b_k, w_k)`: moment and fuel per unit of `x̂_k ∈ [0, 1]`.
    g: [[f32; 4]; N],
    /// Thruster index of slot `k`.
    map: [usize; N],
    nc: usize,
    /// `(B u_lo, wᵀ u_lo)` over all thrusters.
    c0: [f32; 4],
    /// `max |g|` over the moment rows, and over all four rows.
    gmax3: f32,
    gmax4: f32,
}

fn dot3(a: &[f32; 4], b: &[f32; 3]) -> f32 {
    let [a0, a1, a2, _] = *a;
    let [b0, b1, b2] = *b;
    a0 * b0 + a1 * b1 + a2 * b2
}

fn dot4(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    let [a0, a1, a2, a3] = *a;
    let [b0, b1, b2, b3] = *b;
    a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
}

/// Stage-1 facet: pair of slots `(a, b)`, normal `n` oriented so that `n·d > 0`.
struct Facet3 {
    a: usize,
    b: usize,
    n: [f32; 3],
    lambda: f32,
}

/// Stage-2 facet: triple of slots, normal `ν` with `ν₄ < 0`.
struct Facet4 {
    t: [usize; 3],
    nu: [f32; 4],
}

/// See the module docs. `b` is `B` (3 × N), `w` the fuel weights, `map[..nc]` the
/// movable thrusters ([`super::lp::Allocator::movable`]), `lambda_tol` the caller's
/// "attained" tolerance. Inputs are assumed finite with consistent bounds (checked by
/// the caller). `Err` only on an index out of range (a logic error).
pub(crate) fn solve<const N: usize>(
    b: &[[f32; N]; AXES],
    w: &[f32; N],
    bd: &Bounds<N>,
    map: &[usize; N],
    nc: usize,
    m_d: &[f32; AXES],
    lambda_tol: f32,
) -> Result<Option<Geo<N>>, Fault> {
    if nc < 3
        || !w.iter().all(|x| x.is_finite())
        || !bd.lo.iter().zip(bd.hi.iter()).all(|(l, h)| *l <= 0.0 && *h >= 0.0)
    {
        return Ok(None);
    }
    let gens = gather(b, w, bd, map, nc)?;
    let f = match stage1(&gens, m_d, 1.0) {
        Stage1::AtLeastOne => return stage2(b, w, bd, &gens, m_d),
        Stage1::Grazing => return Ok(None),
        Stage1::Facet(f) => f,
    };
    Ok(match facet_point(b, bd, &gens, &f, m_d)? {
        Some((u, lambda)) if lambda >= -lambda_tol && lambda <= 1.0 + lambda_tol => {
            Some(Geo::Boundary { u, lambda: clampf(lambda, 0.0, 1.0) })
        }
        _ => None,
    })
}

/// The boundary point of the attainable set along `m` (no cap on λ) and its `λ`, for
/// Bodson's method: stage 1 with an infinite initial bound, then the facet solve.
/// `Ok(None)` where [`solve`] would decline (and when `0 ∉ Z`); `Err` on a logic error.
pub(crate) fn boundary<const N: usize>(
    b: &[[f32; N]; AXES],
    bd: &Bounds<N>,
    map: &[usize; N],
    nc: usize,
    m: &[f32; AXES],
) -> Result<Option<([f32; N], f32)>, Fault> {
    if nc < 3 || !bd.lo.iter().zip(bd.hi.iter()).all(|(l, h)| *l <= 0.0 && *h >= 0.0) {
        return Ok(None);
    }
    let gens = gather(b, &[0.0; N], bd, map, nc)?;
    match stage1(&gens, m, f32::INFINITY) {
        Stage1::Facet(f) => facet_point(b, bd, &gens, &f, m),
        Stage1::AtLeastOne | Stage1::Grazing => Ok(None),
    }
}

/// On facet `f`: the other generators at the bound of their side, and
/// `[b_a, b_b, -m] [u_a, u_b, λ]ᵀ = -Σ_{k≠a,b} b_k u_k` (compensated right-hand side,
/// refined 3×3 solve): `(u, λ)`, or `None` if the facet is degenerate, the system
/// singular or `u_a`, `u_b` outside their bounds (beyond `BOUND_TOL`).
fn facet_point<const N: usize>(
    b: &[[f32; N]; AXES],
    bd: &Bounds<N>,
    gens: &Gens<N>,
    f: &Facet3,
    m: &[f32; AXES],
) -> Result<Option<([f32; N], f32)>, Fault> {
    let (ja, jb) = (at(&gens.map, f.a)?, at(&gens.map, f.b)?);
    if !facet_is_proper(gens, &f.n, f.a, f.b)? {
        return Ok(None);
    }
    let mut u = bd.lo;
    for (k, gk) in gens.g.iter().enumerate().take(gens.nc) {
        if k != f.a && k != f.b && dot3(gk, &f.n) > 0.0 {
            let j = at(&gens.map, k)?;
            *u.get_mut(j).ok_or(Fault)? = at(&bd.hi, j)?;
        }
    }
    let mut a3 = [[0.0f32; 3]; 3];
    let mut r = [0.0f32; 3];
    for ((arow, ri), (brow, mi)) in a3.iter_mut().zip(r.iter_mut()).zip(b.iter().zip(m.iter())) {
        *arow = [at(brow, ja)?, at(brow, jb)?, -mi];
        *ri = moment_except(0.0, brow, &u, ja, jb, usize::MAX);
    }
    let Some([za, zb, lambda]) = solve3(&a3, &r)? else {
        return Ok(None);
    };
    let (Some(xa), Some(xb)) = (within(za, bd, ja)?, within(zb, bd, jb)?) else {
        return Ok(None);
    };
    if !lambda.is_finite() {
        return Ok(None);
    }
    *u.get_mut(ja).ok_or(Fault)? = xa;
    *u.get_mut(jb).ok_or(Fault)? = xb;
    Ok(Some((u, lambda)))
}

/// `r0 - Σ_{j ∉ {e1, e2, e3}} b_j u_j` over all thrusters, compensated ([`Dot2`]).
fn moment_except<const N: usize>(r0: f32, brow: &[f32; N], u: &[f32; N], e1: usize, e2: usize, e3: usize) -> f32 {
    let mut acc = Dot2::new(r0);
    for (j, (bij, x)) in brow.iter().zip(u.iter()).enumerate() {
        if j != e1 && j != e2 && j != e3 && *bij != 0.0 && *x != 0.0 {
            acc.add_prod(-*bij, *x);
        }
    }
    acc.value()
}

/// `z` if within `[lo_j, hi_j]` up to `BOUND_TOL` of the span (then clamped), else `None`.
fn within<const N: usize>(z: f32, bd: &Bounds<N>, j: usize) -> Result<Option<f32>, Fault> {
    let (lo, hi) = (at(&bd.lo, j)?, at(&bd.hi, j)?);
    let tol = BOUND_TOL * (hi - lo);
    Ok(if z >= lo - tol && z <= hi + tol { Some(clampf(z, lo, hi)) } else { None })
}

fn gather<const N: usize>(
    b: &[[f32; N]; AXES],
    w: &[f32; N],
    bd: &Bounds<N>,
    map: &[usize; N],
    nc: usize,
) -> Result<Gens<N>, Fault> {
    let [bx, by, bz] = b;
    let mut c0 = [0.0f32; 4];
    for ((((x, y), z), wk), lo) in bx.iter().zip(by.iter()).zip(bz.iter()).zip(w.iter()).zip(bd.lo.iter()) {
        if *lo != 0.0 {
            let [c0x, c0y, c0z, c0w] = &mut c0;
            *c0x += x * lo;
            *c0y += y * lo;
            *c0z += z * lo;
            *c0w += wk * lo;
        }
    }
    let mut g = [[0.0f32; 4]; N];
    let (mut gmax3, mut gmax4) = (0.0f32, 0.0f32);
    for (gk, &j) in g.iter_mut().zip(map.iter()).take(nc) {
        let s = at(&bd.hi, j)? - at(&bd.lo, j)?;
        *gk = [s * at(bx, j)?, s * at(by, j)?, s * at(bz, j)?, s * at(w, j)?];
        for (i, v) in gk.iter().enumerate() {
            if i < 3 {
                gmax3 = gmax3.max(v.abs());
            }
            gmax4 = gmax4.max(v.abs());
        }
    }
    Ok(Gens { g, map: *map, nc, c0, gmax3, gmax4 })
}

/// Outcome of [`stage1`].
enum Stage1 {
    /// No facet has `h(n) / (n·d) < cap`: `λ_max >= cap`.
    AtLeastOne,
    /// The minimising facet, `λ < 1`.
    Facet(Facet3),
    /// The ray grazes the minimising facet (`n·d` within `DEGEN_TOL`): ill-conditioned.
    Grazing,
}

/// `λ_max` and its facet (module docs).
fn stage1<const N: usize>(gens: &Gens<N>, d: &[f32; AXES], cap: f32) -> Stage1 {
    let nc = gens.nc;
    let mut best: Option<Facet3> = None;
    // λ is capped (at 1 by eq 18; none for Bodson's boundary point): a facet with
    // h/(n·d) >= cap never matters, so the cap is the initial bound, and a pair is
    // dropped as soon as its partial support (a sum of non-negative terms) reaches
    // `best · n·d`.
    let mut best_lambda = cap;
    for (a, ga) in gens.g.iter().enumerate().take(nc) {
        let [xa, ya, za, _] = *ga;
        for (bi, gb) in gens.g.iter().enumerate().take(nc).skip(a.saturating_add(1)) {
            let [xb, yb, zb, _] = *gb;
            let mut n = [ya * zb - za * yb, za * xb - xa * zb, xa * yb - ya * xb];
            let mut nd = n.iter().zip(d.iter()).map(|(p, q)| p * q).sum::<f32>();
            if nd == 0.0 {
                continue; // parallel to d: does not bound λ (0 ∈ Z)
            }
            if nd < 0.0 {
                n = n.map(|v| -v);
                nd = -nd;
            }
            let lim = best_lambda * nd;
            let mut h = dot3(&gens.c0, &n);
            let mut pruned = false;
            for gk in gens.g.iter().take(nc) {
                let p = dot3(gk, &n);
                if p > 0.0 {
                    h += p;
                    if h >= lim {
                        pruned = true;
                        break;
                    }
                }
            }
            // The pair's own generators give p ≈ 0 (rounding) either side: harmless
            // in h (at most ~1e-7 relative), and the facet test below excludes them.
            let lambda = h / nd;
            if !pruned && lambda < best_lambda {
                best_lambda = lambda;
                best = Some(Facet3 { a, b: bi, n, lambda });
            }
        }
    }
    let Some(f) = best else {
        return Stage1::AtLeastOne;
    };
    // A grazing ray (n·d tiny against ‖n‖‖d‖) makes λ ill-conditioned: decline.
    let nn: f32 = f.n.iter().map(|v| v.abs()).sum();
    let dn: f32 = d.iter().map(|v| v.abs()).sum();
    let nd: f32 = f.n.iter().zip(d.iter()).map(|(p, q)| p * q).sum();
    if !(nd > DEGEN_TOL * nn * dn) || !f.lambda.is_finite() {
        return Stage1::Grazing;
    }
    Stage1::Facet(f)
}

/// No generator other than `a`, `b` within `DEGEN_TOL` of the facet's plane (then the
/// facet is a parallelogram and its point along the ray unique), and `n` not tiny.
fn facet_is_proper<const N: usize>(gens: &Gens<N>, n: &[f32; 3], a: usize, b: usize) -> Result<bool, Fault> {
    let nn: f32 = n.iter().map(|v| v.abs()).sum();
    let tol = DEGEN_TOL * nn * gens.gmax3;
    if !(tol > 0.0) {
        return Ok(false);
    }
    for (k, gk) in gens.g.iter().enumerate().take(gens.nc) {
        if k != a && k != b && !(dot3(gk, n).abs() > tol) {
            return Ok(false);
        }
    }
    Ok(true)
}

/// The fuel optimum for an attainable demand (module docs, stage 2).
fn stage2<const N: usize>(
    b: &[[f32; N]; AXES],
    w: &[f32; N],
    bd: &Bounds<N>,
    gens: &Gens<N>,
    m_d: &[f32; AXES],
) -> Result<Option<Geo<N>>, Fault> {
    let Some(f) = best_lower_facet(gens, m_d) else {
        return Ok(None);
    };
    let Some(OffFacet { mut u, tie }) = off_facet_at_bounds(gens, bd, &f)? else {
        return Ok(None);
    };
    let [t0, t1, t2] = f.t;
    let js = [at(&gens.map, t0)?, at(&gens.map, t1)?, at(&gens.map, t2)?];
    let [j0, j1, j2] = js;
    let mut bt = [[0.0f32; 3]; 3];
    let mut r = [0.0f32; 3];
    for ((brow_t, ri), (brow, mi)) in bt.iter_mut().zip(r.iter_mut()).zip(b.iter().zip(m_d.iter())) {
        *brow_t = [at(brow, j0)?, at(brow, j1)?, at(brow, j2)?];
        *ri = moment_except(*mi, brow, &u, j0, j1, j2);
    }
    let Some(z0) = solve3(&bt, &r)? else {
        return Ok(None);
    };
    let z = match tie {
        None => z0,
        Some(k) => {
            // Segment u_T = z0 + t v, u_e = lo_e + t, t ∈ [0, s_e], B_T v = -b_e.
            let e = at(&gens.map, k)?;
            let mut be = [0.0f32; 3];
            for (x, brow) in be.iter_mut().zip(b.iter()) {
                *x = -at(brow, e)?;
            }
            let Some(v) = solve3(&bt, &be)? else {
                return Ok(None);
            };
            let (lo_e, hi_e) = (at(&bd.lo, e)?, at(&bd.hi, e)?);
            // The feasible t: exact bounds; if rounding empties it, the bounds widened by
            // BOUND_TOL of their spans (the solution is then clamped below).
            let mut range = None;
            for slack in [0.0f32, BOUND_TOL] {
                if range.is_none() {
                    range = t_range(&z0, &v, &js, bd, hi_e - lo_e, slack)?;
                }
            }
            let Some((tmin, tmax)) = range else {
                return Ok(None);
            };
            let t = if least_fuel_slope(w, e, &v, &js)? > 0.0 { tmin } else { tmax };
            *u.get_mut(e).ok_or(Fault)? = lo_e + t;
            let mut z = z0;
            for (zj, vj) in z.iter_mut().zip(v.iter()) {
                *zj += t * vj;
            }
            z
        }
    };
    for (zj, &j) in z.iter().zip(js.iter()) {
        let Some(x) = within(*zj, bd, j)? else {
            return Ok(None);
        };
        *u.get_mut(j).ok_or(Fault)? = x;
    }
    Ok(Some(Geo::Attained { u }))
}

/// The generators of `gens` off the facet `f` at the bound of their side (`hi` where
/// `g·ν > 0`, `lo` otherwise) as a command, and the one generator in the facet's
/// hyperplane (within `DEGEN_TOL`), if any; `None` when two or more lie in it.
fn off_facet_at_bounds<const N: usize>(
    gens: &Gens<N>,
    bd: &Bounds<N>,
    f: &Facet4,
) -> Result<Option<OffFacet<N>>, Fault> {
    let nn: f32 = f.nu.iter().map(|v| v.abs()).sum();
    let tol = DEGEN_TOL * nn * gens.gmax4;
    // Other generators: at the bound of their side; at most one in the hyperplane.
    let mut u = bd.lo;
    let mut tie: Option<usize> = None;
    let [t0, t1, t2] = f.t;
    for (k, gk) in gens.g.iter().enumerate().take(gens.nc) {
        if k == t0 || k == t1 || k == t2 {
            continue;
        }
        let q = dot4(gk, &f.nu);
        if !(q.abs() > tol) {
            if tie.is_some() {
                return Ok(None);
            }
            tie = Some(k);
        } else if q > 0.0 {
            let j = at(&gens.map, k)?;
            *u.get_mut(j).ok_or(Fault)? = at(&bd.hi, j)?;
        }
    }
    Ok(Some(OffFacet { u, tie }))
}

/// [`off_facet_at_bounds`]' result: the command so far and the generator in the plane.
struct OffFacet<const N: usize> {
    u: [f32; N],
    tie: Option<usize>,
}

/// Along the tie segment `u_e = lo_e + t`, `u_T = z0 + t v`: the slope that decides its
/// end, the fuel slope `w_e + Σ w_j v_j` (a near-tie within DEGEN_TOL is still decided by
/// it), or for an exact tie (slope within rounding, `FUEL_TIE`) the slope of
/// `Σ (i + 1) u_i`. The least-fuel end is `t_min` for a positive slope.
fn least_fuel_slope<const N: usize>(w: &[f32; N], e: usize, v: &[f32; 3], js: &[usize; 3]) -> Result<f32, Fault> {
    let (we, idx) = (at(w, e)?, |j: usize| f32::from(u16::try_from(j.saturating_add(1)).unwrap_or(u16::MAX)));
    let (mut fuel_slope, mut fuel_scale, mut idx_slope) = (we, we.abs(), idx(e));
    for (vj, &j) in v.iter().zip(js.iter()) {
        let wj = at(w, j)?;
        fuel_slope += wj * vj;
        fuel_scale += (wj * vj).abs();
        idx_slope += vj * idx(j);
    }
    Ok(if fuel_slope.abs() > FUEL_TIE * fuel_scale { fuel_slope } else { idx_slope })
}

/// `{t ∈ [0, s_e] : lo_j - tol_j <= z_j + t v_j <= hi_j + tol_j}`, `tol_j = slack · span_j`,
/// as `(t_min, t_max)`; `None` if empty.
fn t_range<const N: usize>(
    z: &[f32; 3],
    v: &[f32; 3],
    js: &[usize; 3],
    bd: &Bounds<N>,
    s_e: f32,
    slack: f32,
) -> Result<Option<(f32, f32)>, Fault> {
    let (mut tmin, mut tmax) = (0.0f32, s_e);
    for ((zj, vj), &j) in z.iter().zip(v.iter()).zip(js.iter()) {
        let (lo, hi) = (at(&bd.lo, j)?, at(&bd.hi, j)?);
        let tol = slack * (hi - lo);
        if *vj > 0.0 {
            tmin = tmin.max((lo - tol - zj) / vj);
            tmax = tmax.min((hi + tol - zj) / vj);
        } else if *vj < 0.0 {
            tmin = tmin.max((hi + tol - zj) / vj);
            tmax = tmax.min((lo - tol - zj) / vj);
        } else if !(*zj >= lo - tol && *zj <= hi + tol) {
            return Ok(None);
        }
    }
    Ok(if tmin <= tmax { Some((tmin, tmax)) } else { None })
}

/// The lower facet of `Z₄` above `m_d` (largest `(ν_xyz·m_d - h(ν)) / (-ν₄)`, first on
/// ties); near-vertical triples (`|ν₄|` within `DEGEN_TOL` of `‖ν‖₁`: coplanar
/// thruster moments) are skipped. `None` if there is none.
fn best_lower_facet<const N: usize>(gens: &Gens<N>, m: &[f32; AXES]) -> Option<Facet4> {
    let nc = gens.nc;
    let mut best: Option<Facet4> = None;
    let mut best_f = f32::NEG_INFINITY;
    for (a, ga) in gens.g.iter().enumerate().take(nc) {
        let [xa, ya, za, wa] = *ga;
        for (bi, gb) in gens.g.iter().enumerate().take(nc).skip(a.saturating_add(1)) {
            let [xb, yb, zb, wb] = *gb;
            // 2×2 minors of rows (p, q) of columns a, b.
            let (mxy, mxz, mxw) = (xa * yb - xb * ya, xa * zb - xb * za, xa * wb - xb * wa);
            let (myz, myw, mzw) = (ya * zb - yb * za, ya * wb - yb * wa, za * wb - zb * wa);
            for (c, gc) in gens.g.iter().enumerate().take(nc).skip(bi.saturating_add(1)) {
                let [xc, yc, zc, wc] = *gc;
                // ν_i = (-1)^i det(rows ≠ i) of [G_a G_b G_c], so ν·G = det[G, G_a, G_b, G_c].
                let mut nu = [
                    yc * mzw - zc * myw + wc * myz,
                    -(xc * mzw - zc * mxw + wc * mxz),
                    xc * myw - yc * mxw + wc * mxy,
                    -(xc * myz - yc * mxz + zc * mxy),
                ];
                let [_, _, _, n4] = nu;
                let nn: f32 = nu.iter().map(|v| v.abs()).sum();
                if !(n4.abs() > DEGEN_TOL * nn) {
                    continue;
                }
                if n4 > 0.0 {
                    nu = nu.map(|v| -v);
                }
                let [nx, ny, nz, n4] = nu;
                let [mx, my, mz] = *m;
                let nm = nx * mx + ny * my + nz * mz;
                // f > best_f iff h < nm + best_f·ν₄ (ν₄ < 0): h sums non-negative terms,
                // so the triple is dropped as soon as its partial sum reaches that.
                let lim = nm + best_f * n4;
                let mut h = dot4(&gens.c0, &nu);
                let mut pruned = false;
                for gk in gens.g.iter().take(nc) {
                    let q = dot4(gk, &nu);
                    if q > 0.0 {
                        h += q;
                        if h >= lim {
                            pruned = true;
                            break;
                        }
                    }
                }
                let f = (nm - h) / -n4;
                if !pruned && f > best_f {
                    best_f = f;
                    best = Some(Facet4 { t: [a, bi, c], nu });
                }
            }
        }
    }
    if !best_f.is_finite() {
        return None;
    }
    best
}
