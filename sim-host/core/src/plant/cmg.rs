//! Single-gimbal CMG cluster, general geometry: unit i has gimbal axis `g_i` and rotor
//! momentum `h_i = h0 (cos δ_i s_i + sin δ_i t_i)` with `t_i = g_i × s_i`, so that
//! `∂h_i/∂δ_i = g_i × h_i`. The four-unit pyramid of paper 000 (eq 6) is a preset; a
//! test checks the preset against eq 6 as printed.
//!
//! Hardware limits: gimbal rate saturates at `max_rate_rad_s`; optional angle stops.
//!
//! Optional gimbal servo ([`GimbalServo`]): the real gimbal rate lags the command as a
//! first-order loop with time constant τ and is opposed by Coulomb friction on the gimbal
//! bearing, `δ̈ = (δ̇_cmd - δ̇)/τ - (T_f / I_g) tanh(δ̇ / ε)`; without it the gimbal follows
//! the (saturated) command instantly, as in paper 000.
//!
//! Gimbal-axis misalignment ([`CmgCluster::misaligned`], scenario key
//! `actuators.cmg.gimbal_misalignment_deg`): unit i's whole gimbal frame (gimbal axis,
//! `spin0`, `trans0`) is rotated rigidly by `R(r_i)`, the rotation about `r_i / |r_i|` by
//! `|r_i|` (rotation vector in body axes), so `true = R(r_i) · nominal`. Only the plant is
//! rotated: the flight code keeps the nominal geometry of its parameters. A rotation about
//! the nominal gimbal axis itself is a gimbal-angle offset; one about any other axis tilts
//! the gimbal axis.

use super::MAX_GIMBALS;
use crate::attitude::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CmgUnit {
    /// Rotor momentum direction at δ = 0.
    pub spin0: Vec3,
    /// Direction of ∂h/∂δ at δ = 0 (`g × spin0`).
    pub trans0: Vec3,
    pub h0_nms: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct CmgCluster {
    pub units: Vec<CmgUnit>,
    pub max_rate_rad_s: f64,
    /// `(min, max)` gimbal angle, rad; `None` = unlimited.
    pub angle_limits_rad: Option<(f64, f64)>,
    /// Gimbal rate loop dynamics and friction; `None` = ideal rate servo.
    pub servo: Option<GimbalServo>,
    /// Pure delay of the gimbal-rate commands, s (`[actuators.cmg] rate_delay_s`; applied
    /// by the simulator in whole control periods, [`crate::plant::delay::DelayLine`]).
    pub rate_delay_s: f64,
}

/// First-order gimbal rate servo with Coulomb friction on the gimbal axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GimbalServo {
    pub time_constant_s: f64,
    /// Gimbal (plus rotor, about the gimbal axis) inertia, kg m².
    pub gimbal_inertia_kgm2: f64,
    /// Coulomb friction torque on the gimbal bearing, N m.
    pub friction_nm: f64,
}

/// Rate scale of the smooth friction sign, rad/s.
const FRICTION_SMOOTHING_RAD_S: f64 = 1e-3;

impl GimbalServo {
    /// Gimbal acceleration for the applied command and the actual rate.
    pub fn accel(&self, cmd: f64, rate: f64) -> f64 {
        (cmd - rate) / self.time_constant_s
            - self.friction_nm / self.gimbal_inertia_kgm2 * (rate / FRICTION_SMOOTHING_RAD_S).tanh()
    }
}

impl CmgCluster {
    /// Four-CMG pyramid with skew angle β (paper 000 eq 6).
    pub fn pyramid(skew_rad: f64, h0_nms: f64, max_rate_rad_s: f64, angle_limits_rad: Option<(f64, f64)>) -> Self {
        let (sb, cb) = skew_rad.sin_cos();
        let unit = |s: [f64; 3], t: [f64; 3]| CmgUnit { spin0: Vec3::from(s), trans0: Vec3::from(t), h0_nms };
        Self {
            units: vec![
                unit([0.0, 1.0, 0.0], [-cb, 0.0, sb]),
                unit([-1.0, 0.0, 0.0], [0.0, -cb, sb]),
                unit([0.0, -1.0, 0.0], [cb, 0.0, sb]),
                unit([1.0, 0.0, 0.0], [0.0, cb, sb]),
            ],
            max_rate_rad_s,
            angle_limits_rad,
            servo: None,
            rate_delay_s: 0.0,
        }
    }

