//! Shared test data: the three 6-state models and their weights.
#![allow(dead_code)]
use nalgebra::{DMatrix, DVector, Matrix3};
use sim_core::design::models::*;

/// Bryson weights assumed for paper 002 (its Q, R are not in the OCR text): 10° on
/// angles, 1°/s on rates, the gimbal-rate limit 0.12 rad/s on each input.
pub fn weights002() -> (DMatrix<f64>, DMatrix<f64>) {
    let a = 10f64.to_radians().powi(-2);
    let w = 1f64.to_radians().powi(-2);
    let q = DMatrix::from_diagonal(&DVector::from_row_slice(&[a, a, a, w, w, w]));
    (q, DMatrix::identity(4, 4) / paper002::GIMBAL_RATE_MAX.powi(2))
}

/// Torque-input version: the same Q and `R = 1/T_max²`, `T_max = h0 · 0.12 rad/s`.
pub fn weights_torque() -> (DMatrix<f64>, DMatrix<f64>) {
    let (q, _) = weights002();
    let tmax = paper002::H0_NMS * paper002::GIMBAL_RATE_MAX;
    (q, DMatrix::identity(3, 3) / (tmax * tmax))
}

pub fn weights003() -> (DMatrix<f64>, DMatrix<f64>) {
    (DMatrix::from_diagonal(&DVector::from_row_slice(&paper003::Q_DIAG)), DMatrix::identity(3, 3) * paper003::R_DIAG)
}

pub fn n300() -> f64 {
    circular_orbit_rate(paper002::ALTITUDE_M)
}

/// (name, A, B, Q, R).
pub type Problem = (&'static str, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>);

/// Models a (two inertias), b (two gimbal sets) and c with their weights.
pub fn six_state_problems() -> Vec<Problem> {
    let (qt, rt) = weights_torque();
    let (q2, r2) = weights002();
    let (q3, r3) = weights003();
    let iso = Matrix3::identity() * paper002::INERTIA_DIAG;
    let aniso = Matrix3::from_diagonal(&nalgebra::Vector3::new(2.5, 3.2, 1.8));
    let mut out = vec![];
    let (a, b) = AttitudeModel::orbit_torque(iso, n300()).linear();
    out.push(("a: torque, 2.5 I", a, b, qt.clone(), rt.clone()));
    let (a, b) = AttitudeModel::orbit_torque(aniso, n300()).linear();
    out.push(("a: torque, diag(2.5,3.2,1.8)", a, b, qt, rt));
    let (a, b) = AttitudeModel::paper002(&[0.0; 4]).linear();
    out.push(("b: CMG, delta0 = 0", a, b, q2.clone(), r2.clone()));
    let (a, b) = AttitudeModel::paper002(&[0.0, 0.6, 0.0, -0.6]).linear();
    out.push(("b: CMG, delta0 = [0,.6,0,-.6]", a, b, q2, r2));
    let (a, b) = AttitudeModel::rig003().linear();
    out.push(("c: rig 003 (torque)", a, b, q3, r3));
    out
}
