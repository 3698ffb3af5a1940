//! Noise streams of the sensor models and the draws they share.
//!
//! Each sensor owns a ChaCha8 stream from [`sensor_rng`]`(scenario seed, sensor index)`, so
//! adding, removing or reordering other sensors leaves its noise unchanged (ChaCha:
//! Bernstein 2008, via `rand_chacha`). Every sample draws a fixed number of normals
//! whatever the parameters or validity, so e.g. switching on the bias random walk or an
//! eclipse does not shift the white noise. Indices in use: see [`crate::sensors`].

use crate::attitude::Vec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Noise stream of sensor `index` in a scenario: the key comes from `scenario_seed`, the
/// ChaCha stream (nonce) is `index + 1`. Stream 0 is left to the simulator's existing
/// `SensorSuite`, which uses `ChaCha8Rng::seed_from_u64(seed)`.
pub fn sensor_rng(scenario_seed: u64, index: u32) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(scenario_seed);
    r.set_stream(u64::from(index) + 1);
    r
}

/// A second, independent stream owned by sensor `index` (for a noise source added to an
/// existing model, so that switching it on leaves the model's first stream untouched):
/// ChaCha stream `(sub << 32) | (index + 1)`, disjoint from every [`sensor_rng`] stream
/// for `sub >= 1`.
pub fn sensor_sub_rng(scenario_seed: u64, index: u32, sub: u32) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(scenario_seed);
    r.set_stream((u64::from(sub) << 32) | (u64::from(index) + 1));
    r
}

/// Three independent normals scaled per axis by `sigma` (x, y, z drawn in that order).
pub(crate) fn gauss3(rng: &mut ChaCha8Rng, sigma: &[f64; 3]) -> Vec3 {
    Vec3::from_fn(|i, _| {
        let n: f64 = StandardNormal.sample(rng);
        n * sigma[i]
    })
}
