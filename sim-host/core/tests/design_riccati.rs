//! CARE/DARE: closed forms, residuals on the papers' models, stability, errors, and an
//! independent Newton–Kleinman solution.
#[path = "design_common/mod.rs"]
mod common;
use acs_test_support::rng::Lcg64;
use nalgebra::{DMatrix, dmatrix};
use sim_core::design::c2d;
use sim_core::design::riccati::*;

const RES_TOL: f64 = 1e-9;

#[test]
fn double_integrator_care_closed_form() {
    // A = [[0,1],[0,0]], B = [0,1]ᵀ, Q = I, R = 1  ⇒  X = [[√3, 1], [1, √3]], K = [1, √3].
    let a = dmatrix![0.0, 1.0; 0.0, 0.0];
    let b = dmatrix![0.0; 1.0];
    let q = DMatrix::identity(2, 2);
    let r = dmatrix![1.0];
    let s = care_with(&a, &b, &q, &r, &SdaOptions::default()).unwrap();
    let s3 = 3f64.sqrt();
    let exact = dmatrix![s3, 1.0; 1.0, s3];
    let err = (&s.x - &exact).norm() / exact.norm();
    println!(
        "double integrator: rel err {err:.2e}, residual {:.2e}, {} doublings, gamma {:.3}",
        s.residual_rel, s.iterations, s.gamma
    );
    assert!(err < 1e-13);
    let k = lqr_gain(&b, &r, &s.x).unwrap();
    assert!((k[(0, 0)] - 1.0).abs() < 1e-13 && (k[(0, 1)] - s3).abs() < 1e-13);
}

#[test]
fn scalar_care_and_dare_closed_forms() {
    for &(a, b, q, r) in &[(0.5f64, 2.0f64, 3.0f64, 0.7f64), (-1.0, 1.0, 1.0, 1.0), (2.0, 0.1, 10.0, 1e-3)] {
        let xc = r * (a + (a * a + b * b * q / r).sqrt()) / (b * b);
        let x = care(&dmatrix![a], &dmatrix![b], &dmatrix![q], &dmatrix![r]).unwrap()[(0, 0)];
        assert!((x - xc).abs() <= 1e-12 * xc, "care {x} vs {xc}");
        // b²x² + (r(1 − a²) − q b²) x − q r = 0, positive root.
        let p = r * (1.0 - a * a) - q * b * b;
        let xd = (-p + (p * p + 4.0 * b * b * q * r).sqrt()) / (2.0 * b * b);
        let x = dare(&dmatrix![a], &dmatrix![b], &dmatrix![q], &dmatrix![r]).unwrap()[(0, 0)];
        assert!((x - xd).abs() <= 1e-12 * xd, "dare {x} vs {xd}");
    }
}

#[test]
fn papers_models_care_and_dare_residuals_and_stability() {
    for (name, a, b, q, r) in common::six_state_problems() {
        let s = care_with(&a, &b, &q, &r, &SdaOptions::default()).unwrap();
        let res = care_residual_rel(&a, &b, &q, &r, &s.x).unwrap();
        let k = lqr_gain(&b, &r, &s.x).unwrap();
        let m = spectral_margin(&(&a - &b * &k), Time::Continuous).unwrap();
        println!(
            "CARE {name:32} residual {res:.2e}  doublings {:2}  newton {}  gamma {:.3e}  max Re λ {m:.3e}",
            s.iterations, s.newton_steps, s.gamma
        );
        assert!(res < RES_TOL && m < 0.0);
        // Symmetric PSD.
        assert!((&s.x - s.x.transpose()).norm() <= 1e-14 * s.x.norm());
        assert!(s.x.clone().symmetric_eigenvalues().min() > -1e-10 * s.x.norm());

        for dt in [0.1, 1.0] {
            let (ad, bd) = c2d(&a, &b, dt).unwrap();
            let (qd, rd) = (&q * dt, &r * dt);
            let s = dare_with(&ad, &bd, &qd, &rd, &SdaOptions::default()).unwrap();
            let res = dare_residual_rel(&ad, &bd, &qd, &rd, &s.x).unwrap();
            let k = dlqr_gain(&ad, &bd, &rd, &s.x).unwrap();
            let m = spectral_margin(&(&ad - &bd * &k), Time::Discrete).unwrap();
            println!(
                "DARE {name:32} dt {dt:3} residual {res:.2e}  doublings {:2}  newton {}  max |λ| {m:.6}",
                s.iterations, s.newton_steps
            );
            assert!(res < RES_TOL && m < 1.0);
        }
    }
}

#[test]
fn residual_without_newton_refinement() {
    // The doubling alone must already meet the tolerance (refinement is a safety net).
    let opt = SdaOptions { newton_steps: 0, ..Default::default() };
    for (name, a, b, q, r) in common::six_state_problems() {
        let s = care_with(&a, &b, &q, &r, &opt).unwrap();
        let (ad, bd) = c2d(&a, &b, 0.1).unwrap();
        let d = dare_with(&ad, &bd, &(&q * 0.1), &(&r * 0.1), &opt).unwrap();
        println!("SDA only {name:32} CARE {:.2e}  DARE {:.2e}", s.residual_rel, d.residual_rel);
        assert!(s.residual_rel < RES_TOL && d.residual_rel < RES_TOL);
    }
}

