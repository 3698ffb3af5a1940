//! Steering laws of the CMG pyramid (paper 000 eqs 11-14, GSR): gimbal rates for a body
//! torque, on the cluster's effectiveness ([`crate::allocation::effectiveness::cmg`]).
//! The steering asks for `ḣ = -u - ω × h` and solves `J δ̇ = ḣ`:
//! - Moore-Penrose `δ̇ = Jᵀ (J Jᵀ)⁻¹ ḣ`;
//! - singularity-robust `δ̇ = Jᵀ (J Jᵀ + α I)⁻¹ ḣ` (eq 11) with α from eqs 12-14;
//! - generalized SR `δ̇ = Jᵀ (J Jᵀ + λ E(t))⁻¹ ḣ` with a rotating off-diagonal dither E
//!   (Wie 2005, paper 002), which escapes internal elliptic singularities;
//! - optional null motion `k (I - J⁺J)(δ_pref - δ)` towards preferred gimbal angles (no
//!   body torque), and a check for the momentum-envelope (saturation) singularity: at a
//!   singular set with singular direction u, all unit momenta on the same side of u
//!   (`sign(h_i·u)` equal) means the cluster is saturated, not internally singular.

use super::effectiveness::cmg::{CmgPyramid, GimbalTrig};
use crate::math::f32m::{exp, sin_cos};
use crate::math::{Mat3, Vec3};
use crate::params::{AlphaSchedule, CmgParams, SteeringLaw, SteeringParams};
use crate::types::Status;

/// What a steering call produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SteeringOutput {
    pub gimbal_rate_rad_s: [f32; 4],
    /// `m = det(J₁ J₁ᵀ)`.
    pub singularity_measure: f32,
    /// α used (0 for Moore-Penrose).
    pub alpha: f32,
    /// RATE_SCALED, ANGLE_LIMITED, SINGULAR, MOMENTUM_SATURATION.
    pub status: Status,
}

/// Gimbal rate and angle limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GimbalLimits {
    pub max_rate_rad_s: f32,
    pub min_angle_rad: f32,
    pub max_angle_rad: f32,
    /// Bit i: unit i failed (column removed, rate locked at 0).
    pub failed_mask: u8,
}

impl From<&CmgParams> for GimbalLimits {
    fn from(p: &CmgParams) -> Self {
        Self {
            max_rate_rad_s: p.max_gimbal_rate_rad_s,
            min_angle_rad: p.gimbal_min_rad,
            max_angle_rad: p.gimbal_max_rad,
            failed_mask: p.failed_mask,
        }
    }
}

