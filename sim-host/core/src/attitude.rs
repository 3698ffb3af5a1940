//! f64 attitude helpers for the simulator, in the project convention (see
//! `acs_flight::math`): Hamilton, scalar-last storage, `q_ib` rotates body → reference.

use acs_flight::math::EulerSeq;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

pub type Quat = Quaternion<f64>;
pub type Vec3 = Vector3<f64>;

fn axis(a: usize, ang: f64) -> Quat {
    let (s, c) = (0.5 * ang).sin_cos();
    match a {
        0 => Quat::new(c, s, 0.0, 0.0),
        1 => Quat::new(c, 0.0, s, 0.0),
        _ => Quat::new(c, 0.0, 0.0, s),
    }
}

/// Quaternion from `[roll, pitch, yaw]` in radians.
pub fn quat_from_euler(rpy: [f64; 3], seq: EulerSeq) -> Quat {
    let [r, p, y] = rpy;
    match seq {
        EulerSeq::Zyx321 => axis(2, y) * axis(1, p) * axis(0, r),
        EulerSeq::Xyz123 => axis(0, r) * axis(1, p) * axis(2, y),
    }
}

/// `[roll, pitch, yaw]` in radians.
pub fn euler_from_quat(q: &Quat, seq: EulerSeq) -> [f64; 3] {
    let u = UnitQuaternion::from_quaternion(*q);
    match seq {
        EulerSeq::Zyx321 => {
            let (r, p, y) = u.euler_angles();
            [r, p, y]
        }
        EulerSeq::Xyz123 => {
            let (x, y, z, w) = (q.i, q.j, q.k, q.w);
            let n = q.norm_squared();
            let roll = (2.0 * (w * x - y * z)).atan2(n - 2.0 * (x * x + y * y));
            let pitch = (2.0 * (x * z + w * y) / n).clamp(-1.0, 1.0).asin();
            let yaw = (2.0 * (w * z - x * y)).atan2(n - 2.0 * (y * y + z * z));
            [roll, pitch, yaw]
        }
    }
}

pub fn to_xyzw(q: &Quat) -> [f64; 4] {
    [q.i, q.j, q.k, q.w]
}

pub fn from_xyzw(q: [f64; 4]) -> Quat {
    Quat::new(q[3], q[0], q[1], q[2])
}

/// Principal angle of the rotation from `q_cmd` to `q`, rad, in `[0, π]`.
pub fn error_angle(q: &Quat, q_cmd: &Quat) -> f64 {
    error_angle_and_vector(q, q_cmd).0
}

/// Rotation vector of the error from `q_cmd` to `q` in body axes, rad: the axis of
/// `e = q_cmd* ⊗ q` times its principal angle (shortest way round, so its norm is
/// [`error_angle`]).
pub fn error_vector(q: &Quat, q_cmd: &Quat) -> [f64; 3] {
    error_angle_and_vector(q, q_cmd).1
}

/// [`error_angle`] and [`error_vector`] from one product `e = q_cmd* ⊗ q` (the run loop
/// needs both every step).
pub fn error_angle_and_vector(q: &Quat, q_cmd: &Quat) -> (f64, [f64; 3]) {
    let e = q_cmd.conjugate() * q;
    // The short way round: `-e` is the same rotation.
    let v = if e.w < 0.0 { -e.imag() } else { e.imag() };
    let s = v.norm();
    let angle = 2.0 * s.atan2(e.w.abs());
    if s == 0.0 {
        return (angle, [0.0; 3]);
    }
    let k = angle / s;
    (angle, [v.x * k, v.y * k, v.z * k])
}

/// Express a reference-frame vector in body axes: `v_B = q* ⊗ v_I ⊗ q`.
pub fn rotate_ref_to_body(q: &Quat, v: &Vec3) -> Vec3 {
    UnitQuaternion::new_unchecked(*q).inverse_transform_vector(v)
}

/// Rotation matrix taking body vectors to the reference frame.
pub fn dcm_body_to_ref(q: &Quat) -> nalgebra::Matrix3<f64> {
    UnitQuaternion::from_quaternion(*q).to_rotation_matrix().into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f64_host_and_f32_flight_conversions_agree() {
        // Two independent implementations of the convention must agree.
        for seq in [EulerSeq::Zyx321, EulerSeq::Xyz123] {
            for rpy in [[0.1, -0.4, 2.5], [-1.2, 0.7, -3.0], [0.063, 0.036, 0.218]] {
                let q = quat_from_euler(rpy, seq);
                let qf = acs_flight::math::quat_from_euler(rpy.map(|x| x as f32), seq);
                let d = (q.coords - qf.coords.map(|x| x as f64)).norm();
                assert!(d < 1e-6, "{seq:?} {rpy:?}");
                let back = euler_from_quat(&q, seq);
                for k in 0..3 {
                    assert!((back[k] - rpy[k]).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn nalgebra_euler_is_the_321_sequence() {
        let q = quat_from_euler([0.3, -0.2, 1.1], EulerSeq::Zyx321);
        let n = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        assert!((q.coords - n.quaternion().coords).norm() < 1e-15);
    }

    #[test]
    fn error_angle_of_a_yaw_offset() {
        let a = quat_from_euler([0.0, 0.0, 0.2], EulerSeq::Zyx321);
        let b = quat_from_euler([0.0, 0.0, 0.9], EulerSeq::Zyx321);
        assert!((error_angle(&a, &b) - 0.7).abs() < 1e-12);
        assert!((error_angle(&(-a), &a)).abs() < 1e-12);
    }
}