    /// The same cluster with unit i's gimbal frame rotated by the rotation vector
    /// `rotvecs_rad[i]` (body axes, rad; `true = R · nominal`). Units beyond the slice, and
    /// zero vectors, are left exactly as they are (bit for bit).
    pub fn misaligned(mut self, rotvecs_rad: &[[f64; 3]]) -> Self {
        for (u, rv) in self.units.iter_mut().zip(rotvecs_rad) {
            if rv.iter().all(|x| *x == 0.0) {
                continue;
            }
            let r = nalgebra::Rotation3::new(Vec3::from(*rv));
            u.spin0 = r * u.spin0;
            u.trans0 = r * u.trans0;
        }
        self
    }

    /// Gimbal axis of unit i, `spin0 × trans0` normalised.
    pub fn gimbal_axis(&self, i: usize) -> Vec3 {
        let u = &self.units[i];
        u.spin0.cross(&u.trans0).normalize()
    }

    pub fn len(&self) -> usize {
        self.units.len()
    }

    pub fn is_empty(&self) -> bool {
        self.units.is_empty()
    }

    pub fn unit_momentum(&self, i: usize, delta: f64) -> Vec3 {
        let u = &self.units[i];
        let (s, c) = delta.sin_cos();
        (u.spin0 * c + u.trans0 * s) * u.h0_nms
    }

    /// Cluster momentum, body axes.
    pub fn momentum(&self, delta: &[f64; MAX_GIMBALS]) -> Vec3 {
        (0..self.units.len()).map(|i| self.unit_momentum(i, delta[i])).sum()
    }

    /// Column i of the Jacobian, `∂h/∂δ_i`.
    pub fn jacobian_column(&self, i: usize, delta: f64) -> Vec3 {
        let u = &self.units[i];
        let (s, c) = delta.sin_cos();
        (u.trans0 * c - u.spin0 * s) * u.h0_nms
    }

    /// `ḣ = J δ̇`.
    pub fn momentum_rate(&self, delta: &[f64; MAX_GIMBALS], rate: &[f64; MAX_GIMBALS]) -> Vec3 {
        (0..self.units.len()).map(|i| self.jacobian_column(i, delta[i]) * rate[i]).sum()
    }

    /// `(h, ḣ = J δ̇)` with one `sin_cos` per unit (the RK4 hot path).
    pub fn momentum_and_rate(&self, delta: &[f64; MAX_GIMBALS], rate: &[f64; MAX_GIMBALS]) -> (Vec3, Vec3) {
        let (mut h, mut hd) = (Vec3::zeros(), Vec3::zeros());
        for (i, u) in self.units.iter().enumerate() {
            let (s, c) = delta[i].sin_cos();
            h += (u.spin0 * c + u.trans0 * s) * u.h0_nms;
            hd += (u.trans0 * c - u.spin0 * s) * (u.h0_nms * rate[i]);
        }
        (h, hd)
    }

    /// Cluster momentum with unit i's rotor momentum `scale[i] h0` (a rotor spin-down
    /// fault; exactly [`Self::momentum`] with every scale 1).
    pub fn momentum_scaled(&self, delta: &[f64; MAX_GIMBALS], scale: &[f64; MAX_GIMBALS]) -> Vec3 {
        let mut h = Vec3::zeros();
        for (i, u) in self.units.iter().enumerate() {
            let (s, c) = delta[i].sin_cos();
            h += (u.spin0 * c + u.trans0 * s) * (u.h0_nms * scale[i]);
        }
        h
    }

