//! Plant models (f64). The spacecraft is a rigid body carrying momentum-exchange
//! actuators; the state is integrated with fixed-step RK4 at an integer multiple of the
//! control rate, the quaternion renormalised after every step.
//!
//! Rigid body with a CMG cluster (paper 000 eqs 1-4, gimbal and transverse rotor inertia
//! neglected as in the paper):
//! `H = I ω + h`, `I ω̇ = T_ext - ḣ - ω × (I ω + h)`, `ḣ = Σ δ̇_i (g_i × h_i)`,
//! `q̇ = ½ q ⊗ [ω; 0]`.

pub mod cmg;
pub mod wheel;

use crate::attitude::{Quat, Vec3, dcm_body_to_ref};
use cmg::CmgCluster;
use nalgebra::Matrix3;

/// Largest number of gimbals the fixed-size state holds.
pub const MAX_GIMBALS: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// `q_ib`, body → inertial.
    pub q: Quat,
    /// Body rate, body axes, rad/s.
    pub w: Vec3,
    pub gimbal_rad: [f64; MAX_GIMBALS],
}

/// Actuator inputs held constant over one control period (zero-order hold).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Input {
    pub gimbal_rate_cmd_rad_s: [f64; MAX_GIMBALS],
}

#[derive(Clone, Copy, Debug)]
struct Deriv {
    dq: Quat,
    dw: Vec3,
    dgimbal: [f64; MAX_GIMBALS],
}

#[derive(Clone, Debug)]
pub struct Spacecraft {
    pub inertia: Matrix3<f64>,
    inertia_inv: Matrix3<f64>,
    pub cmg: Option<CmgCluster>,
    /// Constant external torque, body axes, N m.
    pub external_torque_nm: Vec3,
}

impl Spacecraft {
    /// `None` if the inertia is not invertible.
    pub fn new(inertia: Matrix3<f64>, cmg: Option<CmgCluster>) -> Option<Self> {
        Some(Self {
            inertia,
            inertia_inv: inertia.try_inverse()?,
            cmg,
            external_torque_nm: Vec3::zeros(),
        })
    }

    /// Gimbal rates the hardware actually applies (rate limit, angle stops).
    pub fn applied_gimbal_rates(&self, s: &State, u: &Input) -> [f64; MAX_GIMBALS] {
        let mut r = [0.0; MAX_GIMBALS];
        if let Some(c) = &self.cmg {
            for i in 0..c.units.len() {
                r[i] = c.applied_rate(u.gimbal_rate_cmd_rad_s[i], s.gimbal_rad[i]);
            }
        }
        r
    }

    /// Actuator momentum in body axes.
    pub fn actuator_momentum(&self, s: &State) -> Vec3 {
        self.cmg
            .as_ref()
            .map_or(Vec3::zeros(), |c| c.momentum(&s.gimbal_rad))
    }

    /// Torque the actuators exert on the body: `-ḣ - ω × h` (eq 4).
    pub fn actuator_torque(&self, s: &State, u: &Input) -> Vec3 {
        let rates = self.applied_gimbal_rates(s, u);
        match &self.cmg {
            Some(c) => {
                -c.momentum_rate(&s.gimbal_rad, &rates) - s.w.cross(&c.momentum(&s.gimbal_rad))
            }
            None => Vec3::zeros(),
        }
    }

    fn deriv(&self, s: &State, u: &Input) -> Deriv {
        let rates = self.applied_gimbal_rates(s, u);
        let (h, hdot) = match &self.cmg {
            Some(c) => (
                c.momentum(&s.gimbal_rad),
                c.momentum_rate(&s.gimbal_rad, &rates),
            ),
            None => (Vec3::zeros(), Vec3::zeros()),
        };
        let big_h = self.inertia * s.w + h;
        let dw = self.inertia_inv * (self.external_torque_nm - hdot - s.w.cross(&big_h));
        let dq = s.q * Quat::from_imag(s.w) * 0.5;
        Deriv {
            dq,
            dw,
            dgimbal: rates,
        }
    }

    fn add(s: &State, d: &Deriv, h: f64) -> State {
        let mut g = s.gimbal_rad;
        for (x, dx) in g.iter_mut().zip(d.dgimbal.iter()) {
            *x += h * dx;
        }
        State {
            q: s.q + d.dq * h,
            w: s.w + d.dw * h,
            gimbal_rad: g,
        }
    }

