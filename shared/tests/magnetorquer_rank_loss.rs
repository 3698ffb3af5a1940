//! Magnetorquer rank loss (issue 42): with rods masked, the flight's dipole
//! (`allocation::magnetorquers::dipole_for_torque`, a damped normal-equation solve by
//! Cholesky in f32) against a second method written apart: the same damped least squares
//! as the plain least squares of the augmented system `[A; √λ |B| I] m = [T; 0]`
//! (`A`'s columns `e_j × B` of the working rods, formed from the cross product), solved by
//! an f64 SVD. And what the rods then do: the failed rods command nothing, a torque the
//! working rods can make is made, the unloading law commands no masked rod.

#![allow(clippy::disallowed_methods)] // test-side oracles (f64) may use nalgebra's own sqrt

use acs_flight::allocation::magnetorquers::{ROD_LS_DAMPING, allocate, dipole_for_torque};
use acs_flight::control::momentum::unload;
use acs_flight::math::Vec3;
use acs_flight::params::{MagnetorquerParams, MomentumParams};
use acs_test_support::rng::SplitMix64;
use nalgebra::{DMatrix, DVector, Vector3};

/// The damped least-squares dipole by the augmented system and an f64 SVD.
fn reference(b: &Vector3<f64>, t: &Vector3<f64>, mask: u8) -> Vector3<f64> {
    let working: Vec<usize> = (0..3).filter(|j| mask & (1 << j) == 0).collect();
    let n = working.len();
    if n == 0 {
        return Vector3::zeros();
    }
    let damp = (f64::from(ROD_LS_DAMPING)).sqrt() * b.norm();
    let mut a = DMatrix::<f64>::zeros(3 + n, n);
    for (c, &j) in working.iter().enumerate() {
        let col = Vector3::ith(j, 1.0).cross(b);
        for r in 0..3 {
            a[(r, c)] = col[r];
        }
        a[(3 + c, c)] = damp;
    }
    let mut rhs = DVector::<f64>::zeros(3 + n);
    for r in 0..3 {
        rhs[r] = t[r];
    }
    let x = a.svd(true, true).solve(&rhs, 1e-30).unwrap();
    let mut m = Vector3::zeros();
    for (c, &j) in working.iter().enumerate() {
        m[j] = x[c];
    }
    m
}

fn v64(v: &Vec3) -> Vector3<f64> {
    v.cast::<f64>()
}

fn random_unit(rng: &mut SplitMix64) -> Vector3<f64> {
    Vector3::new(rng.normal(), rng.normal(), rng.normal()).normalize()
}

/// 3,000 random fields (20–60 µT) and torques, every mask with a rod failed: the flight's
/// f32 dipole within 1e-4 of the f64 reference (relative to its size, or 1e-6 A m²), the
/// masked rods exactly 0, and all rods failed: no dipole.
#[test]
fn the_masked_dipole_is_the_damped_least_squares() {
    let mut rng = SplitMix64(20_261_131);
    let mut worst = 0.0f64;
    for k in 0..3000 {
        let b = random_unit(&mut rng) * (2.0e-5 + 4.0e-5 * rng.uniform());
        let t = random_unit(&mut rng) * 1.0e-5 * (0.1 + rng.uniform());
        let mask = 1 + (k % 7) as u8; // 1..=7
        let (bf, tf) = (b.cast::<f32>(), t.cast::<f32>());
        let got = dipole_for_torque(&bf, &tf, mask);
        let want = reference(&bf.cast(), &tf.cast(), mask);
        for i in 0..3 {
            if mask & (1 << i) != 0 {
                assert_eq!(got[i], 0.0, "rod {i} masked ({mask:#05b}) but commanded {got:?}");
            }
        }
        let err = (v64(&got) - want).norm() / want.norm().max(1e-6);
        worst = worst.max(err);
        assert!(err < 1e-4, "mask {mask:#05b}: {got:?} against {want:?} (rel {err})");
    }
    println!("masked dipole against the f64 SVD reference: worst relative error {worst:.2e}");
}

