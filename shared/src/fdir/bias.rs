//! The gyro bias-step monitor of the estimation stage (issue 42; docs/fdir.md "Gyro bias
//! step").
//!
//! A step in a gyro's bias makes the filter's propagated attitude drift from the truth at
//! the step's rate: the star tracker's innovation `y = 2 vec(q̂⁻¹ ⊗ q_meas)` grows
//! linearly, `dy/dt = −Δb` (body axes; the `−ω × y` term is negligible over a window of a
//! few samples), until the filter's gate rejects it. Test (a sequential χ² test with
//! persistence): a tracker sample whose NIS exceeds the filter's own gate (χ²₃ at
//! 0.999, [`crate::estimation::mekf::CHI2_3DOF_999`]; per-sample false-alarm probability
//! 1e-3 on a consistent filter) is an exceedance; `k` of the last `n` judged samples
//! declare a bias step ([`super::window`]: the binomial tail).
//!
//! Isolation: a rejected tracker sample says only that the filter and the tracker
//! disagree. The estimation stage judges a sample here only when the star-tracker monitor
//! found the Sun or the field (at least one witness) agreeing with it and no exceedance in
//! its window, so the tracker is right and the propagation — the gyro — is wrong. The step
//! is the least-squares slope of the rejected samples' innovations over their times,
//! `Δb = −Σ(tᵢ−t̄)(yᵢ−ȳ) / Σ(tᵢ−t̄)²`; its 1σ on axis i is `σᵢ / √Σ(tᵢ−t̄)²` (`σᵢ`: the
//! innovation's 1σ on that axis, filter and tracker; the tracker's noise about its
//! boresight is ten times its cross-boresight noise). In those σ units, `zᵢ = Δbᵢ/σ(Δbᵢ)`,
//! the axis is the one with `|zᵢ| ≥` [`MIN_SIGMA`] carrying at least [`AXIS_SHARE`]
//! of `|z|²`; otherwise the step is `ambiguous` (several axes). A slope with `|z| <`
//! [`MIN_SIGMA`] is not declared (the window goes on): rejections without a drift are a
//! tracker that jumped by a small angle or a step too small for the noise to tell, and the
//! filter's divergence rule (`max_consecutive_rejections`) stays in charge of them.
//!
//! Recovery (in the estimation stage): the filter restarts on the tracker with the bias
//! estimate plus the step and the bias σ raised to cover the slope's error, instead of
//! waiting for `max_consecutive_rejections` and restarting with a zero bias.
//!
//! Repeated steps (an erratic axis): a bias steps once. An axis named by
//! [`ERRATIC_STEPS`] declarations within [`ERRATIC_SPAN_S`] is not stepping but noisy or
//! erratic (the issue-42 gyro-noise campaign: a ×10–×1000 noisier axis was declared as
//! hundreds of steps per run, each restarting the filter): the step that completes the count
//! comes back with `erratic` set, and the estimation stage declares the axis failed (read as
//! 0, as a stuck one) instead of restarting. Ambiguous steps are not counted (no axis).

use super::window::Persistence;
use crate::math::{Vec3, f32m};
use crate::params::fdir::{KOfN, MAX_WINDOW};

/// An axis carrying this share of the step's square (in σ units) names the axis.
pub const AXIS_SHARE: f32 = 0.8;
/// A step is declared only when it is this many σ of its error (`|z|`), and an axis
/// named only when its own component is.
pub const MIN_SIGMA: f32 = 3.0;

/// Declarations on one axis within [`ERRATIC_SPAN_S`] that make it erratic (a genuine step
/// is declared once; a second may follow when the first slope was short).
pub const ERRATIC_STEPS: u8 = 3;
/// The span those declarations fall in, s.
pub const ERRATIC_SPAN_S: f32 = 600.0;

/// Rejected samples kept for the slope (the window's largest `n`).
const KEPT: usize = MAX_WINDOW as usize;

/// A declared bias step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasStep {
    /// The step, to add to the bias estimate, rad/s (body axes).
    pub rate_rad_s: Vec3,
    /// `1 / √Σ(tᵢ−t̄)²`, 1/s: the slope's 1σ per unit of innovation noise.
    pub slope_sigma_per_rad: f32,
    /// The axis (0 x, 1 y, 2 z); `None`: ambiguous.
    pub axis: Option<u8>,
    /// The axis's [`ERRATIC_STEPS`]th declaration within [`ERRATIC_SPAN_S`]: not a step but
    /// an erratic axis.
    pub erratic: bool,
}

/// The monitor's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasStepMonitor {
    persistence: Persistence,
    /// Innovations of the rejected samples in the window (judged-sample number, time, y),
    /// oldest first.
    rejected: [(u32, u64, Vec3); KEPT],
    kept: usize,
    /// Samples judged since the window last started (wraps; only differences are used).
    judged: u32,
    last_time_us: Option<u64>,
    events: u16,
    last: Option<BiasStep>,
    /// Per axis: declarations counted and the time of the first of them, µs.
    per_axis: [(u8, u64); 3],
}

