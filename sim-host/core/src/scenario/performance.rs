//! `[performance]`: how a run's pointing is judged — the settle bound and the windows and
//! confidence of the pointing-performance indices (`crate::recorder::pointing`,
//! docs/pointing.md). Every key has a default, so the table is optional.
//!
//! ```toml
//! [performance]
//! settle_bound_deg = 1.0        # settle_time_s: the error stays below this from then on
//! settle_dwell_s = 300.0        # the figures "after settle" start this long after it
//!                               # (default: the settle time again)
//! from_s = 0.0                  # the indices are taken over [from_s, end of the run]
//! confidence = 0.95             # fraction of the period each index stays below its figure
//! window_s = 10.0               # Δt of MPE, RPE and PDE (rounded to whole control steps)
//! drift_separation_s = 100.0    # Δt_s between the two PDE windows (whole windows)
//! stability_window_s = 1.0      # Δt of the stability index e(t + Δt) − e(t)
//! segment_settle_s = 0.0        # per pointing segment: its first seconds left out
//! degraded_hold_error_deg = 0.5 # with [[faults]]: a hold off by more than this through
//!                               # the last 60 s fails the run (default: [modes]
//!                               # hold_enter_error_deg, else settle_bound_deg)
//! propellant_budget_kg = 0.1    # with thrusters: a run that uses more fails (default:
//!                               # none)
//! ```

use super::{Scenario, bad};
use crate::recorder::pointing::Windows;
use anyhow::Result;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PerformanceSpec {
    #[serde(default = "settle_bound")]
    pub settle_bound_deg: f64,
    /// The window of the figures after settle starts this long after the settle time, s
    /// (`None`: the settle time again, i.e. the window starts at twice the settle time).
    #[serde(default)]
    pub settle_dwell_s: Option<f64>,
    #[serde(default)]
    pub from_s: f64,
    #[serde(default = "confidence")]
    pub confidence: f64,
    #[serde(default = "window")]
    pub window_s: f64,
    #[serde(default = "drift_separation")]
    pub drift_separation_s: f64,
    #[serde(default = "stability_window")]
    pub stability_window_s: f64,
    /// The first seconds of each pointing segment (acquisition, blended transition) are
    /// left out of its indices (`crate::recorder::segments`).
    #[serde(default)]
    pub segment_settle_s: f64,
    /// A `[[timeline]]` segment missed (not on target at its start) does not fail the run.
    #[serde(default)]
    pub allow_missed_segments: bool,
    /// With `[[faults]]`: the true error above which a hold through the last 60 s fails the
    /// run (`pointing_degraded`, `crate::recorder::control_lost`), deg. `None`: the mode
    /// manager's `hold_enter_error_deg`, else `settle_bound_deg`.
    #[serde(default)]
    pub degraded_hold_error_deg: Option<f64>,
    /// The most propellant the thrusters may use over the run, kg (`propellant_exceeded`,
    /// `crate::recorder::propellant`). `None`: no budget. Refused without thrusters.
    #[serde(default)]
    pub propellant_budget_kg: Option<f64>,
}

fn settle_bound() -> f64 {
    1.0
}
fn confidence() -> f64 {
    0.95
}
fn window() -> f64 {
    10.0
}
fn drift_separation() -> f64 {
    100.0
}
fn stability_window() -> f64 {
    1.0
}

impl Default for PerformanceSpec {
    fn default() -> Self {
        Self {
            settle_bound_deg: settle_bound(),
            settle_dwell_s: None,
            from_s: 0.0,
            confidence: confidence(),
            window_s: window(),
            drift_separation_s: drift_separation(),
            stability_window_s: stability_window(),
            segment_settle_s: 0.0,
            allow_missed_segments: false,
            degraded_hold_error_deg: None,
            propellant_budget_kg: None,
        }
    }
}

/// The validated `[performance]` of a run at its control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Performance {
    pub settle_bound_deg: f64,
    pub settle_dwell_s: Option<f64>,
    pub from_s: f64,
    pub confidence: f64,
    pub windows: Windows,
    pub segment_settle_s: f64,
    /// `propellant_budget_kg`, checked (> 0, finite).
    pub propellant_budget_kg: Option<f64>,
}

