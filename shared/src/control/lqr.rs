//! Linear-quadratic regulator on the small-angle attitude state (papers 002, 003):
//! `x = [e; ω - ω_c]`, e the 3-2-1 Euler angles of the attitude error (body relative to
//! the commanded frame: inertial, lab, or LVLH), and `u = -K x` a body torque (3×6 K,
//! designed on the host by `sim-host lqr` / at scenario load), limited per axis with the
//! direction kept, then allocated to the actuators like any other torque demand.

use super::{TorqueDemand, scale_to_box};
use crate::estimation::kalman::{KalmanFilter, LinearModel};
use crate::math::{EulerSeq, Quat, Vec3, attitude_error, euler_from_quat, rotation_angle};
use nalgebra::{SMatrix, SVector};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LqrGains {
    /// Row-major 3×6.
    pub k: [[f32; 6]; 3],
    pub torque_limit_nm: Vec3,
}

/// The small-angle state `[e; ω - ω_c]` and the error rotation angle.
pub fn lqr_state(q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, rate_cmd_rad_s: &Vec3) -> ([f32; 6], f32) {
    let e = attitude_error(q, q_cmd);
    let ang = euler_from_quat(&e, EulerSeq::Zyx321);
    let dw = rate_rad_s - rate_cmd_rad_s;
    ([ang[0], ang[1], ang[2], dw.x, dw.y, dw.z], rotation_angle(&e))
}

/// `u = -K x`, limited per axis with the direction kept.
pub fn lqr_from_state(g: &LqrGains, x: &[f32; 6], error_angle_rad: f32) -> TorqueDemand {
    let u = Vec3::from(g.k.map(|row| -row.iter().zip(x.iter()).map(|(k, x)| k * x).sum::<f32>()));
    let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
    TorqueDemand { torque_nm, limited, error_angle_rad }
}

pub fn lqr(g: &LqrGains, q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, rate_cmd_rad_s: &Vec3) -> TorqueDemand {
    let (x, angle) = lqr_state(q, q_cmd, rate_rad_s, rate_cmd_rad_s);
    lqr_from_state(g, &x, angle)
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::quat_from_euler;

    #[test]
    fn u_is_minus_k_x() {
        let mut k = [[0.0f32; 6]; 3];
        for (i, row) in k.iter_mut().enumerate() {
            row[i] = 2.0 + i as f32;
            row[i + 3] = 10.0;
        }
        k[0][2] = 0.5; // a cross term
        let g = LqrGains { k, torque_limit_nm: Vec3::repeat(1e3) };
        let (r, p, y) = (0.01f32, -0.02, 0.03);
        let q = quat_from_euler([r, p, y], EulerSeq::Zyx321);
        let w = Vec3::new(0.001, 0.002, -0.003);
        let d = lqr(&g, &q, &Quat::identity(), &w, &Vec3::zeros());
        let expect = Vec3::new(-(2.0 * r + 0.5 * y + 10.0 * w.x), -(3.0 * p + 10.0 * w.y), -(4.0 * y + 10.0 * w.z));
        assert!((d.torque_nm - expect).norm() < 1e-6, "{:?} vs {expect:?}", d.torque_nm);
    }
}
