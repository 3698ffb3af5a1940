//! The open-loop measurement's estimate of a sinusoid riding on a constant and a ramp
//! (docs/margins.md, "Open-loop measurement"). With the loop broken open, the rigid body is
//! a double integrator: the excited run's difference from its twin carries, besides the
//! sinusoid, a constant and a ramp (the integrals of the onset of the excitation, of an
//! actuator lag's transient), and the flight law answers them with a constant and a ramp
//! of its own. A DFT over whole periods is blind to a constant but not to a ramp; the
//! least-squares fit of `[1, τ, cos φ, sin φ]` over the block removes both exactly.
//! Only the normal equations are accumulated (memory does not grow with the block).

use super::analysis::C64;
use nalgebra::{Matrix4, Vector4};

/// Least-squares fit, over one block of `len` samples, of each of `N` signals to
/// `y_k ≈ c₀ + c₁ τ_k + a cos φ_k + b sin φ_k` (`φ_k` the excitation's sample phase,
/// `τ_k = (k − (len − 1)/2) / len` the centred, scaled sample index: the normal matrix
/// stays well conditioned whatever the block length).
pub struct SineRampFit<const N: usize> {
    len: u64,
    pushed: u64,
    normal: Matrix4<f64>,
    rhs: [Vector4<f64>; N],
}

impl<const N: usize> SineRampFit<N> {
    pub fn new(len: u64) -> Self {
        Self { len: len.max(1), pushed: 0, normal: Matrix4::zeros(), rhs: [Vector4::zeros(); N] }
    }

    /// Adds the next sample (phase `φ_k`, rad, and the signals' values).
    pub fn push(&mut self, phase: f64, y: &[f64; N]) {
        let n = self.len as f64;
        let tau = (self.pushed as f64 - 0.5 * (n - 1.0)) / n;
        let phi = Vector4::new(1.0, tau, phase.cos(), phase.sin());
        self.normal += phi * phi.transpose();
        for (r, v) in self.rhs.iter_mut().zip(y) {
            *r += phi * *v;
        }
        self.pushed += 1;
    }

    /// The block length, samples.
    pub fn block_len(&self) -> u64 {
        self.len
    }

    /// The block is complete.
    pub fn is_full(&self) -> bool {
        self.pushed >= self.len
    }

    /// Each signal's sinusoid as the complex `(a − j b)/2`: the convention of the DFT
    /// `(1/n) Σ y_k e^{−jφ_k}` of a pure sinusoid over whole periods (a common factor of
    /// output and input in any case: it cancels in `L = −U E⁻¹`). `None`: the block is too
    /// short to separate the four columns.
    pub fn solve(&self) -> Option<[C64; N]> {
        Some(self.coefficients()?.map(|c| C64::new(0.5 * c[2], -0.5 * c[3])))
    }

    /// `[c₀, c₁, a, b]` of each signal. At the Nyquist frequency `sin φ_k = 0` at every
    /// sample: the sine column is dropped (`b = 0`).
    fn coefficients(&self) -> Option<[Vector4<f64>; N]> {
        let mut m = self.normal;
        let mut rhs = self.rhs;
        if m[(3, 3)] <= 1e-12 * m[(0, 0)] {
            for i in 0..4 {
                m[(3, i)] = 0.0;
                m[(i, 3)] = 0.0;
            }
            m[(3, 3)] = 1.0;
            rhs.iter_mut().for_each(|r| r[3] = 0.0);
        }
        let chol = m.cholesky()?;
        Some(rhs.map(|r| chol.solve(&r)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn fit(m: u64, n: u64, periods: u64, y: impl Fn(u64, f64) -> f64) -> C64 {
        let len = n * periods;
        let mut f = SineRampFit::<1>::new(len);
        for k in 0..len {
            let phase = 2.0 * PI * ((k * m) % n) as f64 / n as f64;
            f.push(phase, &[y(k, 2.0 * PI * (k * m) as f64 / n as f64)]);
            assert_eq!(f.is_full(), k + 1 == len);
        }
        f.solve().unwrap()[0]
    }

    #[test]
    fn a_sine_on_a_constant_and_a_ramp_is_recovered_exactly() {
        // y = 3 + 0.01 k + 2 cos(φ + 0.3): the sinusoid (2/2) e^{j0.3}, whatever the ramp.
        for (m, n) in [(1, 7), (3, 40), (1, 400)] {
            let z = fit(m, n, 2, |k, p| 3.0 + 0.01 * k as f64 + 2.0 * (p + 0.3).cos());
            let want = C64::from_polar(1.0, 0.3);
            assert!((z - want).norm() < 1e-9, "{m}/{n}: {z} vs {want}");
        }
    }

    #[test]
    fn a_ramp_alone_has_no_sinusoid_and_biases_a_plain_dft() {
        let (m, n) = (1, 10);
        let ramp = |k: u64, _: f64| 5.0 - 0.2 * k as f64;
        assert!(fit(m, n, 3, ramp).norm() < 1e-12);
        // The DFT over the same whole periods sees the ramp (why the fit is needed).
        let dft: C64 =
            (0..3 * n).map(|k| C64::from_polar(ramp(k, 0.0), -2.0 * PI * (k * m) as f64 / n as f64)).sum::<C64>()
                / (3 * n) as f64;
        assert!(dft.norm() > 0.1, "{dft}");
    }

    #[test]
    fn the_nyquist_frequency_has_no_sine_column() {
        // cos(πk) = ±1, sin(πk) = 0: the sinusoid is (a/2), the ramp still removed.
        let z = fit(1, 2, 5, |k, p| 1.0 + 0.3 * k as f64 + 4.0 * p.cos());
        assert!((z - C64::new(2.0, 0.0)).norm() < 1e-9, "{z}");
    }

    /// The excitation of the open-loop method, `a cos(ω t_k)` held over each control period
    /// with its first sample halved, drives a double integrator (exact zero-order-hold
    /// update) without a ramp: the fitted ramp of the attitude is zero, where the plain
    /// cosine leaves one (its rate has the mean `aT/2`). At the Nyquist frequency too.
    #[test]
    fn a_halved_first_sample_leaves_a_double_integrator_without_a_ramp() {
        let t = 0.1;
        for (m, n) in [(1u64, 20u64), (3, 40), (1, 2)] {
            let ramp_of = |first: f64| {
                let (mut theta, mut rate) = (0.0f64, 0.0f64);
                // Fitted over four periods after the first (the sample at t = 0 is before
                // the excitation: the measurement waits, too).
                let mut f = SineRampFit::<1>::new(4 * n);
                for k in 0..5 * n {
                    let phase = 2.0 * PI * (k * m % n) as f64 / n as f64;
                    if k >= n {
                        f.push(phase, &[theta]);
                    }
                    let d = (if k == 0 { first } else { 1.0 }) * phase.cos();
                    theta += rate * t + 0.5 * d * t * t;
                    rate += d * t;
                }
                f.coefficients().unwrap()[0][1]
            };
            let (halved, plain) = (ramp_of(0.5), ramp_of(1.0));
            assert!(halved.abs() < 1e-12, "{m}/{n}: {halved}");
            assert!(plain.abs() > 1e-3, "{m}/{n}: {plain}");
        }
    }
}
