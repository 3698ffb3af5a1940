//! B-dot detumbling with magnetorquers (paper 003): `m = -k dB/dt`, dB/dt from a
//! first-order-filtered difference of the magnetometer (time constant τ, exact discrete
//! gain `a = dt/(τ + dt)`). It is handed to the allocation as the torque `m × B`: the
//! cross-product law returns the part of m perpendicular to B — the only part that
//! produces torque — and applies the dipole limits and dead band.

use crate::math::Vec3;
use crate::types::TorqueDemand;

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
