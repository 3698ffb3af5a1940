//! Flight-side linear Kalman filter (paper 002 eq 13, LQG; the LQR feedback is
//! `crate::control::lqr`).
//!
//! `no_std`, no heap, no panics, f32, fixed sizes: every loop is over a const-generic
//! dimension. Plant `x_{k+1} = A x_k + B u_k + w_k`, `z_k = C x_k + v_k`,
//! `E[wwᵀ] = Q`, `E[vvᵀ] = R`; `N` states, `M` inputs, `P` measurements.
//!
//! Two modes:
//! - covariance mode: `P⁻ = A P Aᵀ + Q`; update with the Joseph form
//!   `P⁺ = (I − KC) P⁻ (I − KC)ᵀ + K R Kᵀ`, symmetrised each step;
//! - steady-state mode: a fixed gain `K∞` (computed on the host by
//!   `sim_host::design::steady_state_kalman` and uploaded), `x⁺ = x⁻ + K∞ (z − C x⁻)`;
//!   the covariance is not propagated.
//!
//! A rejected call (non-finite input, singular innovation covariance, non-finite result)
//! returns a typed error and leaves the estimate and covariance exactly as they were.

use nalgebra::{Cholesky, SMatrix, SVector};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KfError {
    /// A model matrix, initial state or uploaded gain is not finite.
    NonFiniteParameter,
    /// `u` contains NaN/inf; the prediction was skipped.
    NonFiniteInput,
    /// `z` contains NaN/inf; the update was skipped.
    NonFiniteMeasurement,
    /// `S = C P Cᵀ + R` is not numerically positive definite; the update was skipped.
    SingularInnovation,
    /// The step produced NaN/inf (e.g. overflow); it was discarded.
    NonFiniteResult,
}

/// What an accepted measurement update produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateInfo<const P: usize> {
    /// Innovation `y = z − C x⁻`.
    pub innovation: SVector<f32, P>,
    /// Normalised innovation squared `yᵀ S⁻¹ y` (covariance mode; 0 in steady-state mode).
    pub nis: f32,
}

/// Discrete linear plant and noise model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearModel<const N: usize, const M: usize, const P: usize> {
    pub a: SMatrix<f32, N, N>,
    pub b: SMatrix<f32, N, M>,
    pub c: SMatrix<f32, P, N>,
    pub q: SMatrix<f32, N, N>,
    pub r: SMatrix<f32, P, P>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KalmanFilter<const N: usize, const M: usize, const P: usize> {
    model: LinearModel<N, M, P>,
    x: SVector<f32, N>,
    cov: SMatrix<f32, N, N>,
    steady_gain: Option<SMatrix<f32, N, P>>,
}

/// Smallest accepted pivot² of the Cholesky factor of the diagonally scaled innovation
/// covariance `D S D`, `D = diag(S)^(-1/2)` (pivots² lie in (0, 1]); below it S is treated
/// as singular (reciprocal condition ≲ 1e-6, near the limit of f32).
pub const MIN_SCALED_PIVOT_SQ: f32 = 1e-6;

fn finite<const R: usize, const C: usize>(m: &SMatrix<f32, R, C>) -> bool {
    m.iter().all(|v| v.is_finite())
}

fn sym<const N: usize>(m: &SMatrix<f32, N, N>) -> SMatrix<f32, N, N> {
    (m + m.transpose()) * 0.5
}

impl<const N: usize, const M: usize, const P: usize> KalmanFilter<N, M, P> {
    /// Covariance-mode filter with initial estimate `x0` and covariance `p0`.
    pub fn new(model: LinearModel<N, M, P>, x0: SVector<f32, N>, p0: SMatrix<f32, N, N>) -> Result<Self, KfError> {
        let ok = finite(&model.a) && finite(&model.b) && finite(&model.c) && finite(&model.q) && finite(&model.r);
        if !(ok && finite(&x0) && finite(&p0)) {
            return Err(KfError::NonFiniteParameter);
        }
        Ok(Self { model, x: x0, cov: sym(&p0), steady_gain: None })
    }

    pub fn state(&self) -> &SVector<f32, N> {
        &self.x
    }

    /// Current covariance (covariance mode; frozen at its last value in steady-state mode).
    pub fn covariance(&self) -> &SMatrix<f32, N, N> {
        &self.cov
    }

