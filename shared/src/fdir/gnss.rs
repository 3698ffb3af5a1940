//! The GNSS monitor of the estimation stage (issue 42; docs/fdir.md "GNSS"): each fix
//! against the last accepted one carried to its time by the navigation's two-body step.
//!
//! Residual `d = |r_fix − r_pred|`, m, with `r_pred` the last accepted fix propagated over
//! `Δt` to the new fix's time ([`crate::estimation::navigation::Navigation::predict_fix`]:
//! up to 4 s, the usual 1 s at 1 Hz, a second-order Taylor step of two-body motion; beyond,
//! the navigation's Kepler step).
//! With white noise σ_r per axis on every fix's position and σ_v on its velocity, the
//! difference is, per axis, `n_new − n_old − Δt n_v`: normal with variance
//! `σ_d² = 2σ_r² + (σ_v Δt)²`, so `d²/σ_d² ~ χ²₃`. What the two-body step leaves out (J2,
//! drag: an acceleration `a` it does not model) adds at most `½ a Δt²`, and the f32
//! propagation's rounding (with the Taylor step's truncation) at most [`ROUNDING_M`]. A
//! fix is an exceedance when `d > γ σ_d + ½ a Δt² + ROUNDING_M`: per fix `P(χ²₃ > γ²)`,
//! γ = 5 → 1.5e-5, γ = 6 → 7.5e-8 (on the bound's side: the model terms only widen it);
//! `k` of the last `n` judged fixes declare the receiver failed.
//!
//! What it sees: a jump of the reported position (a receiver re-acquiring on a wrong
//! solution), a frozen position with a fresh time (the spacecraft moves 7.5 km/s), any
//! offset larger than the threshold (≈ 40 m at 1 Hz with the 3U's 5 m receiver). What it
//! cannot see: a slow drift below the threshold per fix; an orbit manoeuvre (a Δv the
//! two-body step does not know) is seen as a jump — a spacecraft that fires thrusters must
//! raise `model_accel_m_s2` to its thrust acceleration or clear the fault after a burn.
//!
//! Recovery (the estimation stage): an exceeding fix is not taken by the navigation (the
//! last good fix goes on being propagated, so one bad fix neither moves the orbit nor
//! makes the next good one look like a jump); once declared, no fix is taken until
//! `ClearSensorFaults`. The navigation carries the last good fix for up to
//! [`crate::estimation::navigation::MAX_FIX_AGE_S`]; then the modes that need it lose
//! their input and the mode manager falls back.

use super::window::Persistence;
use crate::math::{Vec3, f32m};
use crate::params::fdir::GnssFdirParams;

