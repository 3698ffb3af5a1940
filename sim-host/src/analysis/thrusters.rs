//! Host-side (std, f64) control-authority analysis for thruster layouts.
//!
//! The attainable moment set `Z = {B u : u_min <= u <= u_max}` (B is 3×N, column `b_k`
//! = torque of thruster k at unit command) is a zonotope. Everything here is computed
//! from its geometry, without an LP solver:
//!
//! * support function `h_Z(n) = Σ_k max(n·b_k u_min_k, n·b_k u_max_k)`;
//! * facet normals `±(b_i × b_j)` over pairs of non-parallel generators (columns with
//!   `u_max > u_min` and `b ≠ 0`); when the generators do not span R³ the set is
//!   completed so that `Z = {x : n·x <= h_Z(n) ∀ n}` still holds (plane normal plus
//!   in-plane edge normals for a flat Z, a frame for a segment or a point);
//! * `ρ(d) = min_{n·d > 0} h_Z(n)/(n·d)`: the largest λ with `λ d ∈ Z` (valid when the
//!   ray from the origin meets Z, e.g. whenever `0 ∈ Z`, which holds for `u_min = 0`);
//! * minimum authority (inradius about the origin) `= min_n h_Z(n)/|n|` over the
//!   facet normals, attained along the minimising normal;
//! * maximum authority `= sup_d ρ(d) =` the largest vertex norm of Z (exact: vertices
//!   are enumerated around every corner `±b_i×b_j` of the normal-fan arrangement).
//!
//! Tolerances: authority `<= 1e-9 · Σ_k |b_k| max(|u_min_k|, |u_max_k|)` counts as zero
//! (no three-axis authority); pairs with `|b_i × b_j| <= 1e-9 |b_i||b_j|` count as
//! parallel; generators with `|n̂·b_k| <= 1e-9 |b_k|` lie in the plane of n̂.

use serde::Serialize;
use sim_core::vec3::{cross, dot, norm};

/// Relative tolerance for parallel / coplanar decisions and the zero-authority threshold.
pub const REL_TOL: f64 = 1e-9;

type V3 = [f64; 3];

