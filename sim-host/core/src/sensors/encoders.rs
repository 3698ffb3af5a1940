//! Gimbal encoders and wheel tachometers.
//!
//! Input: the true gimbal angles, rad, and each wheel's speed relative to the body, rad/s.
//! Output: the measured angles and speeds, on every frame (at the control rate).
//!
//! Error model: white noise of a fixed σ, one normal per gimbal and then one per wheel on
//! each frame, both from the suite's stream 0 (`ChaCha8Rng::seed_from_u64(seed)`), so the
//! order of the calls is part of the noise: gimbals first, then wheels.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The encoders of the gimbals and the tachometers of the wheels, sharing one stream.
#[derive(Clone)]
pub struct Encoders {
    /// Stream 0 of the scenario seed.
    rng: ChaCha8Rng,
    /// 1σ gimbal-angle noise, rad.
    gimbal_sigma_rad: f64,
    /// 1σ wheel-speed noise, rad/s.
    wheel_sigma_rad_s: f64,
}

impl Encoders {
    pub fn new(scenario_seed: u64, gimbal_sigma_rad: f64, wheel_sigma_rad_s: f64) -> Self {
        Self { rng: ChaCha8Rng::seed_from_u64(scenario_seed), gimbal_sigma_rad, wheel_sigma_rad_s }
    }

    /// One normal of σ `sigma` (none drawn when σ is 0).
    fn gauss(&mut self, sigma: f64) -> f64 {
        if sigma > 0.0 {
            let n: f64 = StandardNormal.sample(&mut self.rng);
            n * sigma
        } else {
            0.0
        }
    }

    /// One gimbal's measured angle, rad, for its true angle.
    pub fn gimbal_angle(&mut self, true_rad: f64) -> f64 {
        true_rad + self.gauss(self.gimbal_sigma_rad)
    }

    /// 1σ of a tachometer reading, rad/s.
    pub fn wheel_sigma_rad_s(&self) -> f64 {
        self.wheel_sigma_rad_s
    }

    /// One wheel's measured speed relative to the body, rad/s, for the true one.
    pub fn wheel_speed(&mut self, true_rad_s: f64) -> f64 {
        true_rad_s + self.gauss(self.wheel_sigma_rad_s)
    }
}
