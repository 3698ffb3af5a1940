//! Quaternion helpers of the one convention (scalar-last storage `[x, y, z, w]`, Hamilton
//! product, body → reference; docs/conventions.md): storage conversion, products,
//! rotations and Euler angles, all in pure f32.

use super::f32m::{asin, atan2, sin_cos, sqrt};
use super::{Quat, Vec3};

/// Build a quaternion from scalar-last storage `[x, y, z, w]`.
#[inline]
pub fn quat_from_xyzw(q: [f32; 4]) -> Quat {
    let [x, y, z, w] = q;
    Quat::new(w, x, y, z)
}

/// Scalar-last storage `[x, y, z, w]` of a quaternion.
#[inline]
pub fn quat_to_xyzw(q: &Quat) -> [f32; 4] {
    [q.i, q.j, q.k, q.w]
}

/// Normalise; `None` when the norm is not finite or too small to trust.
#[inline]
pub fn quat_normalized(q: &Quat) -> Option<Quat> {
    let n2 = q.coords.norm_squared();
    if !n2.is_finite() || n2 < 1e-12 {
        return None;
    }
    let n = sqrt(n2);
    Some(Quat::from(q.coords / n))
}

/// Attitude error `q_e = q_c* ⊗ q` with the sign chosen so that `w ≥ 0`.
#[inline]
pub fn attitude_error(q: &Quat, q_cmd: &Quat) -> Quat {
    let e = q_cmd.conjugate() * q;
    if e.w < 0.0 { -e } else { e }
}

/// Rotate a body vector into the reference frame: `v_I = q ⊗ v_B ⊗ q*`.
#[inline]
pub fn rotate_body_to_ref(q: &Quat, v_b: &Vec3) -> Vec3 {
    let p = Quat::from_imag(*v_b);
    let r = q * p * q.conjugate();
    r.imag()
}

/// Rotate a reference-frame vector into body axes: `v_B = q* ⊗ v_I ⊗ q`.
#[inline]
pub fn rotate_ref_to_body(q: &Quat, v_i: &Vec3) -> Vec3 {
    let p = Quat::from_imag(*v_i);
    let r = q.conjugate() * p * q;
    r.imag()
}

/// Elementary rotation about a body axis (0 = x, 1 = y, 2 = z) by `angle_rad`.
#[inline]
fn axis_quat(axis: usize, angle_rad: f32) -> Quat {
    let (s, c) = sin_cos(0.5 * angle_rad);
    match axis {
        0 => Quat::new(c, s, 0.0, 0.0),
        1 => Quat::new(c, 0.0, s, 0.0),
        _ => Quat::new(c, 0.0, 0.0, s),
    }
}

/// Euler rotation sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EulerSeq {
    /// yaw (z), then pitch (y), then roll (x): `q = q_z(ψ) q_y(θ) q_x(φ)`.
    Zyx321,
    /// roll (x), then pitch (y), then yaw (z): `q = q_x(φ) q_y(θ) q_z(ψ)`.
    Xyz123,
}

/// Quaternion from `[roll, pitch, yaw]` in radians.
pub fn quat_from_euler(rpy_rad: [f32; 3], seq: EulerSeq) -> Quat {
    let [r, p, y] = rpy_rad;
    match seq {
        EulerSeq::Zyx321 => axis_quat(2, y) * axis_quat(1, p) * axis_quat(0, r),
        EulerSeq::Xyz123 => axis_quat(0, r) * axis_quat(1, p) * axis_quat(2, y),
    }
}

/// `[roll, pitch, yaw]` in radians from a quaternion. Pitch is clamped to ±90° at the
/// gimbal-lock singularity instead of producing NaN.
pub fn euler_from_quat(q: &Quat, seq: EulerSeq) -> [f32; 3] {
    let (x, y, z, w) = (q.i, q.j, q.k, q.w);
    match seq {
        EulerSeq::Zyx321 => {
            let roll = atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
            let sp = super::clamp_abs(2.0 * (w * y - z * x), 1.0);
            let pitch = asin(sp);
            let yaw = atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
            [roll, pitch, yaw]
        }
        EulerSeq::Xyz123 => {
            // R = Rx(φ) Ry(θ) Rz(ψ): R[0][2] = sin θ.
            let roll = atan2(2.0 * (w * x - y * z), 1.0 - 2.0 * (x * x + y * y));
            let sp = super::clamp_abs(2.0 * (x * z + w * y), 1.0);
            let pitch = asin(sp);
            let yaw = atan2(2.0 * (w * z - x * y), 1.0 - 2.0 * (y * y + z * z));
            [roll, pitch, yaw]
        }
    }
}

/// Principal rotation angle of a quaternion in radians, in `[0, π]`.
pub fn rotation_angle(q: &Quat) -> f32 {
    let v = super::norm(&q.imag());
    2.0 * atan2(v, libm::fabsf(q.w))
}

