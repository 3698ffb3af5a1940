//! Linear-quadratic regulator on the small-angle attitude state (papers 002, 003):
//! `x = [e; ω - ω_c]`, e the 3-2-1 Euler angles of the attitude error (body relative to
//! the commanded frame: inertial, lab, or LVLH), and `u = -K x` a body torque (3×6 K,
//! designed on the host by `sim-host lqr` / at scenario load), limited per axis with the
//! direction kept, then allocated to the actuators like any other torque demand.

use super::scale_to_box;
use crate::math::{EulerSeq, Quat, Vec3, attitude_error, euler_from_quat, rotation_angle};
use crate::types::TorqueDemand;

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

/// State feedback `u = -K x` for any `M×N` gain (torques or gimbal rates).
pub fn state_feedback<const N: usize, const M: usize>(k: &[[f32; N]; M], x: &[f32; N]) -> [f32; M] {
    k.map(|row| -row.iter().zip(x.iter()).map(|(k, x)| k * x).sum::<f32>())
}

/// `u = -K x`, limited per axis with the direction kept.
pub fn lqr_from_state(g: &LqrGains, x: &[f32; 6], error_angle_rad: f32) -> TorqueDemand {
    let u = Vec3::from(state_feedback(&g.k, x));
    let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
    TorqueDemand { torque_nm, limited, error_angle_rad }
}

pub fn lqr(g: &LqrGains, q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, rate_cmd_rad_s: &Vec3) -> TorqueDemand {
    let (x, angle) = lqr_state(q, q_cmd, rate_rad_s, rate_cmd_rad_s);
    lqr_from_state(g, &x, angle)
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
