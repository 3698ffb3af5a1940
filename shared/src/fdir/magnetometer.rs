//! The magnetometer monitor of the estimation stage (issue 42; docs/fdir.md
//! "Magnetometer"): the measured field against the on-board field model, and a stuck axis.
//!
//! - **Field magnitude.** `r = |B_meas| − |B_model|`, T. The magnitude needs no attitude, so
//!   the test holds in a tumble, in eclipse and with a wrong attitude estimate. With white
//!   noise σ_m per axis and |B| ≫ σ_m, `|B + n| − |B| ≈ B̂·n ~ N(0, σ_m²)`; the model's own
//!   error (its degree, the navigation's position, the secular variation) is a slow offset
//!   of 1σ σ_model. A sample is an exceedance when `|r| > γ √(σ_m² + σ_model²)`
//!   (two-sided Gaussian tail per sample: γ = 5 → 5.7e-7); `k` of the last `n` declare.
//!   It sees a bias along the field (a bias `b` moves `|B|` by ≈ `B̂·b`) and a stuck axis
//!   as soon as the field has turned away from the stuck value; it cannot see a bias
//!   perpendicular to the field at that instant (the persistence waits for the field to
//!   turn).
//! - **Stuck axis** ([`super::repeat`]): a live axis carries noise far above its f32
//!   resolution; more than `max_repeats` exact repeats over fresh samples is stuck. It names
//!   the axis; the magnitude test names only the magnetometer (ambiguous axis).
//!
//! Recovery (documented): once either test fires, the magnetometer is dropped from the
//! estimation (no MEKF update, no TRIAD start, no witness for the star-tracker monitor).
//! The laws that use the field itself (B-dot, magnetic momentum dumping) are not changed.
//! A non-finite reading is an exceedance; without a model magnitude (no navigation, no
//! field node yet) only the stuck test runs.

use super::repeat::Repeats;
use super::window::Persistence;
use crate::math::{Vec3, f32m};
use crate::params::fdir::MagnetometerFdirParams;

/// The monitor's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagnetometerMonitor {
    persistence: Persistence,
    repeats: Repeats<3>,
    last_time_us: Option<u64>,
    /// Declared by the magnitude test.
    magnitude_failed: bool,
    /// Bit i: axis i (x, y, z) declared stuck.
    stuck_axes: u8,
    events: u16,
    /// The last judged residual and its threshold, T (telemetry; 0 when not judged).
    last_residual_t: f32,
    last_threshold_t: f32,
    /// The threshold of the parameters it was computed for (a square root, once per set).
    threshold: Option<(MagnetometerFdirParams, f32)>,
}

impl MagnetometerMonitor {
    pub const fn new() -> Self {
        Self {
            persistence: Persistence::new(),
            repeats: Repeats::EMPTY,
            last_time_us: None,
            magnitude_failed: false,
            stuck_axes: 0,
            events: 0,
            last_residual_t: 0.0,
            last_threshold_t: 0.0,
            threshold: None,
        }
    }

    /// `γ √(σ_m² + σ_model²)`, T, computed when the parameters change.
    fn threshold_t(&mut self, p: &MagnetometerFdirParams) -> f32 {
        match self.threshold {
            Some((q, t)) if q == *p => t,
            _ => {
                let t = p.threshold_sigma * f32m::sqrt(p.noise_t * p.noise_t + p.model_sigma_t * p.model_sigma_t);
                self.threshold = Some((*p, t));
                t
            }
        }
    }

    /// Judges a fresh sample (a repeated time tag is not judged): `field_t` measured in
    /// body axes, `model_t` the model's magnitude at its time (`None`: unknown).
    pub fn judge(&mut self, p: &MagnetometerFdirParams, time_us: u64, field_t: &Vec3, model_t: Option<f32>) {
        if self.last_time_us == Some(time_us) {
            return;
        }
        self.last_time_us = Some(time_us);
        let was_magnitude = self.magnitude_failed;
        // Bits 0..=2 of a u32 mask of three components: fits a u8.
        let stuck = u8::try_from(self.repeats.push(p.max_repeats, &[field_t.x, field_t.y, field_t.z]) & 0b111);
        let new_stuck = stuck.unwrap_or(0) & !self.stuck_axes;
        self.stuck_axes |= new_stuck;
        (self.last_residual_t, self.last_threshold_t) = (0.0, 0.0);
        if let Some(model) = model_t {
            let threshold = self.threshold_t(p);
            // |r| ≤ t ⇔ (m − t)² ≤ |B|² ≤ (m + t)² (for m > t; else any |B| ≥ 0 passes
            // below): exact, and no square root in the step (≈ 200 instructions each on the
            // Cortex-M4F, `f32m::sqrt`). NaN compares false: a non-finite reading or model
            // is an exceedance.
            let n2 = field_t.norm_squared();
            let hi = (model + threshold) * (model + threshold);
            let lo = if model > threshold { (model - threshold) * (model - threshold) } else { 0.0 };
            let exceeded = !(lo <= n2 && n2 <= hi);
            self.magnitude_failed |= self.persistence.push(&p.window, exceeded);
            // Telemetry: r to first order, (|B|² − m²) / 2m = r + r²/2m (0.02 nT at r = 1 µT,
            // m = 30 µT); the test above is exact.
            let residual = if model > 0.0 { (n2 - model * model) / (2.0 * model) } else { f32::NAN };
            (self.last_residual_t, self.last_threshold_t) = (residual, threshold);
        }
        // One event per verdict: newly stuck axes (one step), the magnitude test.
        let new_verdicts = u16::from(new_stuck != 0).saturating_add(u16::from(!was_magnitude && self.magnitude_failed));
        self.events = self.events.saturating_add(new_verdicts);
    }

