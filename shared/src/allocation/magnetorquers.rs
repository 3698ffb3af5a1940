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
//!
//! Rank loss (issue 42): a rod the ground masked (`failed_mask`) is commanded nothing and
//! the others realise what they can ([`dipole_for_torque`]).

use super::{AllocResult, AllocStatus};
use crate::math::{Mat3, Vec3};
use crate::params::MagnetorquerParams;

/// Damping of the rods' least squares when a rod is masked, relative to `|B|²`: keeps the
/// normal matrix invertible when the field lies in the plane of the working rods (then
/// they can only make torque along the failed rod's axis). The cost: with rod i failed the
/// normal matrix's weak eigenvalue is `B_i²`, so an achievable torque falls short by at
/// most `λ|B|² / (B_i² + λ|B|²)` of itself (1.1 % at `|B_i| = 0.3|B|`, 0.1 % at `|B|`).
pub const ROD_LS_DAMPING: f32 = 1.0e-3;

/// The dipole of the working rods (rod i along body axis i; bit i of `failed_mask`: rod i
/// failed, commanded 0) whose torque `m × B` is closest to `torque_nm`. All three working:
/// `(B × T) / |B|²` (eq 22: the least-norm exact solution for T ⟂ B). Otherwise the damped
/// least squares over the working rods: with `a_j = e_j × B`, `a_j·a_k = δ_jk |B|² − B_j B_k`
/// and `a_j·T = (B × T)_j`, solve `(G_W + λ|B|² I) m_W = (B × T)_W`, λ =
/// [`ROD_LS_DAMPING`]. Without one rod the undamped system's determinant is `|B|² B_i²`:
/// singular when the field has no component along the failed rod. `Vec3::zeros()` when
/// `|B|² ≤ 0` or the factorisation fails (non-finite input).
pub fn dipole_for_torque(b_body_t: &Vec3, torque_nm: &Vec3, failed_mask: u8) -> Vec3 {
    let b2 = b_body_t.norm_squared();
    let rhs = b_body_t.cross(torque_nm);
    if failed_mask & crate::params::ALL_RODS == 0 {
        return rhs / b2;
    }
    if !(b2 > 0.0) {
        return Vec3::zeros();
    }
    let working = |j: usize| failed_mask & (1u8 << j) == 0;
    let at = |v: &Vec3, j: usize| v.get(j).copied().unwrap_or(0.0);
    let g = Mat3::from_fn(|j, k| match (working(j) && working(k), j == k) {
        (true, true) => b2 - at(b_body_t, j) * at(b_body_t, k) + ROD_LS_DAMPING * b2,
        (true, false) => -at(b_body_t, j) * at(b_body_t, k),
        // A failed rod's row and column: the identity, with 0 on the right: m_i = 0.
        (false, same) => f32::from(u8::from(same)),
    });
    let rhs_w = Vec3::from_fn(|j, _| if working(j) { at(&rhs, j) } else { 0.0 });
    match g.cholesky() {
        Some(c) => {
            let m = c.solve(&rhs_w);
            if m.iter().all(|x| x.is_finite()) { m } else { Vec3::zeros() }
        }
        None => Vec3::zeros(),
    }
}

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
    let m: [f32; 3] = dipole_for_torque(b_body_t, torque_nm, p.failed_mask).into();
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
            failed_mask: 0,
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
