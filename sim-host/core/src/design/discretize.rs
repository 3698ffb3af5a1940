//! Zero-order-hold discretisation and discrete process noise.
//!
//! The matrix exponential is nalgebra's `OMatrix::exp` (it exists for `DMatrix` in 0.35):
//! the Al-Mohy & Higham (2009) scaling-and-squaring algorithm with Padé degree 3…13 chosen
//! from norm estimates — the same algorithm as SciPy's `expm`. Inputs are checked for
//! finiteness first because that routine `unwrap`s internally.

use nalgebra::DMatrix;

#[derive(Clone, Debug, PartialEq)]
pub enum DiscretizeError {
    Dimension(&'static str),
    NonFinite,
    /// `dt` must be finite and > 0.
    BadStep,
}

impl std::fmt::Display for DiscretizeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{self:?}")
    }
}
impl std::error::Error for DiscretizeError {}

/// Matrix exponential with input validation.
pub fn expm(m: &DMatrix<f64>) -> Result<DMatrix<f64>, DiscretizeError> {
    if !m.is_square() {
        return Err(DiscretizeError::Dimension("expm needs a square matrix"));
    }
    if !m.iter().all(|v| v.is_finite()) {
        return Err(DiscretizeError::NonFinite);
    }
    let e = m.exp();
    if e.iter().all(|v| v.is_finite()) { Ok(e) } else { Err(DiscretizeError::NonFinite) }
}

/// Exact ZOH: `exp([[A, B], [0, 0]] dt) = [[A_d, B_d], [0, I]]`, i.e.
/// `A_d = e^{A dt}`, `B_d = ∫₀^dt e^{A s} ds B`.
pub fn c2d(a: &DMatrix<f64>, b: &DMatrix<f64>, dt: f64) -> Result<(DMatrix<f64>, DMatrix<f64>), DiscretizeError> {
    let (n, m) = (a.nrows(), b.ncols());
    if !a.is_square() || b.nrows() != n {
        return Err(DiscretizeError::Dimension("A n×n, B n×m"));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(DiscretizeError::BadStep);
    }
    let mut aug = DMatrix::<f64>::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(a * dt));
    aug.view_mut((0, n), (n, m)).copy_from(&(b * dt));
    let e = expm(&aug)?;
    Ok((e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned()))
}

/// Discrete process-noise covariance of `ẋ = A x + w`, `E[w wᵀ] = W δ(t−s)`, over one
/// step (Van Loan 1978): `exp([[−A, W], [0, Aᵀ]] dt) = [[·, F₁₂], [0, F₂₂]]`,
/// `Q_d = F₂₂ᵀ F₁₂ = ∫₀^dt e^{A s} W e^{Aᵀ s} ds` (symmetrised).
pub fn c2d_noise(a: &DMatrix<f64>, w: &DMatrix<f64>, dt: f64) -> Result<DMatrix<f64>, DiscretizeError> {
    let n = a.nrows();
    if !a.is_square() || w.shape() != (n, n) {
        return Err(DiscretizeError::Dimension("A and W n×n"));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(DiscretizeError::BadStep);
    }
    let mut aug = DMatrix::<f64>::zeros(2 * n, 2 * n);
    aug.view_mut((0, 0), (n, n)).copy_from(&(-a * dt));
    aug.view_mut((0, n), (n, n)).copy_from(&(w * dt));
    aug.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * dt));
    let e = expm(&aug)?;
    let qd = e.view((n, n), (n, n)).transpose() * e.view((0, n), (n, n));
    Ok((&qd + qd.transpose()) * 0.5)
}