/// One rod failed, the field with a component along it (|B_i| ≥ 0.3 |B|): a torque the two
/// working rods can make (`m_W × B`, m_W random on their axes) is made within the damping's
/// share (`λ / (λ + B_i²/|B|²)` relative, ≤ 1.1e-2 here); the allocation realises it, commands nothing on the masked rod,
/// and the plain three-rod law (mask 0) would have used the masked rod.
#[test]
fn a_torque_the_working_rods_can_make_is_made() {
    let mut rng = SplitMix64(7);
    let p = MagnetorquerParams {
        max_dipole_am2: [10.0; 3],
        min_dipole_am2: [10.0; 3],
        deadband_lo_am2: [0.0; 3],
        deadband_hi_am2: [0.0; 3],
        min_field_t: 1e-7,
        failed_mask: 0,
    };
    let mut checked = 0;
    for _ in 0..2000 {
        let b = random_unit(&mut rng) * 4.0e-5;
        let failed = (rng.uniform() * 3.0) as usize % 3;
        if b[failed].abs() < 0.3 * b.norm() {
            continue;
        }
        let mut m_w = Vector3::new(rng.normal(), rng.normal(), rng.normal());
        m_w[failed] = 0.0;
        let t = m_w.cross(&b).cast::<f32>();
        let mask = 1u8 << failed;
        let r = allocate(&MagnetorquerParams { failed_mask: mask, ..p }, &b.cast(), &t);
        assert_eq!(r.u[failed], 0.0);
        let realised = Vector3::from(r.realised).cast::<f64>();
        let rel = (realised - t.cast::<f64>()).norm() / t.cast::<f64>().norm();
        // The damping shrinks the weak direction (eigenvalue B_i² of the normal matrix) by
        // λ|B|² / (B_i² + λ|B|²): the bound on the relative shortfall (+ f32 rounding).
        let lambda = f64::from(ROD_LS_DAMPING);
        let bound = lambda / (lambda + (b[failed] / b.norm()).powi(2)) + 1e-5;
        assert!(rel <= bound, "rod {failed}: realised {realised:?} for {t:?} ({rel} > {bound})");
        // Without the mask the least-norm law puts dipole on every rod (here: the failed one).
        let plain = allocate(&p, &b.cast(), &t);
        assert!(plain.u[failed].abs() > 1e-6, "{:?}", plain.u);
        checked += 1;
    }
    assert!(checked > 500, "{checked}");
}

/// The field in the plane of the working rods (no component along the failed one): the
/// working rods can only make torque along the failed rod's axis. The solve stays finite
/// (the damping) and what it realises is along that axis.
#[test]
fn a_field_in_the_working_plane_gives_a_finite_dipole() {
    let b = Vec3::new(3.0e-5, -2.0e-5, 0.0);
    let t = Vec3::new(1.0e-6, 2.0e-6, 3.0e-6);
    let m = dipole_for_torque(&b, &t, 0b100);
    assert!(m.iter().all(|x| x.is_finite()) && m[2] == 0.0, "{m:?}");
    let realised = m.cross(&b);
    assert!(realised[0].abs() < 1e-12 && realised[1].abs() < 1e-12, "{realised:?}");
    // It makes the achievable part (t's z component) within the damping's share.
    assert!((realised[2] - t[2]).abs() < 2e-3 * t[2].abs(), "{realised:?}");
    // NaN or a zero field: nothing.
    assert_eq!(dipole_for_torque(&Vec3::zeros(), &t, 0b001), Vec3::zeros());
    assert_eq!(dipole_for_torque(&Vec3::new(f32::NAN, 0.0, 1e-5), &t, 0b001), Vec3::zeros());
}

/// The unloading law with a masked rod: the masked rod commands nothing, the torque it
/// reports is what the commanded dipole (with the residual) makes, and it still unloads
/// (without a residual, the torque opposes the momentum error: `τ · h_err ≤ 0`).
#[test]
fn unloading_uses_only_the_working_rods() {
    let mut rng = SplitMix64(11);
    let on = MomentumParams {
        enabled: true,
        gain_per_s: 0.01,
        max_dipole_am2: [0.2; 3],
        residual_dipole_am2: [0.0, 0.0, 0.001],
        ..MomentumParams::OFF
    };
    for k in 0..500 {
        let b = random_unit(&mut rng) * 4.0e-5;
        let h = random_unit(&mut rng) * 1.0e-3;
        let mask = 1u8 << (k % 3);
        let u = unload(&MomentumParams { failed_rods_mask: mask, ..on }, &h.cast(), &b.cast());
        assert_eq!(u.dipole_am2[k % 3], 0.0, "{mask:#05b}: {:?}", u.dipole_am2);
        let made = (u.dipole_am2 + Vec3::from(on.residual_dipole_am2)).cross(&b.cast());
        assert!((made - u.torque_nm).norm() <= 1e-6 * made.norm() + 1e-15);
        // Without a residual to cancel, the torque opposes the momentum error (the damped
        // least squares keeps the demand's descent: τ_r · τ_d ≥ 0).
        let clean = MomentumParams { failed_rods_mask: mask, residual_dipole_am2: [0.0; 3], ..on };
        let u = unload(&clean, &h.cast(), &b.cast());
        assert!(u.torque_nm.cast::<f64>().dot(&h) <= 0.0, "k {k}: the rods add momentum");
    }
}