    /// [`Self::momentum_and_rate`] with unit i's rotor momentum `scale[i] h0` changing at
    /// `scale_rate[i] h0`: `ḣ_i = h0 (scale_rate e_i + scale δ̇ ∂e_i/∂δ)`. Bit for bit
    /// [`Self::momentum_and_rate`] with every scale 1 and every scale rate 0.
    pub fn momentum_and_rate_scaled(
        &self,
        delta: &[f64; MAX_GIMBALS],
        rate: &[f64; MAX_GIMBALS],
        scale: &[f64; MAX_GIMBALS],
        scale_rate: &[f64; MAX_GIMBALS],
    ) -> (Vec3, Vec3) {
        let (mut h, mut hd) = (Vec3::zeros(), Vec3::zeros());
        for (i, u) in self.units.iter().enumerate() {
            let (s, c) = delta[i].sin_cos();
            let e = u.spin0 * c + u.trans0 * s;
            let h0 = u.h0_nms * scale[i];
            h += e * h0;
            hd += (u.trans0 * c - u.spin0 * s) * (h0 * rate[i]);
            if scale_rate[i] != 0.0 {
                hd += e * (u.h0_nms * scale_rate[i]);
            }
        }
        (h, hd)
    }

    /// `ḣ` summed as [`Self::momentum_rate`] sums it (the telemetry's order: bit for bit it
    /// with every scale 1 and every scale rate 0), with the rotor scales and their rates.
    pub fn momentum_rate_scaled(
        &self,
        delta: &[f64; MAX_GIMBALS],
        rate: &[f64; MAX_GIMBALS],
        scale: &[f64; MAX_GIMBALS],
        scale_rate: &[f64; MAX_GIMBALS],
    ) -> Vec3 {
        let mut hd = Vec3::zeros();
        for i in 0..self.units.len() {
            hd += self.jacobian_column(i, delta[i]) * scale[i] * rate[i];
            if scale_rate[i] != 0.0 {
                hd += self.unit_momentum(i, delta[i]) * scale_rate[i];
            }
        }
        hd
    }

    /// `det(J₁ J₁ᵀ)` with unit rotor momentum.
    pub fn singularity_measure(&self, delta: &[f64; MAX_GIMBALS]) -> f64 {
        let mut jjt = nalgebra::Matrix3::<f64>::zeros();
        for i in 0..self.units.len() {
            let c = self.jacobian_column(i, delta[i]) / self.units[i].h0_nms;
            jjt += c * c.transpose();
        }
        jjt.determinant()
    }

    /// The rate the gimbal servo applies for a command.
    pub fn applied_rate(&self, cmd: f64, delta: f64) -> f64 {
        if !cmd.is_finite() {
            return 0.0;
        }
        let r = cmd.clamp(-self.max_rate_rad_s, self.max_rate_rad_s);
        match self.angle_limits_rad {
            Some((lo, _)) if delta <= lo && r < 0.0 => 0.0,
            Some((_, hi)) if delta >= hi && r > 0.0 => 0.0,
            _ => r,
        }
    }

