//! Control lost unnoticed (issue 42; docs/scenario.md "Run status"): with `[[faults]]`,
//! whether the spacecraft, by the truth, held no attitude and no rate through the end of the
//! run after a fault was injected — while the flight's FDIR raised no event. Such a run fails
//! (`run_status` "control_lost", exit 3), never ok.
//!
//! A control step is *lost* when the true attitude error `error_deg` (true attitude to the
//! pointing in force: the mission's target, or with `[guidance]` the truth of the flight's
//! reported mode) exceeds [`CONTROL_LOST_ERROR_DEG`], or the true body rate exceeds the rate
//! the flight itself calls a tumble (`[modes] detumble_enter_rate_deg_s`, else
//! [`CONTROL_LOST_RATE_DEG_S`]). The run lost control when every control step of its last
//! [`CONTROL_LOST_WINDOW_S`] was lost, and all of them at or after the first injection (a
//! run shorter than that after the injection is not judged). A mode fallback (sun-safe,
//! detumble) is not an FDIR event: it names no unit, isolates nothing, and the failed unit
//! stays in use — a run left off its mission pointing by an unnamed fault is what the
//! verdict exists for.
//!
//! Recovery failed (`run_status` "recovery_failed", exit 3): the same loss of control, the
//! FDIR *did* raise an event, and the flight did not end in a safe mode ([`is_safe_mode`]:
//! its last control step's mode is detumble or sun-safe). The issue asks the recovery to
//! "keep pointing, or fall back to a safe mode": a declared fault whose recovery neither
//! holds the pointing in force nor ends in survival is no recovery. A safe mode is not
//! judged by the attitude error: `error_deg` is against the mission's target (or, with
//! `[guidance]`, the safe mode's own pointing, which sun-safe on a degraded sensor set keeps
//! only coarsely), not what the safe mode is for. Its rate is, in sun-safe: the mode
//! manager hands a tumble to detumble, unless it cannot see it — a gyro axis declared stuck
//! reads 0 — so a run ending in sun-safe with the body rate above the tumble bound at every
//! step of the window is no survival and fails too (found by the sensor campaigns: a stuck
//! z axis left the 3U spinning at up to 33°/s in sun-safe, exit 0). Detumble is exempt: its
//! job is to bring that rate down.

use acs_flight::params::Mode;

/// The true attitude error beyond which a control step counts as lost, deg: over three times
/// the coarsest hold tolerance of the shipped scenarios (the mission's `hold_exit_error_deg`,
/// 3 deg; their holds point to 0.01 to 0.1 deg), beyond any controlled hold.
pub const CONTROL_LOST_ERROR_DEG: f64 = 10.0;
/// Body rate beyond which a step counts as lost without `[modes]` (the shipped detumble
/// entry rate), deg/s.
pub const CONTROL_LOST_RATE_DEG_S: f64 = 3.0;
/// How long the loss must last, up to the end of the run, s: longer than a mode manager's
/// persistence and dwell (5 s and 60 s in the shipped tables) so that a transient the flight
/// is still acting on does not count.
pub const CONTROL_LOST_WINDOW_S: f64 = 60.0;

/// Whether `mode` is a safe mode: one whose job is survival, not pointing — detumble (rate
/// damping by B-dot) and sun-safe (power: a panel on the Sun). Stabilise, manoeuvre and
/// hold point to a target (LVLH or the mission's) and are not.
pub fn is_safe_mode(mode: Mode) -> bool {
    matches!(mode, Mode::Detumble | Mode::SunSafe)
}

/// How a run that lost control fails (see the module's documentation).
#[derive(Clone, Debug, PartialEq)]
pub enum LostVerdict {
    /// Lost, and the FDIR raised no event.
    ControlLost(String),
    /// Lost, the FDIR raised an event, and the flight did not end in a safe mode.
    RecoveryFailed(String),
}

/// The watch over one run (every control step).
#[derive(Clone, Debug)]
pub struct ControlWatch {
    rate_bound_rad_s: f64,
    /// Start of the current unbroken run of lost steps, all at or after an injection.
    lost_since_s: Option<f64>,
    /// The same for the rate alone above the bound (tumbling).
    tumbling_since_s: Option<f64>,
    /// The last step's time, error and rate.
    last: Option<(f64, f64, f64)>,
    /// The last step's flight mode (None: no mode manager, or a code it does not name).
    last_mode: Option<Mode>,
}

