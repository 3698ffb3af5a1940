//! The optimised thruster LP (LPs sized to the movable thrusters, fuel stage
//! warm-started from the stage-1 basis, phase 1 skipped when b = 0, no refactorisation
//! when nothing changed) against independent references:
//!
//! - `fitted_capacity_vs_microlp`: the flight configuration (12-thruster capacity,
//!   paper layout fitted in 8, 10 N), demands 1e-3..1e2 N m along random directions,
//!   thruster columns, facet normals and tilted facet normals, with failure masks
//!   {}, {1,4} and random ones that keep three-axis authority (see the test for why). Reference: microlp (f64) on the *full*
//!   uncompacted paper eq 18 LP built here from `B` and the bounds (every thruster a
//!   column, failed ones with h = 0) and on the full fuel LP. Asserts: same status
//!   (Ok iff λ_ref = 1 to 1e-9; cases with λ_ref in (1 - 1e-4, 1 - 1e-9) skipped; a status difference is
//!   accepted, and counted (< 1 %), only if B u is within 1e-5 · Σ|B| of λ m_d: the
//!   f32 solver's feasibility tolerance), |λ - λ_ref| <=
//!   1e-4 · max(λ_ref, 1e-2) + δ_u, fuel within 1e-4 · (1 + fuel_ref) of the f64 fuel
//!   optimum, DP |B u - λ m_d| <= 1e-4 · Σ|B| (as thruster_oracle; Bodson: counted), bounds, failed thrusters off; Bodson: same
//!   status and, when scaled, the same λ.
//! - `warm_fuel_stage_equals_cold`: over random demand sequences, the fuel LP solved
//!   cold and warm (from the stage-1 basis, and from the previous step's fuel basis,
//!   which is often infeasible for the new demand: the guard must fall back) have the
//!   same status and objective within 1e-4 · (1 + |obj|) (as thruster_crosscheck); where the cold optimum is
//!   unique with margin (`dual_margin > 1e-3` and `primal_margin > 1e-3`, scaled),
//!   the same x within 1e-5.
//! - `warm_start_generic_lps`: random generic LPs warm-started from random (often
//!   invalid or infeasible) bases: same status and objective as the cold start.
//! - `capacity_does_not_change_the_answer`: `Allocator<12, 13>` with 8 fitted gives
//!   the status, λ and iterations of `Allocator<8, 9>`, commands within 1e-6.
#![allow(clippy::needless_range_loop)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::{paper_allocator, paper_allocator_in};
use acs_flight::allocation::thruster::{Allocator, Basis, Bounds, Failures, Lp, LpStatus};
use common::*;

fn fitted() -> Allocator<12, 13> {
    paper_allocator_in(10.0)
}

/// The full (uncompacted) stage-1 and fuel LPs of the 8 fitted thrusters, built here.
fn full_lps(b: &[[f32; 12]; 3], bd: &Bounds<12>, m: &[f32; 3]) -> (Lp<3, 9>, Lp<3, 9>) {
    let mut s1 = Lp::<3, 9>::zeroed(3, 9);
    let mut f = Lp::<3, 9>::zeroed(3, 8);
    for i in 0..3 {
        let mut blo = 0.0f32;
        for j in 0..8 {
            s1.a[i][j] = b[i][j];
            f.a[i][j] = b[i][j];
            blo += b[i][j] * bd.lo[j];
        }
        s1.a[i][8] = -m[i];
        s1.b[i] = -blo;
        f.b[i] = m[i] - blo;
    }
    for j in 0..8 {
        s1.h[j] = bd.hi[j] - bd.lo[j];
        f.h[j] = bd.hi[j] - bd.lo[j];
        f.c[j] = 1.0;
    }
    s1.h[8] = 1.0;
    s1.c[8] = -1.0;
    (s1, f)
}

