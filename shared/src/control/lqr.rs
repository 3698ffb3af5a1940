//! Linear-quadratic regulator on the small-angle attitude state (papers 002, 003):
//! `x = [e; ω - ω_c]`, e the 3-2-1 Euler angles of the attitude error (body relative to
//! the commanded frame: inertial, lab, or LVLH), and `u = -K x` a body torque (3×6 K,
//! designed on the host by `sim-host lqr` / at scenario load), limited per axis with the
//! direction kept, then allocated to the actuators like any other torque demand.

use super::{TorqueDemand, scale_to_box};
use crate::math::{EulerSeq, Quat, Vec3, attitude_error, euler_from_quat, rotation_angle};

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

/// Steady-state Kalman filter on the LQR state (LQG, paper 002 eq 13).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LqgEstimator {
    pub a: nalgebra::SMatrix<f32, 6, 6>,
    pub b: nalgebra::SMatrix<f32, 6, 3>,
    pub l: nalgebra::SMatrix<f32, 6, 6>,
    x: nalgebra::SVector<f32, 6>,
    initialised: bool,
}

impl LqgEstimator {
    pub fn new(a: &[[f32; 6]; 6], b: &[[f32; 3]; 6], l: &[[f32; 6]; 6]) -> Self {
        let at = |m: &[[f32; 6]; 6], r: usize, c: usize| m.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0);
        Self {
            a: nalgebra::SMatrix::from_fn(|r, c| at(a, r, c)),
            b: nalgebra::SMatrix::from_fn(|r, c| b.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0)),
            l: nalgebra::SMatrix::from_fn(|r, c| at(l, r, c)),
            x: nalgebra::SVector::zeros(),
            initialised: false,
        }
    }

    /// Predict with the torque applied last step, then correct with the measurement `z`.
    /// The first call adopts the measurement. A non-finite result resets to `z`.
    pub fn update(&mut self, z: &[f32; 6], u_last: &Vec3) -> [f32; 6] {
        let zv = nalgebra::SVector::<f32, 6>::from(*z);
        if !self.initialised {
            self.x = zv;
            self.initialised = true;
        } else {
            let pred = self.a * self.x + self.b * u_last;
            self.x = pred + self.l * (zv - pred);
            if !self.x.iter().all(|v| v.is_finite()) {
                self.x = zv;
            }
        }
        self.x.into()
    }

    pub fn reset(&mut self) {
        self.x = nalgebra::SVector::zeros();
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
