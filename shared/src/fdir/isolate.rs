//! Which unit a fired wheel residual names: the rotor (motor, bearing, drive) or its
//! tachometer.
//!
//! The wheel residual ([`super::wheel`]) compares the command with what the tachometer
//! says the rotor got; it cannot tell a rotor that did not get its torque from a
//! tachometer that lies. The body can: its reaction measured by the gyro,
//! `b = J_b Δω/Δt + ω × (J_b ω + h)`, equals `−Σ aᵢ τᵢ` of the torques the rotors really
//! received (paper 001 eq 5; external torques are small beside a fault and count as
//! noise). With the torques the tachometers imply, `τᵢᵗ`, the mismatch
//! `m = b + Σ aᵢ τᵢᵗ` is zero when every tachometer is honest, and `−r aⱼ` when wheel
//! `j`'s tachometer is off by its residual `r`. So the share of the residual the body
//! sees along `aⱼ`,
//!
//! `s = −(m · aⱼ) / r`,
//!
//! is 0 for a failed rotor and 1 for a lying tachometer. The rule cuts at ½; with the
//! mismatch's noise `σ_m` per axis, `s` has the noise `σ_m/|r|`, so it misnames the unit
//! with probability `Φ(−|r| / (2 σ_m))`, and below `|r| < min_ratio · σ_m` it does not
//! decide ([`WheelIsolation::Ambiguous`], documented in docs/fdir.md).

use crate::math::{Mat3, Vec3};

/// What a fired wheel residual is attributed to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WheelIsolation {
    /// The rotor did not get its torque (seized, lost torque, runaway): the wheel is
    /// dropped from the allocation.
    Rotor,
    /// The rotor works, its tachometer lies: the wheel may stay, its speed comes from the
    /// command history.
    Tachometer,
    /// The residual is too small beside the body's noise to tell (`|r| < min_ratio σ_m`),
    /// or an input is not finite: the unit is treated as a rotor fault (the safe reading:
    /// an unused wheel costs authority, a wrongly trusted one costs control).
    Ambiguous,
}

/// The body's reaction measured by the gyro over one step, less the reaction the
/// tachometers imply (`m` of the module doc), N m. `rate_*`: body rate at the step's ends
/// (rad/s); `h_wheels_nms`: the wheels' momentum in body axes; `tach_torque_axes_nm`:
/// `Σ aᵢ τᵢᵗ`, the tachometer torques turned into body axes by the caller.
pub fn body_mismatch_nm(
    inertia_body: &Mat3,
    rate_before_rad_s: &Vec3,
    rate_after_rad_s: &Vec3,
    dt_s: f32,
    h_wheels_nms: &Vec3,
    tach_torque_axes_nm: &Vec3,
) -> Vec3 {
    let w = (rate_before_rad_s + rate_after_rad_s) * 0.5;
    let accel = (rate_after_rad_s - rate_before_rad_s) / dt_s;
    inertia_body * accel + w.cross(&(inertia_body * w + h_wheels_nms)) + tach_torque_axes_nm
}

/// Attributes a fired residual `residual_nm` of the wheel on `axis` (unit) from the body
/// mismatch `mismatch_nm` and its noise `sigma_mismatch_nm` (per axis, N m).
pub fn isolate_wheel(
    residual_nm: f32,
    axis: &Vec3,
    mismatch_nm: &Vec3,
    sigma_mismatch_nm: f32,
    min_ratio: f32,
) -> WheelIsolation {
    let s = -(mismatch_nm.dot(axis)) / residual_nm;
    // `!(≥)`: a NaN ratio or share is not decided.
    if !(residual_nm.abs() >= min_ratio * sigma_mismatch_nm) || !s.is_finite() {
        return WheelIsolation::Ambiguous;
    }
    if s >= 0.5 { WheelIsolation::Tachometer } else { WheelIsolation::Rotor }
}
