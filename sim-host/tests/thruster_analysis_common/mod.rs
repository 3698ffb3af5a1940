//! Shared test helpers (independent of the library's internals); the seeded generator and
//! the vector helpers come from `acs_test_support`.
#![allow(dead_code)]

pub use acs_test_support::rng::SplitMix64 as Rng;
pub use acs_test_support::vec3::{V3, cross, dot, norm, scale, sphere, unit};

pub fn moment(b: &[V3], u: &[f64]) -> V3 {
    let mut m = [0.0; 3];
    for k in 0..b.len() {
        for a in 0..3 {
            m[a] += b[k][a] * u[k];
        }
    }
    m
}

/// All 2^N box corners' moments (N <= 16).
pub fn corners(b: &[V3], lo: &[f64], hi: &[f64]) -> Vec<V3> {
    let n = b.len();
    (0u32..(1u32 << n))
        .map(|mask| {
            let u: Vec<f64> = (0..n).map(|k| if mask & (1 << k) != 0 { hi[k] } else { lo[k] }).collect();
            moment(b, &u)
        })
        .collect()
}

/// Brute-force support function: max over box corners of n·Bu.
pub fn support_brute(corners: &[V3], n: &V3) -> f64 {
    corners.iter().map(|c| dot(n, c)).fold(f64::NEG_INFINITY, f64::max)
}

/// Constructive attainability certificate for a boundary point x: find a pair (i, j) and
/// a sign such that x lies on the face with normal n = ±b_i×b_j, fix every other u_k at
/// the bound selected by sign(n·b_k), solve the 2×2 system for (u_i, u_j) and check
/// B u = x with u in the box. Returns (n, u).
pub fn certify_attainable(b: &[V3], lo: &[f64], hi: &[f64], x: &V3) -> Option<(V3, Vec<f64>)> {
    let nn = b.len();
    let sc: f64 = (0..nn).map(|k| norm(&b[k]) * lo[k].abs().max(hi[k].abs())).sum();
    for i in 0..nn {
        for j in (i + 1)..nn {
            let c = cross(&b[i], &b[j]);
            if norm(&c) <= 1e-9 * norm(&b[i]) * norm(&b[j]) {
                continue;
            }
            for sgn in [1.0, -1.0] {
                let n = scale(&unit(&c), sgn);
                let mut u = vec![0.0; nn];
                let mut free = Vec::new();
                for k in 0..nn {
                    let p = dot(&n, &b[k]);
                    if p.abs() <= 1e-9 * norm(&b[k]) {
                        free.push(k);
                    } else {
                        u[k] = if p > 0.0 { hi[k] } else { lo[k] };
                    }
                }
                if free.len() != 2 {
                    continue;
                }
                // residual r = x - Σ_fixed b_k u_k must be in span(b_i, b_j)
                let m0 = moment(b, &u);
                let r = [x[0] - m0[0], x[1] - m0[1], x[2] - m0[2]];
                let (p, q) = (b[free[0]], b[free[1]]);
                // normal equations
                let (a11, a12, a22) = (dot(&p, &p), dot(&p, &q), dot(&q, &q));
                let (r1, r2) = (dot(&p, &r), dot(&q, &r));
                let det = a11 * a22 - a12 * a12;
                let ui = (r1 * a22 - r2 * a12) / det;
                let uj = (a11 * r2 - a12 * r1) / det;
                u[free[0]] = ui;
                u[free[1]] = uj;
                let eps = 1e-8;
                let in_box = (0..nn).all(|k| {
                    let w = (hi[k] - lo[k]).max(1e-300);
                    u[k] >= lo[k] - eps * w && u[k] <= hi[k] + eps * w
                });
                let m = moment(b, &u);
                let err = norm(&[m[0] - x[0], m[1] - x[1], m[2] - x[2]]);
                if in_box && err <= 1e-9 * sc.max(1e-300) {
                    return Some((n, u));
                }
            }
        }
    }
    None
}

/// Paper 004, table 2, per unit thrust.
pub fn paper_b() -> Vec<V3> {
    let (r, d) = (0.73, 0.73);
    let s = 1.0 / 2f64.sqrt();
    let rows =
        [[r, 0.0, r, -0.43, -r, 0.0, -r, 0.43], [d, -0.43, -d, 0.0, -d, 0.43, d, 0.0], [d, -d, d, -d, d, -d, d, -d]];
    (0..8).map(|k| [rows[0][k] * s, rows[1][k] * s, rows[2][k] * s]).collect()
}
