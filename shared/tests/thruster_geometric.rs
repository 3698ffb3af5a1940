//! The geometric (zonotope-facet) solve of the direction-preserving allocation
//! (`zonotope.rs`) against the simplex form (`Allocator::direction_preserving_lp`),
//! the f64 zonotope oracle and closed forms.
//!
//! - `flight_configurations_take_the_geometric_path`: the flight allocator (12-slot
//!   capacity, paper layout in 8, 10 N) with failure masks {}, {1,4}, {1,3,7}, {2},
//!   {5,6}; 20,000 demands each, random directions, 1e-3..3e2 N m. Asserts: the
//!   geometric solve declines (falls back to the simplex, `iterations > 0`) for at most
//!   0.05 % of the demands; same status as the simplex except where the simplex is
//!   wrong by the oracle (counted, < 0.05 %); scaled λ within 1e-6 relative of the
//!   simplex's and within 1e-4 · max(λ, 1e-2) + δ_u of the oracle's; attainable: fuel Σu
//!   within 1e-5 · (1 + Σu) of the simplex's fuel optimum and ‖B u - m‖∞ <= 1e-5 · Σ|B|.
//! - `known_simplex_defects_are_fixed`: the two demands recorded as known defects in
//!   `thruster_optimised.rs`: λ and direction against the f64 oracle.
//! - `fuel_ties_break_towards_lower_indices`: pure ±z demands of the paper layout, where
//!   two thruster pairs give the same moment for the same fuel: the documented tie-break
//!   (weights `1 + ε (i + 1)`, ε → 0) picks the lower-index pair, closed form.
//! - `declines_to_the_simplex_when_zero_is_not_admissible`: a stuck-on thruster: the
//!   result is the simplex's, bit for bit.
#![allow(clippy::needless_range_loop)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::{paper_allocator, paper_allocator_in};
use acs_flight::allocation::thruster::{Allocator, Failures};
use common::*;

#[test]
fn flight_configurations_take_the_geometric_path() {
    let al: Allocator<12, 13> = paper_allocator_in(10.0);
    let sum_b: f64 = al.b().iter().flatten().map(|v| v.abs() as f64).sum();
    let mut rng = Rng(0x6E0_7E7);
    for fail in [vec![], vec![1, 4], vec![1, 3, 7], vec![2], vec![5, 6]] {
        let bd = al.bounds(None, Failures::off_1based(&fail));
        let z = zonotope_of(al.b(), &bd);
        let (mut n, mut declined, mut lp_wrong) = (0usize, 0usize, 0usize);
        let (mut worst_l, mut worst_f, mut worst_r) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let d = rng.unit3();
            let mag = 10f64.powf(rng.range(-3.0, 2.5));
            let m = to_f32(&[d[0] * mag, d[1] * mag, d[2] * mag]);
            let mf = [m[0] as f64, m[1] as f64, m[2] as f64];
            let geo = al.direction_preserving(&m, &bd);
            let lp = al.direction_preserving_lp(&m, &bd);
            n += 1;
            if geo.iterations > 0 {
                declined += 1;
                continue;
            }
            let want = z.dp_lambda(&mf).expect("u = 0 admissible");
            let du = 4.0 * f32::EPSILON as f64 * sum_b / norm(&mf);
            let oracle_ok = |lam: f32| (lam as f64 - want).abs() <= 1e-4 * want.max(1e-2) + du;
            assert!(oracle_ok(geo.lambda), "{fail:?} {m:?}: λ {} vs oracle {want}", geo.lambda);
            let bu = moment(al.b(), &geo.u);
            let dir = (0..3).map(|a| (bu[a] - geo.lambda as f64 * mf[a]).abs()).fold(0.0, f64::max) / sum_b;
            assert!(dir <= 1e-5, "{fail:?} {m:?}: |Bu - λm| / Σ|B| = {dir}");
            worst_r = worst_r.max(dir);
            if geo.status != lp.status {
                // Only where the simplex is the one in error.
                assert!(!oracle_ok(lp.lambda) || !lp_direction_ok(&al, &lp.u, lp.lambda, &mf, sum_b), "{m:?}");
                lp_wrong += 1;
                continue;
            }
            match geo.status {
                AllocStatus::Scaled => {
                    let e = (geo.lambda - lp.lambda).abs() / lp.lambda.max(1e-2);
                    assert!(e <= 1e-6, "{fail:?} {m:?}: λ {} vs simplex {}", geo.lambda, lp.lambda);
                    worst_l = worst_l.max(e as f64);
                }
                AllocStatus::Ok => {
                    let (fg, fl) = (geo.u.iter().sum::<f32>() as f64, lp.u.iter().sum::<f32>() as f64);
                    let e = (fg - fl).abs() / (1.0 + fl);
                    assert!(e <= 1e-5, "{fail:?} {m:?}: fuel {fg} vs simplex {fl}");
                    worst_f = worst_f.max(e);
                }
                s => panic!("{fail:?} {m:?}: status {s:?}"),
            }
        }
        println!(
            "failed {fail:?}: {n} demands, declined {declined}, simplex wrong {lp_wrong}; max rel Δλ vs simplex {worst_l:.1e}, \
             max rel Δfuel {worst_f:.1e}, max |Bu - λm|/Σ|B| {worst_r:.1e}"
        );
        assert!(declined * 2000 <= n, "declined {declined} of {n}");
        assert!(lp_wrong * 2000 <= n, "simplex differs {lp_wrong} of {n}");
    }
}

