//! Effectiveness of a reaction-wheel array (paper 001 eqs 5, 26): spin axes
//! `C = [a_1 … a_n]`, the stored momentum they hold, and the body torque of motor torques;
//! the allocation method that inverts it is [`crate::allocation::wheels`].
//!
//! Sign convention: `u[i]` is the torque the motor applies to wheel `i`'s rotor about its
//! spin axis `a_i`; the body receives `-Σ a_i u_i` (paper 001 eq 5).

use crate::math::{Mat3, Vec3};
use crate::params::WheelParams;
use crate::types::MAX_WHEELS;

/// Stored momentum `Σ a_i J_w Ω_i` of the fitted wheels, body axes, N m s (`speed_rad_s`:
/// wheel speeds relative to the body).
pub fn stored_momentum_nms(p: &WheelParams, speed_rad_s: &[f32; MAX_WHEELS]) -> Vec3 {
    let mut h = Vec3::zeros();
    for (a, s) in p.axes.iter().zip(speed_rad_s.iter()).take(usize::from(p.count)) {
        h += Vec3::from(*a) * (p.inertia_kgm2 * s);
    }
    h
}

/// Relative determinant of `C Cᵀ` (to its trace³/27) below which wheels do not span three
/// axes.
pub const RANK_TOL: f32 = 1e-6;

/// Whether the wheels of Gram matrix `m` ([`axes_gram`]) span three axes: one test for the
/// allocation (damped inverse below it) and the mode manager (a wheel mode without three
/// axes lacks an input).
pub fn spans_three_axes(m: &Mat3) -> bool {
    let scale = (m.trace() / 3.0).max(1e-30);
    m.determinant() >= RANK_TOL * scale * scale * scale
}

/// `C Cᵀ = Σ a_i a_iᵀ` over the wheels of the first `n` whose bit is set in `active`.
pub fn axes_gram(p: &WheelParams, n: usize, active: u32) -> Mat3 {
    let mut m = Mat3::zeros();
    for (i, a) in p.axes.iter().enumerate().take(n) {
        if active & (1 << i) != 0 {
            let a = Vec3::from(*a);
            m += a * a.transpose();
        }
    }
    m
}

/// Body torque of the motor torques `u` on the first `n` wheels: `-Σ a_i u_i`, N m.
pub fn torque_on_body_nm(p: &WheelParams, n: usize, u: &[f32; MAX_WHEELS]) -> Vec3 {
    let mut t = Vec3::zeros();
    for (ui, a) in u.iter().zip(p.axes.iter()).take(n) {
        t -= Vec3::from(*a) * *ui;
    }
    t
}
