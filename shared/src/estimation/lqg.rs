//! LQG state estimator (paper 002 eq 13): a Kalman filter on the small-angle LQR state
//! `x = [e; ω - ω_c]` of [`crate::control::lqr`], measurement `z = x`.

use crate::estimation::kalman::{KalmanFilter, LinearModel};
use crate::math::Vec3;
use nalgebra::{SMatrix, SVector};

/// Kalman filter on the LQR state (LQG, paper 002 eq 13), measurement `z = x`:
/// steady-state (fixed gain L from the host) or time-varying (covariance propagated by
/// [`KalmanFilter`], Joseph form).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LqgEstimator {
    pub a: SMatrix<f32, 6, 6>,
    pub b: SMatrix<f32, 6, 3>,
    pub l: SMatrix<f32, 6, 6>,
    /// Time-varying mode: the filter and its initial covariance.
    filter: Option<(KalmanFilter<6, 3, 6>, SMatrix<f32, 6, 6>)>,
    x: SVector<f32, 6>,
    initialised: bool,
}

fn mat66(m: &[[f32; 6]; 6]) -> SMatrix<f32, 6, 6> {
    SMatrix::from_fn(|r, c| m.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0))
}

impl LqgEstimator {
    /// Steady-state estimator with gain `l`.
    pub fn new(a: &[[f32; 6]; 6], b: &[[f32; 3]; 6], l: &[[f32; 6]; 6]) -> Self {
        Self {
            a: mat66(a),
            b: SMatrix::from_fn(|r, c| b.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0)),
            l: mat66(l),
            filter: None,
            x: SVector::zeros(),
            initialised: false,
        }
    }

    /// Time-varying estimator (diagonal noise variances and initial covariance); `None`
    /// if the model is not finite.
    pub fn time_varying(
        a: &[[f32; 6]; 6],
        b: &[[f32; 3]; 6],
        process_noise: &[f32; 6],
        measurement_noise: &[f32; 6],
        p0_diag: &[f32; 6],
    ) -> Option<Self> {
        let mut s = Self::new(a, b, &[[0.0; 6]; 6]);
        let diag = |d: &[f32; 6]| SMatrix::<f32, 6, 6>::from_diagonal(&SVector::from(*d));
        let model =
            LinearModel { a: s.a, b: s.b, c: SMatrix::identity(), q: diag(process_noise), r: diag(measurement_noise) };
        let p0 = diag(p0_diag);
        s.filter = Some((KalmanFilter::new(model, SVector::zeros(), p0).ok()?, p0));
        Some(s)
    }

    /// Predict with the torque applied last step, then correct with the measurement `z`.
    /// The first call adopts the measurement. Documented fallback: a non-finite result,
    /// or a rejected time-varying step (non-finite data, singular innovation covariance),
    /// re-initialises the estimate to `z` (and the covariance to P0).
    pub fn update(&mut self, z: &[f32; 6], u_last: &Vec3) -> [f32; 6] {
        let zv = SVector::<f32, 6>::from(*z);
        let restart = |f: &mut Option<(KalmanFilter<6, 3, 6>, SMatrix<f32, 6, 6>)>| {
            if let Some((kf, p0)) = f {
                // Both only fail on non-finite input; the estimate then stays `z` below.
                let _ = kf.set_state(zv);
                let _ = kf.set_covariance_mode(*p0);
            }
        };
        if !self.initialised {
            self.x = zv;
            restart(&mut self.filter);
            self.initialised = true;
        } else if let Some((kf, _)) = &mut self.filter {
            let step = kf.predict(u_last).and_then(|_| kf.update(&zv));
            if step.is_ok() {
                self.x = *kf.state();
            } else {
                self.x = zv;
                restart(&mut self.filter);
            }
        } else {
            let pred = self.a * self.x + self.b * u_last;
            self.x = pred + self.l * (zv - pred);
        }
        if !self.x.iter().all(|v| v.is_finite()) {
            self.x = zv;
            restart(&mut self.filter);
        }
        self.x.into()
    }

    pub fn reset(&mut self) {
        self.x = SVector::zeros();
        self.initialised = false;
    }
}
