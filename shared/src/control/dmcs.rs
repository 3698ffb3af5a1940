//! Decentralized Minimal Control Synthesis (paper 001 eqs 31-51), per axis i:
//!
//! - reference model (31-35): `ω̇_m = u_m / I_m`, quaternion kinematics, and
//!   `u_m = -k_m1 q_m - k_m2 ω_m`, `k_m1 = ωn² I_m`, `k_m2 = 2 ζ ωn I_m`; the model is
//!   propagated in flight as an error quaternion relative to the target (so it converges
//!   to the commanded attitude), starting from the plant's first measurement;
//! - plant input (44): `u_p = Δk_p x_p + Δk_u u_m`, with `x_p = [q_e,i, ω_i]`;
//! - error (39) `x_e = x_m - x_p`, output (47-48) `y_n = p21 x_e1 + p22 x_e2`, P from the
//!   Lyapunov equation (49) `P A_m + A_mᵀ P = -Q`, `A_m = [[0, ½], [-ωn², -2ζωn]]`;
//! - discrete adaptation (50-51): `Δk(k) = Δk(k-1) + β y_n(k) v(k) - σ y_n(k-1) v(k-1)`,
//!   `σ = β - α S` (S the sample time), v = x_p for Δk_p and u_m for Δk_u.
//!
//! MCS starts from zero gains: all the control comes from adaptation. Every gain is
//! clamped to `± gain_limit` so that a long run cannot overflow f32.
//!
//! Frozen ([`Dmcs::set_frozen`], the host's `FreezeAdaptation`): the increments of eqs
//! 50-51 are skipped and the gains kept, so the law is the fixed-gain loop
//! `u_p = Δk_p x_p + Δk_u u_m` (what `sim-host margins` measures, docs/margins.md); the
//! previous sample stays current, so unfreezing resumes eq 50-51 from the last step.

use super::scale_to_box;
use crate::math::{Quat, Vec3, attitude_error, rotation_angle};
use crate::types::TorqueDemand;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DmcsGains {
    pub wn: f32,
    pub zeta: f32,
    pub model_inertia: Vec3,
    pub alpha: f32,
    pub beta: f32,
    /// `[p21, p22]` per axis (the same for all axes when ωn, ζ are).
    pub p21: f32,
    pub p22: f32,
    pub gain_limit: f32,
    pub torque_limit_nm: Vec3,
}

impl DmcsGains {
    /// P of eq 49 for `A_m = [[0, ½], [-ωn², -2ζωn]]` and `Q = diag(q1, q2)` in closed form:
    /// `p12 = q1 / (2 ωn²)`, `p22 = (q2/2 + p12/2) / (2 ζ ωn)`. `None` for ωn or ζ ≤ 0.
    pub fn lyapunov_p(wn: f32, zeta: f32, q1: f32, q2: f32) -> Option<(f32, f32)> {
        if !(wn > 0.0 && zeta > 0.0) {
            return None;
        }
        let (a12, a21, a22) = (0.5f32, -wn * wn, -2.0 * zeta * wn);
        let p12 = -q1 / (2.0 * a21);
        let p22 = (-q2 / 2.0 - p12 * a12) / a22;
        Some((p12, p22))
    }
}

/// DMCS state: the reference model and the adaptive gains.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dmcs {
    q_m: Option<Quat>,
    w_m: Vec3,
    /// Δk_p per axis: `[on q, on ω]`.
    pub dkp: [[f32; 2]; 3],
    pub dku: [f32; 3],
    /// Previous sample per axis: `(y_n, x_p, u_m)`.
    prev: [Option<AxisSample>; 3],
    /// Adaptation frozen: eqs 50-51 skipped, gains kept (`prev` still updated).
    frozen: bool,
}

type AxisSample = (f32, [f32; 2], f32);

impl Dmcs {
    pub const fn new() -> Self {
        Self {
            q_m: None,
            w_m: nalgebra::Vector3::new(0.0, 0.0, 0.0),
            dkp: [[0.0; 2]; 3],
            dku: [0.0; 3],
            prev: [None; 3],
            frozen: false,
        }
    }

