//! PD on the direction-cosine error matrix (paper 004 eqs 25-27):
//! `A_E = A_S A_Tᵀ` with `A_S`, `A_T` the inertial → body matrices of the spacecraft and
//! of the target, and
//! `M = Kp ∘ [a32 - a23, a13 - a31, a21 - a12] + Kd ∘ ω`.
//! For a small error rotation φ (body relative to target) `A_E ≈ I - [φ×]`, so the
//! bracket is `-2 φ`: with the paper's signs (Kp > 0, Kd < 0: Kpx 21, Kdx -42,
//! Kpy = Kpz = 53, Kdy = Kdz = -91) the law restores and damps.

use super::scale_to_box;
use crate::math::{Quat, Vec3, attitude_error, rotation_angle};
use crate::types::TorqueDemand;
use nalgebra::UnitQuaternion;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DcmPdGains {
    pub kp_nm: Vec3,
    pub kd_nms: Vec3,
    pub torque_limit_nm: Vec3,
}

/// One update; `q`, `q_cmd` unit quaternions (`q_ib` convention), rates in body axes.
pub fn dcm_pd(g: &DcmPdGains, q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, rate_cmd_rad_s: &Vec3) -> TorqueDemand {
    // A_E = A_S A_Tᵀ = R(q)ᵀ R(q_c) = R(q_e)ᵀ with q_e = q_c* ⊗ q.
    let e = attitude_error(q, q_cmd);
    let a = UnitQuaternion::new_unchecked(e).to_rotation_matrix().into_inner().transpose();
    let bracket = Vec3::new(a.m32 - a.m23, a.m13 - a.m31, a.m21 - a.m12);
    let u = g.kp_nm.component_mul(&bracket) + g.kd_nms.component_mul(&(rate_rad_s - rate_cmd_rad_s));
    let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
    TorqueDemand { torque_nm, limited, error_angle_rad: rotation_angle(&e) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler};

    fn paper() -> DcmPdGains {
        DcmPdGains {
            kp_nm: Vec3::new(21.0, 53.0, 53.0),
            kd_nms: Vec3::new(-42.0, -91.0, -91.0),
            torque_limit_nm: Vec3::repeat(1e3),
        }
    }

    #[test]
    fn small_error_law_is_minus_two_kp_phi_plus_kd_omega() {
        let phi = Vec3::new(1e-3, -2e-3, 1.5e-3);
        let q = quat_from_euler([phi.x, phi.y, phi.z], EulerSeq::Zyx321);
        let w = Vec3::new(1e-3, 0.0, -2e-3);
        let d = dcm_pd(&paper(), &q, &Quat::identity(), &w, &Vec3::zeros());
        let expect = -2.0 * paper().kp_nm.component_mul(&phi) + paper().kd_nms.component_mul(&w);
        assert!((d.torque_nm - expect).norm() < 1e-3 * expect.norm(), "{:?} vs {expect:?}", d.torque_nm);
    }

    #[test]
    fn zero_error_zero_rate_zero_torque() {
        let q = quat_from_euler([0.2, -0.1, 0.4], EulerSeq::Zyx321);
        let d = dcm_pd(&paper(), &q, &q, &Vec3::zeros(), &Vec3::zeros());
        assert!(d.torque_nm.norm() < 1e-5 && d.error_angle_rad < 1e-3);
    }
}