impl Default for BiasStepMonitor {
    fn default() -> Self {
        Self::new()
    }
}

impl BiasStepMonitor {
    pub const fn new() -> Self {
        Self {
            persistence: Persistence::new(),
            rejected: [(0, 0, Vec3::new(0.0, 0.0, 0.0)); KEPT],
            kept: 0,
            judged: 0,
            last_time_us: None,
            events: 0,
            last: None,
            per_axis: [(0, 0); 3],
        }
    }

    /// Judges one tracker sample at `time_us` (a repeated tag is not judged): `rejected`,
    /// `None` when the filter's gate accepted it, else its innovation against the filter
    /// and the innovation's 1σ per body axis (for the isolation) — formed by the caller
    /// only for a rejection (a rejected update leaves the filter as it was), so an accepted
    /// sample costs a shift and a popcount. Only a rejected sample can declare. Returns the step when this sample declares one; the window then starts
    /// again (a later step is a new event). A non-finite innovation is not judged (the
    /// star-tracker monitor owns a non-finite tracker).
    pub fn judge(&mut self, window: &KOfN, time_us: u64, rejected: Option<(Vec3, Vec3)>) -> Option<BiasStep> {
        let finite = rejected.is_none_or(|(y, _)| y.iter().all(|x| x.is_finite()));
        if self.last_time_us == Some(time_us) || !finite {
            return None;
        }
        self.last_time_us = Some(time_us);
        self.judged = self.judged.wrapping_add(1);
        // Only the rejections among the last n judged samples count for the slope.
        let n = u32::from(window.n);
        let judged = self.judged;
        self.forget(|seq| judged.wrapping_sub(seq) >= n);
        let Some((innovation_rad, noise_rad)) = rejected else {
            self.persistence.push(window, false);
            return None;
        };
        self.keep(time_us, &innovation_rad);
        if !self.persistence.push(window, true) {
            return None;
        }
        let step = self.slope(&noise_rad).map(|s| BiasStep { erratic: self.count_on_axis(s.axis, time_us), ..s });
        if step.is_some() {
            self.events = self.events.saturating_add(1);
            self.last = step;
            self.clear_window();
        }
        step
    }

    /// Counts a declaration on `axis` at `time_us`; true when it is the axis's
    /// [`ERRATIC_STEPS`]th within [`ERRATIC_SPAN_S`] of the first counted.
    fn count_on_axis(&mut self, axis: Option<u8>, time_us: u64) -> bool {
        let Some(slot) = axis.and_then(|i| self.per_axis.get_mut(usize::from(i))) else { return false };
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // 6e8 µs
        let span_us = (ERRATIC_SPAN_S * 1.0e6) as u64;
        let within = slot.0 > 0 && time_us.checked_sub(slot.1).is_some_and(|d| d <= span_us);
        *slot = if within { (slot.0.saturating_add(1), slot.1) } else { (1, time_us) };
        slot.0 >= ERRATIC_STEPS
    }

    /// Keeps a rejected sample; after [`Self::forget`] at most `n − 1 ≤ 31` are kept, so
    /// there is room.
    fn keep(&mut self, time_us: u64, y: &Vec3) {
        if let Some(slot) = self.rejected.get_mut(self.kept) {
            *slot = (self.judged, time_us, *y);
            self.kept = self.kept.saturating_add(1);
        }
    }

    /// Drops the oldest kept samples while `old(their number)` holds (they are kept in
    /// order, so the old ones are a prefix).
    fn forget(&mut self, old: impl Fn(u32) -> bool) {
        let kept = self.rejected.get(..self.kept).unwrap_or(&[]);
        let drop = kept.iter().take_while(|(seq, _, _)| old(*seq)).count();
        if drop == 0 {
            return;
        }
        // Shifted by hand, not `copy_within` (its range check is a panic path on the
        // target); at most `KEPT` rounds.
        for i in 0..self.kept {
            let moved = i.checked_add(drop).and_then(|j| self.rejected.get(j).copied());
            if let (Some(v), Some(slot)) = (moved, self.rejected.get_mut(i)) {
                *slot = v;
            }
        }
        self.kept = self.kept.saturating_sub(drop);
    }

