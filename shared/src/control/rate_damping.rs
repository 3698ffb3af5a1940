//! Rate damping `T = -Kd ∘ ω` (inertial body rate): detumbling with momentum-exchange
//! actuators or thrusters when there are no magnetorquers. It needs only the gyro — the
//! star tracker may be blind while tumbling — and its demand is limited per axis with the
//! direction kept. With `T = -kd ω` on a spherical body `ω(t) = ω₀ e^{-kd t / I}`.

use super::scale_to_box;
use crate::math::Vec3;
use crate::types::TorqueDemand;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateDampingGains {
    pub kd_nms: Vec3,
    pub torque_limit_nm: Vec3,
}

/// The demand; `error_angle_rad` is 0 (the law has no attitude).
pub fn rate_damping(g: &RateDampingGains, rate_rad_s: &Vec3) -> TorqueDemand {
    let u = -g.kd_nms.component_mul(rate_rad_s);
    let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
    TorqueDemand { torque_nm, limited, error_angle_rad: 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opposes_the_rate_and_saturates_keeping_direction() {
        let g = RateDampingGains { kd_nms: Vec3::new(2.0, 3.0, 4.0), torque_limit_nm: Vec3::repeat(0.1) };
        let d = rate_damping(&g, &Vec3::new(0.01, -0.01, 0.005));
        assert!((d.torque_nm - Vec3::new(-0.02, 0.03, -0.02)).norm() < 1e-7 && !d.limited);
        let w = Vec3::new(1.0, -0.5, 0.25);
        let d = rate_damping(&g, &w);
        assert!(d.limited && (d.torque_nm.amax() - 0.1).abs() < 1e-6);
        let u = -g.kd_nms.component_mul(&w);
        assert!(d.torque_nm.normalize().dot(&u.normalize()) > 0.99999);
    }
}
