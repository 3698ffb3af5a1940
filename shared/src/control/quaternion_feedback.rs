//! Quaternion feedback (Wie; paper 000 eqs 15-18):
//!
//! `u = -K q_e,v - D (ω - ω_c) - Ki ∫ q_e,v dt [+ ω × (I ω + h)]`
//!
//! with `K = 2 ωn² I`, `D = 2 ζ ωn I` for the paper's tuning (the host builds K, D from
//! ζ, ωn; any matrices are accepted). Linearised per axis this is
//! `θ̈ + 2ζωn θ̇ + ωn² θ = 0` because `q_e,v ≈ θ/2`.
//!
//! Eigen-axis slew under a rate limit (Wie & Lu 1995): with `max_slew_rate_rad_s > 0`
//! the attitude term uses `q_e,v` scaled down (direction kept: the eigen-axis) to at most
//! `L = ω_max tr(D)/tr(K)`. When the limit is active the law reads `u = -K q_sat - D ω`,
//! whose equilibrium is a slew about the eigen-axis at `|ω| = ω_max`.
//!
//! The integral term (the "I" of the paper's PID) uses conditional integration: it is
//! frozen while the previous step saturated (torque limit, rate scaling, shortfall), and
//! each component is clamped to `± integral_limit_s`.

use super::scale_to_box;
use crate::math::{Mat3, Quat, Vec3, attitude_error, rotation_angle};
use crate::types::TorqueDemand;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuaternionFeedbackGains {
    pub k: Mat3,
    pub d: Mat3,
    pub ki: Mat3,
    pub integral_limit_s: f32,
    pub torque_limit_nm: Vec3,
    pub gyro_compensation: bool,
    pub max_slew_rate_rad_s: f32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuaternionFeedback {
    /// `∫ q_e,v dt`, s.
    pub integral: Vec3,
}

impl QuaternionFeedback {
    /// One update. `q`, `q_cmd`: unit quaternions; `rate_cmd_rad_s`: rate of the
    /// commanded frame in body axes (zero for inertial pointing); `feedforward_accel`:
    /// its angular acceleration, body axes, when fed forward; `h_act_nms`: actuator
    /// momentum in body axes (gyroscopic compensation); `saturated_last`: anti-windup.
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        g: &QuaternionFeedbackGains,
        inertia: &Mat3,
        q: &Quat,
        q_cmd: &Quat,
        rate_rad_s: &Vec3,
        rate_cmd_rad_s: &Vec3,
        feedforward_accel: Option<&Vec3>,
        h_act_nms: &Vec3,
        dt_s: f32,
        saturated_last: bool,
    ) -> TorqueDemand {
        let e = attitude_error(q, q_cmd);
        let ev = e.imag();
        if !saturated_last {
            let lim = g.integral_limit_s;
            self.integral = (self.integral + ev * dt_s).map(|x| crate::math::clamp_abs(x, lim));
        }
        let ev_sat = if g.max_slew_rate_rad_s > 0.0 {
            let (tk, td) = (g.k.trace(), g.d.trace());
            let limit = if tk > 0.0 { g.max_slew_rate_rad_s * td / tk } else { f32::INFINITY };
            let n = crate::math::norm(&ev);
            if n > limit { ev * (limit / n) } else { ev }
        } else {
            ev
        };
        let mut u = -(g.k * ev_sat) - g.d * (rate_rad_s - rate_cmd_rad_s) - g.ki * self.integral;
        if g.gyro_compensation {
            u += rate_rad_s.cross(&(inertia * rate_rad_s + h_act_nms));
        }
        if let Some(accel_cmd) = feedforward_accel {
            // Tracking feed-forward (Wie 2008 §7.3): the body-axes derivative of the
            // commanded rate `C ω_r` is `C ω̇_r − ω × C ω_r`; supplying `J` times it leaves
            // the feedback only the errors.
            u += inertia * (accel_cmd - rate_rad_s.cross(rate_cmd_rad_s));
        }
        let (torque_nm, limited) = scale_to_box(&u, &g.torque_limit_nm);
        TorqueDemand { torque_nm, limited, error_angle_rad: rotation_angle(&e) }
    }

    pub fn reset(&mut self) {
        self.integral = Vec3::zeros();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler};

    fn gains(inertia: &Mat3, zeta: f32, wn: f32) -> QuaternionFeedbackGains {
        QuaternionFeedbackGains {
            k: inertia * (2.0 * wn * wn),
            d: inertia * (2.0 * zeta * wn),
            ki: Mat3::zeros(),
            integral_limit_s: 0.0,
            torque_limit_nm: Vec3::repeat(1e3),
            gyro_compensation: false,
            max_slew_rate_rad_s: 0.0,
        }
    }

    /// One 10 ms update towards the identity attitude, at rest, nothing fed forward.
    fn hold_identity(
        c: &mut QuaternionFeedback,
        g: &QuaternionFeedbackGains,
        inertia: &Mat3,
        q: &Quat,
        saturated_last: bool,
    ) -> TorqueDemand {
        let zero = Vec3::zeros();
        c.update(g, inertia, q, &Quat::identity(), &zero, &zero, None, &zero, 0.01, saturated_last)
    }

    #[test]
    fn small_angle_law_is_the_second_order_system() {
        // For a small yaw error θ the demand must be -I (ωn² θ + 2 ζ ωn θ̇) (eq 18, small angle).
        let inertia = Mat3::from_diagonal(&Vec3::new(3.1, 3.1, 5.8));
        let (zeta, wn) = (0.47, 0.7);
        let g = gains(&inertia, zeta, wn);
        let theta = 1e-3f32;
        let rate = Vec3::new(0.0, 0.0, 2e-3);
        let q = quat_from_euler([0.0, 0.0, theta], EulerSeq::Zyx321);
        let mut c = QuaternionFeedback::default();
        let d = c.update(&g, &inertia, &q, &Quat::identity(), &rate, &Vec3::zeros(), None, &Vec3::zeros(), 0.01, false);
        let expect = -5.8 * (wn * wn * theta + 2.0 * zeta * wn * 2e-3);
        // Tracking a frame that turns at the measured rate removes the damping term.
        let mut c2 = QuaternionFeedback::default();
        let d2 = c2.update(&g, &inertia, &q, &Quat::identity(), &rate, &rate, None, &Vec3::zeros(), 0.01, false);
        assert!((d2.torque_nm.z + 5.8 * wn * wn * theta).abs() < 1e-4 * 5.8 * wn * wn * theta);
        assert!((d.torque_nm.z - expect).abs() < 1e-4 * expect.abs(), "{} vs {}", d.torque_nm.z, expect);
        assert!(d.torque_nm.x.abs() < 1e-9 && d.torque_nm.y.abs() < 1e-9);
    }

    #[test]
    fn torque_limit_keeps_direction() {
        let inertia = Mat3::identity();
        let mut g = gains(&inertia, 0.9, 1.1);
        g.torque_limit_nm = Vec3::new(0.1, 0.1, 0.1);
        let q = quat_from_euler([0.3, -0.6, 1.0], EulerSeq::Zyx321);
        let mut c = QuaternionFeedback::default();
        let free = {
            let mut g2 = g;
            g2.torque_limit_nm = Vec3::repeat(1e3);
            hold_identity(&mut c, &g2, &inertia, &q, false)
        };
        let lim = hold_identity(&mut c, &g, &inertia, &q, false);
        assert!(lim.limited);
        assert!(lim.torque_nm.amax() <= 0.1 + 1e-7);
        let cos = lim.torque_nm.normalize().dot(&free.torque_nm.normalize());
        assert!(cos > 1.0 - 1e-6);
    }

    #[test]
    fn rate_limited_slew_settles_on_the_eigen_axis_at_the_limit() {
        // Integrate I ω̇ = u for a 150° slew about a skew axis: with the rate limit the body
        // rate plateaus at ω_max about the eigen-axis.
        let inertia = Mat3::from_diagonal(&Vec3::new(3.0, 4.0, 5.0));
        let mut g = gains(&inertia, 0.9, 0.8);
        g.max_slew_rate_rad_s = 0.05;
        let axis = Vec3::new(1.0, 2.0, -1.0).normalize();
        let q_cmd = Quat::from_parts((75f32.to_radians()).cos(), axis * (75f32.to_radians()).sin());
        let (mut q, mut w, dt) = (Quat::identity(), Vec3::zeros(), 0.01f32);
        let mut c = QuaternionFeedback::default();
        let mut peak = 0.0f32;
        for _ in 0..20_000 {
            let d = c.update(&g, &inertia, &q, &q_cmd, &w, &Vec3::zeros(), None, &Vec3::zeros(), dt, false);
            w += inertia.try_inverse().unwrap() * (d.torque_nm - w.cross(&(inertia * w))) * dt;
            q = (q + q * Quat::from_imag(w) * (0.5 * dt)).normalize();
            peak = peak.max(w.norm());
            if d.error_angle_rad > 60f32.to_radians() && d.error_angle_rad < 120f32.to_radians() {
                // Mid-slew: rotating about the eigen-axis (body axes = reference axes here
                // up to the small turn already made, so compare directions loosely).
                assert!(w.normalize().dot(&axis) > 0.95, "{w:?}");
            }
        }
        assert!(peak < 0.05 * 1.1, "peak rate {peak}");
        assert!(peak > 0.05 * 0.9, "the limit is reached: {peak}");
        assert!(crate::math::rotation_angle(&crate::math::attitude_error(&q, &q_cmd)) < 1e-2);
    }

    #[test]
    fn integral_is_clamped_and_frozen_when_saturated() {
        let inertia = Mat3::identity();
        let mut g = gains(&inertia, 0.9, 1.1);
        g.ki = Mat3::identity() * 0.1;
        g.integral_limit_s = 0.05;
        let q = quat_from_euler([0.0, 0.0, 0.5], EulerSeq::Zyx321);
        let mut c = QuaternionFeedback::default();
        for _ in 0..1000 {
            hold_identity(&mut c, &g, &inertia, &q, false);
        }
        assert!((c.integral.z - 0.05).abs() < 1e-7, "clamped at the limit");
        let before = c.integral;
        let q2 = quat_from_euler([0.0, 0.0, -0.5], EulerSeq::Zyx321);
        hold_identity(&mut c, &g, &inertia, &q2, true);
        assert_eq!(c.integral, before, "frozen while saturated");
    }

    #[test]
    fn a_nan_or_negative_integral_limit_never_panics_and_holds_the_integral_at_zero() {
        // `f32::clamp` panics on such bounds; the law must not (it runs in the control step).
        let inertia = Mat3::identity();
        let q = quat_from_euler([0.0, 0.0, 0.5], EulerSeq::Zyx321);
        for lim in [f32::NAN, -1.0, f32::NEG_INFINITY] {
            let mut g = gains(&inertia, 0.9, 1.1);
            g.ki = Mat3::identity() * 0.1;
            g.integral_limit_s = lim;
            let mut c = QuaternionFeedback::default();
            let d = hold_identity(&mut c, &g, &inertia, &q, false);
            assert_eq!(c.integral, Vec3::zeros(), "limit {lim}");
            assert!(d.torque_nm.iter().all(|x| x.is_finite()), "limit {lim}");
        }
    }
}
