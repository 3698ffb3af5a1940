//! The flight code's FDIR as the simulator sees it (issue 42; docs/fdir.md "Wiring"):
//! each step's [`FdirTelemetry`] turned into events (a wheel or the star tracker newly
//! declared failed), matched
//! to the injected `[[faults]]` — an event on a unit with no fault in force is a false
//! alarm and fails the run (`run_status` "fdir_false_alarm", exit 3).

use crate::faults::{FaultRecord, TimedFault};
use acs_flight::link::FdirTelemetry;
use serde::Serialize;

/// One FDIR event in `summary.json` `fdir.events`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FdirEvent {
    /// The unit declared failed, as `[[faults]]` names it (`wheel.2`).
    pub unit: String,
    /// The test that fired.
    pub test: &'static str,
    /// The control step whose report first carried it, s.
    pub detected_at_s: f64,
    /// What isolation named: `rotor`, `tachometer` or `ambiguous` (treated as rotor) for a
    /// wheel; `star_tracker` for the tracker; the axis (`gyro.y`) for a stuck gyro axis;
    /// the axis or `ambiguous` (unit `gyro`) for a gyro bias step; the axis
    /// (`magnetometer.x`) for a stuck magnetometer axis, `ambiguous` (unit `magnetometer`)
    /// for its field-magnitude test; `gnss` for the GNSS receiver.
    pub isolated_as: &'static str,
    /// What the flight code did.
    pub recovery: &'static str,
    /// The `[[faults]]` entry in force on this unit at detection (index), `None`: a false
    /// alarm.
    pub fault: Option<usize>,
}

/// `summary.json` `fdir` (with `[fdir]`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct FdirSummary {
    pub events: Vec<FdirEvent>,
    /// Events on a unit without an injected fault in force.
    pub false_alarms: usize,
    /// The flight's own event counter at the end (equals `events.len()` unless a unit was
    /// declared twice after a clear).
    pub flight_events: u16,
}

/// The FDIR events of a run.
#[derive(Clone, Debug, Default)]
pub struct FdirLog {
    last: FdirTelemetry,
    summary: FdirSummary,
}

fn bit(i: usize) -> u8 {
    u32::try_from(i).ok().and_then(|i| 1u8.checked_shl(i)).unwrap_or(0)
}

impl FdirLog {
    /// The report of the step at `t_s`; `faults`: the scenario's list.
    pub fn observe(&mut self, t_s: f64, f: &FdirTelemetry, faults: &[TimedFault]) {
        let new = f.failed_wheels & !self.last.failed_wheels;
        for i in (0..8).filter(|i| new & bit(*i) != 0) {
            let isolated_as = if f.ambiguous_wheels & bit(i) != 0 {
                "ambiguous"
            } else if f.tachometer_wheels & bit(i) != 0 {
                "tachometer"
            } else {
                "rotor"
            };
            let test = "wheel_torque_residual";
            self.record(t_s, faults, format!("wheel.{i}"), test, isolated_as, "dropped_from_allocation");
        }
        let new_sensors = f.failed_sensors & !self.last.failed_sensors;
        if new_sensors & acs_flight::link::FAILED_STAR_TRACKER != 0 {
            let test = if f.tracker_frozen { "tracker_frozen" } else { "tracker_witness" };
            self.record(t_s, faults, "star_tracker".into(), test, "star_tracker", "dropped_from_estimation");
        }
        let stuck_axes = new_sensors >> 1;
        for (i, unit) in ["gyro.x", "gyro.y", "gyro.z"].into_iter().enumerate() {
            if stuck_axes & bit(i) != 0 {
                // Its own repeats, or the bias-step test naming it again and again.
                let test = if f.gyro_erratic_axes & bit(i) != 0 { "gyro_erratic" } else { "gyro_stuck" };
                self.record(t_s, faults, unit.into(), test, unit, "axis_read_as_zero");
            }
        }
        self.observe_magnetometer(t_s, new_sensors, faults);
        if f.gnss_failed && !self.last.gnss_failed {
            // The declaring fix's residuals are this step's: the position test, unless only
            // the velocity exceeded.
            let test = if f.gnss_residual_m > f.gnss_threshold_m
                || f.gnss_velocity_residual_m_s <= f.gnss_velocity_threshold_m_s
            {
                "gnss_position_consistency"
            } else {
                "gnss_velocity_consistency"
            };
            self.record(t_s, faults, "gnss".into(), test, "gnss", "fixes_refused");
        }
        if f.gyro_bias_steps > self.last.gyro_bias_steps {
            let axis = (0..3).find(|i| f.gyro_bias_axes == bit(*i));
            let (unit, isolated_as) = match axis.and_then(|i| ["gyro.x", "gyro.y", "gyro.z"].get(i).copied()) {
                Some(axis) => (axis, axis),
                None => ("gyro", "ambiguous"),
            };
            let test = "gyro_bias_innovation";
            self.record(t_s, faults, unit.into(), test, isolated_as, "filter_restarted_with_the_step");
        }
        self.summary.flight_events = f.events;
        self.last = *f;
    }

