//! Shared support of the thruster tests: the zonotope oracle (f64, no LP), microlp
//! wrappers; the seeded generator and the vector helpers come from `acs_test_support`.
#![allow(dead_code, unused_imports, clippy::indexing_slicing, clippy::unwrap_used, clippy::expect_used)]

use acs_flight::allocation::thruster::{Bounds, Lp, LpStatus};
pub use acs_test_support::rng::SplitMix64 as Rng;
pub use acs_test_support::vec3::{cross, dot, norm, sphere};

/// Columns of a 3×N f32 matrix as f64 vectors (exactly the f32 data).
pub fn columns<const N: usize>(b: &[[f32; N]; 3]) -> Vec<[f64; 3]> {
    (0..N).map(|j| [b[0][j] as f64, b[1][j] as f64, b[2][j] as f64]).collect()
}

/// The zonotope `Z = {B u : lo <= u <= hi}` written as translation + generators.
pub struct Zonotope {
    /// Columns with `hi > lo` (generators) and their bounds.
    pub gens: Vec<([f64; 3], f64, f64)>,
    /// Σ b_k lo_k over fixed columns (`hi == lo`).
    pub fixed: [f64; 3],
    /// Facet normals: `b_i × b_j` over generator pairs, both signs, unit length.
    pub normals: Vec<[f64; 3]>,
}

impl Zonotope {
    pub fn new(cols: &[[f64; 3]], lo: &[f64], hi: &[f64]) -> Self {
        let mut gens = Vec::new();
        let mut fixed = [0.0; 3];
        for (k, c) in cols.iter().enumerate() {
            if hi[k] > lo[k] {
                gens.push((*c, lo[k], hi[k]));
            } else {
                for a in 0..3 {
                    fixed[a] += c[a] * lo[k];
                }
            }
        }
        let mut normals = Vec::new();
        for i in 0..gens.len() {
            for j in (i + 1)..gens.len() {
                let (a, b) = (gens[i].0, gens[j].0);
                let n = cross(&a, &b);
                let nn = norm(&n);
                // skip (near-)parallel pairs: |a × b| <= 1e-9 |a| |b|
                if nn <= 1e-9 * norm(&a) * norm(&b) {
                    continue;
                }
                let u = [n[0] / nn, n[1] / nn, n[2] / nn];
                normals.push(u);
                normals.push([-u[0], -u[1], -u[2]]);
            }
        }
        Self { gens, fixed, normals }
    }

    /// Support function `h_Z(n) = n·fixed + Σ_k max(n·b_k lo_k, n·b_k hi_k)`.
    pub fn support(&self, n: &[f64; 3]) -> f64 {
        let mut h = dot(n, &self.fixed);
        for (b, lo, hi) in &self.gens {
            let p = dot(n, b);
            h += (p * lo).max(p * hi);
        }
        h
    }

    /// Generators span R³ (else the facet list is incomplete and the oracle is void).
    pub fn full_rank(&self) -> bool {
        let g = &self.gens;
        for i in 0..g.len() {
            for j in (i + 1)..g.len() {
                for k in (j + 1)..g.len() {
                    let d = dot(&cross(&g[i].0, &g[j].0), &g[k].0).abs();
                    if d > 1e-9 * norm(&g[i].0) * norm(&g[j].0) * norm(&g[k].0) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// `{λ : λ m ∈ Z}` = `[λ_min, λ_max]` (None if empty):
    /// every facet gives `λ (n·m) <= h_Z(n)`.
    pub fn ray_interval(&self, m: &[f64; 3]) -> Option<(f64, f64)> {
        let mut lmin = f64::NEG_INFINITY;
        let mut lmax = f64::INFINITY;
        let scale = norm(m);
        for n in &self.normals {
            let s = dot(n, m);
            let h = self.support(n);
            if s > 1e-12 * scale {
                lmax = lmax.min(h / s);
            } else if s < -1e-12 * scale {
                lmin = lmin.max(h / s);
            } else if h < -1e-12 {
                return None;
            }
        }
        if lmin <= lmax { Some((lmin, lmax)) } else { None }
    }

    /// The direction-preserving optimum of eqs 12-18: `max λ ∈ [0, 1]` with `λ m ∈ Z`.
    pub fn dp_lambda(&self, m: &[f64; 3]) -> Option<f64> {
        let (lmin, lmax) = self.ray_interval(m)?;
        let hi = lmax.min(1.0);
        if lmin.max(0.0) <= hi { Some(hi) } else { None }
    }

    /// Inscribed radius about the origin: `min_n h_Z(n)` over unit facet normals
    /// (= min over unit directions of the max λ; <= 0 ⇔ 0 ∉ int Z).
    pub fn min_authority(&self) -> (f64, [f64; 3]) {
        let mut best = (f64::INFINITY, [0.0; 3]);
        for n in &self.normals {
            let h = self.support(n);
            if h < best.0 {
                best = (h, *n);
            }
        }
        best
    }
}

pub fn zonotope_of<const N: usize>(b: &[[f32; N]; 3], bd: &Bounds<N>) -> Zonotope {
    let lo: Vec<f64> = bd.lo.iter().map(|v| *v as f64).collect();
    let hi: Vec<f64> = bd.hi.iter().map(|v| *v as f64).collect();
    Zonotope::new(&columns(b), &lo, &hi)
}

/// Random 3×8 matrix, entries uniform in [-1, 1].
pub fn random_b(rng: &mut Rng) -> [[f32; 8]; 3] {
    let mut b = [[0.0f32; 8]; 3];
    for r in b.iter_mut() {
        for v in r.iter_mut() {
            *v = rng.range(-1.0, 1.0) as f32;
        }
    }
    b
}

pub fn to_f32(v: &[f64; 3]) -> [f32; 3] {
    [v[0] as f32, v[1] as f32, v[2] as f32]
}

pub fn moment<const N: usize>(b: &[[f32; N]; 3], u: &[f32; N]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for a in 0..3 {
        for j in 0..N {
            out[a] += b[a][j] as f64 * u[j] as f64;
        }
    }
    out
}

/// Solve an `Lp` in f64 with microlp. `Ok((objective, x))`, `Err(status)`.
pub fn microlp_solve<const M: usize, const N: usize>(lp: &Lp<M, N>) -> Result<(f64, Vec<f64>), LpStatus> {
    use microlp::{ComparisonOp, Error, OptimizationDirection, Problem};
    let mut p = Problem::new(OptimizationDirection::Minimize);
    let vars: Vec<_> = (0..lp.cols).map(|j| p.add_var(lp.c[j] as f64, (0.0, lp.h[j] as f64))).collect();
    for i in 0..lp.rows {
        let terms: Vec<_> = (0..lp.cols).map(|j| (vars[j], lp.a[i][j] as f64)).collect();
        p.add_constraint(&terms[..], ComparisonOp::Eq, lp.b[i] as f64);
    }
    match p.solve() {
        Ok(out) => match out.into_solution() {
            Ok(sol) => Ok((sol.objective(), vars.iter().map(|v| sol.var_value(*v)).collect())),
            Err(_) => Err(LpStatus::IterationCap),
        },
        Err(Error::Infeasible) => Err(LpStatus::Infeasible),
        Err(Error::Unbounded) => Err(LpStatus::Unbounded),
        Err(_) => Err(LpStatus::NonFinite),
    }
}
