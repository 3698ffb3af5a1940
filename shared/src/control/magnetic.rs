//! Laws used with magnetorquers (paper 003):
//! - PD on Euler-angle errors (eq 23): `T = -Kp ∘ e - Kd ∘ (ω - ω_c)`, e the 3-2-1 Euler
//!   angles of the error rotation (body relative to target), then mapped to dipoles by
//!   the cross-product law of the allocation.
//! - B-dot detumbling: `m = -k dB/dt`, dB/dt from a first-order-filtered difference of
//!   the magnetometer (time constant τ, exact discrete gain `a = dt/(τ + dt)`). It is
//!   handed to the allocation as the torque `m × B`: the cross-product law returns the
//!   part of m perpendicular to B — the only part that produces torque — and applies the
//!   dipole limits and dead band.

use super::{TorqueDemand, scale_to_box};
use crate::math::{EulerSeq, Quat, Vec3, attitude_error, euler_from_quat, rotation_angle};

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

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BdotGains {
    /// k in `m = -k dB/dt`, A m² per (T/s).
    pub gain: f32,
    pub filter_time_constant_s: f32,
}

/// B-dot state: the previous field sample and the filtered derivative.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bdot {
    last_b: Option<Vec3>,
    b_dot: Vec3,
}

impl Bdot {
    pub const fn new() -> Self {
        Self { last_b: None, b_dot: nalgebra::Vector3::new(0.0, 0.0, 0.0) }
    }

    /// Dipole demand for this step (zero on the first sample).
    pub fn update(&mut self, g: &BdotGains, b_body_t: &Vec3, dt_s: f32) -> Vec3 {
        if let Some(last) = self.last_b {
            let raw = (b_body_t - last) / dt_s;
            let a = dt_s / (g.filter_time_constant_s + dt_s);
            self.b_dot += (raw - self.b_dot) * a;
        }
        self.last_b = Some(*b_body_t);
        -self.b_dot * g.gain
    }

    /// B-dot as a torque demand for the dipole allocation: `m × B`.
    pub fn torque_demand(&mut self, g: &BdotGains, b_body_t: &Vec3, dt_s: f32) -> TorqueDemand {
        let m = self.update(g, b_body_t, dt_s);
        TorqueDemand { torque_nm: m.cross(b_body_t), limited: false, error_angle_rad: 0.0 }
    }

    pub fn reset(&mut self) {
        *self = Self::new();
    }
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

    #[test]
    fn bdot_opposes_the_field_rotation() {
        // A body spinning at ω sees dB/dt = -ω × B (field fixed inertially): B-dot's dipole
        // m = k ω × B gives a torque m × B whose projection on ω is ≤ 0 (it removes energy).
        let g = BdotGains { gain: 1e4, filter_time_constant_s: 0.0 };
        let w = Vec3::new(0.1, -0.05, 0.08);
        let b0 = Vec3::new(2e-5, -1e-5, 3e-5);
        let dt = 0.01f32;
        let mut bd = Bdot::default();
        let mut b = b0;
        let mut t = TorqueDemand { torque_nm: Vec3::zeros(), limited: false, error_angle_rad: 0.0 };
        for _ in 0..3 {
            t = bd.torque_demand(&g, &b, dt);
            b -= w.cross(&b) * dt;
        }
        assert!(t.torque_nm.dot(&w) < 0.0, "{:?}", t.torque_nm);
        // Magnitude: m ≈ k |ω × B|.
        let m = bd.update(&g, &b, dt);
        assert!((m.norm() / (1e4 * w.cross(&b).norm()) - 1.0).abs() < 0.05);
    }
}