fn scaled(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn neg(a: &V3) -> V3 {
    scaled(a, -1.0)
}
/// Unit vectors `e1, e2` with `(e1, e2, c)` orthonormal (c unit).
fn frame(c: &V3) -> (V3, V3) {
    // pick the axis least aligned with c
    let ax = if c[0].abs() <= c[1].abs() && c[0].abs() <= c[2].abs() {
        [1.0, 0.0, 0.0]
    } else if c[1].abs() <= c[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let e1 = cross(c, &ax);
    let e1 = scaled(&e1, 1.0 / norm(&e1));
    let e2 = cross(c, &e1);
    (e1, e2)
}

/// Attainable-moment zonotope with a complete list of (unit) facet normals.
struct Zono<'a> {
    b: &'a [V3],
    lo: &'a [f64],
    hi: &'a [f64],
    /// Indices of generator columns (`hi > lo`, `b ≠ 0`).
    gens: Vec<usize>,
    /// Unit normals `±(b_i × b_j)/|b_i × b_j|` over non-parallel generator pairs.
    crosses: Vec<V3>,
    /// Complete normal set (crosses plus completion for rank < 3).
    normals: Vec<V3>,
    /// Dimension of span{b_k : k generator} (with the relative tolerances).
    rank: usize,
    /// `Σ_k |b_k| max(|lo_k|, |hi_k|)`: the scale of the zero-authority threshold.
    scale: f64,
}

impl<'a> Zono<'a> {
    fn new(b: &'a [V3], lo: &'a [f64], hi: &'a [f64]) -> Self {
        assert_eq!(b.len(), lo.len(), "u_min length must equal the number of columns");
        assert_eq!(b.len(), hi.len(), "u_max length must equal the number of columns");
        for k in 0..b.len() {
            assert!(lo[k] <= hi[k], "u_min[{k}] = {} > u_max[{k}] = {}", lo[k], hi[k]);
            assert!(b[k].iter().chain([lo[k], hi[k]].iter()).all(|v| v.is_finite()), "non-finite input");
        }
        let gens: Vec<usize> = (0..b.len()).filter(|&k| hi[k] > lo[k] && norm(&b[k]) > 0.0).collect();
        let scale: f64 = (0..b.len()).map(|k| norm(&b[k]) * lo[k].abs().max(hi[k].abs())).sum();

        let mut crosses = Vec::new();
        let mut best_pair: Option<(f64, V3)> = None; // best-conditioned cross, for rank 2
        for (p, &i) in gens.iter().enumerate() {
            for &j in &gens[p + 1..] {
                let c = cross(&b[i], &b[j]);
                let nc = norm(&c);
                let rel = nc / (norm(&b[i]) * norm(&b[j]));
                if rel <= REL_TOL {
                    continue; // (near-)parallel pair: no facet
                }
                let u = scaled(&c, 1.0 / nc);
                if best_pair.is_none_or(|(r, _)| rel > r) {
                    best_pair = Some((rel, u));
                }
                crosses.push(u);
                crosses.push(neg(&u));
            }
        }

        let rank = if crosses.is_empty() {
            usize::from(!gens.is_empty())
        } else if crosses.iter().step_by(2).any(|c| gens.iter().any(|&k| dot(c, &b[k]).abs() > REL_TOL * norm(&b[k]))) {
            3
        } else {
            2
        };

        let mut normals = crosses.clone();
        match rank {
            3 => {}
            2 => {
                // flat Z in the plane ⟂ p: add the in-plane edge normals ±(p × b_k)
                let p = best_pair.map(|(_, p)| p).unwrap_or([0.0, 0.0, 1.0]);
                for &k in &gens {
                    let e = cross(&p, &b[k]);
                    let ne = norm(&e);
                    if ne > 0.0 {
                        let e = scaled(&e, 1.0 / ne);
                        normals.push(e);
                        normals.push(neg(&e));
                    }
                }
            }
            1 => {
                // segment along a: end normals ±a plus a frame of the complement
                let k = *gens
                    .iter()
                    .max_by(|&&x, &&y| norm(&b[x]).total_cmp(&norm(&b[y])))
                    .expect("rank 1 has a generator");
                let a = scaled(&b[k], 1.0 / norm(&b[k]));
                let (q1, q2) = frame(&a);
                for v in [a, q1, q2] {
                    normals.push(v);
                    normals.push(neg(&v));
                }
            }
            _ => {
                for v in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
                    normals.push(v);
                    normals.push(neg(&v));
                }
            }
        }
        Self { b, lo, hi, gens, crosses, normals, rank, scale }
    }

    /// `h_Z(n) = Σ_k max(n·b_k lo_k, n·b_k hi_k)`.
    fn support(&self, n: &V3) -> f64 {
        let mut h = 0.0;
        for k in 0..self.b.len() {
            let p = dot(n, &self.b[k]);
            h += (p * self.lo[k]).max(p * self.hi[k]);
        }
        h
    }

    /// `ρ(d)` for a unit d.
    fn max_along(&self, d: &V3) -> f64 {
        let mut rho = f64::INFINITY;
        for n in &self.normals {
            let s = dot(n, d);
            if s > 1e-12 {
                rho = rho.min(self.support(n) / s);
            }
        }
        rho
    }

    /// `(min_n h_Z(n), argmin n)` over the unit normals.
    fn min_support(&self) -> (f64, V3) {
        let mut best = (f64::INFINITY, [0.0; 3]);
        for n in &self.normals {
            let h = self.support(n);
            if h < best.0 {
                best = (h, *n);
            }
        }
        best
    }

    /// Vertex of Z selected by the signs `s_k` (`u_k = hi_k` if `s_k > 0`, else `lo_k`).
    fn vertex(&self, sign: impl Fn(usize) -> f64) -> V3 {
        let mut v = [0.0; 3];
        for k in 0..self.b.len() {
            let u = if sign(k) > 0.0 { self.hi[k] } else { self.lo[k] };
            for (va, ba) in v.iter_mut().zip(self.b[k]) {
                *va += ba * u;
            }
        }
        v
    }

    /// All vertices of Z (with repetitions).
    fn vertices(&self) -> Vec<V3> {
        let b = self.b;
        let mut out = Vec::new();
        match self.rank {
            0 => out.push(self.vertex(|_| -1.0)),
            1 => {
                let k = self.gens[0];
                let a = b[k];
                out.push(self.vertex(|j| dot(&a, &b[j])));
                out.push(self.vertex(|j| -dot(&a, &b[j])));
            }
            _ => {
                // Every cell of the arrangement {w : w·b_k = 0} on the sphere touches a
                // corner c = ±b_i×b_j; around c the cells are the sectors of the in-plane
                // line arrangement {t : t·b_k = 0} over the generators k with c·b_k = 0.
                for c in &self.crosses {
                    let zero: Vec<bool> = (0..b.len()).map(|k| dot(c, &b[k]).abs() <= REL_TOL * norm(&b[k])).collect();
                    let (e1, e2) = frame(c);
                    let mut angles = Vec::new();
                    for &k in &self.gens {
                        if zero[k] {
                            let th = dot(&e2, &b[k]).atan2(dot(&e1, &b[k]));
                            for s in [0.5, -0.5] {
                                angles.push((th + s * std::f64::consts::PI).rem_euclid(std::f64::consts::TAU));
                            }
                        }
                    }
                    angles.sort_by(f64::total_cmp);
                    angles.dedup_by(|x, y| (*x - *y).abs() < 1e-12);
                    let m = angles.len();
                    for q in 0..m {
                        let a0 = angles[q];
                        let a1 = if q + 1 < m { angles[q + 1] } else { angles[0] + std::f64::consts::TAU };
                        let mid = 0.5 * (a0 + a1);
                        let t = [
                            e1[0] * mid.cos() + e2[0] * mid.sin(),
                            e1[1] * mid.cos() + e2[1] * mid.sin(),
                            e1[2] * mid.cos() + e2[2] * mid.sin(),
                        ];
                        out.push(self.vertex(|k| if zero[k] { dot(&t, &b[k]) } else { dot(c, &b[k]) }));
                    }
                }
            }
        }
        out
    }
}