fn demands(rng: &mut Rng, b: &[[f32; 12]; 3], n: usize) -> Vec<[f32; 3]> {
    let cols: Vec<[f64; 3]> = (0..8).map(|j| [b[0][j] as f64, b[1][j] as f64, b[2][j] as f64]).collect();
    let mut dirs: Vec<[f64; 3]> = Vec::new();
    for i in 0..8 {
        dirs.push(cols[i]);
        for j in i + 1..8 {
            let c = cross(&cols[i], &cols[j]);
            if norm(&c) > 1e-9 {
                dirs.push(c);
                dirs.push(c.map(|x| -x));
            }
        }
    }
    let mut out = Vec::new();
    for k in 0..n {
        let d = match k % 3 {
            0 => rng.unit3(),
            1 => dirs[rng.below(dirs.len())],
            _ => {
                let s = dirs[rng.below(dirs.len())];
                let e = 10f64.powf(rng.range(-6.0, -2.0)) * norm(&s);
                let r = rng.unit3();
                [s[0] + e * r[0], s[1] + e * r[1], s[2] + e * r[2]]
            }
        };
        // 1e-3..1e2 N m: the flight torque limit is 100 N m per axis. Beyond it a
        // known defect (present before the optimisation too) shows with failures:
        // m = [160.61363, 390.8265, -230.21289] N m, thrusters 4 and 7 failed, gives
        // λ = 0.0321 with B u = [5.16, 8.20, 0] not parallel to m (microlp: λ = 0.0132).
        let mag = 10f64.powf(rng.range(-3.0, 2.0)) / norm(&d);
        out.push(to_f32(&d.map(|x| x * mag)));
    }
    out
}

fn masks(rng: &mut Rng) -> Vec<Failures> {
    let mut v = vec![Failures::NONE, Failures::off_1based(&[1, 4]), Failures::off_1based(&[1, 3, 7])];
    for _ in 0..5 {
        let k = 1 + rng.below(3);
        let ids: Vec<usize> = (0..k).map(|_| 1 + rng.below(8)).collect();
        v.push(Failures::off_1based(&ids));
    }
    v
}

#[test]
fn fitted_capacity_vs_microlp() {
    let al = fitted();
    let b = *al.b();
    let sum_b: f64 = b.iter().flatten().map(|v| v.abs() as f64).sum();
    let mut rng = Rng(0x0B7_1315);
    let (mut n, mut skipped, mut worst_l, mut worst_f, mut edge) = (0usize, 0usize, 0.0f64, 0.0f64, 0usize);
    let mut bodson_off = 0usize;
    for fail in masks(&mut rng) {
        let bd = al.bounds(None, fail);
        let z = zonotope_of(&b, &bd);
        if !z.full_rank() || z.min_authority().0 <= 1e-9 {
            // u = 0 on the boundary of the attainable set (e.g. {1,3,7}: three-axis
            // authority lost, some directions unattainable at any magnitude): a known
            // defect, present before the optimisation too, makes the DP report `Ok`
            // for tiny demands just off the attainable plane, e.g. m = [0.005788064,
            // 8.99964e-8, -0.0057881596] N m gives |B u - m| = 4e-3 N m. Not covered.
            continue;
        }
        for m in demands(&mut rng, &b, 1500) {
            let (s1, fl) = full_lps(&b, &bd, &m);
            let (obj, _) = microlp_solve(&s1).expect("λ = 0, u = 0 is feasible");
            let lam_ref = -obj;
            let r = al.direction_preserving(&m, &bd);
            let rb = al.bodson(&m, &bd);
            // λ_ref = 1 (to 1e-9): attainable; within 1e-4 below 1: too close to call.
            if lam_ref > 1.0 - 1e-4 && lam_ref < 1.0 - 1e-9 {
                skipped += 1;
                continue;
            }
            n += 1;
            let mn = (m.iter().map(|v| (*v as f64).powi(2)).sum::<f64>()).sqrt();
            let du = 4.0 * f32::EPSILON as f64 * sum_b / mn;
            for (res, name) in [(&r, "DP"), (&rb, "Bodson")] {
                let want = if lam_ref >= 1.0 - 1e-9 { AllocStatus::Ok } else { AllocStatus::Scaled };
                if res.status != want {
                    // f32 tolerance edge (pre-existing): a demand off the attainable set
                    // (rank-deficient with failures) by less than the solver's relative
                    // feasibility tolerance is reported attained, or an attained one at
                    // λ within the tolerance scaled. Accepted only if the realised
                    // moment is within 1e-5 · Σ|B| of λ m (the solver's feasibility
                    // tolerance is relative to the rows of B, not to |m|).
                    let bu = moment(&b, &res.u);
                    let lam = if res.status == AllocStatus::Ok { 1.0 } else { res.lambda as f64 };
                    let d = (0..3).map(|a| (bu[a] - lam_ref.min(1.0).max(lam) * m[a] as f64).abs()).fold(0.0, f64::max);
                    let d2 = (0..3).map(|a| (bu[a] - lam * m[a] as f64).abs()).fold(0.0, f64::max);
                    assert!(d.min(d2) <= 1e-5 * sum_b, "{name} {:?} vs λ_ref {lam_ref} at {m:?} {fail:?}", res.status);
                    edge += 1;
                    continue;
                }
                if want == AllocStatus::Scaled {
                    let e = (res.lambda as f64 - lam_ref).abs();
                    assert!(
                        e <= 1e-4 * lam_ref.max(1e-2) + du,
                        "{name} λ {} vs microlp {lam_ref} at {m:?} {fail:?}",
                        res.lambda
                    );
                    worst_l = worst_l.max(e / lam_ref.max(1e-2));
                } else if name == "DP" {
                    let (fuel_ref, _) = microlp_solve(&fl).expect("attainable");
                    let fuel: f64 = r.u.iter().map(|v| *v as f64).sum();
                    let e = (fuel - fuel_ref).abs() / (1.0 + fuel_ref);
                    assert!(e <= 1e-4, "fuel {fuel} vs microlp {fuel_ref} at {m:?} {fail:?}");
                    worst_f = worst_f.max(e);
                }
            }
            for (k, res) in [&r, &rb].into_iter().enumerate() {
                let bu = moment(&b, &res.u);
                let d = (0..3).map(|a| (bu[a] - res.lambda as f64 * m[a] as f64).abs()).fold(0.0, f64::max) / sum_b;
                if k == 0 {
                    assert!(d <= 1e-4, "DP |Bu - λ m| / Σ|B| = {d} at {m:?} {fail:?}");
                } else if d > 1e-4 {
                    // Known Bodson defect, present before the optimisation too (same
                    // bits): some saturated demands come back off-direction, e.g.
                    // m = [31.802322, 50.535122, 18.732944] N m, no failure:
                    // |B u - λ m| = 0.28 N m. Counted and printed, not asserted.
                    bodson_off += 1;
                }
                for j in 0..12 {
                    assert!(res.u[j] >= bd.lo[j] && res.u[j] <= bd.hi[j], "bounds {j} {m:?}");
                    if fail.failed & (1 << j) != 0 || j >= 8 {
                        assert_eq!(res.u[j], 0.0, "failed / not fitted thruster {j} fires");
                    }
                }
            }
        }
    }
    assert!(n > 1500, "{n} cases");
    assert!(edge * 100 < n, "{edge} tolerance-edge status differences in {n} cases");
    println!(
        "fitted allocator vs microlp: {n} cases ({skipped} within 1e-4 of λ = 1 skipped, {edge} tolerance-edge statuses, {bodson_off} Bodson results off-direction: known defect), max rel λ error {worst_l:.2e}, max rel fuel error {worst_f:.2e}"
    );
}

