//! The sample clock shared by the sensor models.
//!
//! All sensors are **discrete**: the suite calls each model's `update(t, truth…)` once per
//! dynamics step boundary (after the RK4 step, with the true state at `t`). A sample is
//! taken when `t` reaches the next point of the sensor's grid `k / rate_hz` (k = 0, 1, …;
//! a step that skips a grid point samples once, late, at `t`); between samples the last
//! reading is held. The sensors have no continuous state; the gyro's bias random walk is
//! propagated exactly (Wiener increment over the actual time between samples) at each
//! sample.

/// Sample clock: grid `k / rate_hz` from t = 0.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Clock {
    period_s: f64,
    next_k: u64,
    last_t_s: Option<f64>,
}

impl Clock {
    pub(crate) fn new(rate_hz: f64) -> Self {
        assert!(rate_hz > 0.0 && rate_hz.is_finite(), "sample rate must be > 0");
        Self { period_s: 1.0 / rate_hz, next_k: 0, last_t_s: None }
    }

    /// `Some(time since the previous sample)` (0 for the first) if a sample is due at `t`.
    pub(crate) fn due(&mut self, t: f64) -> Option<f64> {
        let tol = 1e-9 * self.period_s;
        if (self.next_k as f64) * self.period_s > t + tol {
            return None;
        }
        self.next_k = ((t + tol) / self.period_s).floor() as u64 + 1;
        let dt = self.last_t_s.map_or(0.0, |l| t - l);
        self.last_t_s = Some(t);
        Some(dt)
    }
}
