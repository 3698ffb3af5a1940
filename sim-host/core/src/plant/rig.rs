//! Air-bearing test rig (papers 000 and 003): a spherical air bearing whose centre of
//! mass sits below (or beside) the centre of rotation, so gravity adds a pendulum torque
//! (paper 003 eqs 6, 17-19): `T_p = (m g r) × K`, with `K` the lab's vertical (z) axis in
//! body axes — for 3-2-1 Euler angles `K = [-sθ, sφ cθ, cφ cθ]` (eq 17). The lab frame is
//! the simulation's reference frame; no orbit.
//!
//! Roll and pitch travel are limited by mechanical stops, modelled as a stiff
//! spring-damper acting beyond the limit (stop natural frequency `STOP_WN_RAD_S`, damping
//! ratio 0.7 about the rig's inertia), so RK4 stays smooth.
//!
//! Bearing friction (paper 000 names air-bearing friction among the rig's effects): a
//! viscous torque `-c ∘ ω` and a Coulomb torque `-T_c ∘ sign(ω)`, per body axis, the sign
//! smoothed as `tanh(ω / ω_s)` with `ω_s = BEARING_SMOOTHING_RAD_S` (as the gimbal
//! bearing's, `plant::cmg`), so there is no true stiction: near rest the Coulomb term acts as
//! a steep viscous one.

use crate::attitude::{Quat, Vec3, dcm_body_to_ref};
use nalgebra::Matrix3;

/// Natural frequency of the travel stops, rad/s.
pub const STOP_WN_RAD_S: f64 = 10.0;

/// Rate scale of the smoothed Coulomb sign of the bearing friction, rad/s.
pub const BEARING_SMOOTHING_RAD_S: f64 = 1e-3;

#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    /// `m g r` in body axes, N m (paper 003 eq 28: [-0.004, -0.001, 0.5]).
    pub mgr_nm: Vec3,
    /// Roll and pitch travel limits, rad (`None` = free).
    pub roll_limit_rad: Option<f64>,
    pub pitch_limit_rad: Option<f64>,
    /// Bearing friction per body axis: viscous coefficient, N m s, and Coulomb level, N m.
    pub viscous_nms: Vec3,
    pub coulomb_nm: Vec3,
}

impl Rig {
    /// Pendulum torque plus stop torques, body axes.
    pub fn torque(&self, q: &Quat, w: &Vec3, inertia: &Matrix3<f64>) -> Vec3 {
        let c = dcm_body_to_ref(q);
        // Lab z axis in body axes: third row of the body→lab matrix.
        let k = Vec3::new(c[(2, 0)], c[(2, 1)], c[(2, 2)]);
        let mut t = self.mgr_nm.cross(&k);
        // 3-2-1 roll and pitch from the same matrix.
        let pitch = (-c[(2, 0)]).clamp(-1.0, 1.0).asin();
        let roll = c[(2, 1)].atan2(c[(2, 2)]);
        let stop = |angle: f64, limit: Option<f64>, axis: usize| -> f64 {
            let Some(l) = limit else { return 0.0 };
            let excess = if angle > l {
                angle - l
            } else if angle < -l {
                angle + l
            } else {
                return 0.0;
            };
            let i = inertia[(axis, axis)];
            -i * STOP_WN_RAD_S * STOP_WN_RAD_S * excess - 2.0 * 0.7 * STOP_WN_RAD_S * i * w[axis]
        };
        t.x += stop(roll, self.roll_limit_rad, 0);
        t.y += stop(pitch, self.pitch_limit_rad, 1);
        if self.viscous_nms != Vec3::zeros() || self.coulomb_nm != Vec3::zeros() {
            t += self.friction(w);
        }
        t
    }

    /// Bearing friction torque at body rate `w`, body axes.
    pub fn friction(&self, w: &Vec3) -> Vec3 {
        Vec3::from_fn(|i, _| -self.viscous_nms[i] * w[i] - self.coulomb_nm[i] * (w[i] / BEARING_SMOOTHING_RAD_S).tanh())
    }

    /// No pendulum, no stops, no friction.
    pub fn free() -> Self {
        Rig {
            mgr_nm: Vec3::zeros(),
            roll_limit_rad: None,
            pitch_limit_rad: None,
            viscous_nms: Vec3::zeros(),
            coulomb_nm: Vec3::zeros(),
        }
    }

