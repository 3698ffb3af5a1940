//! Experiment `p000-rig-effects` (paper 000, test 3 on the air-bearing rig): its findings
//! against closed forms and physics, and its verdict against the paper's figures.

use acs_flight::math::EulerSeq;
use sim_core::attitude::{error_angle, quat_from_euler};
use sim_host::report::experiment::{self, Context, Experiment, Explains};
use sim_host::report::experiments::p000_rig::{self, key_num};
use std::sync::OnceLock;

/// One run of the experiment shared by the tests (figures in a temporary directory).
fn exp() -> &'static Experiment {
    static E: OnceLock<Experiment> = OnceLock::new();
    E.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("p000_rig_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let ctx = Context { repo: experiment::repo_root(), fig_dir: dir.clone(), jobs: 2 };
        let e = p000_rig::run(&ctx).unwrap();
        for f in ["p000_rig_sweeps.png", "p000_rig_yaw.png", "p000_rig_combination.png"] {
            assert!(dir.join(f).is_file(), "figure {f} written");
        }
        std::fs::remove_dir_all(&dir).ok();
        e
    })
}

fn get(key: &str) -> f64 {
    exp().finding(key).unwrap()
}

/// Paper 000, table "Tests" (SEEDS.md): initial and desired Euler angles, ζ, ωn.
const TEST1: ([f64; 3], [f64; 3], f64, f64) = ([3.62, 2.04, 12.51], [0.0, 0.0, 50.0], 0.47, 0.7);
const TEST3: ([f64; 3], [f64; 3], f64, f64) = ([2.47, 0.75, 1.28], [0.0, 0.0, 50.0], 0.9, 1.1);
/// Table 2: principal inertia, kg m².
const INERTIA: [f64; 3] = [3.1, 3.1, 5.8];

/// Settle time (|e| < 1° from then on) of the linear second-order response of the PD law
/// (eq 18 with q_e ≈ θ/2) from an initial error A at rest:
/// e(t) = A e^(-ζωn t) (cos ωd t + ζωn/ωd sin ωd t).
fn linear_settle_s(test: ([f64; 3], [f64; 3], f64, f64)) -> f64 {
    let (from, to, zeta, wn) = test;
    let q = |e: [f64; 3]| quat_from_euler(e.map(f64::to_radians), EulerSeq::Zyx321);
    let a = error_angle(&q(from), &q(to)).to_degrees();
    let (s, wd) = (zeta * wn, wn * (1.0 - zeta * zeta).sqrt());
    let mut last = 0.0;
    for i in 0..600_000 {
        let t = i as f64 * 1e-4;
        let e = a * (-s * t).exp() * ((wd * t).cos() + s / wd * (wd * t).sin());
        if e.abs() >= 1.0 {
            last = t;
        }
    }
    last
}

#[test]
fn ideal_settle_times_follow_the_linear_second_order_response() {
    // Test 1's gains stay within the cluster's torque: the run is the linear response.
    let (sim1, lin1) = (get("settle_s_test1_ideal"), linear_settle_s(TEST1));
    assert!((sim1 - lin1).abs() <= 0.03 * lin1, "test 1: {sim1} s vs linear {lin1} s");
    // Test 3 asks ~5.8 N m at the start, more than the pyramid gives at 60°/s: the torque
    // limit can only slow the response, and only modestly.
    let (sim3, lin3) = (get("settle_s_ideal"), linear_settle_s(TEST3));
    assert!(sim3 >= lin3 && sim3 <= 1.2 * lin3, "test 3: {sim3} s vs linear {lin3} s");
}

#[test]
fn a_cm_offset_leaves_the_steady_error_of_the_pd_stiffness() {
    // m g r along body y gives a roll torque m g r cos φ; the PD law balances it with
    // K_x sin(φ/2), K_x = 2 ωn² I_x (eq 17). Solve for φ by fixed-point iteration.
    let (_, _, _, wn) = TEST3;
    let k = 2.0 * wn * wn * INERTIA[0];
    for m in [0.0025, 0.005, 0.01, 0.02, 0.04] {
        let mut phi: f64 = 0.0;
        for _ in 0..50 {
            phi = 2.0 * (m * phi.cos() / k).asin();
        }
        let expect = phi.to_degrees();
        let sim = get(&format!("final_error_deg_cm_offset_{}", key_num(m)));
        assert!((sim - expect).abs() <= 0.02 * expect, "m g r {m}: {sim} deg vs {expect} deg");
    }
}