    /// Freeze (`true`) or resume (`false`) the adaptation; the gains and the reference
    /// model are kept either way.
    pub fn set_frozen(&mut self, frozen: bool) {
        self.frozen = frozen;
    }

    pub fn frozen(&self) -> bool {
        self.frozen
    }

    pub fn update(&mut self, g: &DmcsGains, q: &Quat, q_cmd: &Quat, rate_rad_s: &Vec3, dt_s: f32) -> TorqueDemand {
        let e = attitude_error(q, q_cmd);
        let q_m = *self.q_m.get_or_insert(e);
        let k1 = g.model_inertia * (g.wn * g.wn);
        let k2 = g.model_inertia * (2.0 * g.zeta * g.wn);
        let qmv = q_m.imag();
        let u_m = -k1.component_mul(&qmv) - k2.component_mul(&self.w_m);
        let ev = e.imag();
        let lim = g.gain_limit;
        let sigma = g.beta - g.alpha * dt_s;
        // Per axis: plant state, model state, model input, previous sample.
        let xps = [[ev.x, rate_rad_s.x], [ev.y, rate_rad_s.y], [ev.z, rate_rad_s.z]];
        let xms = [[qmv.x, self.w_m.x], [qmv.y, self.w_m.y], [qmv.z, self.w_m.z]];
        let ums = [u_m.x, u_m.y, u_m.z];
        let prevs = self.prev;
        let adapt = !self.frozen;
        let mut y = [0.0f32; 3];
        let mut uo = [0.0f32; 3];
        let clamp = |v: f32| if v.is_finite() { crate::math::clamp_abs(v, lim) } else { 0.0 };
        for ((((((dkp, dku), (yo, ui)), x_p), x_m), um), pv) in self
            .dkp
            .iter_mut()
            .zip(self.dku.iter_mut())
            .zip(y.iter_mut().zip(uo.iter_mut()))
            .zip(xps.iter())
            .zip(xms.iter())
            .zip(ums.iter())
            .zip(prevs.iter())
        {
            let [xp0, xp1] = *x_p;
            let [xm0, xm1] = *x_m;
            let yn = g.p21 * (xm0 - xp0) + g.p22 * (xm1 - xp1);
            if let Some((yp, xpp, ump)) = pv.filter(|_| adapt) {
                for ((k, xj), xpj) in dkp.iter_mut().zip(x_p.iter()).zip(xpp.iter()) {
                    *k = clamp(*k + g.beta * yn * xj - sigma * yp * xpj);
                }
                *dku = clamp(*dku + g.beta * yn * um - sigma * yp * ump);
            }
            *yo = yn;
            let [k0, k1] = *dkp;
            *ui = k0 * xp0 + k1 * xp1 + *dku * um;
        }
        let xp = xps;
        let u = Vec3::from(uo);
        self.prev = [Some((y[0], xp[0], ums[0])), Some((y[1], xp[1], ums[1])), Some((y[2], xp[2], ums[2]))];
        // Propagate the reference model (explicit Euler on ω, exact rotation for q).
        let w_new = self.w_m + u_m.component_div(&g.model_inertia) * dt_s;
        let half = self.w_m * (0.5 * dt_s);
        let dq = Quat::from_parts(1.0, half);
        let qn = q_m * dq;
        self.q_m = crate::math::quat_normalized(&qn).or(Some(q_m));
        self.w_m = if w_new.iter().all(|x| x.is_finite()) { w_new } else { Vec3::zeros() };
        let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
        TorqueDemand { torque_nm, limited, error_angle_rad: rotation_angle(&e) }
    }

    /// Reference-model attitude error and rate (telemetry).
    pub fn model(&self) -> (Option<Quat>, Vec3) {
        (self.q_m, self.w_m)
    }

    /// Fresh state: zero gains, a new reference model, adaptation running.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler};

