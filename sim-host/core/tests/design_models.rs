//! `linearize` (central differences on the nonlinear models) versus the analytic linear
//! models, the classical LVLH equations and paper 003 eq 17; CMG Jacobian; c2d closed forms.
#[path = "design_common/mod.rs"]
mod common;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3, dmatrix};
use sim_core::design::models::*;
use sim_core::design::{c2d, c2d_noise, linearize};

fn max_abs(x: &DMatrix<f64>, y: &DMatrix<f64>) -> f64 {
    (x - y).abs().max()
}

/// Entry-wise `|X − Y| ≤ 1e-6 |Y| + 1e-12`: relative 1e-6 on every nonzero entry (the
/// 300 km gravity-gradient entries are ~1e-6, so an absolute test would be empty).
fn close_rel(x: &DMatrix<f64>, y: &DMatrix<f64>) -> bool {
    x.zip_map(y, |p, q| (p - q).abs() <= 1e-6 * q.abs() + 1e-12).iter().all(|&ok| ok)
}

fn lin(m: &AttitudeModel, u0: &DVector<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    linearize(|x, u| m.f(x, u), &DVector::zeros(6), u0, 1e-5)
}

#[test]
fn orbit_torque_model_a() {
    // 300 km and an exaggerated n = 0.05 rad/s (makes the n and n² terms O(1e-3..1e-1)).
    for n in [common::n300(), 0.05] {
        for j in [[2.5, 2.5, 2.5], [2.5, 3.2, 1.8], [4.0, 2.0, 3.0]] {
            let m = AttitudeModel::orbit_torque(Matrix3::from_diagonal(&Vector3::from(j)), n);
            assert!(m.bias_torque().norm() == 0.0);
            let (a, b) = m.linear();
            let (ac, bc) = classical_gg_linear(j, n);
            let (an, bn) = lin(&m, &DVector::zeros(3));
            let (e1, e2) = (max_abs(&a, &ac).max(max_abs(&b, &bc)), max_abs(&an, &a).max(max_abs(&bn, &b)));
            println!("a: n {n:.4e} J {j:?}: |analytic − classical| {e1:.1e}, |linearize − analytic| {e2:.1e}");
            assert!(e1 < 1e-15 && close_rel(&an, &a) && close_rel(&bn, &b) && close_rel(&a, &ac));
        }
    }
}

#[test]
fn cmg_jacobian_is_the_momentum_gradient() {
    let c = CmgPyramid::paper002();
    let d = [0.3, -1.1, 2.0, 0.7];
    let (jn, _) = linearize(
        |x, _| {
            let h = c.momentum(&[x[0], x[1], x[2], x[3]]);
            DVector::from_column_slice(h.as_slice())
        },
        &DVector::from_column_slice(&d),
        &DVector::zeros(0),
        1e-6,
    );
    let j = c.jacobian(&d);
    let e = (0..3)
        .flat_map(|r| (0..4).map(move |k| (r, k)))
        .map(|(r, k)| (jn[(r, k)] - j[(r, k)]).abs())
        .fold(0.0, f64::max);
    assert!(e < 1e-9, "{e}");
    // δ = 0: zero momentum, rank-3 Jacobian h0 [[-cβ,0,cβ,0],[0,-cβ,0,cβ],[sβ,sβ,sβ,sβ]].
    assert!(c.momentum(&[0.0; 4]).norm() < 1e-16);
    let j0 = c.jacobian(&[0.0; 4]);
    assert!((j0[(2, 3)] - 0.35 * c.beta.sin()).abs() < 1e-15 && (j0[(0, 0)] + 0.35 * c.beta.cos()).abs() < 1e-15);
}

#[test]
fn paper002_cmg_model_b() {
    // δ₀ = [0, a, 0, −a] stores h = [0, −2 h0 cβ sin a, 0] ∥ pitch: x = 0 stays an equilibrium.
    for n in [common::n300(), 0.05] {
        for d0 in [[0.0; 4], [0.0, 0.6, 0.0, -0.6]] {
            let m = AttitudeModel::orbit_cmg(Matrix3::identity() * 2.5, n, &CmgPyramid::paper002(), &d0);
            assert!(m.bias_torque().norm() < 1e-15);
            let (a, b) = m.linear();
            let (an, bn) = lin(&m, &DVector::zeros(4));
            let e = max_abs(&an, &a).max(max_abs(&bn, &b));
            // Independent: torque-input classical model with B_δ = B_T · (−J(δ₀)) when h = 0.
            if d0 == [0.0; 4] {
                let (ac, bc) = classical_gg_linear([2.5; 3], n);
                let j = CmgPyramid::paper002().jacobian(&d0);
                let bj = &bc * DMatrix::from_fn(3, 4, |r, c| -j[(r, c)]);
                assert!(max_abs(&a, &ac) < 1e-15 && max_abs(&b, &bj) < 1e-15);
            }
            println!("b: n {n:.4e} δ0 {d0:?}: |linearize − analytic| {e:.1e}, h = {:?}", m.stored_momentum.as_slice());
            assert!(close_rel(&an, &a) && close_rel(&bn, &b));
        }
    }
}