    /// Either test has fired: the magnetometer is no longer used by the estimation.
    pub fn failed(&self) -> bool {
        self.magnitude_failed || self.stuck_axes != 0
    }

    /// Declared by the magnitude test (the axis unknown).
    pub fn magnitude_failed(&self) -> bool {
        self.magnitude_failed
    }

    /// Bit i: axis i declared stuck.
    pub fn stuck_axes(&self) -> u8 {
        self.stuck_axes
    }

    /// The last judged residual `|B_meas| − |B_model|` and its threshold, T.
    pub fn last_residual_t(&self) -> (f32, f32) {
        (self.last_residual_t, self.last_threshold_t)
    }

    /// Verdicts since boot: each step that declared axes stuck, each magnitude declaration
    /// (saturating; a clear does not lower it).
    pub fn events(&self) -> u16 {
        self.events
    }

    /// The ground re-enables the magnetometer: verdicts and history forgotten, events kept.
    pub fn clear(&mut self) {
        *self = Self { events: self.events, ..Self::new() };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::fdir::KOfN;

    fn params() -> MagnetometerFdirParams {
        MagnetometerFdirParams {
            noise_t: 1.0e-7,
            model_sigma_t: 2.0e-7,
            threshold_sigma: 5.0,
            window: KOfN { k: 3, n: 4 },
            max_repeats: 3,
        }
    }

    #[test]
    fn a_magnitude_off_by_more_than_the_threshold_declares_after_k_samples_and_once() {
        let p = params();
        let mut m = MagnetometerMonitor::new();
        let model = 3.0e-5;
        // sqrt(1e-14 + 4e-14) * 5 = 1.118e-6 T.
        let threshold = 5.0 * (5.0e-14f32).sqrt();
        for i in 0..20u64 {
            // Healthy (noise-like wiggle well inside the threshold), then 2 µT off from 10 on.
            let off = if i >= 10 { 2.0e-6 } else { 1.0e-7 * (i as f32).sin() };
            // The direction turns (no axis repeats: that would be the stuck test).
            let b = Vec3::new(0.6, 1e-3 * (i + 1) as f32, 0.8).normalize() * (model + off);
            m.judge(&p, i * 500_000, &b, Some(model));
            m.judge(&p, i * 500_000, &b, Some(model)); // a repeated tag is not judged
            assert_eq!(m.failed(), i >= 12, "sample {i}");
        }
        let (r, t) = m.last_residual_t();
        // The first-order residual: r + r²/2m.
        let want = 2.0e-6 + 2.0e-6 * 2.0e-6 / (2.0 * model);
        assert!((r - want).abs() < 1e-9 && (t - threshold).abs() < 1e-10, "{r} {want} {t}");
        assert_eq!((m.events(), m.magnitude_failed(), m.stuck_axes()), (1, true, 0));
        m.clear();
        assert_eq!((m.failed(), m.events()), (false, 1));
    }

    #[test]
    fn a_stuck_axis_is_named_and_a_nan_reading_is_an_exceedance() {
        let p = params();
        let mut m = MagnetometerMonitor::new();
        for i in 0..5u64 {
            let live = 1.0e-5 + 1.0e-8 * i as f32;
            m.judge(&p, i, &Vec3::new(live, 2.0e-5, -live), None);
        }
        // Sample 0 sets y; 1..=4 repeat it: the 4th repeat exceeds 3. No model: no residual.
        assert_eq!((m.stuck_axes(), m.magnitude_failed(), m.last_residual_t()), (0b010, false, (0.0, 0.0)));
        let mut m = MagnetometerMonitor::new();
        for i in 0..3u64 {
            m.judge(&p, i, &Vec3::new(f32::NAN, 1.0 + i as f32, 0.0), Some(1.0));
        }
        assert!(m.magnitude_failed());
    }
}