#[test]
fn a_slowly_varying_ahrs_error_becomes_the_true_steady_error() {
    // The loop nulls the measured error, so the true attitude sits off by the sensor's error.
    for b in [0.25, 0.5, 1.0, 1.5, 2.0] {
        let sim = get(&format!("steady_error_deg_ahrs_slow_error_{}", key_num(b)));
        assert!((sim - b).abs() <= 0.01 * b, "AHRS error {b}: true steady error {sim}");
    }
}

#[test]
fn white_ahrs_error_response_is_linear_in_its_level() {
    // Same seed, noise scaled: near the target the closed loop is linear, so the true
    // error it leaves doubles with the noise.
    for (lo, hi) in [(0.25, 0.5), (0.5, 1.0), (1.0, 2.0)] {
        let r = get(&format!("steady_error_deg_ahrs_noise_{}", key_num(hi)))
            / get(&format!("steady_error_deg_ahrs_noise_{}", key_num(lo)));
        assert!((r - 2.0).abs() < 0.1, "{lo}→{hi} deg: ratio {r}");
    }
}

#[test]
fn servo_lag_only_slows_settling() {
    let mut prev = get("settle_s_ideal");
    for tau in [0.02, 0.05, 0.1, 0.15, 0.2] {
        let s = get(&format!("settle_s_servo_lag_{}", key_num(tau)));
        assert!(s >= prev, "τ {tau}: {s} s after {prev} s");
        prev = s;
    }
}

#[test]
fn bearing_friction_steady_errors() {
    // Viscous friction has no static torque: no steady error.
    for c in [0.01, 0.1, 0.3, 0.6, 1.0] {
        let e = get(&format!("steady_error_deg_bearing_viscous_{}", key_num(c)));
        assert!(e < 1e-3, "viscous {c}: {e} deg");
    }
    // Coulomb friction ≤ T_c cannot hold the body where the PD torque exceeds it: per axis
    // |θ_i| ≤ 2 asin(T_c / K_i), K_i = 2 ωn² I_i.
    let (_, _, _, wn) = TEST3;
    for tc in [0.005, 0.01, 0.02, 0.05, 0.1] {
        let band: f64 =
            INERTIA.iter().map(|i| (2.0 * (tc / (2.0 * wn * wn * i)).asin()).powi(2)).sum::<f64>().sqrt().to_degrees();
        let e = get(&format!("steady_error_deg_bearing_coulomb_{}", key_num(tc)));
        assert!(e <= band, "Coulomb {tc}: {e} deg outside the stiction band {band} deg");
    }
}

#[test]
fn verdict_follows_the_papers_figures() {
    // Paper 000, test 3: ~10 s, about a third of test 1; test 1's steady error below the
    // AHRS's 2° dynamic accuracy. Tolerances: ±2.5 s, ±0.1, ≤ 2°, on every seed.
    assert!(p000_rig::reproduces(10.0, 1.0 / 3.0, 1.0));
    assert!(!p000_rig::reproduces(4.7, 1.0 / 3.0, 1.0));
    assert!(!p000_rig::reproduces(10.0, 0.45, 1.0));
    assert!(!p000_rig::reproduces(10.0, 1.0 / 3.0, 2.5));
    let within = |lo: f64, hi: f64, c: f64, tol: f64| (lo - c).abs() <= tol && (hi - c).abs() <= tol;
    let meets =
        within(get("settle_s_all_effects_min_over_seeds"), get("settle_s_all_effects_max_over_seeds"), 10.0, 2.5)
            && within(
                get("ratio_test3_test1_all_effects_min_over_seeds"),
                get("ratio_test3_test1_all_effects_max_over_seeds"),
                1.0 / 3.0,
                0.1,
            )
            && get("steady_error_deg_test1_all_effects_max_over_seeds") <= 2.0;
    assert_eq!(exp().explains == Explains::Yes, meets, "verdict vs findings");
    // The ideal rig does not meet the paper's figures: the experiment has a gap to explain.
    assert!(!p000_rig::reproduces(get("settle_s_ideal"), get("ratio_test3_test1_ideal"), 0.0));
}

#[test]
fn deterministic_whatever_the_thread_count() {
    let dir = std::env::temp_dir().join(format!("p000_rig_det_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let e = p000_rig::run(&Context { repo: experiment::repo_root(), fig_dir: dir.clone(), jobs: 1 }).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let bits = |e: &Experiment| e.findings.iter().map(|(k, v)| (k.clone(), v.to_bits())).collect::<Vec<_>>();
    assert_eq!(bits(&e), bits(exp()));
    assert_eq!(e.conclusion, exp().conclusion);
}