    /// The magnetometer monitor's new verdicts (`failed_sensors` bits 4-7): a stuck axis
    /// names it; the magnitude test names the magnetometer, its axis ambiguous.
    fn observe_magnetometer(&mut self, t_s: f64, new_sensors: u8, faults: &[TimedFault]) {
        let stuck = new_sensors >> 4;
        for (i, unit) in ["magnetometer.x", "magnetometer.y", "magnetometer.z"].into_iter().enumerate() {
            if stuck & bit(i) != 0 {
                self.record(t_s, faults, unit.into(), "magnetometer_stuck", unit, "dropped_from_estimation");
            }
        }
        if new_sensors & acs_flight::link::FAILED_MAGNETOMETER != 0 {
            let test = "field_magnitude";
            self.record(t_s, faults, "magnetometer".into(), test, "ambiguous", "dropped_from_estimation");
        }
    }

    /// One event on `unit`, matched to the `[[faults]]` entry on it in force by `t_s` (none:
    /// a false alarm).
    fn record(
        &mut self,
        t_s: f64,
        faults: &[TimedFault],
        unit: String,
        test: &'static str,
        isolated_as: &'static str,
        recovery: &'static str,
    ) {
        // An ambiguous event ("gyro", "magnetometer") matches a fault on any of its axes.
        let on_unit = |u: &str| {
            u == unit
                || (unit == "gyro" && u.starts_with("gyro."))
                || (unit == "magnetometer" && u.starts_with("magnetometer."))
        };
        // The unit's fault with the latest onset up to now (the first of equal onsets): a
        // fault that ended before it (a one-fix glitch refused earlier) is not the cause.
        let mut fault: Option<(usize, f64)> = None;
        for (i, x) in faults.iter().enumerate() {
            let onset = x.window.onset_s;
            if on_unit(&x.fault.unit()) && onset <= t_s && fault.is_none_or(|(_, best)| onset > best) {
                fault = Some((i, onset));
            }
        }
        let fault = fault.map(|(i, _)| i);
        self.summary.false_alarms += usize::from(fault.is_none());
        self.summary.events.push(FdirEvent { unit, test, detected_at_s: t_s, isolated_as, recovery, fault });
    }

    /// Fills `detected_at_s` of each injected fault: its first event.
    pub fn mark_detections(&self, records: &mut [FaultRecord]) {
        for e in &self.summary.events {
            if let Some(r) = e.fault.and_then(|i| records.get_mut(i))
                && r.detected_at_s.is_none()
            {
                r.detected_at_s = Some(e.detected_at_s);
            }
        }
    }

    /// Why the run fails: FDIR declared a healthy unit failed.
    pub fn failure_reason(&self) -> Option<String> {
        let first = self.summary.events.iter().find(|e| e.fault.is_none())?;
        Some(format!(
            "FDIR declared {} healthy unit(s) failed (false alarm): first {} at t = {} s by {}",
            self.summary.false_alarms, first.unit, first.detected_at_s, first.test
        ))
    }

    pub fn summary(&self) -> FdirSummary {
        self.summary.clone()
    }
}
