#![allow(clippy::needless_range_loop)]
#[path = "thruster_analysis_common/mod.rs"]
mod common;
use common::*;
use sim_host::analysis::thrusters::*;

const S2: f64 = std::f64::consts::SQRT_2;

fn cube() -> Vec<V3> {
    vec![[1., 0., 0.], [-1., 0., 0.], [0., 1., 0.], [0., -1., 0.], [0., 0., 1.], [0., 0., -1.]]
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn hand_computed_cube() {
    let b = cube();
    let lo = vec![0.0; 6];
    let hi = vec![1.0; 6];
    let a = authority(&b, &lo, &hi);
    assert!(a.three_axis);
    assert!(close(a.min_authority_nm, 1.0, 1e-12), "{a:?}");
    assert!(close(a.max_authority_nm, 3f64.sqrt(), 1e-12), "{a:?}");
    // weakest direction is an axis (ties: any ±e_i)
    let w = a.weakest_direction;
    assert!(close(w.iter().map(|v| v.abs()).fold(0.0, f64::max), 1.0, 1e-12));
    for e in [[1., 0., 0.], [0., -1., 0.], [0., 0., 1.]] {
        assert!(close(max_along(&b, &lo, &hi, &e), 1.0, 1e-12));
    }
    assert!(close(max_along(&b, &lo, &hi, &[1., 1., 0.]), S2, 1e-12)); // normalised internally
    assert!(close(max_along(&b, &lo, &hi, &[1. / S2, 1. / S2, 0.]), S2, 1e-12));
    assert!(close(max_along(&b, &lo, &hi, &[-1., 1., 1.]), 3f64.sqrt(), 1e-12));
    // scaled box: u in [0, 2] for the x pair → ρ(x) = 2
    let hi2 = vec![2.0, 2.0, 1.0, 1.0, 1.0, 1.0];
    assert!(close(max_along(&b, &lo, &hi2, &[1., 0., 0.]), 2.0, 1e-12));
    assert!(close(authority(&b, &lo, &hi2).min_authority_nm, 1.0, 1e-12));

    // remove [0,0,-1]
    let b5 = b[..5].to_vec();
    let a5 = authority(&b5, &lo[..5], &hi[..5]);
    assert!(!a5.three_axis);
    assert_eq!(a5.min_authority_nm, 0.0);
    assert!(close(a5.weakest_direction[2], -1.0, 1e-12), "{a5:?}");
    assert_eq!(max_along(&b5, &lo[..5], &hi[..5], &[0., 0., -1.]), 0.0);
    assert!(close(max_along(&b5, &lo[..5], &hi[..5], &[0., 0., 1.]), 1.0, 1e-12));
    // failure table of the cube: exactly the 1-failures lose authority, all of them
    let t = failure_table(&b, &hi, 3);
    assert_eq!(t.cases.len(), 6 + 15 + 20);
    assert_eq!(t.lost.len(), t.cases.len());
    println!("{}", render_table(&t));
}

#[test]
fn degenerate_layouts() {
    let z = |n: usize| vec![0.0; n];
    let o = |n: usize| vec![1.0; n];
    // N = 0, 1, 2
    let a0 = authority(&[], &[], &[]);
    assert!(!a0.three_axis && a0.min_authority_nm == 0.0 && a0.max_authority_nm == 0.0);
    assert_eq!(max_along(&[], &[], &[], &[1., 0., 0.]), 0.0);
    let b1 = vec![[0., 0., 2.]];
    let a1 = authority(&b1, &z(1), &o(1));
    assert!(!a1.three_axis && close(a1.max_authority_nm, 2.0, 1e-12));
    assert!(close(max_along(&b1, &z(1), &o(1), &[0., 0., 1.]), 2.0, 1e-12));
    assert_eq!(max_along(&b1, &z(1), &o(1), &[0., 0., -1.]), 0.0);
    assert_eq!(max_along(&b1, &z(1), &o(1), &[1., 0., 1.]), 0.0);
    let b2 = vec![[1., 0., 0.], [0., 1., 0.]];
    assert!(!authority(&b2, &z(2), &o(2)).three_axis);
    assert!(close(max_along(&b2, &z(2), &o(2), &[1., 1., 0.]), S2, 1e-12));
    assert!(close(max_along(&b2, &z(2), &o(2), &[1., 2., 0.]), 5f64.sqrt() / 2.0, 1e-12));
    // symmetric bounds: N = 2 is still flat
    assert!(!authority(&b2, &[-1., -1.], &o(2)).three_axis);

    // coplanar square ±x, ±y (flat Z): in-plane ρ is the square's, out of plane 0
    let sq = vec![[1., 0., 0.], [-1., 0., 0.], [0., 1., 0.], [0., -1., 0.]];
    let a = authority(&sq, &z(4), &o(4));
    assert!(!a.three_axis && a.min_authority_nm == 0.0);
    assert!(close(a.weakest_direction[2].abs(), 1.0, 1e-12));
    assert!(close(a.max_authority_nm, S2, 1e-12));
    assert!(close(max_along(&sq, &z(4), &o(4), &[1., 0., 0.]), 1.0, 1e-12));
    assert!(close(max_along(&sq, &z(4), &o(4), &[-1., -1., 0.]), S2, 1e-12));
    assert_eq!(max_along(&sq, &z(4), &o(4), &[1., 0., 1e-3]), 0.0);
    // nearly coplanar (1e-13 out of plane): no three-axis authority
    let mut nq = sq.clone();
    nq.push([0.3, 0.2, 1e-13]);
    nq.push([0.3, -0.2, -1e-13]);
    assert!(!authority(&nq, &z(6), &o(6)).three_axis);
    // but with a real tilt it has (the tilt makes ±z attainable)
    let mut tq = sq.clone();
    tq.push([0., 0., 0.1]);
    tq.push([0., 0., -0.1]);
    let at = authority(&tq, &z(6), &o(6));
    assert!(at.three_axis && close(at.min_authority_nm, 0.1, 1e-12));

    // parallel and anti-parallel duplicates: cube with every column doubled = cube with u in [0,2]
    let mut dup = cube();
    dup.extend(cube().iter().map(|c| scale(c, 0.5)));
    dup.extend(cube().iter().map(|c| scale(c, 0.5)));
    let ad = authority(&dup, &z(18), &o(18));
    assert!(
        ad.three_axis && close(ad.min_authority_nm, 2.0, 1e-12) && close(ad.max_authority_nm, 2.0 * 3f64.sqrt(), 1e-12)
    );
    // all columns parallel (segment)
    let seg = vec![[0., 1., 0.], [0., -2., 0.], [0., 0.5, 0.]];
    let asg = authority(&seg, &z(3), &o(3));
    assert!(!asg.three_axis && close(asg.max_authority_nm, 2.0, 1e-12));
    assert!(close(max_along(&seg, &z(3), &o(3), &[0., 1., 0.]), 1.5, 1e-12));
    assert!(close(max_along(&seg, &z(3), &o(3), &[0., -1., 0.]), 2.0, 1e-12));
    assert_eq!(max_along(&seg, &z(3), &o(3), &[1., 1., 0.]), 0.0);
    // zero columns / zero-width bounds are ignored as generators
    let mut zc = cube();
    zc.push([0., 0., 0.]);
    let az = authority(&zc, &z(7), &o(7));
    assert!(az.three_axis && close(az.min_authority_nm, 1.0, 1e-12));
    // a stuck-on thruster translates Z: cube + (0,0,1) stuck → ρ(-z) = 0, ρ(+z) = 2
    let mut st = cube();
    st.push([0., 0., 1.]);
    let (lo, hi) = (vec![0., 0., 0., 0., 0., 0., 1.], vec![1.; 7]);
    assert!(close(max_along(&st, &lo, &hi, &[0., 0., 1.]), 2.0, 1e-12));
    assert!(max_along(&st, &lo, &hi, &[0., 0., -1.]).abs() < 1e-12);
    assert!(!authority(&st, &lo, &hi).three_axis);
}

/// ρ(d) for random layouts, certified without the library: (a) ρ d = B u with u in the box
/// (constructed on a face), (b) (1+1e-6) ρ d violates that face's brute-force support
/// (max over all 2^N box corners). Also max_authority = max corner norm (exact).
#[test]
fn rho_certified_random() {
    let mut rng = Rng(0x5eed_0004);
    let mut checked = 0;
    let mut worst_gap = 0.0f64;
    for trial in 0..300 {
        let n = 3 + rng.below(8); // 3..=10
        let b = rng.matrix(n);
        let (lo, hi): (Vec<f64>, Vec<f64>) =
            (0..n)
                .map(|_| {
                    if trial % 2 == 0 {
                        (0.0, rng.range(0.2, 2.0))
                    } else {
                        (-rng.range(0.0, 1.0), rng.range(0.2, 2.0))
                    }
                })
                .unzip();
        let cs = corners(&b, &lo, &hi);
        let a = authority(&b, &lo, &hi);
        let far = cs.iter().map(norm).fold(0.0, f64::max);
        assert!(close(a.max_authority_nm, far, 1e-12), "max {} vs corners {far}", a.max_authority_nm);
        let mut dirs: Vec<V3> = (0..6).map(|_| rng.unit3()).collect();
        if a.three_axis {
            dirs.push(a.weakest_direction);
        }
        for d in dirs {
            let rho = max_along(&b, &lo, &hi, &d);
            if rho <= 1e-9 {
                // no authority along d: certify with a brute-force separating face:
                // some ±b_i×b_j with n·d > 0 and brute support <= 0
                let ok = (0..n).any(|i| {
                    (i + 1..n).any(|j| {
                        let c = cross(&b[i], &b[j]);
                        [1.0, -1.0].iter().any(|s| {
                            let nn = scale(&c, *s);
                            dot(&nn, &d) > 0.0 && support_brute(&cs, &nn) <= 1e-9 * norm(&nn)
                        })
                    })
                });
                assert!(ok, "ρ = 0 uncertified");
                assert!(!a.three_axis);
                continue;
            }
            let x = scale(&d, rho);
            let (nf, u) = certify_attainable(&b, &lo, &hi, &x).expect("ρ d not attainable");
            assert!(u.len() == n);
            let xo = scale(&d, rho * (1.0 + 1e-6));
            let h = support_brute(&cs, &nf);
            assert!(dot(&nf, &xo) > h, "(1+1e-6) ρ d not separated: {} vs {h}", dot(&nf, &xo));
            worst_gap = worst_gap.max((dot(&nf, &x) - h).abs() / h.abs().max(1e-12));
            checked += 1;
        }
        if a.three_axis {
            // ρ(d) >= min authority for sampled directions, and the min is approached
            let m = sphere(400).iter().map(|d| max_along(&b, &lo, &hi, d)).fold(f64::INFINITY, f64::min);
            assert!(m >= a.min_authority_nm * (1.0 - 1e-12));
            assert!(close(max_along(&b, &lo, &hi, &a.weakest_direction), a.min_authority_nm, 1e-10));
        }
    }
    println!("certified {checked} (d, ρ) pairs; worst |n·ρd - h_brute|/h = {worst_gap:.2e}");
    assert!(checked > 1000);
}

/// Sampled sup of ρ agrees with the exact vertex-norm max_authority (from below).
#[test]
fn max_authority_vs_sampling() {
    let b = paper_b();
    let (lo, hi) = (vec![0.0; 8], vec![1.0; 8]);
    let a = authority(&b, &lo, &hi);
    let s = sphere(20000).iter().map(|d| max_along(&b, &lo, &hi, d)).fold(0.0, f64::max);
    println!("paper B: exact max authority {:.6}, sampled (20000 dirs) {s:.6}", a.max_authority_nm);
    assert!(s <= a.max_authority_nm * (1.0 + 1e-12) && s >= 0.98 * a.max_authority_nm);
    let smin = sphere(20000).iter().map(|d| max_along(&b, &lo, &hi, d)).fold(f64::INFINITY, f64::min);
    println!("paper B: exact min authority {:.6}, sampled {smin:.6}", a.min_authority_nm);
    assert!(smin >= a.min_authority_nm * (1.0 - 1e-12) && smin <= 1.05 * a.min_authority_nm);
}

/// Independent loss test: with u_min = 0, authority is lost iff the remaining columns do
/// not span R³ or some n = ±b_i×b_j has n·b_k <= 0 for every remaining k (extreme rays
/// of the polar cone are such cross products).
fn lost_by_gordan(b: &[V3], failed: &[usize]) -> bool {
    let rem: Vec<V3> = (0..b.len()).filter(|k| !failed.contains(&(k + 1))).map(|k| b[k]).collect();
    let m = rem.len();
    let mut spans = false;
    for i in 0..m {
        for j in i + 1..m {
            for k in j + 1..m {
                if dot(&cross(&rem[i], &rem[j]), &rem[k]).abs() > 1e-9 * norm(&rem[i]) * norm(&rem[j]) * norm(&rem[k]) {
                    spans = true;
                }
            }
        }
    }
    if !spans {
        return true;
    }
    for i in 0..m {
        for j in i + 1..m {
            let c = cross(&rem[i], &rem[j]);
            if norm(&c) <= 1e-9 * norm(&rem[i]) * norm(&rem[j]) {
                continue;
            }
            let c = unit(&c);
            for s in [1.0, -1.0] {
                if rem.iter().all(|bk| s * dot(&c, bk) <= 1e-9 * norm(bk)) {
                    return true;
                }
            }
        }
    }
    false
}

#[test]
fn paper_004() {
    let b = paper_b();
    let t = failure_table(&b, &[1.0; 8], 3);
    println!("{}", render_table(&t));
    assert!(t.nominal.three_axis);
    for c in &t.cases {
        assert_eq!(!c.three_axis, lost_by_gordan(&b, &c.failed), "{:?}", c.failed);
        if !c.three_axis {
            // the witness direction: no remaining thruster pushes along it
            let w = c.weakest_direction;
            for k in 0..8 {
                if !c.failed.contains(&(k + 1)) {
                    assert!(dot(&w, &b[k]) <= 1e-12, "{:?}: thruster {} has n·b = {}", c.failed, k + 1, dot(&w, &b[k]));
                }
            }
        } else {
            // certified ρ along the weakest direction with the failed thrusters off
            let mut hi = vec![1.0; 8];
            for f in &c.failed {
                hi[f - 1] = 0.0;
            }
            let x = scale(&c.weakest_direction, c.min_authority_nm);
            certify_attainable(&b, &[0.0; 8], &hi, &x).expect("weakest point not attainable");
            let h = support_brute(&corners(&b, &[0.0; 8], &hi), &c.weakest_direction);
            assert!(close(h, c.min_authority_nm, 1e-12));
        }
    }
    let get = |f: &[usize]| t.cases.iter().find(|c| c.failed == f).unwrap().clone();
    let c14 = get(&[1, 4]);
    let c137 = get(&[1, 3, 7]);
    println!("{{1,4}}: {c14:?}");
    println!("{{1,3,7}}: {c137:?}");
    for k in 1..=3 {
        let l: Vec<_> = t.lost.iter().filter(|f| f.len() == k).collect();
        println!("{k} failed: lost {l:?}");
    }
    assert!(c14.three_axis);
    assert!(!c137.three_axis);
    let lost2: Vec<Vec<usize>> = t.lost.iter().filter(|f| f.len() == 2).cloned().collect();
    assert_eq!(lost2, vec![vec![1, 3], vec![1, 7], vec![3, 5], vec![5, 7]]);
    assert!(t.lost.iter().all(|f| f.len() > 1));
    println!("{}", serde_json::to_string(&t.nominal).unwrap());
    let js = serde_json::to_string(&t).unwrap();
    assert!(js.contains("\"lost\""));
}

#[test]
fn scaling_invariance() {
    let mut rng = Rng(42);
    for trial in 0..40 {
        let n = 4 + rng.below(6);
        let b = if trial == 0 { paper_b() } else { rng.matrix(n) };
        let n = b.len();
        let hi: Vec<f64> = (0..n).map(|_| rng.range(0.5, 2.0)).collect();
        let t = failure_table(&b, &hi, 3);
        for s in [1e-3, 2.5, 1e3] {
            let bs: Vec<V3> = b.iter().map(|c| scale(c, s)).collect();
            let ts = failure_table(&bs, &hi, 3);
            assert!(close(ts.nominal.min_authority_nm, s * t.nominal.min_authority_nm, 1e-12));
            assert!(close(ts.nominal.max_authority_nm, s * t.nominal.max_authority_nm, 1e-12));
            assert_eq!(ts.lost, t.lost);
            for (c, cs) in t.cases.iter().zip(&ts.cases) {
                assert_eq!((&c.failed, c.three_axis), (&cs.failed, cs.three_axis));
                assert!(close(cs.min_authority_nm, s * c.min_authority_nm, 1e-12));
            }
            let d = rng.unit3();
            let lo = vec![0.0; n];
            assert!(close(max_along(&bs, &lo, &hi, &d), s * max_along(&b, &lo, &hi, &d), 1e-12));
        }
        // scaling u_max by s is the same as scaling B
        let his: Vec<f64> = hi.iter().map(|v| v * 3.0).collect();
        let th = failure_table(&b, &his, 3);
        assert!(close(th.nominal.min_authority_nm, 3.0 * t.nominal.min_authority_nm, 1e-12));
    }
}

#[test]
fn permutation_invariance() {
    let mut rng = Rng(7);
    for trial in 0..40 {
        let b = if trial == 0 {
            paper_b()
        } else {
            let m = 4 + rng.below(6);
            rng.matrix(m)
        };
        let n = b.len();
        let hi: Vec<f64> = (0..n).map(|_| rng.range(0.5, 2.0)).collect();
        // random permutation: new column p ← old column perm[p]
        let mut perm: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            perm.swap(i, rng.below(i + 1));
        }
        let bp: Vec<V3> = perm.iter().map(|&k| b[k]).collect();
        let hp: Vec<f64> = perm.iter().map(|&k| hi[k]).collect();
        let t = failure_table(&b, &hi, 3);
        let tp = failure_table(&bp, &hp, 3);
        assert!(close(t.nominal.min_authority_nm, tp.nominal.min_authority_nm, 1e-12));
        assert!(close(t.nominal.max_authority_nm, tp.nominal.max_authority_nm, 1e-12));
        assert_eq!(t.cases.len(), tp.cases.len());
        let map = |f: &[usize]| {
            let mut v: Vec<usize> = f.iter().map(|p| perm[p - 1] + 1).collect();
            v.sort();
            v
        };
        for cp in &tp.cases {
            let c = t.cases.iter().find(|c| c.failed == map(&cp.failed)).unwrap();
            assert_eq!(c.three_axis, cp.three_axis);
            assert!(close(c.min_authority_nm, cp.min_authority_nm, 1e-12));
        }
        let mut lost: Vec<Vec<usize>> = tp.lost.iter().map(|f| map(f)).collect();
        lost.sort_by(|a, b| (a.len(), a).cmp(&(b.len(), b)));
        assert_eq!(lost, t.lost);
    }
}