fn lp_direction_ok<const N: usize, const NV: usize>(
    al: &Allocator<N, NV>,
    u: &[f32; N],
    lambda: f32,
    m: &[f64; 3],
    sum_b: f64,
) -> bool {
    let bu = moment(al.b(), u);
    (0..3).all(|a| (bu[a] - lambda as f64 * m[a]).abs() <= 1e-5 * sum_b)
}

#[test]
fn known_simplex_defects_are_fixed() {
    let al: Allocator<12, 13> = paper_allocator_in(10.0);
    let sum_b: f64 = al.b().iter().flatten().map(|v| v.abs() as f64).sum();
    // (failed thrusters, demand N m): from thruster_optimised.rs and the LP sweeps —
    // {1,3,7}: the simplex said Ok with |B u - m| = 4e-3 N m (u = 0 is on the boundary
    // of the attainable set, the demand just off it); {4,7}: λ = 0.0321 with B u not
    // parallel to m (microlp: λ = 0.0132); {1,3,7} again: Ok with |B u - m| = 5.8e-3.
    let cases: [(&[usize], [f32; 3]); 3] = [
        (&[1, 3, 7], [0.005788064, 8.99964e-8, -0.0057881596]),
        (&[4, 7], [160.61363, 390.8265, -230.21289]),
        (&[1, 3, 7], [0.0021624174, -2.666833e-7, 0.002165384]),
    ];
    for (fail, m) in cases {
        let bd = al.bounds(None, Failures::off_1based(fail));
        let mf = [m[0] as f64, m[1] as f64, m[2] as f64];
        let want = zonotope_of(al.b(), &bd).dp_lambda(&mf).expect("u = 0 admissible");
        let r = al.direction_preserving(&m, &bd);
        let lp = al.direction_preserving_lp(&m, &bd);
        let du = 4.0 * f32::EPSILON as f64 * sum_b / norm(&mf);
        println!(
            "{fail:?} {m:?}: oracle λ {want}; geometric {:?} λ {} (iterations {}); simplex {:?} λ {}",
            r.status, r.lambda, r.iterations, lp.status, lp.lambda
        );
        assert_eq!(r.iterations, 0, "geometric path");
        assert!((r.lambda as f64 - want).abs() <= 1e-4 * want.max(1e-2) + du, "λ {} vs {want}", r.lambda);
        assert!(lp_direction_ok(&al, &r.u, r.lambda, &mf, sum_b), "direction");
    }
}

#[test]
fn fuel_ties_break_towards_lower_indices() {
    // Paper B (table 2), 10 N: b1 + b5 = b3 + b7 = (0, 0, 2k d), b2 + b6 = b4 + b8 =
    // (0, 0, -2k d), k = 10/√2 N. A pure z demand has two fuel-optimal pairs; the
    // tie-break minimises Σ (i + 1) u_i: thrusters 1 and 5 for +z, 2 and 6 for -z.
    let al = paper_allocator(10.0);
    let bd = al.nominal_bounds();
    let kd = al.b()[2][0] as f64; // k d
    for (mz, pair) in [(7.5f32, [0usize, 4]), (-7.5, [1, 5]), (3.0, [0, 4]), (-9.9, [1, 5])] {
        let r = al.direction_preserving(&[0.0, 0.0, mz], &bd);
        assert_eq!((r.status, r.iterations), (AllocStatus::Ok, 0));
        let level = (mz as f64).abs() / (2.0 * kd);
        for j in 0..8 {
            let want = if pair.contains(&j) { level } else { 0.0 };
            assert!((r.u[j] as f64 - want).abs() <= 1e-6, "m_z {mz}: u {:?}, want {level} on {pair:?}", r.u);
        }
    }
}

#[test]
fn declines_to_the_simplex_when_zero_is_not_admissible() {
    let al = paper_allocator(10.0);
    let bd = al.bounds(None, Failures { failed: 1 << 2, stuck_on: 1 << 2 });
    let mut rng = Rng(11);
    for _ in 0..200 {
        let d = rng.unit3();
        let m = to_f32(&d.map(|x| x * rng.range(0.1, 30.0)));
        let (r, lp) = (al.direction_preserving(&m, &bd), al.direction_preserving_lp(&m, &bd));
        assert_eq!((r.u, r.outcome), (lp.u, lp.outcome), "{m:?}");
    }
}