    /// The least-squares slope of the kept innovations (module doc); `None` with fewer
    /// than two distinct times or a non-finite result.
    fn slope(&self, noise_rad: &Vec3) -> Option<BiasStep> {
        let kept = self.rejected.get(..self.kept)?;
        let (_, t0, _) = *kept.first()?;
        // Kept in time order (fresh tags only), so u ≥ t0; a window spans seconds, so the
        // µs difference is exact enough in f32.
        #[allow(clippy::cast_precision_loss)]
        let t = |u: u64| u.checked_sub(t0).map(|us| us as f32 * 1.0e-6);
        // ≤ 32 samples: exact in f32.
        #[allow(clippy::cast_precision_loss)]
        let count = kept.len() as f32;
        let t_mean = kept.iter().map(|(_, u, _)| t(*u).unwrap_or(0.0)).sum::<f32>() / count;
        let y_mean = kept.iter().fold(Vec3::zeros(), |a, (_, _, y)| a + y) / count;
        let (mut sxx, mut sxy) = (0.0f32, Vec3::zeros());
        for (_, u, y) in kept {
            let dt = t(*u)? - t_mean;
            sxx += dt * dt;
            sxy += (y - y_mean) * dt;
        }
        if !(sxx > 0.0) {
            return None;
        }
        let rate_rad_s = -sxy / sxx;
        let slope_sigma_per_rad = 1.0 / f32m::sqrt(sxx);
        if !(rate_rad_s.iter().all(|x| x.is_finite()) && slope_sigma_per_rad.is_finite()) {
            return None;
        }
        // In σ units; a zero or non-finite noise gives a non-finite z: no axis.
        let z = rate_rad_s.component_div(&(noise_rad * slope_sigma_per_rad));
        let square = z.norm_squared();
        // NaN (a zero noise) passes: the step is then declared with no axis named.
        if square < MIN_SIGMA * MIN_SIGMA {
            return None;
        }
        let named = |x: f32| libm::fabsf(x) >= MIN_SIGMA && x * x >= AXIS_SHARE * square;
        let axis = (0u8..3).find(|i| square.is_finite() && z.get(usize::from(*i)).is_some_and(|x| named(*x)));
        Some(BiasStep { rate_rad_s, slope_sigma_per_rad, axis, erratic: false })
    }

    fn clear_window(&mut self) {
        self.persistence.clear();
        self.kept = 0;
        self.judged = 0;
    }

    /// Bias steps declared since boot (saturating; a clear does not lower it).
    pub fn events(&self) -> u16 {
        self.events
    }

    /// The last declared step (telemetry).
    pub fn last(&self) -> Option<BiasStep> {
        self.last
    }

