//! Cross-check against an independent f64 LP solver (microlp, dev-dependency only).
//!
//! Tolerances: objective |f32 - f64| <= 1e-4 · (1 + |obj|) for the generic LPs
//! (data O(1)); allocation λ within 1e-4 (relative, floor 1e-2), fuel Σu within
//! 1e-4 · (1 + Σu). Same status for infeasible / unbounded problems.
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::paper_allocator;
use acs_flight::allocation::thruster::{Allocator, Lp, LpStatus, Pricing};
use common::*;

fn check_lp<const M: usize, const N: usize>(lp: &Lp<M, N>, worst: &mut f64, counts: &mut [usize; 3]) {
    let ours = lp.solve();
    let theirs = microlp_solve(lp);
    match (ours.status, theirs) {
        (LpStatus::Optimal, Ok((obj, _))) => {
            let err = (ours.objective as f64 - obj).abs() / (1.0 + obj.abs());
            assert!(err <= 1e-4, "objective {} vs microlp {obj} ({lp:?})", ours.objective);
            *worst = worst.max(err);
            // primal feasibility of our x in f64
            for i in 0..lp.rows {
                let r: f64 = (0..lp.cols).map(|j| lp.a[i][j] as f64 * ours.x[j] as f64).sum::<f64>() - lp.b[i] as f64;
                assert!(r.abs() <= 1e-4 * (1.0 + lp.b[i].abs() as f64), "row {i} residual {r}");
            }
            counts[0] += 1;
        }
        (LpStatus::Infeasible, Err(LpStatus::Infeasible)) => counts[1] += 1,
        (LpStatus::Unbounded, Err(LpStatus::Unbounded)) => counts[2] += 1,
        (s, t) => panic!("status mismatch: ours {s:?}, microlp {t:?} for {lp:?}"),
    }
}

#[test]
fn generic_random_lps() {
    let mut rng = Rng(0xC0FFEE);
    let mut worst = 0.0f64;
    let mut counts = [0usize; 3];
    for case in 0..3000 {
        let kind = case % 3; // 0 feasible bounded, 1 maybe infeasible, 2 some h = inf
        let mut lp = Lp::<3, 10>::zeroed(3, 10);
        lp.pricing = if case % 2 == 0 { Pricing::Bland } else { Pricing::DantzigBland };
        let mut x = [0.0f64; 10];
        for j in 0..10 {
            lp.h[j] = rng.range(0.1, 2.0) as f32;
            if kind == 2 && rng.uniform() < 0.3 {
                lp.h[j] = f32::INFINITY;
            }
            lp.c[j] = rng.range(-1.0, 1.0) as f32;
            x[j] = if lp.h[j].is_finite() { rng.range(0.0, lp.h[j] as f64) } else { rng.range(0.0, 2.0) };
            // degenerate starts: some x at bounds
            if rng.uniform() < 0.3 {
                x[j] = 0.0;
            }
            for i in 0..3 {
                lp.a[i][j] = rng.range(-1.0, 1.0) as f32;
            }
        }
        for i in 0..3 {
            lp.b[i] = if kind == 1 {
                rng.range(-6.0, 6.0) as f32
            } else {
                (0..10).map(|j| lp.a[i][j] as f64 * x[j]).sum::<f64>() as f32
            };
        }
        check_lp(&lp, &mut worst, &mut counts);
    }
    // M = 4 rows, N = 6 columns: other const-generic sizes.
    for _ in 0..1000 {
        let mut lp = Lp::<4, 6>::zeroed(4, 6);
        let mut x = [0.0f64; 6];
        for j in 0..6 {
            lp.h[j] = rng.range(0.1, 2.0) as f32;
            lp.c[j] = rng.range(-1.0, 1.0) as f32;
            x[j] = rng.range(0.0, lp.h[j] as f64);
            for i in 0..4 {
                lp.a[i][j] = rng.range(-1.0, 1.0) as f32;
            }
        }
        for i in 0..4 {
            lp.b[i] = (0..6).map(|j| lp.a[i][j] as f64 * x[j]).sum::<f64>() as f32;
        }
        check_lp(&lp, &mut worst, &mut counts);
    }
    println!(
        "generic LPs vs microlp: {} optimal (max rel objective error {worst:.2e}), {} infeasible, {} unbounded — all statuses agree",
        counts[0], counts[1], counts[2]
    );
}

#[test]
fn allocation_lps_vs_microlp() {
    let mut rng = Rng(0xA110C);
    let mut worst_l = 0.0f64;
    let mut worst_f = 0.0f64;
    let mut n = 0;
    for case in 0..600 {
        let al = if case < 300 {
            paper_allocator(1.0)
        } else {
            Allocator::<8, 9>::new(random_b(&mut rng), [0.0; 8], [1.0; 8])
        };
        let bd = al.nominal_bounds();
        let d = rng.unit3();
        let m = to_f32(&[d[0] * rng.range(0.05, 3.0), d[1] * rng.range(0.05, 3.0), d[2] * rng.range(0.05, 3.0)]);
        // stage 1 (eq 18)
        let lp = al.dp_lp(&m, &bd);
        let (obj, _) = microlp_solve(&lp).expect("stage-1 LP is feasible (λ = 0, u = 0)");
        let lam_ref = -obj;
        let r = al.direction_preserving(&m, &bd);
        let e = (r.lambda as f64 - lam_ref).abs() / lam_ref.max(1e-2);
        assert!(e <= 1e-4, "λ {} vs microlp {lam_ref}", r.lambda);
        worst_l = worst_l.max(e);
        if r.status == AllocStatus::Ok {
            let (fuel_ref, _) = microlp_solve(&al.fuel_lp(&m, &bd)).expect("attainable");
            let fuel: f64 = r.u.iter().map(|v| *v as f64).sum();
            let e = (fuel - fuel_ref).abs() / (1.0 + fuel_ref);
            assert!(e <= 1e-4, "fuel {fuel} vs microlp {fuel_ref}");
            worst_f = worst_f.max(e);
        }
        n += 1;
    }
    println!("allocation LPs vs microlp: {n} demands, max rel λ error {worst_l:.2e}, max rel fuel error {worst_f:.2e}");
}
