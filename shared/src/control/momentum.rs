//! Momentum management: the law-independent outer loop that keeps the momentum stored in
//! the wheels (or the CMG cluster) near a commanded target by magnetic unloading.
//!
//! The cross-product law (Markley & Crassidis 2014 sec 7.5; Sidi 1997 ch 7; Basilisk's
//! `mtbMomentumManagement` as prior art): with `h_err = h - h_target` the stored-momentum
//! error (body axes) and `B` the measured field,
//! `m = k (h_err × B) / |B|²`, so the torque on the body is
//! `m × B = -k (h_err - B̂ (B̂·h_err)) = -k h_err⊥`.
//! Its limit: `m × B` never has a component along `B`, so the part of `h_err` along the
//! field is not unloaded at that instant; the field direction rotates (twice per orbit in
//! the body of an inertially held spacecraft) and the orbit average unloads every axis.
//!
//! The wheel law is told to absorb the unloading torque (feed-forward): the torque
//! demand handed to the allocation is `τ_law - τ_mag`, with `τ_mag = (m + m_res) × B`
//! the magnetic torque the flight code expects (commanded plus the known residual
//! dipole), so the body sees `τ_law` and the pointing is held while the wheels slow down.
//!
//! Dead band: nothing is commanded while `|h_err| <= deadband`. Saturation: the whole
//! dipole is scaled to the rod limits (direction kept). The residual dipole the parameter
//! set carries is cancelled by the torquers (inside the same limit). Masked rods
//! (`failed_rods_mask`, issue 42): the torque of that dipole is realised by the working
//! rods ([`crate::allocation::magnetorquers::dipole_for_torque`]), then scaled.
//!
//! Magnetometer / torquer sharing: the flight code subtracts the torquers' field at the
//! magnetometer, `C · m_last` (the calibrated coupling times the dipole commanded over
//! the period that ends at the sample), see [`torquer_field_t`].

use crate::math::{Mat3, Vec3};
use crate::params::MomentumParams;
use crate::params::rows_to_mat;

/// What the unloading law commands this step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Unloading {
    /// Torquer dipole command, body axes, A m².
    pub dipole_am2: Vec3,
    /// Magnetic torque expected on the body, `(m + m_res) × B`, N m (the feed-forward).
    pub torque_nm: Vec3,
    /// Stored-momentum error `h - h_target`, body axes, N m s.
    pub h_err_nms: Vec3,
    /// The dipole was scaled to the rod limits.
    pub scaled: bool,
}

/// One step of the unloading law. `h_nms`: stored actuator momentum, body axes;
/// `b_body_t`: magnetometer (torquer field already removed). Disabled, non-finite input
/// or a field below `min_field_t`: nothing commanded (documented safe fallback).
pub fn unload(p: &MomentumParams, h_nms: &Vec3, b_body_t: &Vec3) -> Unloading {
    let mut out = Unloading::default();
    if !p.enabled
        || p.method != crate::params::UnloadMethod::Magnetic
        || !h_nms.iter().chain(b_body_t.iter()).all(|x| x.is_finite())
    {
        return out;
    }
    let b2 = b_body_t.norm_squared();
    if !(b2 >= p.min_field_t * p.min_field_t) || !b2.is_finite() {
        return out;
    }
    let h_err = h_nms - Vec3::from(p.target_nms);
    out.h_err_nms = h_err;
    let unload = if h_err.norm_squared() > p.deadband_nms * p.deadband_nms {
        h_err.cross(b_body_t) * (p.gain_per_s / b2)
    } else {
        Vec3::zeros()
    };
    let residual = Vec3::from(p.residual_dipole_am2);
    let wanted = unload - residual;
    // Masked rods (issue 42): the torque that dipole makes, from the working rods.
    let wanted = if p.failed_rods_mask == 0 {
        wanted
    } else {
        crate::allocation::magnetorquers::dipole_for_torque(b_body_t, &wanted.cross(b_body_t), p.failed_rods_mask)
    };
    let (m, scaled) = super::scale_to_box(&wanted, &Vec3::from(p.max_dipole_am2));
    let torque = (m + residual).cross(b_body_t);
    if !(m.iter().chain(torque.iter()).all(|x| x.is_finite())) {
        return Unloading::default();
    }
    out.dipole_am2 = m;
    out.torque_nm = torque;
    out.scaled = scaled;
    out
}