impl PerformanceSpec {
    /// Validates the table against the control period `dt_s`, naming the key at fault.
    pub fn resolve(&self, dt_s: f64) -> Result<Performance> {
        let k = |name: &str| format!("performance.{name}");
        let b = self.settle_bound_deg;
        if !(b.is_finite() && b > 0.0) {
            return Err(bad(&k("settle_bound_deg"), format!("must be > 0 (got {b})")));
        }
        if let Some(d) = self.settle_dwell_s
            && !(d.is_finite() && d >= 0.0)
        {
            return Err(bad(&k("settle_dwell_s"), format!("must be >= 0 (got {d})")));
        }
        if !(self.from_s.is_finite() && self.from_s >= 0.0) {
            return Err(bad(&k("from_s"), format!("must be >= 0 (got {})", self.from_s)));
        }
        let p = self.confidence;
        if !(p > 0.0 && p <= 1.0) {
            return Err(bad(&k("confidence"), format!("must be in (0, 1] (got {p})")));
        }
        let windows = Windows::from_seconds(dt_s, self.window_s, self.drift_separation_s, self.stability_window_s)
            .map_err(|e| bad("performance", e))?;
        let settle = self.segment_settle_s;
        if !(settle.is_finite() && settle >= 0.0) {
            return Err(bad(&k("segment_settle_s"), format!("must be >= 0 (got {settle})")));
        }
        if let Some(d) = self.degraded_hold_error_deg
            && !(d.is_finite() && d > 0.0)
        {
            return Err(bad(&k("degraded_hold_error_deg"), format!("must be > 0 (got {d})")));
        }
        if let Some(m) = self.propellant_budget_kg
            && !(m.is_finite() && m > 0.0)
        {
            return Err(bad(&k("propellant_budget_kg"), format!("must be > 0 (got {m})")));
        }
        Ok(Performance {
            settle_bound_deg: b,
            settle_dwell_s: self.settle_dwell_s,
            from_s: self.from_s,
            confidence: p,
            windows,
            segment_settle_s: settle,
            propellant_budget_kg: self.propellant_budget_kg,
        })
    }
}

impl Scenario {
    /// `[performance]` (its defaults when absent) at the scenario's control period; a
    /// propellant budget needs thrusters to spend it.
    pub fn performance(&self) -> Result<Performance> {
        let p = self.performance.resolve(1.0 / self.timing.control_rate_hz)?;
        if p.propellant_budget_kg.is_some() && self.actuators.thrusters.is_none() {
            return Err(bad(
                "performance.propellant_budget_kg",
                "needs thrusters ([actuators.thrusters]): the spacecraft uses no propellant",
            ));
        }
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_refused_naming_the_key() {
        let ok = PerformanceSpec::default();
        let p = ok.resolve(0.1).unwrap();
        assert_eq!((p.windows.window, p.windows.drift_separation, p.windows.stability), (100, 10, 10));
        for (spec, key) in [
            (PerformanceSpec { settle_bound_deg: 0.0, ..ok.clone() }, "performance.settle_bound_deg"),
            (PerformanceSpec { from_s: f64::NAN, ..ok.clone() }, "performance.from_s"),
            (PerformanceSpec { settle_dwell_s: Some(-1.0), ..ok.clone() }, "performance.settle_dwell_s"),
            (PerformanceSpec { confidence: 1.5, ..ok.clone() }, "performance.confidence"),
            (PerformanceSpec { window_s: -1.0, ..ok.clone() }, "window_s"),
            (PerformanceSpec { stability_window_s: 1e9, ..ok.clone() }, "stability_window_s"),
            (PerformanceSpec { propellant_budget_kg: Some(0.0), ..ok.clone() }, "performance.propellant_budget_kg"),
            (PerformanceSpec { propellant_budget_kg: Some(-1.0), ..ok.clone() }, "performance.propellant_budget_kg"),
            (
                PerformanceSpec { propellant_budget_kg: Some(f64::NAN), ..ok.clone() },
                "performance.propellant_budget_kg",
            ),
            (
                PerformanceSpec { propellant_budget_kg: Some(f64::INFINITY), ..ok.clone() },
                "performance.propellant_budget_kg",
            ),
        ] {
            let e = spec.resolve(0.1).unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        // A window shorter than a control step is one step.
        let short = PerformanceSpec { stability_window_s: 0.01, ..ok };
        assert_eq!(short.resolve(0.1).unwrap().windows.stability, 1);
    }
}