    pub fn clamp_angles(&self, delta: &mut [f64; MAX_GIMBALS]) {
        if let Some((lo, hi)) = self.angle_limits_rad {
            for d in delta.iter_mut().take(self.units.len()) {
                *d = d.clamp(lo, hi);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pyramid_preset_is_eq6_of_paper_000() {
        let beta = 54.73f64.to_radians();
        let c = CmgCluster::pyramid(beta, 0.623, 1.0, None);
        let (cb, sb) = (beta.cos(), beta.sin());
        let mut d = [0.0; MAX_GIMBALS];
        d[..4].copy_from_slice(&[0.4, -1.3, 2.2, 0.9]);
        let (s, k) = (d.map(f64::sin), d.map(f64::cos));
        let eq6 = Vec3::new(
            -cb * s[0] - k[1] + cb * s[2] + k[3],
            k[0] - cb * s[1] - k[2] + cb * s[3],
            sb * (s[0] + s[1] + s[2] + s[3]),
        ) * 0.623;
        assert!((c.momentum(&d) - eq6).norm() < 1e-14);
    }

    #[test]
    fn gimbal_axes_are_unit_and_orthogonal_to_the_momentum() {
        let c = CmgCluster::pyramid(54.73f64.to_radians(), 1.0, 1.0, None);
        for u in &c.units {
            let g = u.spin0.cross(&u.trans0);
            assert!((g.norm() - 1.0).abs() < 1e-12 && u.spin0.dot(&u.trans0).abs() < 1e-12);
            // The gimbal axis leans 90° - β from the z axis: g·z = cos β.
            assert!((g.z - 54.73f64.to_radians().cos()).abs() < 1e-12);
        }
    }

    /// Rodrigues' formula written out, independent of nalgebra's rotation:
    /// `R v = v cos θ + (k × v) sin θ + k (k·v)(1 - cos θ)`.
    fn rodrigues(rv: [f64; 3], v: Vec3) -> Vec3 {
        let r = Vec3::from(rv);
        let th = r.norm();
        let k = r / th;
        v * th.cos() + k.cross(&v) * th.sin() + k * (k.dot(&v) * (1.0 - th.cos()))
    }

    const MIS: [[f64; 3]; 4] = [[0.01, -0.02, 0.005], [-0.03, 0.0, 0.04], [0.0, 0.0, -0.1], [0.12, 0.05, -0.07]];

    #[test]
    fn misaligned_momentum_is_the_rotated_nominal_and_the_jacobian_is_g_cross_h() {
        // Truth: Rodrigues' formula applied to the nominal pyramid (eq 6 preset), tol 1e-12.
        let nom = CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1.0, None);
        let mis = nom.clone().misaligned(&MIS);
        for i in 0..4 {
            let g = mis.gimbal_axis(i);
            assert!((g - rodrigues(MIS[i], nom.gimbal_axis(i))).norm() < 1e-12, "unit {i} gimbal axis");
            for k in 0..73 {
                let d = -3.3 + 0.091 * k as f64;
                let h = mis.unit_momentum(i, d);
                let truth = rodrigues(MIS[i], nom.unit_momentum(i, d));
                assert!((h - truth).norm() < 1e-12, "unit {i} δ {d}: {h} vs {truth}");
                let col = mis.jacobian_column(i, d);
                assert!(col.dot(&g).abs() < 1e-12, "unit {i} δ {d}: column not ⟂ gimbal axis");
                assert!((col - g.cross(&h)).norm() < 1e-12, "unit {i} δ {d}: column ≠ g × h");
                assert!((h.norm() - 0.623).abs() < 1e-12);
            }
        }
        // The RK4 hot path agrees with the per-unit functions.
        let mut d = [0.0; MAX_GIMBALS];
        let mut r = [0.0; MAX_GIMBALS];
        d[..4].copy_from_slice(&[0.4, -1.3, 2.2, 0.9]);
        r[..4].copy_from_slice(&[0.1, 0.7, -0.3, 0.2]);
        let (h, hd) = mis.momentum_and_rate(&d, &r);
        assert!((h - mis.momentum(&d)).norm() < 1e-14 && (hd - mis.momentum_rate(&d, &r)).norm() < 1e-14);
    }

    #[test]
    fn a_rotation_about_the_gimbal_axis_is_a_gimbal_angle_offset() {
        // Closed form: rotating the frame by a about g gives h(δ) = h_nom(δ + a), tol 1e-12.
        let nom = CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1.0, None);
        let a = 0.3f64.to_radians();
        let rv: Vec<[f64; 3]> = (0..4).map(|i| (nom.gimbal_axis(i) * (a * (i as f64 + 1.0))).into()).collect();
        let mis = nom.clone().misaligned(&rv);
        for i in 0..4 {
            let off = a * (i as f64 + 1.0);
            assert!((mis.gimbal_axis(i) - nom.gimbal_axis(i)).norm() < 1e-12);
            for k in 0..50 {
                let d = -3.0 + 0.12 * k as f64;
                assert!((mis.unit_momentum(i, d) - nom.unit_momentum(i, d + off)).norm() < 1e-12, "unit {i} δ {d}");
                assert!((mis.jacobian_column(i, d) - nom.jacobian_column(i, d + off)).norm() < 1e-12);
            }
        }
    }

    #[test]
    fn zero_misalignment_leaves_the_cluster_bit_identical() {
        let nom = CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1.0, None);
        assert_eq!(nom.clone().misaligned(&[[0.0; 3]; 4]), nom);
        assert_eq!(nom.clone().misaligned(&[]), nom);
    }

