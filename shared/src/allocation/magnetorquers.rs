//! Magnetorquer dipole law (paper 003): the torque `T = M × B` (eq 18) can only be
//! perpendicular to B, so the dipole is chosen as
//! `M = (B × T) / |B|²` (eq 22, written there as `-T × B / |B|²`), which realises the
//! component of T perpendicular to B. Eq 21 (`M = M̄ × B / |B|`) is the same law with
//! the controller output expressed as `M̄ = -T / |B|`, so one implementation serves both.
//!
//! Saturation scales the whole dipole so every rod stays within its (asymmetric) limit:
//! the torque direction is kept. A rod whose command falls inside its hysteresis dead
//! band produces nothing on the real hardware: it is reported in `unrealised` and left
//! out of `realised`. Below `min_field_t` the law is undefined: zero dipole, `Singular`.

use super::{AllocResult, AllocStatus};
use crate::math::Vec3;
use crate::params::MagnetorquerParams;

pub fn allocate(p: &MagnetorquerParams, b_body_t: &Vec3, torque_nm: &Vec3) -> AllocResult<3> {
    let mut r = AllocResult::<3>::nothing_realised(torque_nm);
    r.outcome.iterations = 1;
    if !b_body_t.iter().chain(torque_nm.iter()).all(|x| x.is_finite()) {
        r.outcome.status = AllocStatus::NonFinite;
        return r;
    }
    let b2 = b_body_t.norm_squared();
    if b2 < p.min_field_t * p.min_field_t || b2 <= 0.0 {
        r.outcome.status = AllocStatus::Singular;
        return r;
    }
    let m: [f32; 3] = (b_body_t.cross(torque_nm) / b2).into();
    // Finite but huge inputs can overflow |B|² or B × T (then inf/inf = NaN).
    if !(b2.is_finite() && m.iter().all(|x| x.is_finite())) {
        r.outcome.status = AllocStatus::NonFinite;
        return r;
    }
    // Asymmetric per-axis limits: scale the whole vector.
    let mut s = 1.0f32;
    for ((mi, hi), lo) in m.iter().zip(p.max_dipole_am2.iter()).zip(p.min_dipole_am2.iter()) {
        if *mi > *hi && *mi > 0.0 {
            s = s.min(hi / mi);
        } else if *mi < -lo && *mi < 0.0 {
            s = s.min(-lo / mi);
        }
    }
    let m = m.map(|x| x * s.max(0.0));
    let mut eff = m;
    for (i, (e, mi)) in eff.iter_mut().zip(m.iter()).enumerate() {
        let at = |a: &[f32; 3]| a.get(i).copied().unwrap_or(0.0);
        let (lo, hi) = (at(&p.deadband_lo_am2), at(&p.deadband_hi_am2));
        if *mi != 0.0 && *mi > lo && *mi < hi {
            *e = 0.0;
            r.outcome.unrealised |= 1 << i;
        }
        let (mx, mn) = (at(&p.max_dipole_am2), at(&p.min_dipole_am2));
        if *mi >= mx * (1.0 - 1e-6) && mx > 0.0 {
            r.outcome.sat_high |= 1 << i;
        } else if *mi <= -mn * (1.0 - 1e-6) && mn > 0.0 {
            r.outcome.sat_low |= 1 << i;
        }
    }
    let eff = Vec3::from(eff);
    let realised = eff.cross(b_body_t);
    if !realised.iter().all(|x| x.is_finite()) {
        r.outcome.status = AllocStatus::NonFinite;
        return r;
    }
    let short = torque_nm - realised;
    let tn = torque_nm.norm_squared();
    r.u = m;
    r.outcome.realised = realised.into();
    r.outcome.shortfall = short.into();
    r.outcome.lambda = crate::allocation::AllocOutcome::fraction_along(&realised, torque_nm);
    r.outcome.status = if s < 1.0 || r.unrealised != 0 || crate::math::norm(&short) > 1e-3 * crate::math::f32m::sqrt(tn)
    {
        AllocStatus::Scaled
    } else {
        AllocStatus::Ok
    };
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> MagnetorquerParams {
        MagnetorquerParams {
            max_dipole_am2: [12.26; 3],
            min_dipole_am2: [11.76; 3],
            deadband_lo_am2: [-1.26; 3],
            deadband_hi_am2: [1.86; 3],
            min_field_t: 1e-7,
        }
    }

    #[test]
    fn torque_perpendicular_to_b_is_realised_exactly() {
        let b = Vec3::new(2e-5, -1e-5, 4e-5);
        let t = b.cross(&Vec3::new(0.3, 0.1, -0.2)) * 20.0; // ⟂ B by construction, dipoles beyond the dead band
        let r = allocate(&rig(), &b, &t);
        assert_eq!(r.status, AllocStatus::Ok, "{r:?}");
        assert!((Vec3::from(r.realised) - t).norm() < 1e-4 * t.norm());
    }

    #[test]
    fn parallel_component_is_the_shortfall() {
        let b = Vec3::new(0.0, 0.0, 3e-5);
        let t = Vec3::new(1e-4, 0.0, 2e-4);
        let r = allocate(&rig(), &b, &t);
        assert!((Vec3::from(r.realised) - Vec3::new(1e-4, 0.0, 0.0)).norm() < 1e-9);
        assert!((Vec3::from(r.shortfall) - Vec3::new(0.0, 0.0, 2e-4)).norm() < 1e-9);
    }

    #[test]
    fn saturation_clips_asymmetrically_and_keeps_direction() {
        let b = Vec3::new(0.0, 3e-5, 0.0);
        // Needs a large negative x dipole (M × B along z for M along x).
        let t = Vec3::new(0.0, 0.0, -1e-3);
        let r = allocate(&rig(), &b, &t);
        assert!((r.u[0] - (-11.76)).abs() < 1e-4, "{:?}", r.u);
        assert_ne!(r.sat_low & 1, 0);
        assert_eq!(r.status, AllocStatus::Scaled);
        let got = Vec3::from(r.realised);
        assert!(got.normalize().dot(&t.normalize()) > 0.9999);
    }

    #[test]
    fn dead_band_commands_produce_nothing_and_are_reported() {
        let b = Vec3::new(0.0, 3e-5, 0.0);
        let t = Vec3::new(0.0, 0.0, 1.5 * 3e-5); // needs M_x = +1.5, inside (-1.26, 1.86)
        let r = allocate(&rig(), &b, &t);
        assert!((r.u[0] - 1.5).abs() < 1e-4);
        assert_ne!(r.unrealised & 1, 0);
        assert_eq!(Vec3::from(r.realised).norm(), 0.0);
    }

    #[test]
    fn weak_or_bad_field_is_refused() {
        assert_eq!(allocate(&rig(), &Vec3::zeros(), &Vec3::new(1e-4, 0.0, 0.0)).status, AllocStatus::Singular);
        assert_eq!(
            allocate(&rig(), &Vec3::new(f32::NAN, 0.0, 0.0), &Vec3::new(1e-4, 0.0, 0.0)).status,
            AllocStatus::NonFinite
        );
        // Finite but overflowing (found by tests/tests/flight_fuzz.rs): no NaN dipoles.
        let r = allocate(&rig(), &Vec3::new(4e-5, 0.0, 6e32), &Vec3::new(-2.6e32, -6e31, 1e-5));
        assert_eq!(r.status, AllocStatus::NonFinite);
        assert!(r.u.iter().chain(r.realised.iter()).all(|x| x.is_finite() && *x == 0.0), "{r:?}");
    }
}