/// Solve for gimbal rates that produce body torque `torque_nm` at body rate `ω`.
/// `time_s` drives the GSR dither (any clock; only its phase matters).
#[allow(clippy::too_many_arguments)]
pub fn steer(
    pyramid: &CmgPyramid,
    p: &SteeringParams,
    limits: &GimbalLimits,
    t: &GimbalTrig,
    delta_rad: &[f32; 4],
    rate_rad_s: &Vec3,
    torque_nm: &Vec3,
    dt_s: f32,
    time_s: f32,
) -> SteeringOutput {
    let mut j1 = pyramid.unit_jacobian(t);
    for i in 0..4 {
        if limits.failed_mask & (1 << i) != 0 {
            j1.set_column(i, &Vec3::zeros());
        }
    }
    let jjt: Mat3 = j1 * j1.transpose();
    let m = jjt.determinant();
    // Momentum-rate demand in unit-momentum terms: J₁ δ̇ = ḣ / h0.
    let hdot = (-torque_nm - rate_rad_s.cross(&pyramid.momentum(t))) / pyramid.h0_nms;
    let mut st = Status::empty();
    let (alpha, weight) = match &p.law {
        SteeringLaw::MoorePenrose => (0.0, Mat3::identity()),
        SteeringLaw::SingularityRobust(s) => (alpha_of(s, m), Mat3::identity()),
        SteeringLaw::GeneralizedSr { lambda0, mu, eps0, omega_rad_s } => {
            // ε_i = ε0 sin(ωt + φ_i), φ = 0, π/2, π: sin, cos, −sin of one phase. Past
            // the f32 reduction range (|ωt| > 2^16 rad) sin_cos is NaN: the dither
            // then stops (plain SR weight) rather than poisoning the inverse.
            let (s, c) = sin_cos(omega_rad_s * time_s);
            let (s, c) = if s.is_nan() { (0.0, 0.0) } else { (s, c) };
            let e1 = eps0 * s;
            let e2 = eps0 * c;
            let e3 = -(eps0 * s);
            #[rustfmt::skip]
            let e = Mat3::new(
                1.0, e3, e2,
                e3, 1.0, e1,
                e2, e1, 1.0,
            );
            (lambda0 * exp(-mu * m), e)
        }
    };
    let a = jjt + weight * alpha;
    let mut rates = match (m >= p.singular_threshold || alpha > 0.0, a.try_inverse()) {
        (true, Some(inv)) => j1.transpose() * (inv * hdot),
        _ => {
            st |= Status::SINGULAR;
            nalgebra::Vector4::zeros()
        }
    };
    // Null motion (only where the Moore-Penrose projector is well defined).
    if p.null_gain_per_s > 0.0
        && m >= p.singular_threshold
        && let Some(inv) = jjt.try_inverse()
    {
        let d = nalgebra::Vector4::from(*delta_rad);
        let e = nalgebra::Vector4::from(p.preferred_gimbal_rad) - d;
        let proj = e - j1.transpose() * (inv * (j1 * e));
        rates += proj * p.null_gain_per_s;
    }
    if m < p.saturation_check_m && pyramid.at_momentum_envelope(t, &jjt) {
        st |= Status::MOMENTUM_SATURATION;
    }
    let mut r: [f32; 4] = rates.into();
    if !r.iter().all(|x| x.is_finite()) {
        st |= Status::SINGULAR;
        r = [0.0; 4];
    }
    for (i, x) in r.iter_mut().enumerate() {
        if limits.failed_mask & (1 << i) != 0 {
            *x = 0.0;
        }
    }
    st |= limit_rates(&mut r, delta_rad, limits, dt_s);
    SteeringOutput { gimbal_rate_rad_s: r, singularity_measure: m, alpha, status: st }
}

/// α from the schedule (paper 000 eqs 12-14).
pub fn alpha_of(s: &AlphaSchedule, m: f32) -> f32 {
    match *s {
        AlphaSchedule::Quadratic { a0, m0, m_cr } => {
            if m >= m_cr {
                0.0
            } else {
                let r = 1.0 - m / m0;
                a0 * r * r
            }
        }
        AlphaSchedule::Inverse { a0, m_cr, a_max } => {
            if m >= m_cr {
                0.0
            } else if m > a0 / a_max {
                a0 / m
            } else {
                a_max
            }
        }
        AlphaSchedule::Exponential { a0, mu } => a0 * exp(-mu * m),
    }
}