#[test]
fn warm_fuel_stage_equals_cold() {
    let al = fitted();
    let b = *al.b();
    let mut rng = Rng(0x3A_3A57);
    let (mut n, mut unique, mut warm_from_prev_ok) = (0usize, 0usize, 0usize);
    for fail in masks(&mut rng) {
        let bd = al.bounds(None, fail);
        let mut prev: Option<Basis<3, 13>> = None;
        let mut m = [1.0f32, -0.5, 0.3];
        for k in 0..300 {
            // random walk with occasional jumps
            if k % 25 == 0 {
                m = demands(&mut rng, &b, 1)[0];
            } else {
                let s = 0.05 * (m.iter().map(|v| v.abs()).fold(0.0, f32::max) + 0.1);
                for v in m.iter_mut() {
                    *v += s * rng.range(-1.0, 1.0) as f32;
                }
            }
            let mut b1 = Basis::<3, 13>::default();
            let s1 = al.dp_lp(&m, &bd).solve_from(al.lp_iteration_cap, None, Some(&mut b1));
            if s1.status != LpStatus::Optimal || s1.x[Allocator::<12, 13>::movable(&bd).1] < 1.0 {
                continue;
            }
            let lp = al.fuel_lp(&m, &bd);
            let cold = lp.solve_with_cap(al.lp_iteration_cap);
            let mut out = Basis::<3, 13>::default();
            let warm = lp.solve_from(al.lp_iteration_cap, Some(&b1), Some(&mut out));
            let mut warm2 = None;
            if let Some(p) = prev {
                warm2 = Some(lp.solve_from(al.lp_iteration_cap, Some(&p), None));
            }
            prev = Some(out);
            for w in [Some(warm), warm2].into_iter().flatten() {
                assert_eq!(w.status, cold.status, "{m:?} {fail:?}");
                if cold.status != LpStatus::Optimal {
                    continue;
                }
                let e = (w.objective - cold.objective).abs() as f64 / (1.0 + cold.objective.abs() as f64);
                assert!(e <= 1e-4, "objective warm {} vs cold {} at {m:?}", w.objective, cold.objective);
                if cold.dual_margin > 1e-3 && cold.primal_margin > 1e-3 {
                    unique += 1;
                    for j in 0..13 {
                        assert!(
                            (w.x[j] - cold.x[j]).abs() <= 1e-5,
                            "unique optimum, x differs: {:?} vs {:?}",
                            w.x,
                            cold.x
                        );
                    }
                }
                n += 1;
            }
            if warm2.is_some() {
                warm_from_prev_ok += 1;
            }
        }
    }
    assert!(n > 1000 && unique > 200, "{n} cases, {unique} unique");
    println!(
        "warm vs cold fuel LP: {n} comparisons ({unique} with a unique optimum), {warm_from_prev_ok} from the previous step's basis"
    );
}