    /// One classical RK4 step of length `h` with the input held; renormalises `q`.
    pub fn rk4(&self, s: &State, u: &Input, h: f64) -> State {
        let k1 = self.deriv(s, u);
        let k2 = self.deriv(&Self::add(s, &k1, 0.5 * h), u);
        let k3 = self.deriv(&Self::add(s, &k2, 0.5 * h), u);
        let k4 = self.deriv(&Self::add(s, &k3, h), u);
        let mut g = s.gimbal_rad;
        for i in 0..MAX_GIMBALS {
            g[i] += h / 6.0
                * (k1.dgimbal[i] + 2.0 * k2.dgimbal[i] + 2.0 * k3.dgimbal[i] + k4.dgimbal[i]);
        }
        if let Some(c) = &self.cmg {
            c.clamp_angles(&mut g);
        }
        let q = s.q + (k1.dq + (k2.dq + k3.dq) * 2.0 + k4.dq) * (h / 6.0);
        let w = s.w + (k1.dw + (k2.dw + k3.dw) * 2.0 + k4.dw) * (h / 6.0);
        State {
            q: q.normalize(),
            w,
            gimbal_rad: g,
        }
    }

    /// Total angular momentum in the inertial frame, N m s (conserved without T_ext).
    pub fn angular_momentum_inertial(&self, s: &State) -> Vec3 {
        dcm_body_to_ref(&s.q) * (self.inertia * s.w + self.actuator_momentum(s))
    }

    /// Rotational kinetic energy of the body, J (conserved with gimbals at rest).
    pub fn kinetic_energy(&self, s: &State) -> f64 {
        0.5 * s.w.dot(&(self.inertia * s.w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::quat_from_euler;
    use acs_flight::math::EulerSeq;

    fn craft() -> Spacecraft {
        let i = Matrix3::new(3.1, 0.05, -0.02, 0.05, 3.4, 0.03, -0.02, 0.03, 5.8);
        Spacecraft::new(
            i,
            Some(CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1e3, None)),
        )
        .unwrap()
    }

    fn state() -> State {
        let mut g = [0.0; MAX_GIMBALS];
        g[..4].copy_from_slice(&[0.3, -0.7, 1.1, 0.2]);
        State {
            q: quat_from_euler([0.2, -0.1, 0.5], EulerSeq::Zyx321),
            w: Vec3::new(0.05, -0.08, 0.12),
            gimbal_rad: g,
        }
    }

    #[test]
    fn torque_free_with_fixed_gimbals_conserves_momentum_and_energy_over_1000_s() {
        let sc = craft();
        let mut s = state();
        let (h0, e0) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
        let u = Input::default();
        for _ in 0..100_000 {
            s = sc.rk4(&s, &u, 0.01);
        }
        let (h1, e1) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
        // RK4 at 100 Hz on a ~0.15 rad/s tumble: truncation error ~1e-12 per step.
        assert!(
            (h1 - h0).norm() < 1e-9 * h0.norm(),
            "momentum drift {:e}",
            (h1 - h0).norm() / h0.norm()
        );
        assert!(
            (e1 - e0).abs() < 1e-9 * e0,
            "energy drift {:e}",
            (e1 - e0).abs() / e0
        );
    }

    #[test]
    fn moving_gimbals_exchange_momentum_but_conserve_the_total() {
        let sc = craft();
        let mut s = state();
        let h0 = sc.angular_momentum_inertial(&s);
        let mut u = Input::default();
        u.gimbal_rate_cmd_rad_s[..4].copy_from_slice(&[0.3, -0.2, 0.1, 0.4]);
        for _ in 0..100_000 {
            s = sc.rk4(&s, &u, 0.01);
        }
        let h1 = sc.angular_momentum_inertial(&s);
        assert!(
            (h1 - h0).norm() < 1e-9 * h0.norm(),
            "drift {:e}",
            (h1 - h0).norm() / h0.norm()
        );
        // The gimbals really moved (1000 s at 0.3 rad/s): the exchange was not trivial.
        assert!((s.gimbal_rad[0] - 0.3 - 300.0).abs() < 1e-9);
    }

    #[test]
    fn gimbal_motion_from_rest_produces_the_eq4_torque() {
        // From rest, ω = 0: the body sees T = -J δ̇ (eq 4), so I ω̇ = -J δ̇ at t = 0.
        let sc = craft();
        let mut s = state();
        s.w = Vec3::zeros();
        let mut u = Input::default();
        u.gimbal_rate_cmd_rad_s[..4].copy_from_slice(&[0.5, 0.0, -0.25, 0.1]);
        let dt = 1e-4;
        let s1 = sc.rk4(&s, &u, dt);
        let t_expected = sc.actuator_torque(&s, &u);
        let c = sc.cmg.as_ref().unwrap();
        let jd = c.momentum_rate(&s.gimbal_rad, &u.gimbal_rate_cmd_rad_s);
        assert!((t_expected + jd).norm() < 1e-15, "T = -J δ̇ at ω = 0");
        let t_measured = sc.inertia * (s1.w - s.w) / dt;
        assert!(
            (t_measured - t_expected).norm() < 1e-3 * t_expected.norm(),
            "{t_measured:?} vs {t_expected:?}"
        );
    }
}
