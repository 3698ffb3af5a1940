//! Reaction-wheel torque allocation (paper 001 eq 26, `T_cmd = C⁺ u`) with null-space
//! momentum management, saturation that keeps the torque direction, wheel failures and
//! wheels at their speed limit, on the array's effectiveness
//! ([`crate::allocation::effectiveness::wheels`]).
//!
//! Sign convention: `u[i]` is the torque the motor applies to wheel `i`'s rotor about
//! its spin axis `a_i`; the body receives `-Σ a_i u_i` (paper 001 eq 5). For a body
//! demand `T`: `u = -C⁺ T + u_null`, `C = [a_1 … a_n]`, `C⁺ = Cᵀ (C Cᵀ)⁻¹` over the
//! healthy, unsaturated wheels, and
//! `u_null = -k J_w (I - C⁺ C)(Ω - Ω_bias)` drives the wheel speeds towards their bias
//! without any body torque (it lies in the null space of C).
//!
//! Wheels that are failed or would be pushed beyond their speed limit are removed from
//! `C` and the pseudo-inverse recomputed (at most `MAX_WHEELS` passes), so three healthy
//! wheels in general position still give full three-axis torque. Finally the whole
//! command is scaled so that `|u_i| <= max_torque` (direction of the body torque kept).

use super::effectiveness::wheels::{axes_gram, spans_three_axes, torque_on_body_nm};
use super::{AllocResult, AllocStatus};
use crate::math::{Mat3, Vec3};
use crate::params::WheelParams;
use crate::types::MAX_WHEELS;

/// Allocate the body torque demand `torque_nm` to the wheels.
/// `speed_rad_s`: measured wheel speeds relative to the body.
/// Kept out of line: inlined into the family dispatch it enlarges the frame of every
/// family's step (the CMG step measured +200 instructions on the Cortex-M4F).
#[inline(never)]
pub fn allocate(p: &WheelParams, speed_rad_s: &[f32; MAX_WHEELS], torque_nm: &Vec3) -> AllocResult<MAX_WHEELS> {
    let n = (p.count as usize).min(MAX_WHEELS);
    let mut r = AllocResult::<MAX_WHEELS>::nothing_realised(torque_nm);
    if !torque_nm.iter().all(|x| x.is_finite()) || !speed_rad_s.iter().take(n).all(|x| x.is_finite()) {
        r.outcome.status = AllocStatus::NonFinite;
        return r;
    }
    // n <= MAX_WHEELS < 32: the shift cannot overflow (a full mask otherwise).
    let all = 1u32.checked_shl(u32::try_from(n).unwrap_or(u32::MAX)).map_or(u32::MAX, |b| b.wrapping_sub(1));
    let mut active: u32 = all & !u32::from(p.failed_mask);
    let mut u = [0.0f32; MAX_WHEELS];
    let mut status = AllocStatus::Ok;
    // Bounded: each pass removes at least one wheel or ends.
    for pass in 0..=MAX_WHEELS {
        r.outcome.iterations = u16::try_from(pass).unwrap_or(u16::MAX).saturating_add(1);
        let m = axes_gram(p, n, active);
        let scale = (m.trace() / 3.0).max(1e-30);
        let singular = !spans_three_axes(&m);
        // Damped inverse when the healthy wheels do not span 3 axes (best effort).
        let inv = if singular { (m + Mat3::identity() * (1e-3 * scale)).try_inverse() } else { m.try_inverse() };
        let Some(inv) = inv else {
            status = AllocStatus::Singular;
            u = [0.0; MAX_WHEELS];
            break;
        };
        status = if singular { AllocStatus::Singular } else { AllocStatus::Ok };
        let w = inv * torque_nm;
        // Null-space term: projection of the speed error onto the null space of C.
        let mut e = [0.0f32; MAX_WHEELS];
        let mut ce = Vec3::zeros();
        let errors = e.iter_mut().zip(speed_rad_s.iter().zip(p.bias_speed_rad_s.iter()));
        for (i, ((x, (speed, bias)), a)) in errors.zip(p.axes.iter()).enumerate().take(n) {
            if active & (1 << i) != 0 {
                let err = speed - bias;
                *x = err;
                ce += Vec3::from(*a) * err;
            }
        }
        let back = inv * ce;
        let mut newly_blocked = 0u32;
        let wheels = u.iter_mut().zip(e.iter().zip(speed_rad_s.iter())).zip(p.axes.iter());
        for (i, ((ui, (ei, &speed)), a)) in wheels.enumerate().take(n) {
            if active & (1 << i) == 0 {
                *ui = 0.0;
                continue;
            }
            let a = Vec3::from(*a);
            let null = ei - a.dot(&back);
            *ui = -a.dot(&w) - p.null_gain_per_s * p.inertia_kgm2 * null;
            // A wheel at its speed limit cannot accelerate further in that direction.
            if libm::fabsf(speed) >= p.max_speed_rad_s && *ui * speed > 0.0 {
                newly_blocked |= 1 << i;
            }
        }
        if newly_blocked == 0 {
            break;
        }
        active &= !newly_blocked;
        r.outcome.unrealised |= newly_blocked;
    }
    limit_and_report(p, n, u, torque_nm, status, r)
}