/// Quaternion of a rotation matrix (body → reference, `v_I = R v_B`), Shepperd's method:
/// the largest of `w², x², y², z²` is taken from the trace and diagonal, the others from
/// the off-diagonal sums, so no division by a small number. Scalar ≥ 0. `None` if `R` is
/// not finite.
pub fn quat_from_rotation_matrix(r: &super::Mat3) -> Option<Quat> {
    if !r.iter().all(|v| v.is_finite()) {
        return None;
    }
    let (m00, m01, m02) = (r.m11, r.m12, r.m13);
    let (m10, m11, m12) = (r.m21, r.m22, r.m23);
    let (m20, m21, m22) = (r.m31, r.m32, r.m33);
    let tr = m00 + m11 + m22;
    let q = if tr >= m00 && tr >= m11 && tr >= m22 {
        let w = 0.5 * sqrt((1.0 + tr).max(0.0));
        let f = 0.25 / w;
        Quat::new(w, (m21 - m12) * f, (m02 - m20) * f, (m10 - m01) * f)
    } else if m00 >= m11 && m00 >= m22 {
        let x = 0.5 * sqrt((1.0 + 2.0 * m00 - tr).max(0.0));
        let f = 0.25 / x;
        Quat::new((m21 - m12) * f, x, (m01 + m10) * f, (m02 + m20) * f)
    } else if m11 >= m22 {
        let y = 0.5 * sqrt((1.0 + 2.0 * m11 - tr).max(0.0));
        let f = 0.25 / y;
        Quat::new((m02 - m20) * f, (m01 + m10) * f, y, (m12 + m21) * f)
    } else {
        let z = 0.5 * sqrt((1.0 + 2.0 * m22 - tr).max(0.0));
        let f = 0.25 / z;
        Quat::new((m10 - m01) * f, (m02 + m20) * f, (m12 + m21) * f, z)
    };
    let q = quat_normalized(&q)?;
    Some(if q.w < 0.0 { -q } else { q })
}

#[cfg(test)]
mod tests {
    use super::*;
    const TOL: f32 = 1e-5;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn hamilton_identity_ijk_is_minus_one() {
        let i = Quat::new(0.0, 1.0, 0.0, 0.0);
        let j = Quat::new(0.0, 0.0, 1.0, 0.0);
        let k = Quat::new(0.0, 0.0, 0.0, 1.0);
        let p = i * j * k;
        assert!(close(p.w, -1.0, 0.0) && p.imag().norm() == 0.0);
    }

    #[test]
    fn yaw_90_maps_body_x_to_reference_y() {
        let q = quat_from_euler([0.0, 0.0, core::f32::consts::FRAC_PI_2], EulerSeq::Zyx321);
        let v = rotate_body_to_ref(&q, &Vec3::new(1.0, 0.0, 0.0));
        assert!((v - Vec3::new(0.0, 1.0, 0.0)).norm() < TOL);
        let back = rotate_ref_to_body(&q, &v);
        assert!((back - Vec3::new(1.0, 0.0, 0.0)).norm() < TOL);
    }

    #[test]
    fn euler_round_trip_both_sequences() {
        let cases = [[0.1, -0.4, 2.5], [-1.2, 0.7, -3.0], [0.0, 1.2, 0.3], [0.05, 0.02, 0.87]];
        for seq in [EulerSeq::Zyx321, EulerSeq::Xyz123] {
            for c in cases {
                let q = quat_from_euler(c, seq);
                assert!(close(q.norm(), 1.0, TOL));
                let e = euler_from_quat(&q, seq);
                for k in 0..3 {
                    assert!(close(e[k], c[k], 1e-4), "{seq:?} {c:?} -> {e:?}");
                }
            }
        }
    }

    #[test]
    fn sequence_321_matches_rotation_matrix_product() {
        // Independent truth: R = Rz(ψ) Ry(θ) Rx(φ) built from elementary matrices.
        let (r, p, y) = (0.3f32, -0.2f32, 1.1f32);
        let rx = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, r.cos(), -r.sin(), 0.0, r.sin(), r.cos());
        let ry = nalgebra::Matrix3::new(p.cos(), 0.0, p.sin(), 0.0, 1.0, 0.0, -p.sin(), 0.0, p.cos());
        let rz = nalgebra::Matrix3::new(y.cos(), -y.sin(), 0.0, y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0);
        let m = rz * ry * rx;
        let q = quat_from_euler([r, p, y], EulerSeq::Zyx321);
        for v in [Vec3::x(), Vec3::y(), Vec3::z(), Vec3::new(0.3, -0.5, 0.8)] {
            assert!((m * v - rotate_body_to_ref(&q, &v)).norm() < TOL);
        }
    }

    #[test]
    fn error_is_identity_at_target_and_short_way() {
        let qc = quat_from_euler([0.2, 0.1, -0.5], EulerSeq::Zyx321);
        let e = attitude_error(&qc, &qc);
        assert!(close(e.w, 1.0, TOL) && e.imag().norm() < TOL);
        // -q is the same attitude: the error must still be the identity with w >= 0.
        let e2 = attitude_error(&(-qc), &qc);
        assert!(close(e2.w, 1.0, TOL));
        // A 10° yaw offset gives a rotation angle of 10°.
        let q = quat_from_euler([0.2, 0.1, -0.5], EulerSeq::Zyx321) * axis_quat(2, 10f32.to_radians());
        assert!(close(rotation_angle(&attitude_error(&q, &qc)).to_degrees(), 10.0, 1e-3));
    }

    #[test]
    fn normalise_rejects_nan_and_zero() {
        assert!(quat_normalized(&Quat::new(f32::NAN, 0.0, 0.0, 0.0)).is_none());
        assert!(quat_normalized(&Quat::new(0.0, 0.0, 0.0, 0.0)).is_none());
        let n = quat_normalized(&Quat::new(2.0, 0.0, 0.0, 0.0)).unwrap();
        assert!(close(n.w, 1.0, 0.0));
    }
}