    #[test]
    fn lyapunov_solution_satisfies_eq_49() {
        let (wn, zeta, q1, q2) = (0.035f32, 0.95f32, 0.1f32, 1.0f32);
        let (p12, p22) = DmcsGains::lyapunov_p(wn, zeta, q1, q2).unwrap();
        let (a12, a21, a22) = (0.5f32, -wn * wn, -2.0 * zeta * wn);
        let p11 = -(p12 * a22 + p22 * a21) / a12;
        // P A + Aᵀ P + Q = 0, element by element.
        let r11 = 2.0 * p12 * a21 + q1;
        let r12 = p11 * a12 + p12 * a22 + p22 * a21;
        let r22 = 2.0 * (p12 * a12 + p22 * a22) + q2;
        assert!(r11.abs() < 1e-4 && r12.abs() < 1e-4 * p11.abs().max(1.0) && r22.abs() < 1e-4, "{r11} {r12} {r22}");
        assert!(p11 > 0.0 && p11 * p22 - p12 * p12 > 0.0, "P is positive definite");
    }

    /// The gains of the one-axis tests: model inertia 400, ωn 0.05, ζ 0.95.
    fn one_axis_gains() -> DmcsGains {
        let (p21, p22) = DmcsGains::lyapunov_p(0.05, 0.95, 0.1, 1.0).unwrap();
        DmcsGains {
            wn: 0.05,
            zeta: 0.95,
            model_inertia: Vec3::repeat(400.0),
            alpha: 55.0,
            beta: 220.0,
            p21,
            p22,
            gain_limit: 1e7,
            torque_limit_nm: Vec3::repeat(1e3),
        }
    }

    #[test]
    fn adaptive_loop_tracks_the_model_on_a_double_integrator() {
        // One axis: plant inertia 500 (model 400), the model brings 0.2 rad to 0.
        let g = one_axis_gains();
        let mut c = Dmcs::new();
        let inertia = 500.0f32;
        let (mut ang, mut w, dt) = (0.2f32, 0.0f32, 0.1f32);
        for _ in 0..3000 {
            let q = quat_from_euler([0.0, 0.0, ang], EulerSeq::Zyx321);
            let d = c.update(&g, &q, &Quat::identity(), &Vec3::new(0.0, 0.0, w), dt);
            w += d.torque_nm.z / inertia * dt;
            ang += w * dt;
        }
        assert!(ang.abs() < 0.01, "final angle {ang}");
        assert!(c.dku[2] > 0.0, "the feed-forward gain adapted: {}", c.dku[2]);
    }

    /// Frozen, the gains stay bit-identical over steps with a nonzero error; unfrozen
    /// again, they adapt at once (the previous sample was kept current).
    #[test]
    fn frozen_adaptation_keeps_the_gains() {
        let g = one_axis_gains();
        let mut c = Dmcs::new();
        let rate = Vec3::new(0.01, -0.02, 0.005);
        let q_at = |a: f32| quat_from_euler([0.1 * a, -0.2 * a, 0.3 * a], EulerSeq::Zyx321);
        for k in 0..20 {
            c.update(&g, &q_at(1.0 - 0.01 * k as f32), &Quat::identity(), &rate, 0.1);
        }
        let (dkp, dku) = (c.dkp, c.dku);
        assert!(dkp.iter().flatten().any(|k| *k != 0.0), "adapted before the freeze: {dkp:?}");
        c.set_frozen(true);
        for k in 0..50 {
            let d = c.update(&g, &q_at(0.8 - 0.01 * k as f32), &Quat::identity(), &rate, 0.1);
            assert!(d.torque_nm.norm() > 0.0);
            assert_eq!((c.dkp, c.dku), (dkp, dku), "step {k}: frozen gains changed");
        }
        c.set_frozen(false);
        c.update(&g, &q_at(0.2), &Quat::identity(), &rate, 0.1);
        assert!(c.dkp != dkp && c.dku != dku, "unfrozen: the gains adapt again");
        c.reset();
        assert!(!c.frozen(), "a reset law adapts");
    }
}