/// Upper bound on the f32 two-body step's rounding, m (the navigation's own bound, from
/// sim-host/core/tests/onboard_orbit.rs: < 4 m). It covers the short step too: truncation
/// ≤ 0.47 m at 4 s (`models::orbit::short_step_truncation_m`) plus rounding ≤ 0.43 m in LEO.
pub const ROUNDING_M: f32 = 4.0;

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
        }
    }

    /// The threshold on `d` for a fix `dt_s` after the last accepted one, m.
    pub fn threshold_m(p: &GnssFdirParams, dt_s: f32) -> f32 {
        let (sr, sv) = (p.position_sigma_m, p.velocity_sigma_m_s * dt_s);
        let sigma = f32m::sqrt(2.0 * sr * sr + sv * sv);
        p.threshold_sigma * sigma + 0.5 * p.model_accel_m_s2 * dt_s * dt_s + ROUNDING_M
    }

    /// Whether [`GnssMonitor::judge`] would look at the prediction for the fix at
    /// `fix_time_us`: not once the receiver is declared, nor for a repeated time tag (the
    /// fix held in the next frame). The caller skips the propagation then.
    pub fn judges(&self, fix_time_us: u64) -> bool {
        !self.failed && self.last_time_us != Some(fix_time_us)
    }

    /// Judges the fix at `fix_time_us` whose position is `r_fix_m`, against `predicted`: the
    /// last accepted fix carried to that time and the time between them, s (`None`: no
    /// accepted fix to judge against, taken unjudged). A repeated time tag is not judged
    /// again: it gets the verdict it had.
    pub fn judge(
        &mut self,
        p: &GnssFdirParams,
        fix_time_us: u64,
        r_fix_m: &Vec3,
        predicted: Option<(Vec3, f32)>,
    ) -> Verdict {
        if self.failed {
            // Not judged any more: the telemetry says so (0, 0), not the last residual.
            (self.last_residual_m, self.last_threshold_m) = (0.0, 0.0);
            return Verdict::Refuse;
        }
        if self.last_time_us == Some(fix_time_us) {
            return if self.last_refused { Verdict::Refuse } else { Verdict::Take };
        }
        self.last_time_us = Some(fix_time_us);
        self.last_refused = false;
        let Some((r_pred_m, dt_s)) = predicted else {
            (self.last_residual_m, self.last_threshold_m) = (0.0, 0.0);
            return Verdict::Take;
        };
        let threshold = Self::threshold_m(p, dt_s);
        let d2 = (r_fix_m - r_pred_m).norm_squared();
        // NaN (a non-finite fix the plausibility check would refuse anyway) is an exceedance.
        let exceeded = !(d2 <= threshold * threshold);
        (self.last_residual_m, self.last_threshold_m) = (f32m::sqrt(d2), threshold);
        if self.persistence.push(&p.window, exceeded) {
            self.failed = true;
            self.events = self.events.saturating_add(1);
        }
        self.last_refused = exceeded || self.failed;
        if self.last_refused { Verdict::Refuse } else { Verdict::Take }
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
        assert_eq!(m.judge(&p, 1, &r, None), Verdict::Take);
        assert_eq!(m.judge(&p, 2, &r, Some((r, 1.0))), Verdict::Take);
        assert_eq!(m.judge(&p, 2, &r, Some((r, 1.0))), Verdict::Take, "a repeated tag keeps its verdict");
        let jumped = r + Vec3::new(1000.0, 0.0, 0.0);
        assert_eq!(m.judge(&p, 3, &jumped, Some((r, 1.0))), Verdict::Refuse);
        assert!(!m.failed());
        assert_eq!(m.judge(&p, 4, &jumped, Some((r, 2.0))), Verdict::Refuse);
        assert!(!m.failed());
        assert_eq!(m.judge(&p, 4, &jumped, Some((r, 2.0))), Verdict::Refuse, "a repeated tag keeps its verdict");
        assert!(!m.failed());
        assert_eq!(m.judge(&p, 5, &jumped, Some((r, 3.0))), Verdict::Refuse);
        assert!(m.failed() && m.events() == 1);
        assert!(m.last_residual_m().0 > 999.0, "the declaring fix's residual is reported");
        // Refused until cleared, even a good fix, and no longer judged.
        assert_eq!(m.judge(&p, 6, &r, Some((r, 4.0))), Verdict::Refuse);
        assert_eq!(m.last_residual_m(), (0.0, 0.0));
        m.clear();
        assert_eq!(m.judge(&p, 7, &r, Some((r, 1.0))), Verdict::Take);
        assert_eq!(m.events(), 1);
    }

    /// Where `judges` says no, the verdict and the state do not depend on the prediction
    /// (so the estimation stage may skip the propagation); where it says yes, they do.
    #[test]
    fn the_prediction_is_needed_exactly_when_judges_says_so() {
        let p = params();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        let far = Some((r + Vec3::new(1.0e4, 0.0, 0.0), 1.0));
        let mut m = GnssMonitor::new();
        // Tags: new, repeated, new, ... through a declaration (the far fixes) and a clear.
        let tags = [1u64, 1, 2, 2, 3, 4, 4, 5, 6, 6, 7];
        let (mut skipped, mut judged) = (0, 0);
        for (i, &t) in tags.iter().enumerate() {
            if i == 9 {
                m.clear();
            }
            let pred = if (3..=5).contains(&t) { far } else { Some((r, 1.0)) };
            let (mut with, mut without) = (m, m);
            let (a, b) = (with.judge(&p, t, &r, pred), without.judge(&p, t, &r, None));
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

    #[test]
    fn a_nan_fix_is_an_exceedance_and_no_prediction_takes_it_unjudged() {
        let p = params();
        let mut m = GnssMonitor::new();
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        assert_eq!(m.judge(&p, 1, &Vec3::new(f32::NAN, 0.0, 0.0), Some((r, 1.0))), Verdict::Refuse);
        assert_eq!(m.judge(&p, 2, &r, None), Verdict::Take);
        assert_eq!(m.last_residual_m(), (0.0, 0.0));
    }
}
