//! PD on Euler-angle errors (paper 003 eq 23), usually with magnetorquers:
//! `T = -Kp ∘ e - Kd ∘ (ω - ω_c)`, e the 3-2-1 Euler angles of the error rotation (body
//! relative to target), then mapped to dipoles by the cross-product law of the allocation.

use super::scale_to_box;
use crate::math::{EulerSeq, Quat, Vec3, attitude_error, euler_from_quat, rotation_angle};
use crate::types::TorqueDemand;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerPdGains {
    pub kp_nm: Vec3,
    pub kd_nms: Vec3,
    pub torque_limit_nm: Vec3,
}

/// Paper 003 eq 23.
pub fn euler_pd(g: &EulerPdGains, q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, rate_cmd_rad_s: &Vec3) -> TorqueDemand {
    let e = attitude_error(q, q_cmd);
    let ang = Vec3::from(euler_from_quat(&e, EulerSeq::Zyx321));
    let u = -g.kp_nm.component_mul(&ang) - g.kd_nms.component_mul(&(rate_rad_s - rate_cmd_rad_s));
    let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
    TorqueDemand { torque_nm, limited, error_angle_rad: rotation_angle(&e) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::quat_from_euler;

    #[test]
    fn euler_pd_is_minus_kp_angles_minus_kd_rates() {
        let g = EulerPdGains {
            kp_nm: Vec3::new(0.001584, 0.001608, 0.002628),
            kd_nms: Vec3::new(0.1799, 0.1826, 0.2985),
            torque_limit_nm: Vec3::repeat(1.0),
        };
        let (r, p, y) = (0.01f32, -0.02f32, 0.5f32);
        let q = quat_from_euler([r, p, y], EulerSeq::Zyx321);
        let w = Vec3::new(0.001, 0.0, -0.002);
        let d = euler_pd(&g, &q, &Quat::identity(), &w, &Vec3::zeros());
        let expect = -g.kp_nm.component_mul(&Vec3::new(r, p, y)) - g.kd_nms.component_mul(&w);
        assert!((d.torque_nm - expect).norm() < 1e-6, "{:?} vs {expect:?}", d.torque_nm);
    }
}
