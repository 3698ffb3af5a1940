//! The GNSS monitor of the estimation stage (issue 42; docs/fdir.md "GNSS"): each fix
//! against the last accepted one carried to its time by the navigation's two-body step,
//! in position and in velocity.
//!
//! Position residual `d = |r_fix − r_pred|`, m, with `r_pred` the last accepted fix
//! propagated over `Δt` to the new fix's time
//! ([`crate::estimation::navigation::Navigation::predict_fix`]: up to 4 s, the usual 1 s at
//! 1 Hz, a second-order Taylor step of two-body motion; beyond, the navigation's Kepler
//! step). With white noise σ_r per axis on every fix's position and σ_v on its velocity,
//! the difference is, per axis, `n_new − n_old − Δt n_v`: normal with variance
//! `σ_d² = 2σ_r² + (σ_v Δt)²`, so `d²/σ_d² ~ χ²₃`. What the two-body step leaves out (J2,
//! drag: an acceleration `a` it does not model) adds at most `½ a Δt²`, and the f32
//! propagation's rounding (with the Taylor step's truncation) at most [`ROUNDING_M`]. A
//! fix exceeds when `d > γ σ_d + ½ a Δt² + ROUNDING_M`.
//!
//! Velocity residual `e = |v_fix − v_pred|`, m/s: per axis `n_v,new − n_v,old − G Δt n_r,old`
//! (G the gravity gradient, eigenvalues `2μ/r³, −μ/r³, −μ/r³`), variance at most
//! `σ_e² = 2σ_v² + (g Δt σ_r)²` with `g` = [`GRAVITY_GRADIENT_MAX_S2`] (the second term is
//! 1.9e-5 m/s at 1 s: it matters only across long gaps), so `e²/σ_e² ≤ χ²₃`. The model
//! adds at most `a Δt`, the step's truncation at most
//! [`crate::models::orbit::short_step_velocity_truncation_m_s`] (≤ 4 s) and the rounding
//! at most [`ROUNDING_M_S`]` (1 + n Δt)` (n the fastest mean motion: the Kepler step's
//! rounding grows with the mean anomaly). It exceeds when `e > γ σ_e + a Δt + …`: 0.386 m/s
//! at 1 Hz with the 3U's 0.05 m/s receiver.
//!
//! A fix is an exceedance when either test exceeds: per fix at most `2 P(χ²₃ > γ²)`,
//! γ = 5 → 3.0e-5, γ = 6 → 1.5e-7 (on the bound's side: the model terms only widen it);
//! `k` of the last `n` judged fixes declare the receiver failed.
//!
//! What it sees: a jump of the reported position (a receiver re-acquiring on a wrong
//! solution), a frozen position with a fresh time (the spacecraft moves 7.5 km/s), any
//! offset larger than the threshold (≈ 40 m at 1 Hz with the 3U's 5 m receiver); a
//! corrupt velocity (≈ 0.4 m/s at 1 Hz) — which, taken, would make every later good fix
//! look like a jump against the orbit carried with it and the healthy receiver declared
//! failed. What it cannot see: a slow drift below the thresholds per fix; the first fix
//! after boot or a clear (nothing to judge it against: taken); an orbit manoeuvre (a Δv
//! the two-body step does not know) is seen as a jump — a spacecraft that fires thrusters
//! must raise `model_accel_m_s2` to its thrust acceleration or clear the fault after a burn.
//!
//! Recovery (the estimation stage): an exceeding fix is not taken by the navigation (the
//! last good fix goes on being propagated, so one bad fix neither moves the orbit nor
//! makes the next good one look like a jump); once declared, no fix is taken until
//! `ClearSensorFaults`. The navigation carries the last good fix for up to
//! [`crate::estimation::navigation::MAX_FIX_AGE_S`]; then the modes that need it lose
//! their input and the mode manager falls back.

use super::window::Persistence;
use crate::math::{Vec3, f32m};
use crate::models::orbit::{MU_EARTH_M3_S2, SHORT_STEP_MAX_S, short_step_velocity_truncation_m_s};
use crate::params::fdir::GnssFdirParams;
use crate::types::PredictedFix;

/// Upper bound on the f32 two-body step's rounding, m (the navigation's own bound, from
/// sim-host/core/tests/onboard_orbit.rs: < 4 m). It covers the short step too: truncation
/// ≤ 0.47 m at 4 s (`models::orbit::short_step_truncation_m`) plus rounding ≤ 0.43 m in LEO.
pub const ROUNDING_M: f32 = 4.0;

/// Upper bound on the f32 velocity propagation's rounding at `Δt = 0`, m/s: the Kepler
/// step's `16 · 2⁻²⁴ · v` (sim-host/core/tests/onboard_orbit.rs) at 11.58 km/s is 11 mm/s;
/// the short step's half ulp per axis is ≤ 0.85 mm/s. It grows with `1 +`
/// [`MEAN_MOTION_MAX_RAD_S`]` · Δt`.
pub const ROUNDING_M_S: f32 = 0.012;

