//! Extremes, status counters and mode transitions over a run, for its summary.

use crate::plant::wheel::WheelOutput;
use crate::recorder::summary::{ModeTransition, StatusCounts, nan_max};
use acs_flight::link::{ActuatorCommand, status};
use acs_flight::modes::Reason;
use acs_flight::params::Mode;

/// The name of a flight mode code (`none` for an unknown one).
pub(super) fn mode_name(code: u8) -> String {
    Mode::from_code(code).map_or("none", Mode::name).into()
}

/// Extremes and counters over the run.
#[derive(Clone, Default)]
pub(super) struct Metrics {
    pub(super) counts: StatusCounts,
    pub(super) max_gimbal_rate: f64,
    pub(super) min_singularity: f64,
    pub(super) max_wheel_rpm: f64,
    pub(super) max_wheel_w: f64,
    pub(super) max_wheel_a: f64,
    pub(super) max_ticks: u32,
    pub(super) sum_ticks: f64,
    pub(super) n_ticks: u64,
    pub(super) frames_dropped_flight: u32,
    /// Flight steps after the start-up allowance, and those of them uncontrolled
    /// (`bad_input` or `no_estimate`): the no-control check.
    pub(super) steps_after_startup: u64,
    pub(super) uncontrolled_after_startup: u64,
    pub(super) mode_now: Option<u8>,
    pub(super) mode_transitions: Vec<ModeTransition>,
}

impl Metrics {
    pub(super) fn status(&mut self, s: u16) {
        let c = &mut self.counts;
        for (bit, n) in [
            (status::TORQUE_LIMITED, &mut c.torque_limited),
            (status::RATE_SCALED, &mut c.rate_scaled),
            (status::ANGLE_LIMITED, &mut c.angle_limited),
            (status::SINGULAR, &mut c.singular),
            (status::BAD_INPUT, &mut c.bad_input),
            (status::TORQUE_SHORTFALL, &mut c.torque_shortfall),
            (status::ALLOC_FALLBACK, &mut c.alloc_fallback),
            (status::UNREALISED, &mut c.unrealised),
            (status::LAW_FAULT, &mut c.law_fault),
            (status::NO_ESTIMATE, &mut c.no_estimate),
        ] {
            *n += u64::from(s & bit != 0);
        }
    }

    pub(super) fn ticks(&mut self, ticks: u32) {
        if ticks > 0 {
            self.max_ticks = self.max_ticks.max(ticks);
            self.sum_ticks += ticks as f64;
            self.n_ticks += 1;
        }
    }

    pub(super) fn wheels<'o>(&mut self, out: impl Iterator<Item = &'o WheelOutput>) {
        for o in out {
            self.max_wheel_rpm = nan_max(self.max_wheel_rpm, o.speed_rad_s.abs() * 30.0 / std::f64::consts::PI);
            self.max_wheel_w = nan_max(self.max_wheel_w, o.power_w.abs());
            self.max_wheel_a = nan_max(self.max_wheel_a, o.current_a.abs());
        }
    }

    /// Logs a change of the flight mode reported at `t`.
    pub(super) fn mode(&mut self, t: f64, cmd: &ActuatorCommand) {
        if self.mode_now == Some(cmd.mode) {
            return;
        }
        if let Some(from) = self.mode_now {
            self.mode_transitions.push(ModeTransition {
                t_s: t,
                from: mode_name(from),
                to: mode_name(cmd.mode),
                reason: Reason::from_code(cmd.mode_reason).map_or("unknown", Reason::name).into(),
            });
        }
        self.mode_now = Some(cmd.mode);
    }
}
