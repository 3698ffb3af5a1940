//! Rate gyro: a three-axis triad.
//!
//! Input: the true body rate ω at the sample time, rad/s, body axes. Output: the measured
//! rate, rad/s, along the triad's own axes ([`GyroReading`], held between samples).
//!
//! Error model, in the order of the signal chain: misalignment R(θ), scale factor,
//! constant bias, bias random walk (rate random walk K), Gauss–Markov bias instability,
//! white rate noise (angle random walk N), output range (clip) and LSB (round). N and K
//! are the two-parameter gyro model with Allan deviations N/√τ and K √(τ/3) (Allan 1966;
//! IEEE Std 952-1997); the Gauss–Markov bias is discretised exactly (Maybeck vol. 1,
//! §4.11; Farrell & Barth, §4.9). Noise: its own stream ([`sensor_rng`]) for the white
//! noise and random walk, the bias instability on [`sensor_sub_rng`] sub 1.

use super::clock::Clock;
use super::noise::{gauss3, sensor_rng, sensor_sub_rng};
use crate::attitude::Vec3;
use nalgebra::UnitQuaternion;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Sub-stream of the gyro's stream for the angle random walk of its angle increments
/// ([`sensor_sub_rng`]; 1 is the bias instability, 2 the sample-time jitter).
pub const INCREMENT_SUB_STREAM: u32 = 3;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GyroModel {
    pub rate_hz: f64,
    /// Angle random walk N per axis, rad/s/√Hz (= rad/√s). Per-sample white noise σ =
    /// N √rate_hz; Allan deviation N / √τ.
    pub arw_rad_sqrt_s: [f64; 3],
    /// Rate random walk K per axis, rad/s²/√Hz (= rad/s/√s): bias variance grows as K² t;
    /// Allan deviation K √(τ/3).
    pub rrw_rad_s_sqrt_s: [f64; 3],
    /// Constant bias, rad/s.
    pub bias_rad_s: [f64; 3],
    /// Scale-factor error per axis (dimensionless, 1e-3 = 1000 ppm).
    pub scale_factor: [f64; 3],
    /// Misalignment: the triad's axes are the body axes turned by this rotation vector
    /// (rad); the gyro senses `R(θ)ᵀ ω` (components of ω along its own axes). Zero: none.
    #[serde(default)]
    pub misalignment_rad: [f64; 3],
    /// Output range: each axis is clipped to ±this (rad/s). `None`: unlimited.
    #[serde(default)]
    pub saturation_rad_s: Option<f64>,
    /// Output LSB (rad/s): each axis is rounded to the nearest multiple. 0: continuous.
    #[serde(default)]
    pub quantisation_rad_s: f64,
    /// Bias instability: 1σ of a first-order Gauss–Markov bias per axis, rad/s (0: none).
    #[serde(default)]
    pub bias_instability_rad_s: f64,
    /// Correlation time τ of the Gauss–Markov bias, s (> 0 when the instability is on).
    #[serde(default)]
    pub bias_correlation_s: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GyroReading {
    pub t_s: f64,
    pub rate_rad_s: [f64; 3],
    /// False until the first sample.
    pub valid: bool,
}

/// Rate gyro: `ω_m = Q(clip((1 + s) ∘ R(θ)ᵀ ω + b0 + b_rw(t) + b_gm(t) + n))`, per axis:
/// misalignment R(θ), scale factor, biases and noise, then the output range (clip) and the
/// converter's LSB (round to nearest), in the order of the signal chain.
///
/// `b_gm` is a first-order Gauss–Markov process (bias instability) of stationary 1σ σ and
/// correlation time τ, propagated with its exact discretisation over the time Δt since the
/// previous sample, `b ← e^{−Δt/τ} b + σ √(1 − e^{−2Δt/τ}) n` (Maybeck, *Stochastic Models,
/// Estimation and Control* vol. 1, §4.11; Farrell & Barth, *GPS and INS*, §4.9). It
/// starts from its stationary distribution N(0, σ²) at the first sample and draws from its
/// own stream ([`sensor_sub_rng`] sub 1), so switching it on leaves ARW and RRW unchanged.
#[derive(Clone, Debug)]
pub struct Gyro {
    pub spec: GyroModel,
    rng: ChaCha8Rng,
    gm_rng: ChaCha8Rng,
    /// Angle random walk of the angle increments (sub-stream 3: the rate samples' white
    /// noise keeps its sequence).
    increment_rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
    bias_rw: Vec3,
    bias_gm: Vec3,
    gm_started: bool,
    last: GyroReading,
}

impl Gyro {
    pub fn new(spec: GyroModel, scenario_seed: u64, index: u32) -> Self {
        assert!(spec.saturation_rad_s.is_none_or(|s| s > 0.0), "gyro saturation must be > 0");
        assert!(spec.quantisation_rad_s >= 0.0 && spec.quantisation_rad_s.is_finite(), "gyro LSB must be >= 0");
        assert!(
            spec.bias_instability_rad_s == 0.0 || (spec.bias_instability_rad_s > 0.0 && spec.bias_correlation_s > 0.0),
            "gyro bias instability needs σ >= 0 and, when on, a correlation time > 0"
        );
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            gm_rng: sensor_sub_rng(scenario_seed, index, 1),
            increment_rng: sensor_sub_rng(scenario_seed, index, INCREMENT_SUB_STREAM),
            bias_rw: Vec3::zeros(),
            bias_gm: Vec3::zeros(),
            gm_started: false,
            last: GyroReading::default(),
        }
    }

    /// Gauss–Markov bias update over `dt` (exact discretisation; the first call draws the
    /// stationary state). Three normals per sample while on.
    fn step_bias_instability(&mut self, dt: f64) {
        let sigma = self.spec.bias_instability_rad_s;
        if sigma <= 0.0 {
            return;
        }
        let n = gauss3(&mut self.gm_rng, &[1.0; 3]);
        if self.gm_started {
            let phi = (-dt / self.spec.bias_correlation_s).exp();
            self.bias_gm = self.bias_gm * phi + n * (sigma * (1.0 - phi * phi).max(0.0).sqrt());
        } else {
            self.bias_gm = n * sigma;
            self.gm_started = true;
        }
    }

    /// Discrete: true body rate at `t`; samples if due, returns the held reading.
    pub fn update(&mut self, t_s: f64, w_true_rad_s: &[f64; 3]) -> GyroReading {
        if let Some(dt) = self.clock.due(t_s) {
            // A noiseless gyro draws nothing (its stream is its own: no other sensor shifts).
            let noiseless = self.spec.arw_rad_sqrt_s == [0.0; 3] && self.spec.rrw_rad_s_sqrt_s == [0.0; 3];
            let white = if noiseless {
                Vec3::zeros()
            } else {
                let sd = self.spec.rate_hz.sqrt();
                let white = gauss3(&mut self.rng, &self.spec.arw_rad_sqrt_s.map(|n| n * sd));
                let sq = dt.sqrt();
                self.bias_rw += gauss3(&mut self.rng, &self.spec.rrw_rad_s_sqrt_s.map(|k| k * sq));
                white
            };
            self.step_bias_instability(dt);
            let mut w = Vec3::from(*w_true_rad_s);
            // Skipped when zero so that gyros without misalignment keep their exact bits.
            if self.spec.misalignment_rad != [0.0; 3] {
                w = UnitQuaternion::from_scaled_axis(Vec3::from(self.spec.misalignment_rad)).inverse() * w;
            }
            let sf = Vec3::from(self.spec.scale_factor);
            let mut m = w + w.component_mul(&sf) + Vec3::from(self.spec.bias_rad_s) + self.bias_rw + white;
            // Added only when on so that gyros without it keep their exact bits.
            if self.spec.bias_instability_rad_s > 0.0 {
                m += self.bias_gm;
            }
            if let Some(sat) = self.spec.saturation_rad_s {
                m = m.map(|x| x.clamp(-sat, sat));
            }
            let lsb = self.spec.quantisation_rad_s;
            if lsb > 0.0 {
                m = m.map(|x| (x / lsb).round() * lsb);
            }
            self.last = GyroReading { t_s, rate_rad_s: m.into(), valid: true };
        }
        self.last
    }

    pub fn reading(&self) -> GyroReading {
        self.last
    }

    /// The measured angle increment (rad, triad axes) over `interval_s` whose true value is
    /// `angle_true_rad` = ∫ω dt (body axes), with the error model of the rate samples
    /// applied consistently: misalignment and scale factor on the integrated angle, the
    /// bias now (constant + random walk + Gauss–Markov, after this sample's update) times
    /// the interval, and the angle random walk, σ = N √interval per axis (white rate noise
    /// of density N integrates to an angle variance N² T; IEEE Std 952-1997 §B), drawn from
    /// sub-stream [`INCREMENT_SUB_STREAM`]. Not clipped or quantised (an IMU's delta-angle
    /// counter has range and resolution to spare).
    pub fn angle_increment(&mut self, angle_true_rad: &[f64; 3], interval_s: f64) -> [f64; 3] {
        let mut a = Vec3::from(*angle_true_rad);
        if self.spec.misalignment_rad != [0.0; 3] {
            a = UnitQuaternion::from_scaled_axis(Vec3::from(self.spec.misalignment_rad)).inverse() * a;
        }
        let mut m =
            a + a.component_mul(&Vec3::from(self.spec.scale_factor)) + Vec3::from(self.bias_rad_s()) * interval_s;
        if self.spec.arw_rad_sqrt_s != [0.0; 3] {
            let sd = interval_s.max(0.0).sqrt();
            m += gauss3(&mut self.increment_rng, &self.spec.arw_rad_sqrt_s.map(|n| n * sd));
        }
        m.into()
    }

    /// Current total bias (constant + random walk + Gauss–Markov), rad/s — truth for
    /// estimator tests.
    pub fn bias_rad_s(&self) -> [f64; 3] {
        (Vec3::from(self.spec.bias_rad_s) + self.bias_rw + self.bias_gm).into()
    }

    /// Current Gauss–Markov (bias instability) part of the bias, rad/s.
    pub fn bias_instability_state_rad_s(&self) -> [f64; 3] {
        self.bias_gm.into()
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::magnetometer::{Magnetometer, MagnetometerModel};
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Overlapping Allan deviation of a rate series sampled at `tau0`, cluster size `m`.
    fn adev(rate: &[f64], tau0: f64, m: usize) -> f64 {
        let mut theta = vec![0.0; rate.len() + 1];
        for (k, w) in rate.iter().enumerate() {
            theta[k + 1] = theta[k] + w * tau0;
        }
        let n = theta.len();
        let tau = m as f64 * tau0;
        let s: f64 = (0..n - 2 * m)
            .map(|k| {
                let d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
                d * d
            })
            .sum();
        (s / (2.0 * tau * tau * (n - 2 * m) as f64)).sqrt()
    }

    /// Least-squares slope of log σ against log τ.
    fn slope(pts: &[(f64, f64)]) -> f64 {
        let l: Vec<(f64, f64)> = pts.iter().map(|(t, s)| (t.ln(), s.ln())).collect();
        let n = l.len() as f64;
        let (mx, my) = (l.iter().map(|p| p.0).sum::<f64>() / n, l.iter().map(|p| p.1).sum::<f64>() / n);
        l.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / l.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
    }

    fn gyro_spec() -> GyroModel {
        GyroModel {
            rate_hz: 10.0,
            arw_rad_sqrt_s: [1e-3, 2e-3, 5e-4],
            rrw_rad_s_sqrt_s: [1e-4, 5e-5, 2e-4],
            bias_rad_s: [0.0; 3],
            scale_factor: [0.0; 3],
            misalignment_rad: [0.0; 3],
            saturation_rad_s: None,
            quantisation_rad_s: 0.0,
            bias_instability_rad_s: 0.0,
            bias_correlation_s: 0.0,
        }
    }

    #[test]
    fn gyro_allan_deviation() {
        // 8 independent gyros (sensor indices 0..8), 10⁵ s each at 10 Hz; Allan variances
        // averaged over the runs (long-τ estimates have few degrees of freedom).
        let spec = gyro_spec();
        let (f, n, runs) = (spec.rate_hz, 1_000_000, 8);
        let short_m = [1usize, 2, 4, 8]; // τ = 0.1 … 0.8 s (ARW region, τ ≪ √3 N/K ≥ 4 s)
        let long_m = [5000usize, 10000, 20000]; // τ = 500 … 2000 s (RRW region)
        let mut avar = [[0.0; 7]; 3];
        for run in 0..runs {
            let mut g = Gyro::new(spec, 7, run);
            let mut series = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for k in 0..n {
                let r = g.update(k as f64 / f, &[0.0; 3]);
                for a in 0..3 {
                    series[a][k] = r.rate_rad_s[a];
                }
            }
            for a in 0..3 {
                for (j, &m) in short_m.iter().chain(&long_m).enumerate() {
                    avar[a][j] += adev(&series[a], 1.0 / f, m).powi(2) / runs as f64;
                }
            }
        }
        for a in 0..3 {
            let (nn, kk) = (spec.arw_rad_sqrt_s[a], spec.rrw_rad_s_sqrt_s[a]);
            let pts: Vec<(f64, f64)> =
                short_m.iter().chain(&long_m).zip(avar[a]).map(|(&m, v)| (m as f64 / f, v.sqrt())).collect();
            let (short, long) = pts.split_at(short_m.len());
            let (ss, sl) = (slope(short), slope(long));
            let arw_fit = short.iter().map(|(t, s)| s * t.sqrt()).sum::<f64>() / short.len() as f64;
            // RRW magnitude with the (small) white-noise share removed.
            let rrw_fit =
                long.iter().map(|(t, s)| ((s * s - nn * nn / t) * 3.0 / t).sqrt()).sum::<f64>() / long.len() as f64;
            println!(
                "axis {a}: short slope {ss:+.3}, N fit {arw_fit:.4e} (true {nn:.1e}, {:+.1}%); \
                 long slope {sl:+.3}, K fit {rrw_fit:.4e} (true {kk:.1e}, {:+.1}%)",
                100.0 * (arw_fit / nn - 1.0),
                100.0 * (rrw_fit / kk - 1.0)
            );
            assert!((ss + 0.5).abs() < 0.03, "ARW slope {ss}");
            assert!((arw_fit / nn - 1.0).abs() < 0.10, "ARW {arw_fit}");
            assert!((sl - 0.5).abs() < 0.1, "RRW slope {sl}");
            assert!((rrw_fit / kk - 1.0).abs() < 0.2, "RRW {rrw_fit}");
        }
    }

    #[test]
    fn bias_random_walk_variance_grows_linearly() {
        let mut spec = gyro_spec();
        spec.arw_rad_sqrt_s = [0.0; 3];
        spec.bias_rad_s = [1.0, 2.0, 3.0];
        let (runs, checks) = (4000, [10usize, 100, 1000]); // sample counts at 10 Hz
        let mut sum2 = [[0.0; 3]; 3];
        for r in 0..runs {
            let mut g = Gyro::new(spec, 1234, r as u32);
            let mut ci = 0;
            for k in 0..=1000 {
                g.update(k as f64 / spec.rate_hz, &[0.0; 3]);
                if k == checks[ci] {
                    let b = g.bias_rad_s();
                    for a in 0..3 {
                        sum2[ci][a] += (b[a] - spec.bias_rad_s[a]).powi(2);
                    }
                    ci = (ci + 1).min(2);
                }
            }
        }
        for (ci, &k) in checks.iter().enumerate() {
            let t = k as f64 / spec.rate_hz;
            for a in 0..3 {
                let ratio = sum2[ci][a] / runs as f64 / (spec.rrw_rad_s_sqrt_s[a].powi(2) * t);
                println!("t = {t:6.1} s axis {a}: var / (K² t) = {ratio:.3}");
                // 4000 runs: 1σ of a variance estimate is √(2/4000) = 2.2 %.
                assert!((ratio - 1.0).abs() < 0.08, "{ratio}");
            }
        }
    }

    #[test]
    fn gyro_scale_factor_bias_and_hold() {
        let spec = GyroModel {
            rate_hz: 4.0,
            arw_rad_sqrt_s: [0.0; 3],
            rrw_rad_s_sqrt_s: [0.0; 3],
            bias_rad_s: [1e-3, 0.0, -1e-3],
            scale_factor: [0.01, -0.02, 0.0],
            misalignment_rad: [0.0; 3],
            saturation_rad_s: None,
            quantisation_rad_s: 0.0,
            bias_instability_rad_s: 0.0,
            bias_correlation_s: 0.0,
        };
        let mut g = Gyro::new(spec, 1, 0);
        let r = g.update(0.0, &[0.1, 0.1, 0.1]);
        assert!(r.valid);
        let want = [0.101 + 1e-3, 0.098, 0.1 - 1e-3];
        for a in 0..3 {
            assert!((r.rate_rad_s[a] - want[a]).abs() < 1e-15);
        }
        // Held until the next 0.25 s grid point (steps of 0.1 s: sample at 0.3).
        assert_eq!(g.update(0.1, &[0.0; 3]), r);
        assert_eq!(g.update(0.2, &[0.0; 3]), r);
        let r2 = g.update(0.3, &[0.0; 3]);
        assert_eq!((r2.t_s, r2.rate_rad_s), (0.3, [1e-3, 0.0, -1e-3]));
        assert_eq!(g.update(0.4, &[5.0; 3]), r2);
    }

    fn noiseless_gyro() -> GyroModel {
        GyroModel { arw_rad_sqrt_s: [0.0; 3], rrw_rad_s_sqrt_s: [0.0; 3], ..gyro_spec() }
    }

    #[test]
    fn gyro_misalignment_rotates_a_known_rate() {
        // Triad turned 90° about body z: its x axis is body y, its y axis is body −x, so a
        // body rate (1, 2, 3) reads (2, −1, 3).
        let spec = GyroModel { misalignment_rad: [0.0, 0.0, std::f64::consts::FRAC_PI_2], ..noiseless_gyro() };
        let r = Gyro::new(spec, 1, 0).update(0.0, &[1.0, 2.0, 3.0]);
        let want = [2.0, -1.0, 3.0];
        for a in 0..3 {
            assert!((r.rate_rad_s[a] - want[a]).abs() < 1e-15, "{:?}", r.rate_rad_s);
        }
        // Small misalignment θ: reading ≈ ω − θ × ω to first order, error O(|θ|² |ω|).
        let th = [1e-3, -2e-3, 0.5e-3];
        let spec = GyroModel { misalignment_rad: th, ..noiseless_gyro() };
        let w = Vec3::new(0.1, -0.05, 0.2);
        let r = Gyro::new(spec, 1, 0).update(0.0, &w.into());
        let lin = w - Vec3::from(th).cross(&w);
        assert!((Vec3::from(r.rate_rad_s) - lin).norm() < 1e-5 * w.norm(), "{:?} vs {lin:?}", r.rate_rad_s);
        // A rotation preserves the magnitude exactly.
        assert!((Vec3::from(r.rate_rad_s).norm() - w.norm()).abs() < 1e-15);
    }

    #[test]
    fn gyro_saturation_clips_exactly() {
        let spec = GyroModel { saturation_rad_s: Some(0.5), bias_rad_s: [0.1, 0.0, 0.0], ..noiseless_gyro() };
        let mut g = Gyro::new(spec, 1, 0);
        // Axis x: 0.45 + bias 0.1 exceeds the range; y, z inside / below it.
        let r = g.update(0.0, &[0.45, 0.3, -7.0]);
        assert_eq!(r.rate_rad_s, [0.5, 0.3, -0.5]);
        let r = g.update(1.0, &[0.39, -0.5, 0.5]);
        assert!((r.rate_rad_s[0] - 0.49).abs() < 1e-15);
        assert_eq!(&r.rate_rad_s[1..], &[-0.5, 0.5]);
    }

    #[test]
    fn gyro_quantisation_error_is_uniform_within_half_lsb() {
        // Noiseless gyro fed a ramp of golden-ratio × LSB steps (~62 000 LSBs): the
        // fractional part of ω/LSB is equidistributed: the error q(ω) − ω must stay in ±LSB/2 with
        // mean 0 and variance LSB²/12 (uniform quantisation noise).
        let lsb = 1e-4;
        let spec = GyroModel { quantisation_rad_s: lsb, ..noiseless_gyro() };
        let mut g = Gyro::new(spec, 1, 0);
        let n = 100_000;
        let step = 0.618_033_988_749_895 * lsb;
        let (mut sum, mut sum2, mut max) = (0.0, 0.0, 0.0_f64);
        for k in 0..n {
            let w = -0.05 + k as f64 * step;
            let (w0, w1) = (w, 2.0 * w + 0.01);
            let r = g.update(k as f64 / spec.rate_hz, &[w0, w1, 0.0]);
            for (a, &wa) in [w0, w1].iter().enumerate() {
                let e = r.rate_rad_s[a] - wa;
                let lsbs = r.rate_rad_s[a] / lsb;
                assert!((lsbs - lsbs.round()).abs() < 1e-6, "not on the LSB grid: {lsbs}");
                sum += e;
                sum2 += e * e;
                max = max.max(e.abs());
            }
        }
        let m = 2.0 * n as f64;
        let (mean, var) = (sum / m, sum2 / m - (sum / m).powi(2));
        let ratio = var / (lsb * lsb / 12.0);
        println!(
            "quantisation: mean {:.2e} LSB, var / (LSB²/12) = {ratio:.4}, max |e| {:.4} LSB",
            mean / lsb,
            max / lsb
        );
        assert!(max <= 0.5 * lsb * (1.0 + 1e-9), "{max}");
        // Equidistributed (not random) fractional parts: deviations O(1/n), far below 1 %.
        assert!(mean.abs() < 0.01 * lsb, "{mean}");
        assert!((ratio - 1.0).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn gyro_bias_instability_is_gauss_markov() {
        // σ = 1e-4 rad/s, τ = 20 s at 10 Hz; 8 gyros × 40 000 s (2000 τ each). Truth: a
        // stationary first-order Gauss–Markov process has variance σ² and autocorrelation
        // e^{−|lag|/τ}, so e^{−1} at lag τ.
        let (sigma, tau, f) = (1e-4, 20.0, 10.0);
        let spec = GyroModel { bias_instability_rad_s: sigma, bias_correlation_s: tau, rate_hz: f, ..noiseless_gyro() };
        let (n, runs, lag) = (400_000usize, 8u32, (tau * f) as usize);
        let (mut s2, mut c_lag, mut m) = (0.0, 0.0, 0.0);
        let mut c_lag_n = 0.0;
        for run in 0..runs {
            let mut g = Gyro::new(spec, 99, run);
            let mut series = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for k in 0..n {
                let r = g.update(k as f64 / f, &[0.0; 3]);
                let b = g.bias_instability_state_rad_s();
                for a in 0..3 {
                    // Noise-free gyro at rest: the reading is the bias.
                    assert_eq!(r.rate_rad_s[a], b[a]);
                    series[a][k] = b[a];
                }
            }
            for x in &series {
                for k in 0..n {
                    s2 += x[k] * x[k];
                    m += 1.0;
                    if k + lag < n {
                        c_lag += x[k] * x[k + lag];
                        c_lag_n += 1.0;
                    }
                }
            }
        }
        let var = s2 / m;
        let rho = (c_lag / c_lag_n) / var;
        println!(
            "Gauss–Markov: var / σ² = {:.4}, autocorrelation at τ = {rho:.4} (e^-1 = 0.3679)",
            var / sigma.powi(2)
        );
        // Variance estimate of an AR(1) series: relative 1σ ≈ √(2τ/T) = √(2·20/960 000 s) = 0.6 %.
        assert!((var / sigma.powi(2) - 1.0).abs() < 0.04, "{var}");
        // Autocorrelation estimate: 1σ ≈ √(τ/T) ≈ 0.5 %; tolerance 0.02.
        assert!((rho - (-1.0f64).exp()).abs() < 0.02, "{rho}");
    }

    #[test]
    fn gyro_bias_instability_adds_to_an_unchanged_white_noise() {
        // Own stream: with the instability on, the reading is the same white noise and
        // random walk plus the Gauss–Markov state (to rounding).
        let base = gyro_spec();
        let on = GyroModel { bias_instability_rad_s: 3e-4, bias_correlation_s: 5.0, ..base };
        let (mut a, mut b) = (Gyro::new(base, 5, 1), Gyro::new(on, 5, 1));
        for k in 0..1000 {
            let t = k as f64 / base.rate_hz;
            let (ra, rb) = (a.update(t, &[0.01, 0.0, -0.02]), b.update(t, &[0.01, 0.0, -0.02]));
            let gm = b.bias_instability_state_rad_s();
            assert!(gm.iter().all(|x| *x != 0.0));
            for i in 0..3 {
                assert!((rb.rate_rad_s[i] - ra.rate_rad_s[i] - gm[i]).abs() < 1e-15, "{k} {i}");
            }
        }
    }

    #[test]
    fn determinism_and_independent_streams() {
        let spec = gyro_spec();
        let run = |seed, idx, with_other: bool| {
            let mut g = Gyro::new(spec, seed, idx);
            let mut other = Magnetometer::new(
                MagnetometerModel {
                    rate_hz: 10.0,
                    noise_t: [1e-7; 3],
                    bias_t: [0.0; 3],
                    coupling_t_per_am2: [[0.0; 3]; 3],
                    misalignment_rad: [0.0; 3],
                },
                seed,
                idx + 1,
            );
            (0..1000)
                .map(|k| {
                    let t = k as f64 / 10.0;
                    if with_other {
                        other.update(t, &[1e-5; 3], &[0.0; 3]);
                    }
                    g.update(t, &[0.01, 0.0, 0.0]).rate_rad_s.map(f64::to_bits)
                })
                .collect::<Vec<_>>()
        };
        let a = run(42, 0, false);
        assert_eq!(a, run(42, 0, false), "same seed, same bits");
        assert_eq!(a, run(42, 0, true), "another sensor does not disturb this one");
        assert_ne!(a, run(42, 1, false), "other index, other stream");
        assert_ne!(a, run(43, 0, false), "other seed, other stream");
        // Stream 0 (the existing SensorSuite's) is not used by index 0.
        let mut legacy = ChaCha8Rng::seed_from_u64(42);
        let mut idx0 = sensor_rng(42, 0);
        let (x, y): (f64, f64) = (StandardNormal.sample(&mut legacy), StandardNormal.sample(&mut idx0));
        assert_ne!(x.to_bits(), y.to_bits());
    }
}
