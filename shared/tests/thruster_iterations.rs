//! Worst-case simplex iteration counts over a sweep (saturated, attainable,
//! degenerate demands; failures; rate limits). Cap per LP: 4 (rows + cols) = 48 for
//! the 8-thruster problems; `AllocResult::iterations` sums all LPs of one call.
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::paper_allocator;
use acs_flight::allocation::thruster::simplex::default_iteration_cap;
use acs_flight::allocation::thruster::{Allocator, Bounds, Failures, LpStatus, Pricing, RateLimit};
use common::*;

#[derive(Default, Debug)]
struct Worst {
    dp: u16,
    bodson: u16,
    stage1: u16,
    stage1_bland: u16,
    n: usize,
}

fn sweep_one<const N: usize, const NV: usize>(al: &Allocator<N, NV>, bd: &Bounds<N>, m: &[f32; 3], w: &mut Worst) {
    let r = al.direction_preserving(m, bd);
    let b = al.bodson(m, bd);
    assert_ne!(r.status, AllocStatus::IterationCap, "DP cap at {m:?}");
    assert_ne!(b.status, AllocStatus::IterationCap, "Bodson cap at {m:?}");
    w.dp = w.dp.max(r.iterations);
    w.bodson = w.bodson.max(b.iterations);
    let mut lp = al.dp_lp(m, bd);
    let s = lp.solve();
    assert_ne!(s.status, LpStatus::IterationCap);
    w.stage1 = w.stage1.max(s.iterations);
    lp.pricing = Pricing::Bland;
    let s = lp.solve();
    assert_ne!(s.status, LpStatus::IterationCap);
    w.stage1_bland = w.stage1_bland.max(s.iterations);
    w.n += 1;
}

fn demands(z: &Zonotope, cols: &[[f64; 3]], ndir: usize) -> Vec<[f32; 3]> {
    let mut dirs = sphere(ndir);
    dirs.extend(cols.iter().copied());
    dirs.extend(z.normals.iter().copied());
    for i in 0..cols.len() {
        for j in (i + 1)..cols.len() {
            dirs.push([cols[i][0] + cols[j][0], cols[i][1] + cols[j][1], cols[i][2] + cols[j][2]]);
        }
    }
    dirs.push([1.0, 0.0, 0.0]);
    dirs.push([0.0, 0.0, 0.0]);
    let mut out = Vec::new();
    for d in dirs {
        let reach = z.ray_interval(&d).map(|r| r.1).filter(|r| r.is_finite() && *r > 1e-9).unwrap_or(1.0);
        for f in [0.01, 0.5, 0.999, 1.0, 1.001, 2.0, 1e3] {
            out.push(to_f32(&[d[0] * reach * f, d[1] * reach * f, d[2] * reach * f]));
        }
    }
    out
}

#[test]
fn worst_case_iterations() {
    let al = paper_allocator(1.0);
    let cap = default_iteration_cap(3, 9);
    let cols = columns(al.b());
    let mut w = Worst::default();
    // nominal
    let bd = al.nominal_bounds();
    let z = zonotope_of(al.b(), &bd);
    for m in demands(&z, &cols, 20000) {
        sweep_one(&al, &bd, &m, &mut w);
    }
    println!("paper B nominal: {w:?}");
    // every 1-, 2-, 3-thruster failure
    let mut wf = Worst::default();
    for mask in 1u32..256 {
        if mask.count_ones() > 3 {
            continue;
        }
        let bd = al.bounds(None, Failures { failed: mask, stuck_on: 0 });
        let z = zonotope_of(al.b(), &bd);
        for m in demands(&z, &cols, 300) {
            sweep_one(&al, &bd, &m, &mut wf);
        }
    }
    println!("paper B, all 1-3 thruster failures: {wf:?}");
    // rate limits + stuck-on
    let mut rng = Rng(123);
    let mut wr = Worst::default();
    for _ in 0..20000 {
        let mut rl = RateLimit { u_prev: [0.0; 8], rho_min: [-3.0; 8], rho_max: [3.0; 8], dt: 0.1 };
        for v in rl.u_prev.iter_mut() {
            *v = if rng.uniform() < 0.5 { 0.0 } else { rng.uniform() as f32 };
        }
        let fail =
            if rng.uniform() < 0.2 { Failures { failed: 1 << rng.below(8), stuck_on: 0xff } } else { Failures::NONE };
        let bd = al.bounds(Some(&rl), fail);
        let d = rng.unit3();
        let s = rng.range(0.0, 2.0);
        sweep_one(&al, &bd, &to_f32(&[d[0] * s, d[1] * s, d[2] * s]), &mut wr);
    }
    println!("paper B, random rate limits / stuck-on: {wr:?}");
    // random B
    let mut wb = Worst::default();
    for _ in 0..1000 {
        let b = random_b(&mut rng);
        let al = Allocator::<8, 9>::new(b, [0.0; 8], [1.0; 8]);
        let bd = al.nominal_bounds();
        let z = zonotope_of(&b, &bd);
        let cols = columns(&b);
        for m in demands(&z, &cols, 20) {
            sweep_one(&al, &bd, &m, &mut wb);
        }
    }
    println!("1000 random B: {wb:?}");
    println!("cap per LP = {cap}");
    for x in [&w, &wf, &wr, &wb] {
        assert!(x.stage1 < cap && x.stage1_bland < cap);
    }
}