/// The fastest mean motion of an accepted orbit, rad/s: `√(μ / r³)` at 5.95e6 m.
pub const MEAN_MOTION_MAX_RAD_S: f32 = 1.376e-3;

/// The largest eigenvalue of the gravity gradient, 1/s²: `2μ / r³` at 5.95e6 m.
pub const GRAVITY_GRADIENT_MAX_S2: f32 = 2.0 * MU_EARTH_M3_S2 / (5.95e6 * 5.95e6 * 5.95e6);

/// The monitor's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GnssMonitor {
    persistence: Persistence,
    last_time_us: Option<u64>,
    /// The verdict on that fix (a fix repeated in the next frame gets the same one).
    last_refused: bool,
    failed: bool,
    events: u16,
    /// The last judged residual and its threshold, m (telemetry; 0 when not judged).
    last_residual_m: f32,
    last_threshold_m: f32,
    /// The same for the velocity, m/s.
    last_velocity_residual_m_s: f32,
    last_velocity_threshold_m_s: f32,
}

/// What the monitor says about one fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Take it (consistent, or nothing to judge it against).
    Take,
    /// Leave it: it exceeded, or the receiver is declared failed.
    Refuse,
}

impl GnssMonitor {
    pub const fn new() -> Self {
        Self {
            persistence: Persistence::new(),
            last_time_us: None,
            last_refused: false,
            failed: false,
            events: 0,
            last_residual_m: 0.0,
            last_threshold_m: 0.0,
            last_velocity_residual_m_s: 0.0,
            last_velocity_threshold_m_s: 0.0,
        }
    }

    /// The threshold on `d` for a fix `dt_s` after the last accepted one, m.
    pub fn threshold_m(p: &GnssFdirParams, dt_s: f32) -> f32 {
        let (sr, sv) = (p.position_sigma_m, p.velocity_sigma_m_s * dt_s);
        let sigma = f32m::sqrt(2.0 * sr * sr + sv * sv);
        p.threshold_sigma * sigma + 0.5 * p.model_accel_m_s2 * dt_s * dt_s + ROUNDING_M
    }

    /// The threshold on `e` for a fix `dt_s` after the last accepted one, m/s.
    pub fn velocity_threshold_m_s(p: &GnssFdirParams, dt_s: f32) -> f32 {
        let (sv, sg) = (p.velocity_sigma_m_s, GRAVITY_GRADIENT_MAX_S2 * dt_s * p.position_sigma_m);
        let sigma = f32m::sqrt(2.0 * sv * sv + sg * sg);
        // The Taylor step's truncation up to 4 s; beyond, the Kepler step has none.
        let truncation = if dt_s <= SHORT_STEP_MAX_S { short_step_velocity_truncation_m_s(dt_s) } else { 0.0 };
        p.threshold_sigma * sigma
            + p.model_accel_m_s2 * dt_s
            + truncation
            + ROUNDING_M_S * (1.0 + MEAN_MOTION_MAX_RAD_S * dt_s)
    }

    /// Whether [`GnssMonitor::judge`] would look at the prediction for the fix at
    /// `fix_time_us`: not once the receiver is declared, nor for a repeated time tag (the
    /// fix held in the next frame). The caller skips the propagation then.
    pub fn judges(&self, fix_time_us: u64) -> bool {
        !self.failed && self.last_time_us != Some(fix_time_us)
    }

    /// Judges the fix at `fix_time_us` whose position and velocity are `r_fix_m` and
    /// `v_fix_m_s`, against `predicted`: the last accepted fix carried to that time
    /// (`None`: no accepted fix to judge against, taken unjudged). A repeated time tag is not
    /// judged again: it gets the verdict it had.
    pub fn judge(
        &mut self,
        p: &GnssFdirParams,
        fix_time_us: u64,
        (r_fix_m, v_fix_m_s): (&Vec3, &Vec3),
        predicted: Option<&PredictedFix>,
    ) -> Verdict {
        if self.failed {
            // Not judged any more: the telemetry says so (0, 0), not the last residual.
            self.forget_residuals();
            return Verdict::Refuse;
        }
        if self.last_time_us == Some(fix_time_us) {
            return if self.last_refused { Verdict::Refuse } else { Verdict::Take };
        }
        self.last_time_us = Some(fix_time_us);
        self.last_refused = false;
        let Some(pred) = predicted else {
            self.forget_residuals();
            return Verdict::Take;
        };
        let threshold = Self::threshold_m(p, pred.dt_s);
        let threshold_v = Self::velocity_threshold_m_s(p, pred.dt_s);
        let d2 = (r_fix_m - pred.r_m).norm_squared();
        let e2 = (v_fix_m_s - pred.v_m_s).norm_squared();
        // NaN (a non-finite fix the plausibility check would refuse anyway) is an exceedance.
        let exceeded = !(d2 <= threshold * threshold && e2 <= threshold_v * threshold_v);
        (self.last_residual_m, self.last_threshold_m) = (f32m::sqrt(d2), threshold);
        (self.last_velocity_residual_m_s, self.last_velocity_threshold_m_s) = (f32m::sqrt(e2), threshold_v);
        if self.persistence.push(&p.window, exceeded) {
            self.failed = true;
            self.events = self.events.saturating_add(1);
        }
        self.last_refused = exceeded || self.failed;
        if self.last_refused { Verdict::Refuse } else { Verdict::Take }
    }