/// Enforce the rate limit by scaling the whole vector (direction kept), then stop any
/// gimbal that would cross its angle limit within `dt`. Returns status bits.
pub fn limit_rates(r: &mut [f32; 4], delta_rad: &[f32; 4], l: &GimbalLimits, dt_s: f32) -> Status {
    let mut st = Status::empty();
    if crate::math::scale_to_peak(r, l.max_rate_rad_s) {
        st |= Status::RATE_SCALED;
    }
    for (x, d) in r.iter_mut().zip(delta_rad.iter()) {
        let next = d + *x * dt_s;
        if next > l.max_angle_rad && *x > 0.0 {
            *x = ((l.max_angle_rad - d) / dt_s).max(0.0);
            st |= Status::ANGLE_LIMITED;
        } else if next < l.min_angle_rad && *x < 0.0 {
            *x = ((l.min_angle_rad - d) / dt_s).min(0.0);
            st |= Status::ANGLE_LIMITED;
        }
    }
    st
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::allocation::effectiveness::cmg::GimbalTrig;
    use nalgebra::Vector4;

    const BETA: f32 = 0.955_233_9; // 54.73 deg

    fn deg4(d: [f32; 4]) -> [f32; 4] {
        d.map(|x| x.to_radians())
    }

    fn sp(law: SteeringLaw) -> SteeringParams {
        SteeringParams {
            law,
            singular_threshold: 1e-6,
            null_gain_per_s: 0.0,
            preferred_gimbal_rad: [0.0; 4],
            saturation_check_m: 0.05,
        }
    }

    fn lim() -> GimbalLimits {
        GimbalLimits { max_rate_rad_s: 10.0, min_angle_rad: -1e3, max_angle_rad: 1e3, failed_mask: 0 }
    }

    #[test]
    fn sr_tends_to_mp_as_alpha_goes_to_zero() {
        let p = CmgPyramid::new(BETA, 0.623);
        let d = [0.3f32, -0.4, 0.8, 0.1];
        let t = GimbalTrig::new(&d);
        let w = Vec3::new(0.01, -0.02, 0.03);
        let u = Vec3::new(0.05, -0.02, 0.08);
        let mp = steer(&p, &sp(SteeringLaw::MoorePenrose), &lim(), &t, &d, &w, &u, 0.01, 0.0);
        assert_eq!(mp.status, Status::empty());
        // MP realises the torque exactly (away from singularities).
        let got = p.torque_on_body(&t, &w, &mp.gimbal_rate_rad_s);
        assert!((got - u).norm() < 1e-5 * u.norm().max(1.0), "{got:?}");
        let mut prev = f32::INFINITY;
        let mut ratio = 0.0;
        for a0 in [1e-1f32, 1e-2, 1e-3, 1e-4] {
            let law = SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0, mu: 0.0 });
            let sr = steer(&p, &sp(law), &lim(), &t, &d, &w, &u, 0.01, 0.0);
            let diff: f32 =
                sr.gimbal_rate_rad_s.iter().zip(mp.gimbal_rate_rad_s.iter()).map(|(a, b)| (a - b).abs()).sum();
            assert!(diff < prev, "difference shrinks with alpha");
            ratio = diff / prev;
            prev = diff;
        }
        let scale: f32 = mp.gimbal_rate_rad_s.iter().map(|x| x.abs()).sum();
        // SR - MP = O(α): a tenfold smaller α gives a tenfold smaller difference.
        assert!((0.08..0.12).contains(&ratio), "convergence ratio {ratio}");
        assert!(prev < 5e-3 * scale, "relative difference {} at alpha 1e-4", prev / scale);
    }

    #[test]
    fn elliptic_singularity_mp_is_safe_and_sr_is_stuck() {
        // δ = (90, 0, -90, 0) deg: every column of J has zero x component, torque along x
        // is unreachable; J Jᵀ is singular.
        let p = CmgPyramid::new(BETA, 0.623);
        let d = deg4([90.0, 0.0, -90.0, 0.0]);
        let t = GimbalTrig::new(&d);
        let j = p.unit_jacobian(&t);
        assert!((j * j.transpose()).determinant().abs() < 1e-6);
        let u = Vec3::new(0.1, 0.0, 0.0);
        let mp = steer(&p, &sp(SteeringLaw::MoorePenrose), &lim(), &t, &d, &Vec3::zeros(), &u, 0.01, 0.0);
        assert!(mp.gimbal_rate_rad_s.iter().all(|x| x.is_finite()));
        assert!(mp.status.contains(Status::SINGULAR));
        let law = SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0: 0.01, mu: 10.0 });
        let sr = steer(&p, &sp(law), &lim(), &t, &d, &Vec3::zeros(), &u, 0.01, 0.0);
        let peak = sr.gimbal_rate_rad_s.iter().fold(0.0f32, |a, x| a.max(x.abs()));
        assert!(peak < 1e-4, "SR is stuck at the elliptic singularity: {peak}");
        assert!(sr.alpha > 0.0);
    }

    #[test]
    fn rate_limit_scaling_keeps_direction() {
        let mut r = [0.4f32, -2.0, 1.0, 0.1];
        let orig = Vector4::from(r);
        let l = GimbalLimits { max_rate_rad_s: 0.5, ..lim() };
        let st = limit_rates(&mut r, &[0.0; 4], &l, 0.01);
        assert!(st.contains(Status::RATE_SCALED));
        let v = Vector4::from(r);
        assert!((v.amax() - 0.5).abs() < 1e-6);
        assert!((v.normalize().dot(&orig.normalize()) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn angle_limit_stops_the_gimbal_at_the_stop() {
        let mut r = [1.0f32, -1.0, 0.0, 0.0];
        let l = GimbalLimits { max_rate_rad_s: 10.0, min_angle_rad: -0.5, max_angle_rad: 0.5, failed_mask: 0 };
        let st = limit_rates(&mut r, &[0.495, -0.5, 0.0, 0.0], &l, 0.01);
        assert!(st.contains(Status::ANGLE_LIMITED));
        assert!((0.495 + r[0] * 0.01 - 0.5).abs() < 1e-6);
        assert_eq!(r[1], 0.0);
    }

    /// Gimbal kinematics only (body held): integrate δ under the steering law; returns the
    /// first time the realised torque delivers half of the x demand (None: never).
    fn time_to_deliver(p: &CmgPyramid, law: SteeringLaw, start: [f32; 4], u: Vec3, seconds: f32) -> Option<f32> {
        let (mut d, dt) = (start, 0.01f32);
        for k in 0..(seconds / dt) as usize {
            let t = GimbalTrig::new(&d);
            let out = steer(p, &sp(law), &lim(), &t, &d, &Vec3::zeros(), &u, dt, k as f32 * dt);
            let got = p.torque_on_body(&t, &Vec3::zeros(), &out.gimbal_rate_rad_s);
            if got.x / u.x > 0.5 {
                return Some(k as f32 * dt);
            }
            for (x, r) in d.iter_mut().zip(out.gimbal_rate_rad_s) {
                *x += r * dt;
            }
        }
        None
    }

    #[test]
    fn gsr_leaves_the_elliptic_singularity_where_sr_is_stuck() {
        // Wie's parameters: λ0 = 0.01, μ = 10, ε0 = 0.01, ω = π/2 rad/s (dither period 4 s);
        // a demand of 0.5 N m along x (≈ 0.8 h0 per second), unreachable at the singularity.
        let p = CmgPyramid::new(BETA, 0.623);
        let start = deg4([90.0, 0.0, -90.0, 0.0]);
        let u = Vec3::new(0.5, 0.0, 0.0);
        let omega = core::f32::consts::FRAC_PI_2;
        let sr = SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0: 0.01, mu: 10.0 });
        let gsr = SteeringLaw::GeneralizedSr { lambda0: 0.01, mu: 10.0, eps0: 0.01, omega_rad_s: omega };
        assert_eq!(time_to_deliver(&p, sr, start, u, 8.0), None, "SR stays stuck");
        let t = time_to_deliver(&p, gsr, start, u, 8.0).expect("GSR escapes");
        std::eprintln!("GSR delivers half the x torque after {t:.2} s (dither period 4 s)");
        assert!(t < 4.0, "within one dither period: {t}");
    }

    #[test]
    fn null_motion_moves_gimbals_without_body_torque() {
        let p = CmgPyramid::new(BETA, 0.623);
        let d = [0.3f32, -0.4, 0.8, 0.1];
        let t = GimbalTrig::new(&d);
        let u = Vec3::new(0.02, -0.01, 0.03);
        let mut with = sp(SteeringLaw::MoorePenrose);
        with.null_gain_per_s = 0.5;
        let a = steer(&p, &sp(SteeringLaw::MoorePenrose), &lim(), &t, &d, &Vec3::zeros(), &u, 0.01, 0.0);
        let b = steer(&p, &with, &lim(), &t, &d, &Vec3::zeros(), &u, 0.01, 0.0);
        let diff: f32 = a.gimbal_rate_rad_s.iter().zip(b.gimbal_rate_rad_s.iter()).map(|(x, y)| (x - y).abs()).sum();
        assert!(diff > 1e-2, "null motion is active");
        let ta = p.torque_on_body(&t, &Vec3::zeros(), &a.gimbal_rate_rad_s);
        let tb = p.torque_on_body(&t, &Vec3::zeros(), &b.gimbal_rate_rad_s);
        assert!((ta - tb).norm() < 1e-5 * u.norm() * 10.0, "{ta:?} vs {tb:?}");
        // It drives δ towards the preferred angles (0): the null part opposes δ.
        let null: [f32; 4] = core::array::from_fn(|i| b.gimbal_rate_rad_s[i] - a.gimbal_rate_rad_s[i]);
        assert!(null.iter().zip(d.iter()).map(|(n, x)| n * x).sum::<f32>() < 0.0);
    }

    #[test]
    fn saturation_singularity_is_told_apart_from_the_internal_one() {
        let p = CmgPyramid::new(BETA, 0.623);
        let check = |deg: [f32; 4]| {
            let t = GimbalTrig::new(&deg4(deg));
            let j = p.unit_jacobian(&t);
            p.at_momentum_envelope(&t, &(j * j.transpose()))
        };
        // All gimbals at 90°: every rotor tilts to +z, h = 4 h0 sin β ẑ, the envelope.
        assert!(check([90.0, 90.0, 90.0, 90.0]));
        // The elliptic internal singularity is not the envelope.
        assert!(!check([90.0, 0.0, -90.0, 0.0]));
        let out = steer(
            &p,
            &sp(SteeringLaw::MoorePenrose),
            &lim(),
            &GimbalTrig::new(&deg4([90.0; 4])),
            &deg4([90.0; 4]),
            &Vec3::zeros(),
            &Vec3::new(0.0, 0.0, -0.1),
            0.01,
            0.0,
        );
        assert!(out.status.contains(Status::MOMENTUM_SATURATION));
    }

    #[test]
    fn a_failed_cmg_is_locked_and_the_other_three_still_realise_the_torque() {
        let p = CmgPyramid::new(BETA, 0.623);
        let d = [0.3f32, -0.4, 0.8, 0.1];
        let t = GimbalTrig::new(&d);
        let u = Vec3::new(0.02, -0.01, 0.03);
        let l = GimbalLimits { failed_mask: 0b0100, ..lim() };
        let out = steer(&p, &sp(SteeringLaw::MoorePenrose), &l, &t, &d, &Vec3::zeros(), &u, 0.01, 0.0);
        assert_eq!(out.gimbal_rate_rad_s[2], 0.0);
        let got = p.torque_on_body(&t, &Vec3::zeros(), &out.gimbal_rate_rad_s);
        assert!((got - u).norm() < 1e-4 * u.norm() * 10.0, "{got:?}");
    }

    #[test]
    fn alpha_schedules_follow_eqs_12_to_14() {
        let q = AlphaSchedule::Quadratic { a0: 0.1, m0: 0.5, m_cr: 0.3 };
        assert_eq!(alpha_of(&q, 0.4), 0.0);
        assert!((alpha_of(&q, 0.1) - 0.1 * 0.8f32.powi(2)).abs() < 1e-7);
        let i = AlphaSchedule::Inverse { a0: 1e-3, m_cr: 0.3, a_max: 0.05 };
        assert_eq!(alpha_of(&i, 0.5), 0.0);
        assert!((alpha_of(&i, 0.1) - 1e-2).abs() < 1e-7);
        assert_eq!(alpha_of(&i, 1e-4), 0.05);
        let e = AlphaSchedule::Exponential { a0: 0.01, mu: 10.0 };
        assert!((alpha_of(&e, 0.1) - 0.01 * (-1.0f32).exp()).abs() < 1e-8);
    }
}