/// Field of the torquers at the magnetometer for the dipole `dipole_am2` held over the
/// period that ends at the sample, T (the flight code subtracts it). Zero when the
/// coupling is zero or the dipole not finite.
pub fn torquer_field_t(p: &MomentumParams, dipole_am2: &Vec3) -> Vec3 {
    let c: Mat3 = rows_to_mat(&p.mag_coupling_t_per_am2);
    let f = c * dipole_am2;
    if f.iter().all(|x| x.is_finite()) { f } else { Vec3::zeros() }
}

/// Thruster momentum dump (the `dump_*` fields): with `h_err = h - h_target`, a dump
/// starts when `|h_err| > dump_start_nms` and ends when `|h_err| < dump_stop_nms`
/// (hysteresis, `active` carries the state between steps). While it runs the body torque
/// demanded of the thrusters is `τ_dump = -k_dump h_err`, scaled as a whole to
/// `dump_torque_max_nm`. Returns zero when not dumping; a non-finite momentum ends the
/// dump (documented safe fallback).
pub fn dump_torque_nm(p: &MomentumParams, h_nms: &Vec3, active: &mut bool) -> Vec3 {
    let h_err = h_nms - Vec3::from(p.target_nms);
    let e = crate::math::norm(&h_err);
    if !p.dumps() || !e.is_finite() {
        *active = false;
        return Vec3::zeros();
    }
    if e > p.dump_start_nms {
        *active = true;
    } else if e < p.dump_stop_nms {
        *active = false;
    }
    if !*active {
        return Vec3::zeros();
    }
    let tau = h_err * -p.dump_gain_per_s;
    let n = crate::math::norm(&tau);
    if n > p.dump_torque_max_nm && n > 0.0 { tau * (p.dump_torque_max_nm / n) } else { tau }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn params() -> MomentumParams {
        MomentumParams { enabled: true, gain_per_s: 0.01, max_dipole_am2: [0.2; 3], ..MomentumParams::OFF }
    }

    /// A small deterministic generator (xorshift) for the random field and momentum.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
        fn vec(&mut self, scale: f64) -> Vector3<f64> {
            Vector3::new(self.next(), self.next(), self.next()) * scale
        }
    }

    /// Independent f64 reference: `τ = -k (h - B̂ (B̂·h))`, the perpendicular part.
    #[test]
    fn torque_is_never_along_the_field_and_matches_the_perpendicular_law() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut unscaled = 0;
        for _ in 0..20_000 {
            let b = rng.vec(5e-5);
            let h = rng.vec(2e-3);
            let mut p = params();
            p.max_dipole_am2 = [(0.2 * rng.next().abs() + 1e-3) as f32; 3];
            let u = unload(&p, &h.cast::<f32>(), &b.cast::<f32>());
            // What the commanded dipole does, in f64.
            let m = u.dipole_am2.cast::<f64>();
            let tau = m.cross(&b);
            let bh = b.normalize();
            // Round-off only: the f32 dipole is perpendicular to B to ~1e-6 of its size.
            assert!(m.dot(&bh).abs() <= 2e-6 * m.norm() + 1e-30, "m·B̂ = {}", m.dot(&bh));
            assert!(tau.dot(&bh).abs() <= 1e-12 * tau.norm().max(1e-30));
            // Without saturation the torque is -k h⊥; with it, the same direction, shorter.
            let want = -(h - bh * bh.dot(&h)) * f64::from(p.gain_per_s);
            let along = tau.dot(&want) / want.norm_squared();
            assert!((tau - want * along).norm() <= 1e-5 * want.norm(), "direction kept");
            if u.scaled {
                assert!(along > 0.0 && along < 1.0 + 1e-6, "{along}");
                let peak = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                assert!((peak - f64::from(p.max_dipole_am2[0])).abs() <= 1e-6 * peak);
            } else {
                unscaled += 1;
                assert!((along - 1.0).abs() < 1e-5, "{along}");
            }
            // The feed-forward is what the dipole does.
            assert!((u.torque_nm.cast::<f64>() - tau).norm() <= 1e-5 * tau.norm() + 1e-15);
        }
        assert!(unscaled > 1000 && unscaled < 19_000, "both regimes exercised: {unscaled}");
    }

    #[test]
    fn dead_band_residual_dipole_and_fallbacks() {
        let b = Vec3::new(2e-5, -1e-5, 3e-5);
        let p = MomentumParams { deadband_nms: 1e-4, ..params() };
        // Inside the dead band: nothing.
        let u = unload(&p, &Vec3::new(5e-5, 0.0, 0.0), &b);
        assert_eq!(u.dipole_am2, Vec3::zeros());
        assert_eq!(u.h_err_nms, Vec3::new(5e-5, 0.0, 0.0));
        // Just outside: unloading.
        assert!(unload(&p, &Vec3::new(2e-4, 0.0, 0.0), &b).dipole_am2.norm() > 0.0);
        // At the target nothing is unloaded, but the known residual dipole is cancelled:
        // commanded + residual = 0, no magnetic torque expected.
        let p = MomentumParams { residual_dipole_am2: [0.0, 0.0, 1e-3], target_nms: [1e-4, 0.0, 0.0], ..params() };
        let u = unload(&p, &Vec3::new(1e-4, 0.0, 0.0), &b);
        assert_eq!(u.dipole_am2, Vec3::new(0.0, 0.0, -1e-3));
        assert!(u.torque_nm.norm() < 1e-15);
        // Disabled, weak field, non-finite input: nothing.
        let off = MomentumParams { enabled: false, ..params() };
        assert_eq!(unload(&off, &Vec3::new(1e-3, 0.0, 0.0), &b), Unloading::default());
        assert_eq!(unload(&params(), &Vec3::new(1e-3, 0.0, 0.0), &(b * 1e-4)), Unloading::default());
        assert_eq!(unload(&params(), &Vec3::new(f32::NAN, 0.0, 0.0), &b), Unloading::default());
        assert_eq!(
            unload(&params(), &Vec3::new(1e-3, 0.0, 0.0), &Vec3::new(f32::INFINITY, 0.0, 0.0)).dipole_am2,
            Vec3::zeros()
        );
    }

    #[test]
    fn dump_starts_above_start_ends_below_stop_and_is_capped() {
        use crate::params::UnloadMethod;
        let p = MomentumParams {
            enabled: true,
            method: UnloadMethod::Thrusters,
            dump_gain_per_s: 0.5,
            dump_torque_max_nm: 0.2,
            dump_start_nms: 1.0,
            dump_stop_nms: 0.1,
            target_nms: [0.0, 0.0, 0.05],
            ..MomentumParams::OFF
        };
        let mut on = false;
        // Below start: nothing, not active.
        assert_eq!(dump_torque_nm(&p, &Vec3::new(0.9, 0.0, 0.05), &mut on), Vec3::zeros());
        assert!(!on);
        // Above start: capped at 0.2 N m, direction -h_err.
        let t = dump_torque_nm(&p, &Vec3::new(1.2, 0.0, 0.05), &mut on);
        assert!(on && (t - Vec3::new(-0.2, 0.0, 0.0)).norm() < 1e-6, "{t:?}");
        // Between stop and start: still dumping (hysteresis), uncapped -k h_err.
        let t = dump_torque_nm(&p, &Vec3::new(0.0, 0.3, 0.05), &mut on);
        assert!(on && (t - Vec3::new(0.0, -0.15, 0.0)).norm() < 1e-6, "{t:?}");
        // Below stop: ends, and stays off below start.
        assert_eq!(dump_torque_nm(&p, &Vec3::new(0.0, 0.05, 0.05), &mut on), Vec3::zeros());
        assert!(!on);
        assert_eq!(dump_torque_nm(&p, &Vec3::new(0.0, 0.5, 0.05), &mut on), Vec3::zeros());
        // NaN momentum or the magnetic method: off.
        on = true;
        assert_eq!(dump_torque_nm(&p, &Vec3::new(f32::NAN, 0.0, 0.0), &mut on), Vec3::zeros());
        assert!(!on);
        on = true;
        let mag = MomentumParams { method: UnloadMethod::Magnetic, ..p };
        assert_eq!(dump_torque_nm(&mag, &Vec3::new(5.0, 0.0, 0.0), &mut on), Vec3::zeros());
        assert!(!on);
    }

    #[test]
    fn torquer_field_is_the_coupling_times_the_dipole() {
        let p = MomentumParams {
            mag_coupling_t_per_am2: [[1e-6, 0.0, 2e-7], [0.0, -3e-6, 0.0], [0.0, 0.0, 1e-6]],
            ..params()
        };
        let f = torquer_field_t(&p, &Vec3::new(0.1, 0.2, -0.1));
        assert!((f - Vec3::new(1e-7 - 2e-8, -6e-7, -1e-7)).norm() < 1e-12);
        assert_eq!(torquer_field_t(&p, &Vec3::new(f32::NAN, 0.0, 0.0)), Vec3::zeros());
    }
}
