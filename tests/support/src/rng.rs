//! Seeded generators for tests, benches and examples: reproducible, tiny, no dependency.
//! Tests pin their seeds, so these must keep drawing exactly the numbers of the copies
//! they replaced (one generator each, pasted into eight files before).

use nalgebra::{Quaternion, Vector3};

/// SplitMix64 (Steele, Lea & Flood 2014), with uniform and Box–Muller normal draws.
/// Construct with the seed: `SplitMix64(seed)`.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1): the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }

    /// Uniform integer in [0, n) (modulo; the bias is negligible for test sizes).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// Standard normal by Box–Muller (one of the pair; two uniforms per draw).
    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// Three standard normals.
    pub fn vec(&mut self) -> Vector3<f64> {
        Vector3::new(self.normal(), self.normal(), self.normal())
    }

    /// Uniform direction on the unit sphere (normalised Gaussian vector).
    pub fn unit(&mut self) -> Vector3<f64> {
        self.vec().normalize()
    }

    /// Uniform attitude (normalised Gaussian 4-vector; `w` drawn first).
    pub fn quat(&mut self) -> Quaternion<f64> {
        Quaternion::new(self.normal(), self.normal(), self.normal(), self.normal()).normalize()
    }

    /// Uniform direction on the unit sphere by rejection from the cube [−1, 1)³ (the
    /// thruster tests' draw; a different stream from [`Self::unit`]).
    pub fn unit3(&mut self) -> [f64; 3] {
        loop {
            let v = [self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0)];
            let n = crate::vec3::norm(&v);
            if n > 1e-3 && n <= 1.0 {
                return [v[0] / n, v[1] / n, v[2] / n];
            }
        }
    }

    /// `n` columns with entries uniform in [−1, 1).
    pub fn matrix(&mut self, n: usize) -> Vec<[f64; 3]> {
        (0..n).map(|_| [self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0)]).collect()
    }
}

/// Knuth's MMIX linear congruential generator (multiplier 6364136223846793005, increment
/// 1442695040888963407): the cheaper stream some tests and benches draw their data from.
/// Construct with the seed: `Lcg64(seed)`.
#[derive(Clone, Debug)]
pub struct Lcg64(pub u64);

impl Lcg64 {
    /// The next state (also the output).
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1): the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [−1, 1).
    pub fn symmetric(&mut self) -> f64 {
        self.uniform() * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first outputs of SplitMix64 from seed 0 (the published reference values).
    #[test]
    fn splitmix64_matches_the_reference_sequence() {
        let mut r = SplitMix64(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
    }

    /// Some copies wrote the Box–Muller angle `TAU * u2`: the same number as `2π * u2`.
    #[test]
    fn two_pi_is_tau_to_the_bit() {
        assert_eq!((2.0 * std::f64::consts::PI).to_bits(), std::f64::consts::TAU.to_bits());
    }

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut r = SplitMix64(7);
        let mut l = Lcg64(7);
        for _ in 0..10_000 {
            assert!((0.0..1.0).contains(&r.uniform()));
            assert!((-2.0..3.0).contains(&r.range(-2.0, 3.0)));
            assert!(r.below(5) < 5);
            assert!((crate::vec3::norm(&r.unit3()) - 1.0).abs() < 1e-12);
            assert!((r.unit().norm() - 1.0).abs() < 1e-12);
            assert!((-1.0..1.0).contains(&l.symmetric()));
        }
    }
}