    pub fn model(&self) -> &LinearModel<N, M, P> {
        &self.model
    }

    /// Replace the estimate (e.g. after a reset); rejected if not finite.
    pub fn set_state(&mut self, x: SVector<f32, N>) -> Result<(), KfError> {
        if !finite(&x) {
            return Err(KfError::NonFiniteParameter);
        }
        self.x = x;
        Ok(())
    }

    /// Switch to steady-state mode with the host-computed gain `K∞` (N×P).
    pub fn set_steady_state_gain(&mut self, k: SMatrix<f32, N, P>) -> Result<(), KfError> {
        if !finite(&k) {
            return Err(KfError::NonFiniteParameter);
        }
        self.steady_gain = Some(k);
        Ok(())
    }

    /// Back to covariance mode, restarting from covariance `p`.
    pub fn set_covariance_mode(&mut self, p: SMatrix<f32, N, N>) -> Result<(), KfError> {
        if !finite(&p) {
            return Err(KfError::NonFiniteParameter);
        }
        self.cov = sym(&p);
        self.steady_gain = None;
        Ok(())
    }

    pub fn is_steady_state(&self) -> bool {
        self.steady_gain.is_some()
    }

    /// Time update: `x⁻ = A x + B u`, `P⁻ = A P Aᵀ + Q` (covariance mode).
    pub fn predict(&mut self, u: &SVector<f32, M>) -> Result<(), KfError> {
        if !finite(u) {
            return Err(KfError::NonFiniteInput);
        }
        let m = &self.model;
        let x = m.a * self.x + m.b * u;
        if !finite(&x) {
            return Err(KfError::NonFiniteResult);
        }
        if self.steady_gain.is_none() {
            let p = sym(&(m.a * self.cov * m.a.transpose() + m.q));
            if !finite(&p) {
                return Err(KfError::NonFiniteResult);
            }
            self.cov = p;
        }
        self.x = x;
        Ok(())
    }

    /// Measurement update with `z`; Joseph form in covariance mode, fixed gain in
    /// steady-state mode.
    pub fn update(&mut self, z: &SVector<f32, P>) -> Result<UpdateInfo<P>, KfError> {
        if !finite(z) {
            return Err(KfError::NonFiniteMeasurement);
        }
        let m = &self.model;
        let y = z - m.c * self.x;
        if let Some(k) = self.steady_gain {
            let x = self.x + k * y;
            if !finite(&x) {
                return Err(KfError::NonFiniteResult);
            }
            self.x = x;
            return Ok(UpdateInfo { innovation: y, nis: 0.0 });
        }

        let cp = m.c * self.cov; // P×N, = (P Cᵀ)ᵀ
        let s = sym(&(cp * m.c.transpose() + m.r));
        // Scale to unit diagonal, factor, and test the pivots (see MIN_SCALED_PIVOT_SQ).
        let dg = s.diagonal();
        if !dg.iter().all(|&d| d.is_finite() && d > 0.0) {
            return Err(KfError::SingularInnovation);
        }
        let dinv = dg.map(|d| 1.0 / crate::math::f32m::sqrt(d));
        let ds = SMatrix::<f32, P, P>::from_diagonal(&dinv);
        let chol = Cholesky::new(ds * s * ds).ok_or(KfError::SingularInnovation)?;
        let piv = chol.l_dirty().diagonal();
        if !piv.iter().all(|&l| l * l >= MIN_SCALED_PIVOT_SQ) {
            return Err(KfError::SingularInnovation);
        }
        // S⁻¹ = D (D S D)⁻¹ D;  Kᵀ = S⁻¹ C P.
        let kt = ds * chol.solve(&(ds * cp));
        let k = kt.transpose();
        let sy = ds * chol.solve(&(ds * y));
        let nis = y.dot(&sy);

        let x = self.x + k * y;
        let ikc = SMatrix::<f32, N, N>::identity() - k * m.c;
        let p = sym(&(ikc * self.cov * ikc.transpose() + k * m.r * k.transpose()));
        if !(finite(&x) && finite(&p) && nis.is_finite()) {
            return Err(KfError::NonFiniteResult);
        }
        self.x = x;
        self.cov = p;
        Ok(UpdateInfo { innovation: y, nis })
    }
}