#[test]
fn warm_start_generic_lps() {
    let mut rng = Rng(0x6E_6E71C);
    let mut n = 0;
    for _ in 0..3000 {
        let mut lp = Lp::<3, 8>::zeroed(3, 8);
        let mut x = [0.0f64; 8];
        for j in 0..8 {
            lp.h[j] = if rng.uniform() < 0.1 { 0.0 } else { rng.range(0.1, 2.0) as f32 };
            lp.c[j] = rng.range(-1.0, 1.0) as f32;
            x[j] = rng.range(0.0, lp.h[j] as f64);
            for i in 0..3 {
                lp.a[i][j] = rng.range(-1.0, 1.0) as f32;
            }
        }
        for i in 0..3 {
            lp.b[i] = (0..8).map(|j| lp.a[i][j] as f64 * x[j]).sum::<f64>() as f32;
        }
        let mut w = Basis::<3, 8>::default();
        for v in w.vars.iter_mut() {
            *v = rng.below(12); // structurals 0..8, artificials 8..11, duplicates
        }
        for u in w.upper.iter_mut() {
            *u = rng.uniform() < 0.5;
        }
        let cold = lp.solve();
        let warm = lp.solve_from(64, Some(&w), None);
        assert_eq!(warm.status, cold.status);
        if cold.status == LpStatus::Optimal {
            let e = (warm.objective - cold.objective).abs() / (1.0 + cold.objective.abs());
            assert!(e <= 1e-5, "warm {} vs cold {}", warm.objective, cold.objective);
            for i in 0..3 {
                let r: f64 = (0..8).map(|j| lp.a[i][j] as f64 * warm.x[j] as f64).sum::<f64>() - lp.b[i] as f64;
                assert!(r.abs() <= 1e-4 * (1.0 + lp.b[i].abs() as f64), "row {i} residual {r}");
            }
            n += 1;
        }
    }
    assert!(n > 2500);
}

#[test]
fn capacity_does_not_change_the_answer() {
    let big = fitted();
    let small = paper_allocator(10.0);
    let mut rng = Rng(0xB175);
    let b = *big.b();
    for fail in masks(&mut rng) {
        let (bd12, bd8) = (big.bounds(None, fail), small.bounds(None, fail));
        for m in demands(&mut rng, &b, 300) {
            for bodson in [false, true] {
                let (r12, r8) = if bodson {
                    (big.bodson(&m, &bd12), small.bodson(&m, &bd8))
                } else {
                    (big.direction_preserving(&m, &bd12), small.direction_preserving(&m, &bd8))
                };
                // Same status, λ, iterations and saturation; commands within 1e-6
                // (the last bit can differ: not the same monomorphised code).
                let (o12, o8) = (r12.outcome, r8.outcome);
                assert_eq!(
                    (o12.status, o12.lambda, o12.iterations),
                    (o8.status, o8.lambda, o8.iterations),
                    "{m:?} {fail:?}"
                );
                for j in 0..8 {
                    assert!((r12.u[j] - r8.u[j]).abs() <= 1e-6, "{m:?} {fail:?}: {:?} vs {:?}", r12.u, r8.u);
                }
            }
        }
    }
}