/// Control authority of `Z = {B u : u_min <= u <= u_max}` (units of `B·u`, e.g. N·m).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Authority {
    /// Minimum over unit demand directions of `ρ(d)` = inradius of Z about the origin
    /// (0 when there is no three-axis authority).
    pub min_authority_nm: f64,
    /// Unit demand direction achieving the minimum (the minimising facet normal; for a
    /// flat Z the normal of its plane).
    pub weakest_direction: [f64; 3],
    /// `sup_d ρ(d)` = largest vertex norm of Z (exact, not sampled).
    pub max_authority_nm: f64,
    /// 0 in the interior of Z (authority above the tolerance and generators spanning R³).
    pub three_axis: bool,
}

fn authority_of(z: &Zono) -> (bool, f64, V3) {
    let (h, n) = z.min_support();
    let three = z.rank == 3 && h > REL_TOL * z.scale;
    (three, if three { h } else { 0.0 }, n)
}

/// Minimum / maximum control authority of `B` (columns `b`) with `u_min <= u <= u_max`.
///
/// Panics if the slice lengths differ, `u_min > u_max` somewhere or an input is not finite.
pub fn authority(b: &[[f64; 3]], u_min: &[f64], u_max: &[f64]) -> Authority {
    let z = Zono::new(b, u_min, u_max);
    let (three_axis, min_authority_nm, weakest_direction) = authority_of(&z);
    let max_authority_nm = z.vertices().iter().map(norm).fold(0.0, f64::max);
    Authority { min_authority_nm, weakest_direction, max_authority_nm, three_axis }
}

/// ρ(d): largest attainable moment along the unit direction d.
///
/// `d` is normalised internally (a zero `d` gives NaN). Returns `max{λ : λ d̂ ∈ Z}`
/// when the ray from the origin meets Z (always when `0 ∈ Z`, e.g. `u_min <= 0 <= u_max`);
/// 0 along directions of no authority, `+∞` never happens for a bounded Z.
pub fn max_along(b: &[[f64; 3]], u_min: &[f64], u_max: &[f64], d: &[f64; 3]) -> f64 {
    let nd = norm(d);
    if nd.is_nan() || nd == 0.0 {
        return f64::NAN;
    }
    let z = Zono::new(b, u_min, u_max);
    z.max_along(&scaled(d, 1.0 / nd))
}

/// One failure combination.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailureCase {
    /// Failed thrusters, 1-based, ascending.
    pub failed: Vec<usize>,
    pub three_axis: bool,
    /// Inradius about the origin with these thrusters off (0 when authority is lost).
    pub min_authority_nm: f64,
    /// Weakest demand direction (for a lost case: a direction with no positive authority).
    pub weakest_direction: [f64; 3],
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailureTable {
    /// No failure (`u_min = 0`).
    pub nominal: Authority,
    /// Every combination of 1..=max_failed failed thrusters, by size then lexicographic.
    pub cases: Vec<FailureCase>,
    /// The combinations that lose three-axis authority (same order as `cases`).
    pub lost: Vec<Vec<usize>>,
}