    /// The ground's clear: the window and the per-axis counts start again (the last step
    /// stays in the telemetry).
    pub fn clear(&mut self) {
        self.clear_window();
        self.last_time_us = None;
        self.per_axis = [(0, 0); 3];
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn the_third_step_on_one_axis_within_the_span_is_an_erratic_axis() {
        let mut m = BiasStepMonitor::new();
        let s = |t: f32| (t * 1.0e6) as u64;
        assert!(!m.count_on_axis(Some(0), s(100.0)));
        assert!(!m.count_on_axis(Some(1), s(150.0)), "another axis counts apart");
        assert!(!m.count_on_axis(None, s(160.0)), "an ambiguous step is not counted");
        assert!(!m.count_on_axis(Some(0), s(400.0)));
        assert!(m.count_on_axis(Some(0), s(100.0 + ERRATIC_SPAN_S)), "3 within the span, its end included");
        // Beyond the span from the first counted: the count starts again.
        let mut m = BiasStepMonitor::new();
        assert!(!m.count_on_axis(Some(2), s(0.0)));
        assert!(!m.count_on_axis(Some(2), s(500.0)));
        assert!(!m.count_on_axis(Some(2), s(ERRATIC_SPAN_S + 1.0)));
        assert!(!m.count_on_axis(Some(2), s(ERRATIC_SPAN_S + 2.0)));
        assert!(m.count_on_axis(Some(2), s(ERRATIC_SPAN_S + 3.0)));
        m.clear();
        assert!(!m.count_on_axis(Some(2), s(ERRATIC_SPAN_S + 4.0)), "a clear forgets the counts");
        // An out-of-range axis is never counted (no panic).
        assert!(!m.count_on_axis(Some(7), s(1.0)));
    }
    use super::*;

    const W: KOfN = KOfN { k: 3, n: 4 };
    const NOISE: Vec3 = Vec3::new(1e-4, 1e-4, 1e-3);

    /// Judges samples every 0.5 s from `t0_us` with the innovation of a filter drifting
    /// at `-step` since `t0_us` (noise-free), all rejected; returns the declaring sample's
    /// index and the step.
    fn drift(m: &mut BiasStepMonitor, t0_us: u64, step: Vec3) -> Option<(u32, BiasStep)> {
        (1..=10u32).find_map(|i| {
            let t = t0_us + u64::from(i) * 500_000;
            let y = -step * (i as f32 * 0.5);
            m.judge(&W, t, Some((y, NOISE))).map(|s| (i, s))
        })
    }

    #[test]
    fn a_linear_drift_is_declared_after_exactly_k_rejections_with_its_rate_and_axis() {
        let mut m = BiasStepMonitor::new();
        let step = Vec3::new(2e-3, 0.0, 0.0);
        let (i, s) = drift(&mut m, 1_000_000, step).expect("declared");
        assert_eq!(i, u32::from(W.k));
        // Noise-free line: the least-squares slope is exact (f32 rounding).
        assert!((s.rate_rad_s - step).norm() < 1e-7, "{:?}", s.rate_rad_s);
        assert_eq!(s.axis, Some(0));
        // Three samples 0.5 s apart: Σ(t − t̄)² = 0.5 s².
        assert!((s.slope_sigma_per_rad - 1.0 / 0.5f32.sqrt()).abs() < 1e-5);
        assert_eq!((m.events(), m.last()), (1, Some(s)));
        // The window starts again: the next k samples of the same drift are a new step.
        let again = drift(&mut m, 10_000_000, step).expect("a second step");
        assert_eq!((again.0, m.events()), (u32::from(W.k), 2));
    }

    #[test]
    fn a_step_between_axes_is_ambiguous_and_a_dominant_one_names_its_axis() {
        // The slope's σ is √2 × the noise: 1e-3 rad/s on x and y is 7 σ each, neither
        // 80 % of the square; 1e-3 on x plus 2e-3 on z (boresight noise 1e-3 rad) is
        // z = (7.1, 0, 1.4): x.
        let mut m = BiasStepMonitor::new();
        assert_eq!(drift(&mut m, 0, Vec3::new(1e-3, 1e-3, 0.0)).map(|x| x.1.axis), Some(None));
        let mut m = BiasStepMonitor::new();
        assert_eq!(drift(&mut m, 0, Vec3::new(1e-3, 0.0, 2e-3)).map(|x| x.1.axis), Some(Some(0)));
        let mut m = BiasStepMonitor::new();
        assert_eq!(drift(&mut m, 0, Vec3::new(0.0, 0.0, 1e-2)).map(|x| x.1.axis), Some(Some(2)));
    }

    #[test]
    fn rejections_without_a_drift_beyond_3_sigma_are_not_a_bias_step() {
        // 1e-3 rad/s on z is 0.7 σ of the slope with the boresight's noise; a constant
        // innovation (a tracker that jumped) has no slope at all.
        let mut m = BiasStepMonitor::new();
        assert_eq!(drift(&mut m, 0, Vec3::new(0.0, 0.0, 1e-3)), None);
        let mut m = BiasStepMonitor::new();
        let jump = Vec3::new(2e-3, 0.0, 0.0);
        assert!((1..50u64).all(|i| m.judge(&W, i * 500_000, Some((jump, NOISE))).is_none()));
        assert_eq!(m.events(), 0);
    }

    #[test]
    fn rejections_outside_the_window_do_not_count_and_accepted_samples_never_declare() {
        let mut m = BiasStepMonitor::new();
        let y = Vec3::new(1e-3, 0.0, 0.0);
        // Two rejections, n accepted, two rejections: never 3 of the last 4.
        let pattern = [true, true, false, false, false, false, true, true, false, false];
        for (i, r) in pattern.iter().enumerate() {
            assert_eq!(m.judge(&W, i as u64 * 500_000, r.then_some((y, NOISE))), None, "sample {i}");
        }
        for i in 20..200u64 {
            assert_eq!(m.judge(&W, i * 500_000, None), None);
        }
        assert_eq!(m.events(), 0);
    }

    #[test]
    fn a_repeated_tag_or_a_non_finite_innovation_is_not_judged_and_a_zero_noise_names_no_axis() {
        let mut m = BiasStepMonitor::new();
        let y = Vec3::new(1e-3, 0.0, 0.0);
        for _ in 0..10 {
            assert_eq!(m.judge(&W, 7, Some((y, NOISE))), None);
        }
        for bad in [f32::NAN, f32::INFINITY] {
            assert_eq!(m.judge(&W, 8, Some((Vec3::new(bad, 0.0, 0.0), NOISE))), None);
        }
        // One judged rejection so far (the first at t = 7): two more declare.
        assert_eq!(m.judge(&W, 9, Some((y * 2.0, NOISE))), None);
        let s = m.judge(&W, 10, Some((y * 3.0, NOISE))).expect("declared");
        assert!(s.rate_rad_s.iter().all(|x| x.is_finite()));
        // A zero noise (absurd parameters) names no axis rather than dividing by zero.
        let mut z = BiasStepMonitor::new();
        let zero = Vec3::zeros();
        let declared = (1..=3u64).find_map(|i| z.judge(&W, i, Some((y * i as f32, zero))));
        assert_eq!(declared.map(|s| s.axis), Some(None));
    }
}
