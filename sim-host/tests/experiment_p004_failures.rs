//! Experiment p004-failures (paper 004, thruster failures) against independent methods
//! written here: B typed from the paper's table 2, three-axis authority by the positive
//! spanning test (no nonzero c with cᵀb_k <= 0 for every remaining column), and the
//! ray radius of the attainable set as a linear programme solved by enumerating its
//! basic solutions.

use acs_test_support::vec3::{V3, cross, dot, norm};
use sim_host::report::experiment::{self, Context, Explains};
use sim_host::report::experiments::p004_failures::{losing_pairs, section, u_max_failed};

/// Paper 004 table 2 times the scenarios' 10 N (SEEDS.md section 004), columns = thrusters.
fn table2_b() -> Vec<V3> {
    let (r, d, s) = (0.73, 0.73, 10.0 / 2f64.sqrt());
    let rows =
        [[r, 0.0, r, -0.43, -r, 0.0, -r, 0.43], [d, -0.43, -d, 0.0, -d, 0.43, d, 0.0], [d, -d, d, -d, d, -d, d, -d]];
    (0..8).map(|k| [rows[0][k] * s, rows[1][k] * s, rows[2][k] * s]).collect()
}

/// Whether the columns positively span R³. They do iff they span R³ and no nonzero c has
/// `c·b_k <= 0` for all k; that cone of c is then pointed, so if nonempty it has an
/// extreme ray on two of the planes `c·b_i = 0`: `c = ±(b_i × b_j)`.
fn positively_spans(cols: &[V3]) -> bool {
    let scale = cols.iter().map(norm).fold(0.0, f64::max);
    let mut rank3 = false;
    for i in 0..cols.len() {
        for j in i + 1..cols.len() {
            for k in j + 1..cols.len() {
                if dot(&cross(&cols[i], &cols[j]), &cols[k]).abs() > 1e-9 * scale.powi(3) {
                    rank3 = true;
                }
            }
        }
    }
    if !rank3 {
        return false;
    }
    for i in 0..cols.len() {
        for j in i + 1..cols.len() {
            let c = cross(&cols[i], &cols[j]);
            let nc = norm(&c);
            if nc <= 1e-9 * scale * scale {
                continue;
            }
            for sgn in [1.0, -1.0] {
                let cc = c.map(|x| x * sgn);
                if cols.iter().all(|b| dot(&cc, b) <= 1e-9 * nc * norm(b)) {
                    return false;
                }
            }
        }
    }
    true
}

/// max λ s.t. B u = λ d, 0 <= u_k <= u_max_k: at an optimal basic solution λ and two u's
/// are basic and every other u sits at 0 or its upper bound; enumerate them all.
fn lp_radius(b: &[V3], u_max: &[f64], d: &V3) -> f64 {
    let n = b.len();
    let mut best = 0.0f64;
    for i in 0..n {
        for j in i + 1..n {
            // Columns [b_i, b_j, -d]; the 2^(n-2) bound patterns of the rest.
            let m = [b[i], b[j], d.map(|x| -x)];
            let det = dot(&m[0], &cross(&m[1], &m[2]));
            if det.abs() < 1e-12 {
                continue;
            }
            let others: Vec<usize> = (0..n).filter(|&k| k != i && k != j).collect();
            for mask in 0u32..(1 << others.len()) {
                let mut rhs = [0.0; 3];
                for (bit, &k) in others.iter().enumerate() {
                    if mask & (1 << bit) != 0 {
                        for a in 0..3 {
                            rhs[a] -= b[k][a] * u_max[k];
                        }
                    }
                }
                // Cramer: m x = rhs, x = (u_i, u_j, λ).
                let x0 = dot(&rhs, &cross(&m[1], &m[2])) / det;
                let x1 = dot(&m[0], &cross(&rhs, &m[2])) / det;
                let lam = dot(&m[0], &cross(&m[1], &rhs)) / det;
                let ok = |u: f64, hi: f64| u >= -1e-9 && u <= hi + 1e-9;
                if ok(x0, u_max[i]) && ok(x1, u_max[j]) && lam > best {
                    best = lam;
                }
            }
        }
    }
    best
}

#[test]
fn losing_pairs_match_the_positive_spanning_test() {
    let b = table2_b();
    let mut independent = Vec::new();
    for i in 1..=8 {
        for j in i + 1..=8 {
            let rest: Vec<V3> = (1..=8).filter(|&k| k != i && k != j).map(|k| b[k - 1]).collect();
            if !positively_spans(&rest) {
                independent.push((i, j));
            }
        }
    }
    assert_eq!(losing_pairs(&b), independent);
    // The intact layout and every single failure keep three-axis control.
    assert!(positively_spans(&b));
    for i in 0..8 {
        let rest: Vec<V3> = (0..8).filter(|&k| k != i).map(|k| b[k]).collect();
        assert!(positively_spans(&rest), "single failure {}", i + 1);
    }
}

