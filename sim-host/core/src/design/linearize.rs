//! Jacobian linearisation by central differences (paper 002: "Jacobian method", eqs 9-11).

use nalgebra::{DMatrix, DVector};

/// `(A, B) = (∂f/∂x, ∂f/∂u)` at `(x0, u0)` by central differences.
///
/// The step for component j is `eps · max(1, |v_j|)`, rounded so that `v_j ± h` is exact.
/// The error is `O(h² f''')` truncation plus `O(ε_mach |f| / h)` round-off; `eps ≈ 1e-5`
/// balances the two for O(1) data (≈ 1e-10 absolute).
pub fn linearize<F>(f: F, x0: &DVector<f64>, u0: &DVector<f64>, eps: f64) -> (DMatrix<f64>, DMatrix<f64>)
where
    F: Fn(&DVector<f64>, &DVector<f64>) -> DVector<f64>,
{
    let nf = f(x0, u0).len();
    let a = jac(nf, x0, eps, |x| f(x, u0));
    let b = jac(nf, u0, eps, |u| f(x0, u));
    (a, b)
}

fn jac(nf: usize, v0: &DVector<f64>, eps: f64, g: impl Fn(&DVector<f64>) -> DVector<f64>) -> DMatrix<f64> {
    let mut j = DMatrix::<f64>::zeros(nf, v0.len());
    for k in 0..v0.len() {
        let h = eps * v0[k].abs().max(1.0);
        let (mut vp, mut vm) = (v0.clone(), v0.clone());
        vp[k] += h;
        vm[k] -= h;
        let dh = vp[k] - vm[k];
        j.set_column(k, &((g(&vp) - g(&vm)) / dh));
    }
    j
}