impl ControlWatch {
    /// `rate_bound_deg_s`: the tumble rate (`[modes] detumble_enter_rate_deg_s`, else
    /// [`CONTROL_LOST_RATE_DEG_S`]).
    pub fn new(rate_bound_deg_s: f64) -> Self {
        Self {
            rate_bound_rad_s: rate_bound_deg_s.to_radians(),
            lost_since_s: None,
            tumbling_since_s: None,
            last: None,
            last_mode: None,
        }
    }

    /// The control step at `t_s`: `injected`, a fault has been in force at or before it;
    /// `err_deg`, the true attitude error; `rate_rad_s`, the true body rate; `mode`, the
    /// flight's reported mode (None without a mode manager).
    pub fn push(&mut self, t_s: f64, injected: bool, err_deg: f64, rate_rad_s: [f64; 3], mode: Option<Mode>) {
        let rate = rate_rad_s.iter().map(|w| w * w).sum::<f64>().sqrt();
        // `!(x <= bound)`: a NaN counts as lost.
        let tumbling = injected && !(rate <= self.rate_bound_rad_s);
        let lost = tumbling || (injected && !(err_deg <= CONTROL_LOST_ERROR_DEG));
        self.lost_since_s = if lost { self.lost_since_s.or(Some(t_s)) } else { None };
        self.tumbling_since_s = if tumbling { self.tumbling_since_s.or(Some(t_s)) } else { None };
        self.last = Some((t_s, err_deg, rate));
        self.last_mode = mode;
    }

    /// Whether every step of the last [`CONTROL_LOST_WINDOW_S`] was lost (1e-9 s: the float
    /// of a step time).
    pub fn lost(&self) -> bool {
        self.whole_window(self.lost_since_s)
    }

    fn whole_window(&self, since_s: Option<f64>) -> bool {
        match (since_s, self.last) {
            (Some(since), Some((t, _, _))) => since <= t - CONTROL_LOST_WINDOW_S + 1e-9,
            _ => false,
        }
    }

    /// Whether the run ended in survival: its last step in detumble, or in sun-safe
    /// without tumbling over the whole window (module doc).
    pub fn ended_safe(&self) -> bool {
        match self.last_mode {
            Some(Mode::SunSafe) => !self.whole_window(self.tumbling_since_s),
            Some(m) => is_safe_mode(m),
            None => false,
        }
    }

