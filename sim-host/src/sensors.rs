//! Sensor models: attitude sensor (star tracker / AHRS) with small-rotation white noise,
//! rate gyro with white noise and constant bias, gimbal encoders with white noise.
//! One seeded ChaCha stream per run: same scenario and seed, same bits.

use crate::attitude::{Quat, Vec3, to_xyzw};
use crate::plant::State;
use crate::scenario::Sensors as SensorSpec;
use acs_flight::protocol::{SensorFrame, valid};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

pub struct SensorSuite {
    rng: ChaCha8Rng,
    att_sigma_rad: f64,
    rate_sigma_rad_s: f64,
    rate_bias_rad_s: Vec3,
    gimbal_sigma_rad: f64,
}

impl SensorSuite {
    pub fn new(s: &SensorSpec) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(s.seed),
            att_sigma_rad: s.attitude_noise_deg.to_radians(),
            rate_sigma_rad_s: s.rate_noise_rad_s,
            rate_bias_rad_s: s.rate_bias_rad_s.into(),
            gimbal_sigma_rad: s.gimbal_noise_deg.to_radians(),
        }
    }

    fn gauss3(&mut self, sigma: f64) -> Vec3 {
        if sigma == 0.0 {
            return Vec3::zeros();
        }
        Vec3::from_fn(|_, _| {
            let n: f64 = StandardNormal.sample(&mut self.rng);
            n * sigma
        })
    }

    /// Measure the true state at time `t_s`.
    pub fn sample(&mut self, seq: u32, t_s: f64, s: &State, n_gimbals: usize) -> SensorFrame {
        // Attitude: q_meas = q ⊗ δq, δq a small body-frame rotation of angle ~ N(0, σ²) per axis.
        let e = self.gauss3(self.att_sigma_rad);
        let q_meas = if e == Vec3::zeros() {
            s.q
        } else {
            let dq = Quat::from_parts(1.0, e * 0.5);
            (s.q * dq).normalize()
        };
        let w = s.w + self.rate_bias_rad_s + self.gauss3(self.rate_sigma_rad_s);
        let mut g = [0.0f32; 4];
        for (i, x) in g.iter_mut().enumerate().take(n_gimbals) {
            let noise: f64 = if self.gimbal_sigma_rad > 0.0 {
                let n: f64 = StandardNormal.sample(&mut self.rng);
                n * self.gimbal_sigma_rad
            } else {
                0.0
            };
            *x = (s.gimbal_rad[i] + noise) as f32;
        }
        SensorFrame {
            q_ib_xyzw: to_xyzw(&q_meas).map(|x| x as f32),
            rate_rad_s: [w.x as f32, w.y as f32, w.z as f32],
            gimbal_angle_rad: g,
            valid: valid::ATTITUDE | valid::RATE | valid::GIMBALS,
            ..SensorFrame::empty(seq, (t_s * 1e6).round() as u64)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::MAX_GIMBALS;

    fn state() -> State {
        State {
            q: Quat::identity(),
            w: Vec3::new(0.01, 0.02, 0.03),
            gimbal_rad: [0.0; MAX_GIMBALS],
            wheels: Default::default(),
        }
    }

    #[test]
    fn ideal_sensors_return_the_truth() {
        let mut s = SensorSuite::new(&SensorSpec::default());
        let f = s.sample(3, 1.5, &state(), 4);
        assert_eq!(f.q_ib_xyzw, [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(f.rate_rad_s, [0.01, 0.02, 0.03]);
        assert_eq!(f.time_us, 1_500_000);
    }

    #[test]
    fn noise_statistics_and_determinism() {
        let spec = SensorSpec {
            seed: 42,
            attitude_noise_deg: 2.0,
            rate_noise_rad_s: 1e-3,
            rate_bias_rad_s: [1e-4, 0.0, 0.0],
            gimbal_noise_deg: 0.0,
        };
        let (mut a, mut b) = (SensorSuite::new(&spec), SensorSuite::new(&spec));
        let n = 20_000;
        let (mut sum_ang2, mut sum_w) = (0.0, 0.0);
        for k in 0..n {
            let fa = a.sample(k, 0.0, &state(), 4);
            assert_eq!(fa, b.sample(k, 0.0, &state(), 4), "same seed, same bits");
            let q = Quat::new(
                fa.q_ib_xyzw[3] as f64,
                fa.q_ib_xyzw[0] as f64,
                fa.q_ib_xyzw[1] as f64,
                fa.q_ib_xyzw[2] as f64,
            );
            let ang = 2.0 * q.imag().norm().atan2(q.w);
            sum_ang2 += ang * ang;
            sum_w += fa.rate_rad_s[0] as f64 - 0.01;
        }
        // Rotation angle² of a 3-axis N(0, σ²) small rotation has mean 3σ².
        let rms = (sum_ang2 / n as f64 / 3.0).sqrt().to_degrees();
        assert!((rms - 2.0).abs() < 0.05, "per-axis rms {rms} deg");
        // Bias shows in the mean: 1e-4 ± 3 σ/√n.
        let mean = sum_w / n as f64;
        assert!(
            (mean - 1e-4).abs() < 3.0 * 1e-3 / (n as f64).sqrt(),
            "{mean}"
        );
    }
}
