//! Air-bearing test rig (papers 000 and 003): a spherical air bearing whose centre of
//! mass sits below (or beside) the centre of rotation, so gravity adds a pendulum torque
//! (paper 003 eqs 6, 17-19): `T_p = (m g r) × K`, with `K` the lab's vertical (z) axis in
//! body axes — for 3-2-1 Euler angles `K = [-sθ, sφ cθ, cφ cθ]` (eq 17). The lab frame is
//! the simulation's reference frame; no orbit.
//!
//! Roll and pitch travel are limited by mechanical stops, modelled as a stiff
//! spring-damper acting beyond the limit (stop natural frequency `STOP_WN_RAD_S`, damping
//! ratio 0.7 about the rig's inertia), so RK4 stays smooth.

use crate::attitude::{Quat, Vec3, dcm_body_to_ref};
use nalgebra::Matrix3;

/// Natural frequency of the travel stops, rad/s.
pub const STOP_WN_RAD_S: f64 = 10.0;

#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    /// `m g r` in body axes, N m (paper 003 eq 28: [-0.004, -0.001, 0.5]).
    pub mgr_nm: Vec3,
    /// Roll and pitch travel limits, rad (`None` = free).
    pub roll_limit_rad: Option<f64>,
    pub pitch_limit_rad: Option<f64>,
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
        t
    }

    /// Paper 000's rig (table 2): roll and pitch travel ±45°, yaw free (the table's ±180°
    /// belongs to yaw: its yaw manoeuvres exceed 45°; see SEEDS.md). The paper gives no
    /// centre-of-mass offset, so no pendulum term.
    pub fn paper000() -> Self {
        Rig {
            mgr_nm: Vec3::zeros(),
            roll_limit_rad: Some(45f64.to_radians()),
            pitch_limit_rad: Some(45f64.to_radians()),
        }
    }

    /// Paper 003's rig (eqs 27-28), ±40° roll and pitch travel.
    pub fn paper003() -> (Matrix3<f64>, Self) {
        let i = Matrix3::new(1.76, -0.01, -0.05, -0.01, 1.79, -0.01, -0.05, -0.01, 2.92);
        let rig = Rig {
            mgr_nm: Vec3::new(-0.004, -0.001, 0.5),
            roll_limit_rad: Some(40f64.to_radians()),
            pitch_limit_rad: Some(40f64.to_radians()),
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
        let rig = Rig { mgr_nm: Vec3::new(0.0, 0.0, 1.0), roll_limit_rad: None, pitch_limit_rad: None };
        // T = e_z × K = [-K_y, K_x, 0]
        let t = rig.torque(&q, &Vec3::zeros(), &Matrix3::identity());
        let k = Vec3::new(-theta.sin(), phi.sin() * theta.cos(), phi.cos() * theta.cos());
        assert!((t - Vec3::new(-k.y, k.x, 0.0)).norm() < 1e-12);
    }
}