/// Independent algorithm: Newton–Kleinman from a stabilising gain, Lyapunov equations
/// solved by Kronecker products. Must agree with SDA.
#[test]
fn agrees_with_newton_kleinman() {
    for (name, a, b, q, r) in common::six_state_problems() {
        let n = a.nrows();
        let x_sda = care(&a, &b, &q, &r).unwrap();
        // Stabilising start: the LQR gain for 100·Q (any stabilising K works).
        let mut k = lqr(&a, &b, &(&q * 100.0), &r).unwrap().0;
        let eye = DMatrix::<f64>::identity(n, n);
        let mut x = DMatrix::<f64>::zeros(n, n);
        for _ in 0..50 {
            let ak = &a - &b * &k;
            let rhs = -(&q + k.transpose() * &r * &k);
            let op = eye.kronecker(&ak.transpose()) + ak.transpose().kronecker(&eye);
            let v = op.lu().solve(&nalgebra::DVector::from_column_slice(rhs.as_slice())).unwrap();
            let xn = DMatrix::from_column_slice(n, n, v.as_slice());
            let done = (&xn - &x).norm() <= 1e-15 * xn.norm();
            x = (&xn + xn.transpose()) * 0.5;
            k = lqr_gain(&b, &r, &x).unwrap();
            if done {
                break;
            }
        }
        let d = (&x - &x_sda).norm() / x_sda.norm();
        println!("{name:32} |X_NK − X_SDA| / |X| = {d:.2e}");
        assert!(d < 1e-8);
    }
}

#[test]
fn random_12_state_4_input_problems() {
    // Deterministic LCG data; A has unstable modes.
    let mut lcg = Lcg64(0x9e3779b97f4a7c15);
    let mut rnd = move || lcg.symmetric();
    for _ in 0..5 {
        let a = DMatrix::from_fn(12, 12, |_, _| rnd());
        let b = DMatrix::from_fn(12, 4, |_, _| rnd());
        let c = DMatrix::from_fn(12, 12, |_, _| rnd());
        let q = c.transpose() * c;
        let r = DMatrix::identity(4, 4) * 0.5;
        let sc = care_with(&a, &b, &q, &r, &SdaOptions::default()).unwrap();
        let (ad, bd) = c2d(&a, &b, 0.2).unwrap();
        let sd = dare_with(&ad, &bd, &q, &r, &SdaOptions::default()).unwrap();
        println!(
            "12×4: CARE residual {:.1e} ({} doublings), DARE residual {:.1e} ({} doublings)",
            sc.residual_rel, sc.iterations, sd.residual_rel, sd.iterations
        );
        assert!(sc.residual_rel < RES_TOL && sc.closed_loop_margin < 0.0);
        assert!(sd.residual_rel < RES_TOL && sd.closed_loop_margin < 1.0);
    }
}

#[test]
fn typed_errors() {
    let eye2 = DMatrix::<f64>::identity(2, 2);
    // Unstable mode not reachable: A = I (unstable in continuous and on |λ| = 1 boundary… use 2I for DARE).
    let b = dmatrix![1.0; 0.0];
    let r = dmatrix![1.0];
    assert!(matches!(care(&eye2, &b, &eye2, &r), Err(RiccatiError::NotStabilisable { .. })));
    assert!(matches!(dare(&(&eye2 * 2.0), &b, &eye2, &r), Err(RiccatiError::NotStabilisable { .. })));
    // Oscillator with Q = 0: imaginary-axis modes unobservable ⇒ no stabilising solution.
    let osc = dmatrix![0.0, 1.0; -1.0, 0.0];
    let b2 = dmatrix![0.0; 1.0];
    let z = DMatrix::<f64>::zeros(2, 2);
    assert!(matches!(care(&osc, &b2, &z, &r), Err(RiccatiError::NoStabilisingSolution { .. })));
    let rot = dmatrix![0.6, 0.8; -0.8, 0.6]; // |λ| = 1
    assert!(matches!(dare(&rot, &b2, &z, &r), Err(RiccatiError::NoStabilisingSolution { .. })));
    // Singular / indefinite R, non-finite data, bad shapes, indefinite Q.
    assert_eq!(care(&osc, &b2, &eye2, &dmatrix![0.0]), Err(RiccatiError::SingularR));
    assert_eq!(dare(&osc, &b2, &eye2, &dmatrix![-1.0]), Err(RiccatiError::SingularR));
    assert_eq!(care(&dmatrix![f64::NAN, 1.0; 0.0, 0.0], &b2, &eye2, &r), Err(RiccatiError::NonFinite));
    assert!(matches!(care(&osc, &dmatrix![1.0], &eye2, &r), Err(RiccatiError::Dimension(_))));
    assert_eq!(care(&osc, &b2, &dmatrix![1.0, 0.0; 0.0, -1.0], &r), Err(RiccatiError::QNotPsd));
    // Iteration budget exhausted ⇒ NoConvergence (the problem itself is fine).
    let opt = SdaOptions { max_iter: 1, tol: 1e-300, newton_steps: 0 };
    let (_, a, b, q, r) = common::six_state_problems().pop().unwrap();
    assert!(matches!(care_with(&a, &b, &q, &r, &opt), Err(RiccatiError::NoConvergence { .. })));
}
