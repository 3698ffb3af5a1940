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

/// The watch over one run (every control step).
#[derive(Clone, Debug)]
pub struct ControlWatch {
    rate_bound_rad_s: f64,
    /// Start of the current unbroken run of lost steps, all at or after an injection.
    lost_since_s: Option<f64>,
    /// The last step's time, error and rate.
    last: Option<(f64, f64, f64)>,
}

impl ControlWatch {
    /// `rate_bound_deg_s`: the tumble rate (`[modes] detumble_enter_rate_deg_s`, else
    /// [`CONTROL_LOST_RATE_DEG_S`]).
    pub fn new(rate_bound_deg_s: f64) -> Self {
        Self { rate_bound_rad_s: rate_bound_deg_s.to_radians(), lost_since_s: None, last: None }
    }

    /// The control step at `t_s`: `injected`, a fault has been in force at or before it;
    /// `err_deg`, the true attitude error; `rate_rad_s`, the true body rate.
    pub fn push(&mut self, t_s: f64, injected: bool, err_deg: f64, rate_rad_s: [f64; 3]) {
        let rate = rate_rad_s.iter().map(|w| w * w).sum::<f64>().sqrt();
        // `!(x <= bound)`: a NaN counts as lost.
        let lost = injected && (!(err_deg <= CONTROL_LOST_ERROR_DEG) || !(rate <= self.rate_bound_rad_s));
        self.lost_since_s = if lost { self.lost_since_s.or(Some(t_s)) } else { None };
        self.last = Some((t_s, err_deg, rate));
    }

    /// Whether every step of the last [`CONTROL_LOST_WINDOW_S`] was lost (1e-9 s: the float
    /// of a step time).
    pub fn lost(&self) -> bool {
        match (self.lost_since_s, self.last) {
            (Some(since), Some((t, _, _))) => since <= t - CONTROL_LOST_WINDOW_S + 1e-9,
            _ => false,
        }
    }

    /// Why the run fails, if it lost control and the FDIR raised none of its `fdir_events`.
    pub fn failure_reason(&self, fdir_events: usize) -> Option<String> {
        let (since, (t, err, rate)) = self.lost_since_s.zip(self.last).filter(|_| self.lost() && fdir_events == 0)?;
        Some(format!(
            "control lost with no FDIR event: from t = {since} s to the end ({t} s) the true attitude error exceeded \
             {CONTROL_LOST_ERROR_DEG} deg or the body rate {:.3} deg/s at every control step (at the end: {err:.2} deg, \
             {:.3} deg/s)",
            self.rate_bound_rad_s.to_degrees(),
            rate.to_degrees()
        ))
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
            c.push(t, t >= inj, e(t), [w(t).to_radians(), 0.0, 0.0]);
        }
        c
    }

    #[test]
    fn lost_only_when_every_step_of_the_last_window_after_injection_is_lost() {
        // 20 deg from 100 s to the end (200 s): lost, reason given; with an FDIR event: not.
        let c = watch(200.0, 50.0, |t| if t >= 100.0 { 20.0 } else { 1.0 }, |_| 0.0);
        assert!(c.lost());
        let r = c.failure_reason(0).unwrap();
        assert!(r.contains("from t = 100 s") && r.contains("20.00 deg"), "{r}");
        assert!(c.failure_reason(1).is_none());
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
}
