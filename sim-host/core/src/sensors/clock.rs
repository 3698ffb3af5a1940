//! The sample clock shared by the sensor models.
//!
//! All sensors are **discrete**. The simulation offers each sensor the true state at every
//! dynamics-substep boundary (after each RK4 substep, and at t = 0); a sample is taken at
//! the first boundary at or after the next point of the sensor's grid
//! `phase_s + k / rate_hz + u_k` (k = 0, 1, …; `u_k` the timing jitter, uniform on
//! `[−jitter_s, +jitter_s]`, one draw per grid point from its own stream). Sample times are
//! therefore quantised to the substep h: a sample is up to one substep late, never early.
//! A boundary that passes several grid points samples once (the skipped points are lost);
//! between samples the model holds its last reading. With phase and jitter zero and a rate
//! that divides the control rate, the samples fall on control steps exactly (the grid
//! test allows 1e-9 of a period of rounding).
//!
//! The sensors have no continuous state; the gyro's bias random walk is propagated exactly
//! (Wiener increment over the actual time between samples) at each sample.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// When a sensor samples and how long its samples take to arrive: the grid and the
/// transport delay of one sensor (`[sensors.<sensor>]` `rate_hz`, `phase_s`, `jitter_s`,
/// `latency_s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleTiming {
    pub rate_hz: f64,
    /// Offset of the grid from t = 0, s, in `[0, 1/rate_hz)`.
    pub phase_s: f64,
    /// Half-width of the uniform timing jitter of each grid point, s, `< 1/(2 rate_hz)`.
    pub jitter_s: f64,
    /// Exposure → delivery, s (≥ 0).
    pub latency_s: f64,
}

impl SampleTiming {
    /// A plain grid `k / rate_hz` without jitter or delay.
    pub fn at_rate(rate_hz: f64) -> Self {
        Self { rate_hz, phase_s: 0.0, jitter_s: 0.0, latency_s: 0.0 }
    }
}

/// Which sensor's sample clock (each has its own [`SampleTiming`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampled {
    Gyro,
    StarTracker,
    Magnetometer,
    Sun,
    Css,
    Gnss,
}

impl Sampled {
    pub const ALL: [Sampled; 6] =
        [Sampled::Gyro, Sampled::StarTracker, Sampled::Magnetometer, Sampled::Sun, Sampled::Css, Sampled::Gnss];

    /// The sensor's table key in a scenario (`sensors.<key>`).
    pub fn key(self) -> &'static str {
        match self {
            Sampled::Gyro => "gyro",
            Sampled::StarTracker => "star_tracker",
            Sampled::Magnetometer => "magnetometer",
            Sampled::Sun => "sun",
            Sampled::Css => "css",
            Sampled::Gnss => "gnss",
        }
    }
}

/// Sample clock: grid `phase + k / rate_hz (+ jitter)` from t = 0.
#[derive(Clone, Debug)]
pub(crate) struct Clock {
    period_s: f64,
    phase_s: f64,
    jitter_s: f64,
    next_k: u64,
    /// Jitter of grid point `next_k`, s.
    next_jitter_s: f64,
    /// Jitter draws (`None` without jitter: nothing drawn).
    jitter_rng: Option<ChaCha8Rng>,
    last_t_s: Option<f64>,
}

impl Clock {
    pub(crate) fn new(rate_hz: f64) -> Self {
        assert!(rate_hz > 0.0 && rate_hz.is_finite(), "sample rate must be > 0");
        Self {
            period_s: 1.0 / rate_hz,
            phase_s: 0.0,
            jitter_s: 0.0,
            next_k: 0,
            next_jitter_s: 0.0,
            jitter_rng: None,
            last_t_s: None,
        }
    }

