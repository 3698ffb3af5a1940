//! `[f64; 3]` vector helpers for tests whose data are plain arrays (thruster columns,
//! torque demands). nalgebra's arithmetic, the same sums in the same order as the
//! hand-written `a[0] * b[0] + a[1] * b[1] + a[2] * b[2]` they replaced.

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

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-identical to the component formulas the tests used before.
    #[test]
    fn same_bits_as_the_component_formulas() {
        let mut r = crate::rng::SplitMix64(3);
        for _ in 0..10_000 {
            let (a, b) = (r.matrix(1)[0].map(|x| x * 1e3), r.matrix(1)[0].map(|x| x * 1e-3));
            let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
            assert_eq!(dot(&a, &b).to_bits(), d.to_bits());
            assert_eq!(cross(&a, &b).map(f64::to_bits), c.map(f64::to_bits));
            assert_eq!(norm(&a).to_bits(), (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().to_bits());
        }
    }
}