    /// Paper 000's rig (table 2): roll and pitch travel ±45°, yaw free (the table's ±180°
    /// belongs to yaw: its yaw manoeuvres exceed 45°; see `docs/papers.md`, paper 000). The
    /// paper gives no centre-of-mass offset, so no pendulum term.
    pub fn paper000() -> Self {
        Rig {
            mgr_nm: Vec3::zeros(),
            roll_limit_rad: Some(45f64.to_radians()),
            pitch_limit_rad: Some(45f64.to_radians()),
            viscous_nms: Vec3::zeros(),
            coulomb_nm: Vec3::zeros(),
        }
    }

    /// Paper 003's rig (eqs 27-28), ±40° roll and pitch travel.
    pub fn paper003() -> (Matrix3<f64>, Self) {
        let i = Matrix3::new(1.76, -0.01, -0.05, -0.01, 1.79, -0.01, -0.05, -0.01, 2.92);
        let rig = Rig {
            mgr_nm: Vec3::new(-0.004, -0.001, 0.5),
            roll_limit_rad: Some(40f64.to_radians()),
            pitch_limit_rad: Some(40f64.to_radians()),
            viscous_nms: Vec3::zeros(),
            coulomb_nm: Vec3::zeros(),
        };
        (i, rig)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::quat_from_euler;
    use acs_flight::math::EulerSeq;

    #[test]
    fn k_is_eq17() {
        let (phi, theta) = (0.3f64, -0.2f64);
        let q = quat_from_euler([phi, theta, 1.1], EulerSeq::Zyx321);
        let rig = Rig { mgr_nm: Vec3::new(0.0, 0.0, 1.0), ..Rig::free() };
        // T = e_z × K = [-K_y, K_x, 0]
        let t = rig.torque(&q, &Vec3::zeros(), &Matrix3::identity());
        let k = Vec3::new(-theta.sin(), phi.sin() * theta.cos(), phi.cos() * theta.cos());
        assert!((t - Vec3::new(-k.y, k.x, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn bearing_friction_decays_a_spin_as_the_closed_forms() {
        // A free yaw spin I ω' = -c ω - T_c tanh(ω/ω_s), integrated by RK4 at 1 ms.
        // Viscous only: ω(t) = ω0 exp(-c t / I). Coulomb only (|ω| ≫ ω_s): ω falls
        // linearly at T_c / I.
        let (i, w0, t_end, h) = (5.8, 0.2, 2.0, 1e-3);
        let spin = |rig: &Rig| {
            let f = |w: f64| rig.friction(&Vec3::new(0.0, 0.0, w)).z / i;
            let mut w = w0;
            for _ in 0..(t_end / h) as usize {
                let k1 = f(w);
                let k2 = f(w + 0.5 * h * k1);
                let k3 = f(w + 0.5 * h * k2);
                let k4 = f(w + h * k3);
                w += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            }
            w
        };
        let viscous = Rig { viscous_nms: Vec3::new(0.0, 0.0, 0.3), ..Rig::free() };
        let expect = w0 * (-0.3 * t_end / i).exp();
        assert!((spin(&viscous) - expect).abs() < 1e-9 * w0, "{} vs {expect}", spin(&viscous));
        let coulomb = Rig { coulomb_nm: Vec3::new(0.0, 0.0, 0.05), ..Rig::free() };
        let expect = w0 - 0.05 / i * t_end;
        assert!((spin(&coulomb) - expect).abs() < 1e-9, "{} vs {expect}", spin(&coulomb));
        // The friction opposes the rate on every axis and vanishes at rest.
        let both =
            Rig { viscous_nms: Vec3::new(0.1, 0.2, 0.3), coulomb_nm: Vec3::new(0.01, 0.02, 0.03), ..Rig::free() };
        let w = Vec3::new(0.1, -0.2, 0.3);
        let t = both.friction(&w);
        assert!((0..3).all(|k| t[k] * w[k] < 0.0), "{t:?}");
        assert_eq!(both.friction(&Vec3::zeros()), Vec3::zeros());
    }
}