#[test]
fn section_radii_match_the_lp() {
    let b = table2_b();
    let planes =
        [([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]), ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]), ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])];
    for failed in [vec![], vec![1, 4], vec![1, 3]] {
        let um = u_max_failed(8, &failed);
        for (e1, e2) in planes {
            // 16 rays: along ±e1, ±e2 and between; the polygon's first point repeats last.
            let poly = section(&b, &um, e1, e2, 16);
            assert_eq!(poly.len(), 17);
            assert_eq!(poly[0], poly[16]);
            for (k, (x, y)) in poly.iter().take(16).enumerate() {
                let a = std::f64::consts::TAU * k as f64 / 16.0;
                let d: V3 = std::array::from_fn(|i| a.cos() * e1[i] + a.sin() * e2[i]);
                let r = lp_radius(&b, &um, &d);
                let got = x.hypot(*y);
                assert!((got - r).abs() <= 1e-9 * (1.0 + r), "{failed:?} ray {k}: section {got}, LP {r}");
                // The point lies along its ray.
                assert!((x * a.sin() - y * a.cos()).abs() <= 1e-9 * (1.0 + r));
            }
        }
    }
}

#[test]
fn failures_experiment_against_independent_truths() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fig_dir = std::env::var("P004_FIG_DIR").map_or_else(|_| dir.path().to_path_buf(), std::path::PathBuf::from);
    let ctx = Context { repo: experiment::repo_root(), fig_dir, jobs: 2 };
    let e = sim_host::report::experiments::p004_failures::run(&ctx).expect("experiment runs");
    for (k, v) in &e.findings {
        eprintln!("{k} = {v}");
    }
    let f = |k: &str| e.finding(k).expect("finding");
    let b = table2_b();
    // The counts from the positive spanning test.
    let lost_of = |k: usize| {
        let mut lost = 0;
        let mut total = 0;
        for mask in 0u32..256 {
            if mask.count_ones() as usize == k {
                total += 1;
                let rest: Vec<V3> = (0..8).filter(|&i| mask & (1 << i) == 0).map(|i| b[i]).collect();
                if !positively_spans(&rest) {
                    lost += 1;
                }
            }
        }
        (lost as f64, total as f64)
    };
    assert_eq!((f("double_failures_losing"), f("double_failures_total")), lost_of(2));
    assert_eq!((f("triple_failures_losing"), f("triple_failures_total")), lost_of(3));
    assert_eq!(f("single_failures_losing"), 0.0);
    let rest137: Vec<V3> = (1..=8).filter(|k| ![1, 3, 7].contains(k)).map(|k| b[k - 1]).collect();
    assert_eq!(f("fail_1_3_7_lost") == 1.0, !positively_spans(&rest137));
    // Minimum authority with {1,4} out is at most the LP radius along any direction, and
    // equals it along some: sample the sphere densely and compare the minimum.
    let um = u_max_failed(8, &[1, 4]);
    let mut min_r = f64::INFINITY;
    for i in 0..40 {
        for j in 0..80 {
            let th = std::f64::consts::PI * (i as f64 + 0.5) / 40.0;
            let ph = std::f64::consts::TAU * j as f64 / 80.0;
            let d = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            min_r = min_r.min(lp_radius(&b, &um, &d));
        }
    }
    let a14 = f("min_authority_1_4_nm");
    assert!(a14 <= min_r + 1e-9 && a14 >= 0.9 * min_r, "authority {{1,4}} {a14} vs sampled LP minimum {min_r}");
    assert!((f("min_authority_1_4_nm_per_n") - a14 / 10.0).abs() < 1e-12);
    // Closed loop: a pair without authority cannot bring a 15/15/15 deg error to the
    // 1 deg settle bound; the surviving pair does (the paper flies it: table 6).
    assert!(f("final_error_deg_fail_1_3") > 5.0, "{{1,3}} should not converge");
    assert!(f("final_error_deg_fail_1_4") < 1.0, "{{1,4}} should converge");
    assert_eq!(e.explains, if f("double_failures_losing") > 0.0 { Explains::Yes } else { Explains::No });
    assert_eq!(e.blocks.iter().filter(|b| matches!(b, experiment::Block::Figure { .. })).count(), 2);
}