    /// The same rate with a phase and a jitter (uniform ±`jitter_s`, drawn from `rng`);
    /// before the first sample.
    pub(crate) fn set_grid(&mut self, phase_s: f64, jitter_s: f64, rng: ChaCha8Rng) {
        assert!((0.0..self.period_s).contains(&phase_s), "sample phase must be in [0, period)");
        assert!((0.0..0.5 * self.period_s).contains(&jitter_s), "sample jitter must be in [0, period / 2)");
        self.phase_s = phase_s;
        self.jitter_s = jitter_s;
        self.jitter_rng = (jitter_s > 0.0).then_some(rng);
        self.next_jitter_s = self.draw_jitter();
    }

    fn draw_jitter(&mut self) -> f64 {
        let j = self.jitter_s;
        self.jitter_rng.as_mut().map_or(0.0, |r| r.random_range(-j..=j))
    }

    /// Time of the next grid point (phase and jitter included), s.
    pub(crate) fn next_grid_time_s(&self) -> f64 {
        self.phase_s + (self.next_k as f64) * self.period_s + self.next_jitter_s
    }

    fn tolerance_s(&self) -> f64 {
        1e-9 * self.period_s
    }

    /// Whether a sample is due at `t` (without taking it).
    pub(crate) fn is_due(&self, t: f64) -> bool {
        self.next_grid_time_s() <= t + self.tolerance_s()
    }

    /// `Some(time since the previous sample)` (0 for the first) if a sample is due at `t`;
    /// moves on to the first grid point after `t`.
    pub(crate) fn due(&mut self, t: f64) -> Option<f64> {
        if !self.is_due(t) {
            return None;
        }
        let passed = ((t + self.tolerance_s() - self.phase_s) / self.period_s).floor() as u64 + 1;
        self.next_k = passed.max(self.next_k + 1);
        self.next_jitter_s = self.draw_jitter();
        let dt = self.last_t_s.map_or(0.0, |l| t - l);
        self.last_t_s = Some(t);
        Some(dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::noise::sensor_sub_rng;

    /// Offers a clock the boundaries of a substep `h` for `n` steps; the sample times.
    fn sample_times(clock: &mut Clock, h: f64, n: u32) -> Vec<f64> {
        (0..=n).map(|i| i as f64 * h).filter(|t| clock.due(*t).is_some()).collect()
    }

    #[test]
    fn phase_and_jitter_stay_within_their_bounds() {
        // 7 Hz, phase 0.05 s, jitter ±0.02 s, substep 1 ms over 1000 s: each sample is at
        // the first boundary at or after its grid point, which lies within ±jitter of the
        // nominal phase + k / rate; so the sample is in [nominal − j, nominal + j + h].
        let (rate, phase, jitter, h) = (7.0, 0.05, 0.02, 1e-3);
        let mut c = Clock::new(rate);
        c.set_grid(phase, jitter, sensor_sub_rng(9, 2, 2));
        let times = sample_times(&mut c, h, 1_000_000);
        assert_eq!(times.len(), 7000, "one sample per grid point");
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, t) in times.iter().enumerate() {
            let off = t - (phase + k as f64 / rate);
            assert!(off >= -jitter - 1e-9 && off <= jitter + h + 1e-9, "sample {k} at {t}: offset {off}");
            lo = lo.min(off);
            hi = hi.max(off);
        }
        // The jitter is used: the offsets span most of [−j, j + h].
        assert!(lo < -0.9 * jitter && hi > 0.9 * jitter, "offsets in [{lo}, {hi}]");
    }

    #[test]
    fn without_phase_or_jitter_the_grid_is_k_over_rate() {
        let mut c = Clock::new(4.0);
        c.set_grid(0.0, 0.0, sensor_sub_rng(1, 1, 2));
        // Substep 0.05 s: the 4 Hz grid (0.25 s) falls on every fifth boundary.
        let times = sample_times(&mut c, 0.05, 100);
        assert_eq!(times.len(), 21);
        for (k, t) in times.iter().enumerate() {
            assert!((t - k as f64 * 0.25).abs() < 1e-12, "{k}: {t}");
        }
    }
}