    #[test]
    fn servo_lag_reaches_the_command_exponentially_and_friction_leaves_a_deficit() {
        // δ̈ = (c - δ̇)/τ: after one τ the rate is (1 - 1/e) of a step command.
        let s = GimbalServo { time_constant_s: 0.05, gimbal_inertia_kgm2: 1e-3, friction_nm: 0.0 };
        let (mut r, dt) = (0.0, 1e-5);
        for _ in 0..5000 {
            r += dt * s.accel(0.5, r);
        }
        assert!((r / 0.5 - (1.0 - (-1.0f64).exp())).abs() < 1e-4, "{r}");
        // With friction the steady rate falls short by τ T_f / I_g.
        let f = GimbalServo { friction_nm: 2e-3, ..s };
        let mut r = 0.0;
        for _ in 0..200_000 {
            r += dt * f.accel(0.5, r);
        }
        assert!((r - (0.5 - 0.05 * 2e-3 / 1e-3)).abs() < 1e-6, "{r}");
    }

    #[test]
    fn scaled_momentum_rate_is_the_derivative_of_the_scaled_momentum() {
        // Truth: the central difference of h(δ + δ̇ t, s + ṡ t) at t = 0, tol 1e-9; the
        // two summation orders agree to round-off; with scales 1 and rates 0 they are the
        // unscaled functions to the bit.
        let c = CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1.0, None);
        let (mut d, mut r, mut sc, mut sr) =
            ([0.0; MAX_GIMBALS], [0.0; MAX_GIMBALS], [1.0; MAX_GIMBALS], [0.0; MAX_GIMBALS]);
        d[..4].copy_from_slice(&[0.4, -1.3, 2.2, 0.9]);
        r[..4].copy_from_slice(&[0.1, 0.7, -0.3, 0.2]);
        assert_eq!(c.momentum_rate_scaled(&d, &r, &sc, &sr), c.momentum_rate(&d, &r));
        assert_eq!(c.momentum_and_rate_scaled(&d, &r, &sc, &sr), c.momentum_and_rate(&d, &r));
        assert_eq!(c.momentum_scaled(&d, &sc), c.momentum(&d));
        sc[..4].copy_from_slice(&[0.9, 0.5, 1.0, 0.2]);
        sr[..4].copy_from_slice(&[-0.09, -0.1, 0.0, -0.02]);
        let at = |t: f64| {
            let (mut dt, mut st) = (d, sc);
            for i in 0..4 {
                dt[i] += r[i] * t;
                st[i] += sr[i] * t;
            }
            c.momentum_scaled(&dt, &st)
        };
        let e = 1e-5;
        let fd = (at(e) - at(-e)) / (2.0 * e);
        let (_, hd) = c.momentum_and_rate_scaled(&d, &r, &sc, &sr);
        assert!((hd - fd).norm() < 1e-9, "{hd} vs {fd}");
        assert!((c.momentum_rate_scaled(&d, &r, &sc, &sr) - hd).norm() < 1e-15);
    }

    #[test]
    fn servo_limits() {
        let c = CmgCluster::pyramid(1.0, 1.0, 0.5, Some((-1.0, 1.0)));
        assert_eq!(c.applied_rate(2.0, 0.0), 0.5);
        assert_eq!(c.applied_rate(f64::NAN, 0.0), 0.0);
        assert_eq!(c.applied_rate(0.3, 1.0), 0.0);
        assert_eq!(c.applied_rate(-0.3, 1.0), -0.3);
    }
}