    /// Why the run fails, if it lost control: with none of `fdir_events`, control lost; with
    /// some, recovery failed unless the flight ended in a safe mode.
    pub fn verdict(&self, fdir_events: usize) -> Option<LostVerdict> {
        let (since, (t, err, rate)) = self.lost_since_s.zip(self.last).filter(|_| self.lost())?;
        let span = format!(
            "from t = {since} s to the end ({t} s) the true attitude error exceeded {CONTROL_LOST_ERROR_DEG} deg \
             or the body rate {:.3} deg/s at every control step (at the end: {err:.2} deg, {:.3} deg/s)",
            self.rate_bound_rad_s.to_degrees(),
            rate.to_degrees()
        );
        if fdir_events == 0 {
            return Some(LostVerdict::ControlLost(format!("control lost with no FDIR event: {span}")));
        }
        if self.ended_safe() {
            return None;
        }
        let mode = self.last_mode.map_or("none (no mode manager)", Mode::name);
        Some(LostVerdict::RecoveryFailed(format!(
            "recovery failed: the FDIR raised {fdir_events} event(s), yet {span}, and the flight ended in mode \
             {mode}, not a safe mode (detumble, or sun_safe without tumbling)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps every 0.5 s from 0 to `end` with the error `e(t)` and rate `w(t)` (deg/s about
    /// x), a fault in force from `inj`.
    fn watch(end: f64, inj: f64, e: impl Fn(f64) -> f64, w: impl Fn(f64) -> f64) -> ControlWatch {
        let mut c = ControlWatch::new(3.0);
        for k in 0..=(end / 0.5) as u64 {
            let t = k as f64 * 0.5;
            c.push(t, t >= inj, e(t), [w(t).to_radians(), 0.0, 0.0], Some(Mode::Hold));
        }
        c
    }

    #[test]
    fn lost_only_when_every_step_of_the_last_window_after_injection_is_lost() {
        // 20 deg from 100 s to the end (200 s): lost, reason given; with an FDIR event: not.
        let c = watch(200.0, 50.0, |t| if t >= 100.0 { 20.0 } else { 1.0 }, |_| 0.0);
        assert!(c.lost());
        let Some(LostVerdict::ControlLost(r)) = c.verdict(0) else { panic!("{:?}", c.verdict(0)) };
        assert!(r.contains("from t = 100 s") && r.contains("20.00 deg"), "{r}");
        // Exactly the window (from 140 s): lost; from 140.5 s: not (one step short).
        assert!(watch(200.0, 0.0, |t| if t >= 140.0 { 20.0 } else { 1.0 }, |_| 0.0).lost());
        assert!(!watch(200.0, 0.0, |t| if t >= 140.5 { 20.0 } else { 1.0 }, |_| 0.0).lost());
        // One step back under the bound inside the window: not lost.
        assert!(!watch(200.0, 0.0, |t| if t == 190.0 { 9.9 } else { 20.0 }, |_| 0.0).lost());
        // At the bound is not beyond it; NaN is.
        assert!(!watch(200.0, 0.0, |_| 10.0, |_| 0.0).lost());
        assert!(watch(200.0, 0.0, |_| f64::NAN, |_| 0.0).lost());
        // The rate alone: 3.5 deg/s with the attitude on target.
        assert!(watch(200.0, 0.0, |_| 0.0, |_| 3.5).lost());
        assert!(!watch(200.0, 0.0, |_| 0.0, |_| 2.9).lost());
        // Lost since the start but injected only 30 s before the end: not judged.
        assert!(!watch(200.0, 170.0, |_| 90.0, |_| 0.0).lost());
        // No fault ever in force: never.
        assert!(!watch(200.0, f64::INFINITY, |_| 90.0, |_| 10.0).lost());
    }

    /// The same steps, the last one's mode `last` (the others in hold).
    fn ending_in(last: Option<Mode>, e: f64) -> ControlWatch {
        let mut c = ControlWatch::new(3.0);
        for k in 0..=400u64 {
            let t = k as f64 * 0.5;
            c.push(t, t >= 10.0, e, [0.0; 3], if k == 400 { last } else { Some(Mode::Hold) });
        }
        c
    }

    #[test]
    fn with_an_fdir_event_a_loss_fails_unless_the_flight_ended_in_a_safe_mode() {
        assert!(is_safe_mode(Mode::Detumble) && is_safe_mode(Mode::SunSafe));
        assert!(![Mode::Stabilise, Mode::Manoeuvre, Mode::Hold].into_iter().any(is_safe_mode));
        for last in [Some(Mode::Hold), Some(Mode::Stabilise), Some(Mode::Manoeuvre), None] {
            let c = ending_in(last, 20.0);
            let Some(LostVerdict::RecoveryFailed(r)) = c.verdict(2) else { panic!("{last:?}: {:?}", c.verdict(2)) };
            assert!(r.contains("2 event(s)") && r.contains("from t = 10 s") && r.contains("ended in mode"), "{r}");
            // Without an event the same run is control_lost.
            assert!(matches!(c.verdict(0), Some(LostVerdict::ControlLost(_))));
        }
        assert!(ending_in(None, 20.0).verdict(1).is_some_and(|v| format!("{v:?}").contains("no mode manager")));
        for safe in [Mode::Detumble, Mode::SunSafe] {
            let c = ending_in(Some(safe), 20.0);
            assert!(c.ended_safe() && c.verdict(1).is_none(), "{safe:?}");
            assert!(matches!(c.verdict(0), Some(LostVerdict::ControlLost(_))), "{safe:?}");
        }
        // Not lost (on target at 9.9 deg): no verdict in any mode.
        assert!(ending_in(Some(Mode::Hold), 9.9).verdict(1).is_none());
    }
}
