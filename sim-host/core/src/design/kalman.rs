//! Steady-state Kalman filter design (paper 002 eq 13, LQG) by duality.
//!
//! Plant `x_{k+1} = A x_k + B u_k + w_k`, `z_k = C x_k + v_k`, `E[wwᵀ] = Q_n`,
//! `E[vvᵀ] = R_n`. The a-priori covariance solves the filter DARE
//! `P = A P Aᵀ − A P Cᵀ (C P Cᵀ + R_n)⁻¹ C P Aᵀ + Q_n`, which is the control DARE of the
//! dual pair `(Aᵀ, Cᵀ, Q_n, R_n)`. The measurement-update gain is
//! `K = P Cᵀ (C P Cᵀ + R_n)⁻¹` and the a-posteriori covariance `(I − K C) P`.

use crate::design::riccati::{Result, RiccatiError, dare, sym};
use nalgebra::DMatrix;

/// `(K, P)`: update gain (n×p) and a-priori steady-state covariance (n×n).
pub fn steady_state_kalman(
    ad: &DMatrix<f64>,
    cd: &DMatrix<f64>,
    qn: &DMatrix<f64>,
    rn: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let p = dare(&ad.transpose(), &cd.transpose(), qn, rn)?;
    let s = sym(&(cd * &p * cd.transpose() + rn));
    let ch = s.cholesky().ok_or(RiccatiError::SingularR)?;
    let k = ch.solve(&(cd * &p)).transpose();
    Ok((k, p))
}

/// A-posteriori covariance `(I − K C) P (I − K C)ᵀ + K R Kᵀ` (Joseph form).
pub fn posterior_covariance(k: &DMatrix<f64>, cd: &DMatrix<f64>, p: &DMatrix<f64>, rn: &DMatrix<f64>) -> DMatrix<f64> {
    let n = p.nrows();
    let ikc = DMatrix::<f64>::identity(n, n) - k * cd;
    sym(&(&ikc * p * ikc.transpose() + k * rn * k.transpose()))
}
