//! `[f64; 3]` vector helpers for the models and tools whose data are plain arrays (wheel
//! geometry, thruster columns). nalgebra's arithmetic (the simulator's vector type): its
//! 3-vector `dot` and `cross` compute `a0 b0 + a1 b1 + a2 b2` and the component
//! differences in the same order as the hand-written formulas they replaced, so results
//! are bit-identical.

use nalgebra::Vector3;

/// `a · b`.
pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    Vector3::from(*a).dot(&Vector3::from(*b))
}

/// `a × b`.
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    Vector3::from(*a).cross(&Vector3::from(*b)).into()
}

/// `|a|` (`√(a · a)`).
pub fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Same bits as the component formulas, over seeded data of mixed magnitudes; the
    /// tests' helpers (`acs_test_support::vec3`) too.
    #[test]
    fn bit_identical_to_the_component_formulas() {
        let mut rng = acs_test_support::rng::SplitMix64(11);
        for _ in 0..10_000 {
            let a = [rng.range(-1e3, 1e3), rng.range(-1.0, 1.0), rng.range(-1e-3, 1e-3)];
            let b = [rng.range(-1.0, 1.0), rng.range(-1e3, 1e3), rng.range(-1e6, 1e6)];
            let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
            assert_eq!(dot(&a, &b).to_bits(), d.to_bits());
            assert_eq!(cross(&a, &b).map(f64::to_bits), c.map(f64::to_bits));
            assert_eq!(norm(&a).to_bits(), (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().to_bits());
            use acs_test_support::vec3 as support;
            assert_eq!(support::dot(&a, &b).to_bits(), d.to_bits());
            assert_eq!(support::cross(&a, &b).map(f64::to_bits), c.map(f64::to_bits));
            assert_eq!(support::norm(&a).to_bits(), norm(&a).to_bits());
        }
    }
}
