//! `[f64; 3]` vector helpers for tests whose data are plain arrays (thruster columns,
//! torque demands). nalgebra's arithmetic, the same sums in the same order as the
//! hand-written `a[0] * b[0] + a[1] * b[1] + a[2] * b[2]` they replaced (checked bit for
//! bit, with `sim_core::vec3`, in sim-host/core/src/vec3.rs).

use nalgebra::Vector3;

pub type V3 = [f64; 3];

pub fn dot(a: &V3, b: &V3) -> f64 {
    Vector3::from(*a).dot(&Vector3::from(*b))
}

pub fn cross(a: &V3, b: &V3) -> V3 {
    Vector3::from(*a).cross(&Vector3::from(*b)).into()
}

pub fn norm(a: &V3) -> f64 {
    dot(a, a).sqrt()
}

pub fn scale(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a / |a|` (as `a · (1/|a|)`).
pub fn unit(a: &V3) -> V3 {
    scale(a, 1.0 / norm(a))
}

/// Fibonacci-sphere directions (deterministic, near-uniform).
pub fn sphere(n: usize) -> Vec<V3> {
    let ga = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = ga * i as f64;
            [r * t.cos(), r * t.sin(), z]
        })
        .collect()
}

/// `v` rotated by the quaternion `q = [x, y, z, w]` (scalar last, normalised here; body →
/// reference for the simulator's attitude): `v + 2w (u × v) + 2 u × (u × v)`, written apart
/// from nalgebra's quaternion product so that a test checks the simulator against it.
pub fn rotate_xyzw(q: &[f64; 4], v: &V3) -> V3 {
    let [x, y, z, w] = *q;
    let n = (x * x + y * y + z * z + w * w).sqrt();
    let (w, u) = (w / n, [x / n, y / n, z / n]);
    let c = |a: &V3, b: &V3| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = c(&u, v).map(|e| 2.0 * e);
    let ut = c(&u, &t);
    [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]]
}