#[test]
fn rig_model_c_matches_eq17() {
    let m = AttitudeModel::rig003();
    let (a, b) = m.linear();
    let (a17, b17) = rig_eq17_linear(&m.inertia, &m.mgr);
    assert!(max_abs(&a, &a17) < 1e-15 && max_abs(&b, &b17) < 1e-15);
    // Trim: cancel the constant pendulum torque m g [r_y, −r_x, 0] so x = 0 is an equilibrium.
    let bias = m.bias_torque();
    assert!((bias - Vector3::new(-0.001, 0.004, 0.0)).norm() < 1e-15);
    let u0 = DVector::from_column_slice((-bias).as_slice());
    assert!(m.f(&DVector::zeros(6), &u0).norm() < 1e-15);
    let (an, bn) = lin(&m, &u0);
    let e = max_abs(&an, &a).max(max_abs(&bn, &b));
    println!("c: |linearize(trim) − eq 17| {e:.1e}");
    assert!(close_rel(&an, &a) && close_rel(&bn, &b));
    // Without the trim the exact Jacobian picks up bias × angle terms (~|I⁻¹ m g r_xy| ≈ 2e-3).
    let (an0, _) = lin(&m, &DVector::zeros(3));
    let e0 = max_abs(&an0, &a);
    println!("c: |linearize(u = 0) − eq 17| {e0:.2e} (bias terms dropped by the paper)");
    assert!(e0 > 1e-4 && e0 < 1e-2);
    // Yaw is free: A has a double zero eigenvalue pair, roll/pitch are pendulums.
    println!("rig A = {a:.5}");
}

#[test]
fn nonlinear_model_sanity() {
    // Torque-free rig at rest tilted: restoring roll acceleration ≈ −m g r_z sinφ / I_xx.
    let mut m = AttitudeModel::rig003();
    m.inertia = Matrix3::from_diagonal(&Vector3::new(1.76, 1.79, 2.92));
    m.mgr = Vector3::new(0.0, 0.0, 0.5);
    let x = DVector::from_column_slice(&[0.3, 0.0, 1.0, 0.0, 0.0, 0.0]);
    let xd = m.f(&x, &DVector::zeros(3));
    assert!((xd[3] + 0.5 * 0.3f64.sin() / 1.76).abs() < 1e-14);
    // In orbit, a body at rest in LVLH with principal axes aligned stays there.
    let o = AttitudeModel::orbit_torque(Matrix3::from_diagonal(&Vector3::new(2.0, 3.0, 4.0)), 0.05);
    assert!(o.f(&DVector::zeros(6), &DVector::zeros(3)).norm() < 1e-15);
}

#[test]
fn c2d_double_integrator_and_oscillator_closed_forms() {
    let a = dmatrix![0.0, 1.0; 0.0, 0.0];
    let b = dmatrix![0.0; 1.0];
    for dt in [1e-3, 0.1, 1.0, 10.0] {
        let (ad, bd) = c2d(&a, &b, dt).unwrap();
        let e = max_abs(&ad, &dmatrix![1.0, dt; 0.0, 1.0]).max(max_abs(&bd, &dmatrix![dt * dt / 2.0; dt]));
        // Van Loan noise for white acceleration of PSD w: w [[dt³/3, dt²/2], [dt²/2, dt]].
        let qd = c2d_noise(&a, &dmatrix![0.0, 0.0; 0.0, 0.7], dt).unwrap();
        let qe = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt] * 0.7;
        let eq = max_abs(&qd, &qe) / qe.abs().max();
        println!("dt {dt}: ZOH max err {e:.1e}, Q_d rel err {eq:.1e}");
        assert!(e <= 1e-14 * dt.max(1.0).powi(2) && eq < 1e-13);
    }
    // Oscillator ẍ = −w² x + u: A_d = [[c, s/w], [−w s, c]], B_d = [(1 − c)/w², s/w].
    let w: f64 = 2.0;
    let a = dmatrix![0.0, 1.0; -w * w, 0.0];
    let dt: f64 = 0.7;
    let (c, s) = ((w * dt).cos(), (w * dt).sin());
    let (ad, bd) = c2d(&a, &b, dt).unwrap();
    let e = max_abs(&ad, &dmatrix![c, s / w; -w * s, c]).max(max_abs(&bd, &dmatrix![(1.0 - c) / (w * w); s / w]));
    assert!(e < 1e-14, "{e}");
    assert!(c2d(&a, &b, 0.0).is_err() && c2d(&a, &b, f64::NAN).is_err());
}