    fn forget_residuals(&mut self) {
        (self.last_residual_m, self.last_threshold_m) = (0.0, 0.0);
        (self.last_velocity_residual_m_s, self.last_velocity_threshold_m_s) = (0.0, 0.0);
    }

    /// The receiver is declared failed (its fixes are refused).
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// Declarations since boot (saturating).
    pub fn events(&self) -> u16 {
        self.events
    }

    /// The last judged residual and its threshold, m (0, 0 when not judged).
    pub fn last_residual_m(&self) -> (f32, f32) {
        (self.last_residual_m, self.last_threshold_m)
    }

    /// The last judged velocity residual and its threshold, m/s (0, 0 when not judged).
    pub fn last_velocity_residual_m_s(&self) -> (f32, f32) {
        (self.last_velocity_residual_m_s, self.last_velocity_threshold_m_s)
    }

    /// The ground re-enables the receiver: forgotten exceedances, fixes taken again.
    pub fn clear(&mut self) {
        self.failed = false;
        self.persistence.clear();
        self.last_time_us = None;
        self.last_refused = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::fdir::KOfN;

    /// The fixes' velocity (the position tests keep it consistent).
    const V: Vec3 = Vec3::new(0.0, 7.5e3, 0.0);

    /// The last accepted fix carried `dt` s to `r`.
    fn at(r: Vec3, dt: f32) -> Option<PredictedFix> {
        Some(PredictedFix { r_m: r, v_m_s: V, dt_s: dt })
    }

    fn params() -> GnssFdirParams {
        GnssFdirParams {
            position_sigma_m: 5.0,
            velocity_sigma_m_s: 0.05,
            model_accel_m_s2: 0.02,
            threshold_sigma: 5.0,
            window: KOfN { k: 3, n: 4 },
        }
    }

    #[test]
    fn the_threshold_is_the_closed_form() {
        let p = params();
        // dt = 1 s: 5 sqrt(2 * 25 + 0.0025) + 0.01 + 4.
        let want = 5.0 * (50.0025f32).sqrt() + 0.01 + ROUNDING_M;
        assert!((GnssMonitor::threshold_m(&p, 1.0) - want).abs() < 1e-4);
        // It grows with the gap: 600 s without a fix adds 3.6 km of model error.
        assert!(GnssMonitor::threshold_m(&p, 600.0) > 3600.0);
    }

    #[test]
    fn a_jump_is_refused_at_once_and_declared_at_the_kth_fix() {
        let p = params();
        let mut m = GnssMonitor::new();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        assert_eq!(m.judge(&p, 1, (&r, &V), None), Verdict::Take);
        assert_eq!(m.judge(&p, 2, (&r, &V), at(r, 1.0).as_ref()), Verdict::Take);
        assert_eq!(m.judge(&p, 2, (&r, &V), at(r, 1.0).as_ref()), Verdict::Take, "a repeated tag keeps its verdict");
        let jumped = r + Vec3::new(1000.0, 0.0, 0.0);
        assert_eq!(m.judge(&p, 3, (&jumped, &V), at(r, 1.0).as_ref()), Verdict::Refuse);
        assert!(!m.failed());
        assert_eq!(m.judge(&p, 4, (&jumped, &V), at(r, 2.0).as_ref()), Verdict::Refuse);
        assert!(!m.failed());
        assert_eq!(
            m.judge(&p, 4, (&jumped, &V), at(r, 2.0).as_ref()),
            Verdict::Refuse,
            "a repeated tag keeps its verdict"
        );
        assert!(!m.failed());
        assert_eq!(m.judge(&p, 5, (&jumped, &V), at(r, 3.0).as_ref()), Verdict::Refuse);
        assert!(m.failed() && m.events() == 1);
        assert!(m.last_residual_m().0 > 999.0, "the declaring fix's residual is reported");
        // Refused until cleared, even a good fix, and no longer judged.
        assert_eq!(m.judge(&p, 6, (&r, &V), at(r, 4.0).as_ref()), Verdict::Refuse);
        assert_eq!(m.last_residual_m(), (0.0, 0.0));
        m.clear();
        assert_eq!(m.judge(&p, 7, (&r, &V), at(r, 1.0).as_ref()), Verdict::Take);
        assert_eq!(m.events(), 1);
    }

    /// Where `judges` says no, the verdict and the state do not depend on the prediction
    /// (so the estimation stage may skip the propagation); where it says yes, they do.
    #[test]
    fn the_prediction_is_needed_exactly_when_judges_says_so() {
        let p = params();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        let far = at(r + Vec3::new(1.0e4, 0.0, 0.0), 1.0);
        let mut m = GnssMonitor::new();
        // Tags: new, repeated, new, ... through a declaration (the far fixes) and a clear.
        let tags = [1u64, 1, 2, 2, 3, 4, 4, 5, 6, 6, 7];
        let (mut skipped, mut judged) = (0, 0);
        for (i, &t) in tags.iter().enumerate() {
            if i == 9 {
                m.clear();
            }
            let pred = if (3..=5).contains(&t) { far } else { at(r, 1.0) };
            let (mut with, mut without) = (m, m);
            let (a, b) = (with.judge(&p, t, (&r, &V), pred.as_ref()), without.judge(&p, t, (&r, &V), None));
            if m.judges(t) {
                judged += 1;
                // A prediction judged (consistent or far) differs from taking it unjudged
                // in the residual kept, or in the verdict.
                assert!(a != b || with != without, "tag {t}: the prediction was not used");
            } else {
                skipped += 1;
                assert_eq!((a, with), (b, without), "tag {t}: the prediction mattered");
            }
            m = with;
        }
        assert!(m.events() == 1 && skipped >= 4 && judged >= 5, "{skipped} skipped, {judged} judged");
    }

    /// The velocity threshold is its closed form, and a fix with a good position but a
    /// corrupt velocity is refused (the bug it closes: such a fix was taken, and every good
    /// fix after it was judged against the orbit carried with that velocity).
    #[test]
    fn a_corrupt_velocity_is_refused_and_the_next_good_fix_taken() {
        let p = params();
        // dt = 1 s: 5 sqrt(2 * 0.05^2 + (g * 5)^2) + 0.02 + 1.07e-3 / 6 + 0.012 (1 + n).
        let g = 2.0 * 3.986_004_4e14f64 / 5.95e6f64.powi(3);
        let want = 5.0 * (2.0 * 0.0025 + (g * 5.0).powi(2)).sqrt() + 0.02 + 1.07e-3 / 6.0 + 0.012 * (1.0 + 1.376e-3);
        let got = GnssMonitor::velocity_threshold_m_s(&p, 1.0);
        assert!((f64::from(got) - want).abs() < 1e-6, "{got} against {want}");
        assert!((0.385..0.387).contains(&got), "0.386 m/s at 1 Hz: {got}");
        let mut m = GnssMonitor::new();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        assert_eq!(m.judge(&p, 1, (&r, &V), None), Verdict::Take);
        // Just inside and just outside, along any axis.
        let inside = V + Vec3::new(0.0, 0.0, 0.99 * got);
        assert_eq!(m.judge(&p, 2, (&r, &inside), at(r, 1.0).as_ref()), Verdict::Take);
        let outside = V + Vec3::new(1.01 * got, 0.0, 0.0);
        assert_eq!(m.judge(&p, 3, (&r, &outside), at(r, 1.0).as_ref()), Verdict::Refuse);
        let (e, threshold) = m.last_velocity_residual_m_s();
        assert!((e - 1.01 * got).abs() < 1e-3 && threshold == got, "{e} {threshold}");
        assert!(m.last_residual_m().0 == 0.0, "the position was good");
        // One bad fix: the next good one is taken, nothing declared.
        assert_eq!(m.judge(&p, 4, (&r, &V), at(r, 1.0).as_ref()), Verdict::Take);
        assert!(!m.failed());
        // Declared failed, the velocity residual reads 0 like the position's.
        for t in 5..8 {
            m.judge(&p, t, (&r, &outside), at(r, 1.0).as_ref());
        }
        assert!(m.failed());
        m.judge(&p, 8, (&r, &V), at(r, 1.0).as_ref());
        assert_eq!(m.last_velocity_residual_m_s(), (0.0, 0.0));
    }

    #[test]
    fn a_nan_fix_is_an_exceedance_and_no_prediction_takes_it_unjudged() {
        let p = params();
        let mut m = GnssMonitor::new();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        assert_eq!(m.judge(&p, 1, (&Vec3::new(f32::NAN, 0.0, 0.0), &V), at(r, 1.0).as_ref()), Verdict::Refuse);
        assert_eq!(m.judge(&p, 2, (&r, &V), None), Verdict::Take);
        assert_eq!(m.last_residual_m(), (0.0, 0.0));
    }
}
