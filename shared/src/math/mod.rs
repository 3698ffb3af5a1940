//! Math types and the project's attitude conventions.
//!
//! # Quaternion convention (the only one in the project)
//! - Hamilton algebra (`i j k = -1`), stored scalar-last `[x, y, z, w]` — the same order
//!   as papers 000/002 (`q4` scalar) and as nalgebra's `Quaternion::coords`.
//! - An attitude quaternion `q_ib` rotates vectors from the body frame B into the
//!   reference (inertial, or LVLH when stated) frame I: `v_I = q ⊗ v_B ⊗ q*`.
//!   Kinematics: `dq/dt = ½ q ⊗ [ω_B; 0]` with ω the body rate in body axes.
//! - Attitude error: `q_e = q_c* ⊗ q`, the body attitude relative to the commanded
//!   frame, vector part in body axes; its sign is chosen with `w ≥ 0` (short way round).
//!   This is the same physical error as eq. 16 of paper 000 (written there in Wie's
//!   reversed-product notation).
//!
//! # Euler angles
//! `[roll φ, pitch θ, yaw ψ]`. Sequence 3-2-1 (default): `q = q_z(ψ) ⊗ q_y(θ) ⊗ q_x(φ)`,
//! i.e. yaw first, about the reference z axis. Sequence 1-2-3 (paper 003):
//! `q = q_x(φ) ⊗ q_y(θ) ⊗ q_z(ψ)`.
//!
//! nalgebra supplies the algebra; its trigonometric and norm helpers are *not* used in
//! flight code: elementary functions come from [`f32m`] (pure f32, same bits on host and
//! target), norms from [`norm`]. `shared/clippy.toml` disallows the alternatives.

pub mod f32m;
mod quat;
pub use quat::*;

pub type Vec3 = nalgebra::Vector3<f32>;
pub type Mat3 = nalgebra::Matrix3<f32>;
pub type Quat = nalgebra::Quaternion<f32>;

/// Euclidean norm through [`f32m::sqrt`]. Bit-identical to nalgebra's `norm()` (the same
/// `norm_squared()` then a correctly rounded square root) but without its route through
/// `simba`/`libm::sqrtf` (integer software) on the target. Works for vectors and, via
/// `q.coords`, quaternions.
#[inline]
pub fn norm<R: nalgebra::Dim, C: nalgebra::Dim, S: nalgebra::Storage<f32, R, C>>(
    v: &nalgebra::Matrix<f32, R, C, S>,
) -> f32 {
    f32m::sqrt(v.norm_squared())
}

/// True when every component is finite (not NaN, not ±inf).
#[inline]
pub fn all_finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `x` limited to `[-limit, limit]`. Unlike `f32::clamp` it never panics: a NaN or
/// negative `limit` counts as 0 (the safe side for every gain and integral limit), and a
/// NaN `x` stays NaN so that the caller's finiteness check still sees it. For finite `x`
/// and `limit >= 0` the result is bit-identical to `x.clamp(-limit, limit)`.
#[inline]
pub fn clamp_abs(x: f32, limit: f32) -> f32 {
    let l = if limit >= 0.0 { limit } else { 0.0 };
    if x > l {
        l
    } else if x < -l {
        -l
    } else {
        x
    }
}

/// Scale `v` so that `max |v_i| <= max_abs`, keeping its direction (one factor for the
/// whole vector). Returns whether scaling happened.
pub fn scale_to_peak<const N: usize>(v: &mut [f32; N], max_abs: f32) -> bool {
    let peak = v.iter().fold(0.0f32, |a, x| a.max(libm::fabsf(*x)));
    if peak > max_abs {
        let s = max_abs / peak;
        v.iter_mut().for_each(|x| *x *= s);
        true
    } else {
        false
    }
}

#[cfg(test)]
mod clamp_tests {
    use super::clamp_abs;

    // `f32::clamp` is the reference here, on the bounds where it is defined.
    #[allow(clippy::disallowed_methods)]
    #[test]
    fn clamp_abs_matches_clamp_where_clamp_is_defined_and_never_panics_elsewhere() {
        let xs = [-3.0f32, -1.0, -0.5, -0.0, 0.0, 0.25, 1.0, 7.5, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE];
        for &x in &xs {
            for &l in &[0.0f32, 0.5, 1.0, 10.0, f32::INFINITY] {
                assert_eq!(clamp_abs(x, l).to_bits(), x.clamp(-l, l).to_bits(), "x {x} l {l}");
            }
            // Bounds on which f32::clamp panics: NaN or negative -> limit 0.
            for &l in &[f32::NAN, -1.0, f32::NEG_INFINITY] {
                assert_eq!(clamp_abs(x, l), 0.0, "x {x} l {l}");
            }
        }
        assert!(clamp_abs(f32::NAN, 1.0).is_nan());
        assert!(clamp_abs(f32::NAN, f32::NAN).is_nan());
    }
}
