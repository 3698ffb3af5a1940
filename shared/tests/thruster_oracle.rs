//! λ of the simplex allocators vs the zonotope oracle (no LP, f64).
//!
//! Tolerance: |λ_lp - λ_oracle| <= 1e-4 · max(λ_oracle, 1e-2) + δ_u, relative 1e-4 with
//! an absolute floor near λ = 0, for the paper's B and 1000 random B's. δ_u = 4 ε Σ|B|/‖m‖₂
//! is what rounding the commands u ∈ [0,1] to f32 can move λ by (it matters only for
//! demands ~1e-3 of the authority, where B u cancels; Bodson reads λ from B u).
//! Direction check: |B u - λ m_d| <= 1e-4 · (Σ_ij |B_ij|) (u ∈ [0,1]).
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::paper_allocator;
use acs_flight::allocation::thruster::{Allocator, Bounds};
use common::*;

struct Stats {
    n: usize,
    max_abs: f64,
    max_rel: f64,
    max_dir: f64,
    max_iter: u16,
    /// cases beyond 1e-4 relative but within the f32 command-rounding term δ_u
    rep: usize,
}
impl Stats {
    fn new() -> Self {
        Self { n: 0, max_abs: 0.0, max_rel: 0.0, max_dir: 0.0, max_iter: 0, rep: 0 }
    }
}

fn check<const N: usize, const NV: usize>(
    al: &Allocator<N, NV>,
    z: &Zonotope,
    bd: &Bounds<N>,
    m: &[f64; 3],
    bodson: bool,
    st: &mut Stats,
) {
    let md = to_f32(m);
    let mf = [md[0] as f64, md[1] as f64, md[2] as f64]; // oracle on the f32 demand
    let want = z.dp_lambda(&mf).expect("0 is admissible, the ray meets Z");
    let r = if bodson { al.bodson(&md, bd) } else { al.direction_preserving(&md, bd) };
    assert!(matches!(r.status, AllocStatus::Ok | AllocStatus::Scaled), "status {:?} for m {m:?}", r.status);
    let got = r.lambda as f64;
    let err = (got - want).abs();
    let rel = err / want.max(1e-2);
    let scale: f64 = al.b().iter().flat_map(|r| r.iter()).map(|v| v.abs() as f64).sum();
    let delta_u = 4.0 * f32::EPSILON as f64 * scale / norm(&mf);
    assert!(err <= 1e-4 * want.max(1e-2) + delta_u, "λ {got} vs oracle {want} (m {m:?}, bodson {bodson})");
    if err > 1e-4 * want.max(1e-2) {
        st.rep += 1;
    }
    let bu = moment(al.b(), &r.u);
    let dir = (0..3).map(|a| (bu[a] - got * mf[a]).abs()).fold(0.0, f64::max) / scale;
    assert!(dir <= 1e-4, "|Bu - λm| / Σ|B| = {dir} (m {m:?}, bodson {bodson})");
    st.n += 1;
    st.max_abs = st.max_abs.max(err);
    st.max_rel = st.max_rel.max(rel);
    st.max_dir = st.max_dir.max(dir);
    st.max_iter = st.max_iter.max(r.iterations);
}

#[test]
fn paper_b_many_directions() {
    let al = paper_allocator(1.0);
    let bd = al.nominal_bounds();
    let z = zonotope_of(al.b(), &bd);
    assert!(z.full_rank());
    for bodson in [false, true] {
        let mut st = Stats::new();
        for d in sphere(4000) {
            let (_, reach) = z.ray_interval(&d).unwrap();
            for f in [0.05, 0.3, 0.7, 0.999, 1.0, 1.001, 1.5, 3.0, 50.0] {
                let m = [d[0] * reach * f, d[1] * reach * f, d[2] * reach * f];
                check(&al, &z, &bd, &m, bodson, &mut st);
            }
        }
        println!(
            "paper B, {}: {} demands, max |Δλ| {:.2e}, max rel {:.2e}, max |Bu-λm|/Σ|B| {:.2e}, max iterations {}",
            if bodson { "Bodson" } else { "DP (eqs 12-18)" },
            st.n,
            st.max_abs,
            st.max_rel,
            st.max_dir,
            st.max_iter
        );
    }
}

#[test]
fn random_b_1000() {
    let mut rng = Rng(0x004_5EED);
    let mut st = [Stats::new(), Stats::new()];
    let mut skipped = 0;
    let mut zero_reach = 0;
    for _ in 0..1000 {
        let b = random_b(&mut rng);
        let al = Allocator::<8, 9>::new(b, [0.0; 8], [1.0; 8]);
        let bd = al.nominal_bounds();
        let z = zonotope_of(&b, &bd);
        if !z.full_rank() {
            skipped += 1;
            continue;
        }
        for _ in 0..20 {
            let d = rng.unit3();
            let (_, reach) = z.ray_interval(&d).unwrap();
            let f = if rng.uniform() < 0.1 { 1.0 } else { rng.range(0.1, 3.0) };
            let s = if reach > 1e-9 {
                reach * f
            } else {
                zero_reach += 1;
                1.0
            };
            let m = [d[0] * s, d[1] * s, d[2] * s];
            check(&al, &z, &bd, &m, false, &mut st[0]);
            check(&al, &z, &bd, &m, true, &mut st[1]);
        }
    }
    for (k, s) in st.iter().enumerate() {
        println!(
            "random B (1000 × 20 demands, {skipped} rank-deficient skipped, {zero_reach} rays with λmax = 0), {}: max |Δλ| {:.2e}, max rel {:.2e}, max |Bu-λm|/Σ|B| {:.2e}, max iterations {}, beyond 1e-4 rel (within δ_u): {}",
            if k == 1 { "Bodson" } else { "DP" },
            s.max_abs,
            s.max_rel,
            s.max_dir,
            s.max_iter,
            s.rep
        );
    }
}

/// Extended run (`cargo test --release --test oracle -- --ignored`): 5000 random B ×
/// 20 demands, both methods, same tolerance.
#[test]
#[ignore]
fn random_b_5000_extended() {
    let mut rng = Rng(0xBEEF);
    let mut st = [Stats::new(), Stats::new()];
    for _ in 0..5000 {
        let b = random_b(&mut rng);
        let al = Allocator::<8, 9>::new(b, [0.0; 8], [1.0; 8]);
        let bd = al.nominal_bounds();
        let z = zonotope_of(&b, &bd);
        if !z.full_rank() {
            continue;
        }
        for _ in 0..20 {
            let d = rng.unit3();
            let (_, reach) = z.ray_interval(&d).unwrap();
            let s = if reach > 1e-9 { reach * rng.range(0.1, 3.0) } else { 1.0 };
            let m = [d[0] * s, d[1] * s, d[2] * s];
            check(&al, &z, &bd, &m, false, &mut st[0]);
            check(&al, &z, &bd, &m, true, &mut st[1]);
        }
    }
    for (k, s) in st.iter().enumerate() {
        println!(
            "5000 random B, {}: {} demands, max rel Δλ {:.2e}, {} beyond 1e-4 (within δ_u), max iterations {}",
            if k == 1 { "Bodson" } else { "DP" },
            s.n,
            s.max_rel,
            s.rep,
            s.max_iter
        );
    }
}