/// Torque limit (everything scaled: body-torque direction kept, null part stays null),
/// then the realised torque, saturation and status of the commands `u`.
fn limit_and_report(
    p: &WheelParams,
    n: usize,
    mut u: [f32; MAX_WHEELS],
    torque_nm: &Vec3,
    status: AllocStatus,
    mut r: AllocResult<MAX_WHEELS>,
) -> AllocResult<MAX_WHEELS> {
    let peak = u.iter().fold(0.0f32, |a, x| a.max(libm::fabsf(*x)));
    let s = if peak > p.max_torque_nm { p.max_torque_nm / peak } else { 1.0 };
    for (i, ui) in u.iter_mut().enumerate().take(n) {
        *ui *= s;
        if *ui >= p.max_torque_nm * (1.0 - 1e-6) {
            r.outcome.sat_high |= 1 << i;
        } else if *ui <= -p.max_torque_nm * (1.0 - 1e-6) {
            r.outcome.sat_low |= 1 << i;
        }
    }
    let realised = torque_on_body_nm(p, n, &u);
    let short = torque_nm - realised;
    r.u = u;
    r.outcome.realised = realised.into();
    r.outcome.shortfall = short.into();
    let tn = torque_nm.norm_squared();
    r.outcome.lambda = crate::allocation::AllocOutcome::fraction_along(&realised, torque_nm);
    r.outcome.status = match status {
        AllocStatus::Ok if s < 1.0 || crate::math::norm(&short) > 1e-4 * crate::math::f32m::sqrt(tn) + 1e-9 => {
            AllocStatus::Scaled
        }
        other => other,
    };
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::WheelParams;

    fn pyramid() -> WheelParams {
        // Paper 001 eq 9 with α = 45°, β = 54.73°.
        let (a, b) = (45f32.to_radians(), 54.73f32.to_radians());
        let (ca, sa, cb, sb) = (a.cos(), a.sin(), b.cos(), b.sin());
        let mut axes = [[0.0; 3]; MAX_WHEELS];
        axes[0] = [ca * sb, sa * sb, cb];
        axes[1] = [-sa * sb, ca * sb, cb];
        axes[2] = [-ca * sb, -sa * sb, cb];
        axes[3] = [sa * sb, -ca * sb, cb];
        WheelParams {
            count: 4,
            axes,
            max_torque_nm: 0.75,
            max_speed_rad_s: 628.0,
            inertia_kgm2: 0.086,
            null_gain_per_s: 0.0,
            bias_speed_rad_s: [0.0; MAX_WHEELS],
            failed_mask: 0,
        }
    }

    #[test]
    fn unsaturated_demand_is_realised_exactly() {
        let r = allocate(&pyramid(), &[0.0; MAX_WHEELS], &Vec3::new(0.1, -0.2, 0.05));
        assert_eq!(r.status, AllocStatus::Ok);
        let d = Vec3::from(r.realised) - Vec3::new(0.1, -0.2, 0.05);
        assert!(d.norm() < 1e-6);
    }

    #[test]
    fn null_space_commands_do_not_change_body_torque() {
        let mut p = pyramid();
        let speeds = [100.0, -50.0, 30.0, 200.0, 0.0, 0.0];
        let t = Vec3::new(0.05, 0.02, -0.03);
        let base = allocate(&p, &speeds, &t);
        p.null_gain_per_s = 0.01;
        let with_null = allocate(&p, &speeds, &t);
        let diff: f32 = base.u.iter().zip(with_null.u.iter()).map(|(a, b)| (a - b).abs()).sum();
        assert!(diff > 1e-3, "the null term is active");
        let d = Vec3::from(with_null.realised) - Vec3::from(base.realised);
        assert!(d.norm() <= 1e-6 * t.norm(), "body torque changed by {}", d.norm());
        // It drives the speeds towards the bias: d/dt Σ (Ω_i - 0)² < 0 from the null part.
        let null: [f32; 4] = core::array::from_fn(|i| with_null.u[i] - base.u[i]);
        let dv: f32 = (0..4).map(|i| speeds[i] * null[i]).sum();
        assert!(dv < 0.0);
    }

    #[test]
    fn one_failed_wheel_still_gives_full_three_axis_torque() {
        for failed in 0..4 {
            let mut p = pyramid();
            p.failed_mask = 1 << failed;
            for t in [
                Vec3::new(0.1, 0.0, 0.0),
                Vec3::new(0.0, 0.1, 0.0),
                Vec3::new(0.0, 0.0, 0.1),
                Vec3::new(0.05, -0.07, 0.03),
            ] {
                let r = allocate(&p, &[0.0; MAX_WHEELS], &t);
                assert_eq!(r.u[failed], 0.0);
                assert!((Vec3::from(r.realised) - t).norm() < 1e-5, "wheel {failed} failed, demand {t:?}: {r:?}");
            }
        }
    }

    #[test]
    fn saturation_scales_and_keeps_the_direction() {
        let t = Vec3::new(2.0, -1.0, 3.0);
        let r = allocate(&pyramid(), &[0.0; MAX_WHEELS], &t);
        assert_eq!(r.status, AllocStatus::Scaled);
        assert!(r.u.iter().all(|x| x.abs() <= 0.75 + 1e-6));
        let got = Vec3::from(r.realised);
        assert!(got.normalize().dot(&t.normalize()) > 1.0 - 1e-6);
        assert!(r.sat_high | r.sat_low != 0);
    }

    #[test]
    fn wheel_at_speed_limit_is_removed_and_reported() {
        // Wheel 0 at +max speed; a demand that needs it to spin up further.
        let p = pyramid();
        let t = Vec3::new(-0.1, -0.1, -0.1); // body torque = -Σ a u → u0 > 0 for a0 ≈ (+,+,+)
        let mut speeds = [0.0; MAX_WHEELS];
        speeds[0] = 628.0;
        let r = allocate(&p, &speeds, &t);
        assert_eq!(r.u[0], 0.0);
        assert_ne!(r.unrealised & 1, 0);
        assert!((Vec3::from(r.realised) - t).norm() < 1e-5, "three wheels still realise it");
    }

    #[test]
    fn bad_input_is_refused() {
        let r = allocate(&pyramid(), &[f32::NAN; MAX_WHEELS], &Vec3::new(0.1, 0.0, 0.0));
        assert_eq!(r.status, AllocStatus::NonFinite);
        assert_eq!(r.u, [0.0; MAX_WHEELS]);
        let mut p = pyramid();
        p.failed_mask = 0b0111;
        let r = allocate(&p, &[0.0; MAX_WHEELS], &Vec3::new(0.1, 0.0, 0.0));
        assert_eq!(r.status, AllocStatus::Singular);
        assert!(r.u.iter().all(|x| x.is_finite()));
    }
}