/// Calls `f` with every k-subset of `0..n` in lexicographic order.
fn for_each_combination(n: usize, k: usize, mut f: impl FnMut(&[usize])) {
    if k > n {
        return;
    }
    let mut idx: Vec<usize> = (0..k).collect();
    loop {
        f(&idx);
        // advance
        let mut i = k;
        loop {
            if i == 0 {
                return;
            }
            i -= 1;
            if idx[i] < n - k + i {
                idx[i] += 1;
                for j in i + 1..k {
                    idx[j] = idx[j - 1] + 1;
                }
                break;
            }
            if i == 0 {
                return;
            }
        }
    }
}

/// Failure table with `u_min = 0`; failed thrusters have `u_min = u_max = 0` (failed off).
/// Covers every combination of 1..=`max_failed` (clamped to N) thrusters.
pub fn failure_table(b: &[[f64; 3]], u_max: &[f64], max_failed: usize) -> FailureTable {
    let n = b.len();
    assert_eq!(u_max.len(), n, "u_max length must equal the number of columns");
    let lo = vec![0.0; n];
    let nominal = authority(b, &lo, u_max);
    let mut cases = Vec::new();
    let mut lost = Vec::new();
    let mut hi = u_max.to_vec();
    for k in 1..=max_failed.min(n) {
        for_each_combination(n, k, |idx| {
            hi.copy_from_slice(u_max);
            for &i in idx {
                hi[i] = 0.0;
            }
            // The threshold scale is that of the intact layout (Σ|b_k| u_max_k), so a
            // combination is judged against the same absolute tolerance as the nominal.
            let mut z = Zono::new(b, &lo, &hi);
            z.scale = (0..n).map(|k| norm(&b[k]) * u_max[k].abs()).sum();
            let (three_axis, min_authority_nm, weakest_direction) = authority_of(&z);
            let failed: Vec<usize> = idx.iter().map(|i| i + 1).collect();
            if !three_axis {
                lost.push(failed.clone());
            }
            cases.push(FailureCase { failed, three_axis, min_authority_nm, weakest_direction });
        });
    }
    FailureTable { nominal, cases, lost }
}

fn set(v: &[usize]) -> String {
    let s: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("{{{}}}", s.join(","))
}

/// Human-readable summary: per number of failed thrusters, how many combinations lose
/// three-axis authority, which ones, and the smallest surviving authority.
pub fn render_table(t: &FailureTable) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let nm = &t.nominal;
    let _ = writeln!(
        s,
        "nominal: three-axis {}, min authority {:.6} (weakest direction [{:.4}, {:.4}, {:.4}]), max authority {:.6}",
        if nm.three_axis { "yes" } else { "NO" },
        nm.min_authority_nm,
        nm.weakest_direction[0],
        nm.weakest_direction[1],
        nm.weakest_direction[2],
        nm.max_authority_nm
    );
    let kmax = t.cases.iter().map(|c| c.failed.len()).max().unwrap_or(0);
    let _ = writeln!(
        s,
        "{:>6} | {:>6} | {:>5} | {:>28} | lost combinations (1-based)",
        "failed", "combos", "lost", "smallest surviving authority"
    );
    for k in 1..=kmax {
        let cs: Vec<&FailureCase> = t.cases.iter().filter(|c| c.failed.len() == k).collect();
        let lost: Vec<&FailureCase> = cs.iter().copied().filter(|c| !c.three_axis).collect();
        let surv = cs.iter().filter(|c| c.three_axis).min_by(|a, b| a.min_authority_nm.total_cmp(&b.min_authority_nm));
        let sv = match surv {
            Some(c) => format!("{:.6} at {}", c.min_authority_nm, set(&c.failed)),
            None => "none survive".to_string(),
        };
        let list = if lost.is_empty() {
            "-".to_string()
        } else {
            lost.iter().map(|c| set(&c.failed)).collect::<Vec<_>>().join(" ")
        };
        let _ = writeln!(s, "{:>6} | {:>6} | {:>5} | {:>28} | {}", k, cs.len(), lost.len(), sv, list);
    }
    s
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn combinations_count_and_order() {
        let mut v = Vec::new();
        for_each_combination(5, 3, |c| v.push(c.to_vec()));
        assert_eq!(v.len(), 10);
        assert_eq!(v[0], vec![0, 1, 2]);
        assert_eq!(v[9], vec![2, 3, 4]);
        let mut w = Vec::new();
        for_each_combination(4, 0, |c| w.push(c.to_vec()));
        assert_eq!(w, vec![Vec::<usize>::new()]);
        let mut x = 0;
        for_each_combination(2, 3, |_| x += 1);
        assert_eq!(x, 0);
        let mut y = 0;
        for_each_combination(12, 3, |_| y += 1);
        assert_eq!(y, 220);
    }
}
