//! Fuzz-like robustness: 100 000 random cases mixing NaN, ±inf, huge, tiny,
//! subnormal and ordinary values in every input. Asserts: no panic (the test
//! profile keeps overflow checks and debug assertions on), outputs finite, `u`
//! inside finite consistent bounds, `NonFinite` iff an input is non-finite.
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::paper::PAPER_PWPF;
use acs_flight::allocation::thruster::{Allocator, Bounds, Failures, Lp, LpStatus, Pwpf, RateLimit};
use common::*;

fn wild(rng: &mut Rng) -> f32 {
    match rng.below(14) {
        0 => f32::NAN,
        1 => f32::INFINITY,
        2 => f32::NEG_INFINITY,
        3 => f32::MAX,
        4 => -f32::MAX,
        5 => 1e30 * rng.range(-1.0, 1.0) as f32,
        6 => 1e-30 * rng.range(-1.0, 1.0) as f32,
        7 => f32::MIN_POSITIVE * 0.25, // subnormal
        8 => 0.0,
        9 => -0.0,
        _ => rng.range(-2.0, 2.0) as f32,
    }
}

fn maybe_wild(rng: &mut Rng, p: f64, normal: f32) -> f32 {
    if rng.uniform() < p { wild(rng) } else { normal }
}

#[test]
fn fuzz_100k() {
    let mut rng = Rng(0xF022);
    let mut statuses = [0usize; 5];
    let mut lp_statuses = [0usize; 5];
    let mut max_it = 0u16;
    for case in 0..100_000 {
        let p = [0.0, 0.01, 0.1, 0.5][case % 4];
        let mut b = random_b(&mut rng);
        for r in b.iter_mut() {
            for v in r.iter_mut() {
                *v = maybe_wild(&mut rng, p, *v);
            }
        }
        let mut umin = [0.0f32; 8];
        let mut umax = [1.0f32; 8];
        for j in 0..8 {
            umin[j] = maybe_wild(&mut rng, p, 0.0);
            umax[j] = maybe_wild(&mut rng, p, 1.0);
        }
        let al = Allocator::<8, 9>::new(b, umin, umax);
        let m = [
            {
                let v = rng.range(-3.0, 3.0) as f32;
                maybe_wild(&mut rng, p, v)
            },
            {
                let v = rng.range(-3.0, 3.0) as f32;
                maybe_wild(&mut rng, p, v)
            },
            {
                let v = rng.range(-3.0, 3.0) as f32;
                maybe_wild(&mut rng, p, v)
            },
        ];
        let rate = if rng.uniform() < 0.3 {
            let mut rl =
                RateLimit { u_prev: [0.0; 8], rho_min: [-1.0; 8], rho_max: [1.0; 8], dt: maybe_wild(&mut rng, p, 0.1) };
            for j in 0..8 {
                rl.u_prev[j] = {
                    let v = rng.uniform() as f32;
                    maybe_wild(&mut rng, p, v)
                };
                rl.rho_min[j] = maybe_wild(&mut rng, p, -1.0);
                rl.rho_max[j] = maybe_wild(&mut rng, p, 1.0);
            }
            Some(rl)
        } else {
            None
        };
        let fail = Failures {
            failed: rng.next_u64() as u32 & if rng.uniform() < 0.2 { 0xffff_ffff } else { 0 },
            stuck_on: rng.next_u64() as u32,
        };
        let bd = al.bounds(rate.as_ref(), fail);
        let bd = if rng.uniform() < 0.05 {
            // raw garbage bounds too
            let mut g = Bounds { lo: [0.0; 8], hi: [0.0; 8] };
            for j in 0..8 {
                g.lo[j] = wild(&mut rng);
                g.hi[j] = wild(&mut rng);
            }
            g
        } else {
            bd
        };
        let inputs_finite = m.iter().all(|v| v.is_finite())
            && b.iter().all(|r| r.iter().all(|v| v.is_finite()))
            && bd.lo.iter().chain(bd.hi.iter()).all(|v| v.is_finite())
            && umin.iter().chain(umax.iter()).all(|v| v.is_finite());
        let consistent = bd.lo.iter().zip(bd.hi.iter()).all(|(l, h)| l <= h);
        // finite but so large that f32 sums/products may overflow inside the LP
        let huge = m.iter().chain(b.iter().flatten()).chain(bd.lo.iter()).chain(bd.hi.iter()).any(|v| v.abs() > 1e15);
        for bodson in [false, true] {
            let r = if bodson { al.bodson(&m, &bd) } else { al.direction_preserving(&m, &bd) };
            statuses[r.status as usize] += 1;
            max_it = max_it.max(r.iterations);
            assert!(r.u.iter().all(|v| v.is_finite()));
            assert!(r.realised.iter().chain(r.shortfall.iter()).all(|v| v.is_finite()));
            assert!(r.lambda.is_finite() && r.lambda >= 0.0 && r.lambda <= 1.0);
            if !inputs_finite {
                assert_eq!(r.status, AllocStatus::NonFinite);
            } else if r.status == AllocStatus::NonFinite {
                assert!(huge, "NonFinite on ordinary finite inputs");
            }
            if inputs_finite && consistent {
                for j in 0..8 {
                    assert!(r.u[j] >= bd.lo[j] && r.u[j] <= bd.hi[j]);
                }
            }
            if !consistent && inputs_finite {
                assert_eq!(r.status, AllocStatus::Infeasible);
            }
        }
        // raw LP with garbage
        let mut lp = Lp::<3, 9>::zeroed(rng.below(5), rng.below(12));
        for i in 0..3 {
            lp.b[i] = {
                let v = rng.range(-2.0, 2.0) as f32;
                maybe_wild(&mut rng, p, v)
            };
            for j in 0..9 {
                lp.a[i][j] = {
                    let v = rng.range(-1.0, 1.0) as f32;
                    maybe_wild(&mut rng, p, v)
                };
            }
        }
        for j in 0..9 {
            lp.c[j] = {
                let v = rng.range(-1.0, 1.0) as f32;
                maybe_wild(&mut rng, p, v)
            };
            lp.h[j] = {
                let v = rng.range(0.0, 2.0) as f32;
                maybe_wild(&mut rng, p, v)
            };
        }
        let s = lp.solve_with_cap(rng.below(60) as u16);
        lp_statuses[s.status as usize] += 1;
        assert!(s.x.iter().all(|v| v.is_finite() && *v >= 0.0), "{lp:?} -> {s:?}");
        if s.status == LpStatus::Optimal {
            assert!(s.objective.is_finite());
        }
        // PWPF with garbage
        if case % 10 == 0 {
            if let Some(mut pw) = Pwpf::<8>::new(PAPER_PWPF, maybe_wild(&mut rng, p, 0.01)) {
                for _ in 0..10 {
                    let mut r = [0.0f32; 8];
                    for v in r.iter_mut() {
                        *v = wild(&mut rng);
                    }
                    pw.step(&r);
                    assert!(pw.filter().iter().all(|v| v.is_finite()));
                }
            }
        }
    }
    println!(
        "fuzz 100k: alloc statuses [Ok, Scaled, Infeasible, NonFinite, IterationCap] = {statuses:?}; \
         LP [Optimal, Infeasible, Unbounded, IterationCap, NonFinite] = {lp_statuses:?}; max alloc iterations {max_it}"
    );
}
