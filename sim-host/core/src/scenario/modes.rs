//! The mode manager of a scenario (`[modes]`) and timed ground commands (`[[commands]]`).
//!
//! ```toml
//! [modes]
//! initial = "detumble"
//! detumble_enter_rate_deg_s = 3.0   # any mode → detumble above this rate …
//! detumble_exit_rate_deg_s = 0.5    # … and back out below this one
//! stabilise_exit_error_deg = 5.0
//! stabilise_exit_rate_deg_s = 0.1
//! hold_enter_error_deg = 0.5
//! hold_enter_rate_deg_s = 0.05
//! hold_exit_error_deg = 2.0
//! dwell_s = 30.0
//! trigger_persistence_s = 2.0
//! [modes.detumble]
//! actuator = "magnetorquers"
//! controller = { type = "bdot", gain_am2_s_per_t = 2e4 }
//! [modes.stabilise]
//! actuator = "wheels"
//! target = { frame = "lvlh", euler_deg = [0, 0, 0] }
//! controller = { type = "lqr", q_diag = [...], r_diag = [...] }
//! ```
//! A table gives only the thresholds of the transitions it can make
//! ([`ModesSpec::thresholds`]): a hold + sun-safe table needs neither the detumble rates
//! nor the hold entry and exit, only `dwell_s` and `trigger_persistence_s`.
//! Manoeuvre and hold point at the scenario's `[target]` or `[guidance]` (the mission
//! pointing, which `[[commands]]` may change); the other modes may have their own
//! (`target` or `guidance`).

use super::{AttitudeSpec, Controller, GuidanceSpec, RefFrame, Scenario, bad, fixed_guidance};
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

pub use crate::link::ModeTable;
use acs_flight::params::{MODE_COUNT, Mode, ModeManagerParams, ModeRequest};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModesSpec {
    #[serde(default = "default_initial")]
    pub initial: String,
    /// Any mode → detumble above this rate; required with `[modes.detumble]` and another
    /// mode (see [`ModesSpec::thresholds`]).
    #[serde(default)]
    pub detumble_enter_rate_deg_s: Option<f64>,
    #[serde(default)]
    pub detumble_exit_rate_deg_s: Option<f64>,
    #[serde(default)]
    pub stabilise_exit_error_deg: f64,
    #[serde(default)]
    pub stabilise_exit_rate_deg_s: f64,
    /// Manoeuvre ↔ hold; required with `[modes.manoeuvre]` and `[modes.hold]`.
    #[serde(default)]
    pub hold_enter_error_deg: Option<f64>,
    #[serde(default)]
    pub hold_enter_rate_deg_s: Option<f64>,
    #[serde(default)]
    pub hold_exit_error_deg: Option<f64>,
    pub dwell_s: f64,
    pub trigger_persistence_s: f64,
    /// Momentum FDIR: a wheel above this fraction of its speed limit for
    /// `trigger_persistence_s` is a momentum event (0 = off; docs/momentum.md).
    #[serde(default)]
    pub momentum_trip_speed_fraction: f64,
    /// Sun-safe hands back below this fraction (< trip).
    #[serde(default)]
    pub momentum_recover_speed_fraction: f64,
    /// "Unloading cannot keep up": stored wheel momentum above this fraction of
    /// `J_w Ω_max` for `slow_fdir_persistence_s` is a keep-up event (flag only; 0 = off).
    #[serde(default)]
    pub momentum_keepup_fraction: f64,
    /// CMG gimbal saturation: `det(J₁J₁ᵀ)` below this (or a gimbal at its angle limit)
    /// for `slow_fdir_persistence_s` is a gimbal event (flag only; 0 = angle test only).
    #[serde(default)]
    pub gimbal_singularity_min: f64,
    /// Persistence of the keep-up and gimbal monitors, s (0 = both off).
    #[serde(default)]
    pub slow_fdir_persistence_s: f64,
    #[serde(default)]
    pub detumble: Option<ModeSpec>,
    #[serde(default)]
    pub stabilise: Option<ModeSpec>,
    #[serde(default)]
    pub manoeuvre: Option<ModeSpec>,
    #[serde(default)]
    pub hold: Option<ModeSpec>,
    /// Sun-pointing safe mode (between detumble and the pointing modes; entered when the
    /// fine attitude is lost).
    #[serde(default)]
    pub sun_safe: Option<ModeSpec>,
}

/// The mode manager's thresholds in the keys' units (deg, deg/s, s), resolved once
/// ([`ModesSpec::thresholds`]): each transition the table can make with the keys given,
/// the others with inert values that never trigger.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    pub detumble_enter_rate_deg_s: f64,
    pub detumble_exit_rate_deg_s: f64,
    pub stabilise_exit_error_deg: f64,
    pub stabilise_exit_rate_deg_s: f64,
    pub hold_enter_error_deg: f64,
    pub hold_enter_rate_deg_s: f64,
    pub hold_exit_error_deg: f64,
    pub dwell_s: f64,
    pub trigger_persistence_s: f64,
}

/// The flight code's largest threshold in degrees (less one part in 1e6: the degree
/// figure is rounded to f32 radians on upload).
fn max_threshold_deg() -> f64 {
    f64::from(acs_flight::params::MAX_THRESHOLD).to_degrees() * (1.0 - 1e-6)
}

/// Inert detumble thresholds for a table that cannot detumble (the rate test runs only
/// with a detumble slot): the flight code's largest rate and half of it, deg/s.
pub fn unused_detumble_rates_deg_s() -> (f64, f64) {
    (max_threshold_deg(), max_threshold_deg() / 2.0)
}

/// Inert hold thresholds for a table without manoeuvre or hold: manoeuvre never
/// converges (error and rate below 0) and hold never leaves (error above 180°, which a
/// principal angle cannot exceed).
pub const UNUSED_HOLD_ENTER_DEG: f64 = 0.0;
pub const UNUSED_HOLD_EXIT_DEG: f64 = 180.0;

impl ModesSpec {
    /// The thresholds to arm, parsed once (issue 38: a table asks only for the
    /// thresholds of the transitions it can make). The detumble pair is required when
    /// `[modes.detumble]` and another mode are present; the hold triple
    /// (`hold_enter_error_deg`, `hold_enter_rate_deg_s`, `hold_exit_error_deg`) when
    /// `[modes.manoeuvre]` and `[modes.hold]` are. A group given in part is refused
    /// (naming the missing key); a group not needed and not given takes inert values.
    pub fn thresholds(&self) -> Result<Thresholds> {
        let present = self.slots().iter().filter(|(_, s)| s.is_some()).count();
        let detumble_used = self.detumble.is_some() && present > 1;
        let hold_used = self.manoeuvre.is_some() && self.hold.is_some();
        let (enter, exit) = unused_detumble_rates_deg_s();
        let [detumble_enter_rate_deg_s, detumble_exit_rate_deg_s] = group(
            detumble_used,
            "[modes.detumble] with another mode (any mode → detumble above the enter rate, detumble → next below the exit rate)",
            [
                ("detumble_enter_rate_deg_s", self.detumble_enter_rate_deg_s, enter),
                ("detumble_exit_rate_deg_s", self.detumble_exit_rate_deg_s, exit),
            ],
        )?;
        let [hold_enter_error_deg, hold_enter_rate_deg_s, hold_exit_error_deg] = group(
            hold_used,
            "[modes.manoeuvre] with [modes.hold] (manoeuvre → hold below the enter error and rate, hold → manoeuvre above the exit error)",
            [
                ("hold_enter_error_deg", self.hold_enter_error_deg, UNUSED_HOLD_ENTER_DEG),
                ("hold_enter_rate_deg_s", self.hold_enter_rate_deg_s, UNUSED_HOLD_ENTER_DEG),
                ("hold_exit_error_deg", self.hold_exit_error_deg, UNUSED_HOLD_EXIT_DEG),
            ],
        )?;
        Ok(Thresholds {
            detumble_enter_rate_deg_s,
            detumble_exit_rate_deg_s,
            stabilise_exit_error_deg: self.stabilise_exit_error_deg,
            stabilise_exit_rate_deg_s: self.stabilise_exit_rate_deg_s,
            hold_enter_error_deg,
            hold_enter_rate_deg_s,
            hold_exit_error_deg,
            dwell_s: self.dwell_s,
            trigger_persistence_s: self.trigger_persistence_s,
        })
    }

    /// The thresholds `modes.png` draws, in the units of `[modes]` (deg, deg/s): those
    /// the file gives (zero ones, unused, are left out). The hold-entry rate is compared
    /// on board with the rate relative to the target, drawn against the body rate norm.
    pub fn plot_thresholds(&self) -> crate::recorder::output::ModeThresholds {
        let keep = |v: &[(Option<f64>, &str)]| -> Vec<(f64, String)> {
            v.iter().filter_map(|(x, l)| x.filter(|x| *x > 0.0).map(|x| (x, l.to_string()))).collect()
        };
        crate::recorder::output::ModeThresholds {
            error_deg: keep(&[
                (Some(self.stabilise_exit_error_deg), "stabilise exit"),
                (self.hold_enter_error_deg, "hold enter"),
                (self.hold_exit_error_deg, "hold exit"),
            ]),
            rate_deg_s: keep(&[
                (self.detumble_enter_rate_deg_s, "detumble enter"),
                (self.detumble_exit_rate_deg_s, "detumble exit"),
                (Some(self.stabilise_exit_rate_deg_s), "stabilise exit"),
                (self.hold_enter_rate_deg_s, "hold enter (rel.)"),
            ]),
        }
    }
}

/// One group of thresholds of a transition: all given, or (when the table cannot make
/// the transition) none given and each inert. `why` says when the group is needed.
fn group<const N: usize>(used: bool, why: &str, keys: [(&str, Option<f64>, f64); N]) -> Result<[f64; N]> {
    let given = keys.iter().any(|k| k.1.is_some());
    let mut out = [0.0; N];
    for (o, (key, value, inert)) in out.iter_mut().zip(keys) {
        *o = match value {
            Some(v) => v,
            None if used || given => {
                return Err(anyhow::anyhow!(
                    "missing key `modes.{key}`: the [modes] table needs it with {why} (docs/scenario.md)"
                ));
            }
            None => inert,
        };
    }
    Ok(out)
}

fn default_initial() -> String {
    "detumble".into()
}

/// One mode: its law, the actuator family it commands and (detumble, stabilise) its target.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModeSpec {
    pub controller: Controller,
    /// "cmg", "wheels", "magnetorquers" or "thrusters"; may be omitted with one family.
    #[serde(default)]
    pub actuator: Option<String>,
    /// Default: the scenario's `[target]`. Not allowed for manoeuvre and hold.
    #[serde(default)]
    pub target: Option<AttitudeSpec>,
    /// The mode's own pointing (instead of `target`; default: the mission's). Not allowed
    /// for manoeuvre and hold.
    #[serde(default)]
    pub guidance: Option<GuidanceSpec>,
}

impl ModeSpec {
    /// The key of this mode's pointing (`modes.<mode>.target` / `.guidance`), or the
    /// mission's (`target` / `guidance`) when it has none of its own.
    pub fn pointing_key(spec: Option<&ModeSpec>, mode: Mode, sc: &Scenario) -> String {
        let key = format!("modes.{}", mode.name());
        match spec {
            Some(s) if s.target.is_some() => format!("{key}.target"),
            Some(s) if s.guidance.is_some() => format!("{key}.guidance"),
            _ if sc.guidance.is_some() => "guidance".into(),
            _ => "target".into(),
        }
    }
}

/// A ground command at `at_s`: a new mission target and/or a mode command.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CommandSpec {
    pub at_s: f64,
    /// New mission target, in the frame of `[target]`.
    #[serde(default)]
    pub target: Option<AttitudeSpec>,
    /// New mission pointing (`SetPointing`; with `[guidance]`).
    #[serde(default)]
    pub guidance: Option<GuidanceSpec>,
    /// "detumble", "sun_safe", "stabilise", "manoeuvre", "hold" (enter) or "auto" (resume automatic
    /// transitions).
    #[serde(default)]
    pub mode: Option<String>,
    /// With a mode: stay there (automatic transitions suspended until "auto").
    #[serde(default)]
    pub lock: bool,
}

pub fn parse_mode(s: &str) -> Option<Mode> {
    Mode::ALL.into_iter().find(|m| m.name() == s)
}

impl ModesSpec {
    pub fn slots(&self) -> [(Mode, Option<&ModeSpec>); MODE_COUNT] {
        [
            (Mode::Detumble, self.detumble.as_ref()),
            (Mode::Stabilise, self.stabilise.as_ref()),
            (Mode::Manoeuvre, self.manoeuvre.as_ref()),
            (Mode::Hold, self.hold.as_ref()),
            (Mode::SunSafe, self.sun_safe.as_ref()),
        ]
    }
}

/// The mode manager's thresholds: each within the flight code's range, and the
/// hysteresis of detumble and hold.
fn validate_mode_thresholds(m: &Thresholds) -> Result<()> {
    let max_deg = max_threshold_deg();
    let max_s = f64::from(acs_flight::params::MAX_THRESHOLD);
    for (k, v, max) in [
        ("modes.detumble_enter_rate_deg_s", m.detumble_enter_rate_deg_s, max_deg),
        ("modes.detumble_exit_rate_deg_s", m.detumble_exit_rate_deg_s, max_deg),
        ("modes.stabilise_exit_error_deg", m.stabilise_exit_error_deg, max_deg),
        ("modes.stabilise_exit_rate_deg_s", m.stabilise_exit_rate_deg_s, max_deg),
        ("modes.hold_enter_error_deg", m.hold_enter_error_deg, max_deg),
        ("modes.hold_enter_rate_deg_s", m.hold_enter_rate_deg_s, max_deg),
        ("modes.hold_exit_error_deg", m.hold_exit_error_deg, max_deg),
        ("modes.dwell_s", m.dwell_s, max_s),
        ("modes.trigger_persistence_s", m.trigger_persistence_s, max_s),
    ] {
        if !(v.is_finite() && v >= 0.0 && v <= max) {
            return Err(bad(k, format!("must be in [0, {max:.6e}] (the flight code's range)")));
        }
    }
    if !(m.detumble_enter_rate_deg_s > m.detumble_exit_rate_deg_s && m.detumble_exit_rate_deg_s > 0.0) {
        return Err(bad("modes.detumble_enter_rate_deg_s", "must exceed detumble_exit_rate_deg_s (> 0): hysteresis"));
    }
    if m.hold_exit_error_deg.partial_cmp(&m.hold_enter_error_deg) != Some(std::cmp::Ordering::Greater) {
        return Err(bad("modes.hold_exit_error_deg", "must exceed hold_enter_error_deg: hysteresis"));
    }
    Ok(())
}

impl Scenario {
    pub(super) fn validate_modes(&self, m: &ModesSpec) -> Result<()> {
        let initial = parse_mode(&m.initial).ok_or_else(|| {
            bad("modes.initial", "must be \"detumble\", \"sun_safe\", \"stabilise\", \"manoeuvre\" or \"hold\"")
        })?;
        validate_mode_thresholds(&m.thresholds()?)?;
        self.validate_mode_monitors(m)?;
        self.validate_mode_slots(m, initial)?;
        self.validate_mode_table(m)
    }

    /// The momentum, singularity and slow-FDIR monitors: ranges, and the wheels the
    /// momentum monitors need.
    fn validate_mode_monitors(&self, m: &ModesSpec) -> Result<()> {
        let (trip, recover) = (m.momentum_trip_speed_fraction, m.momentum_recover_speed_fraction);
        if !(trip.is_finite() && (0.0..=1.0).contains(&trip)) {
            return Err(bad("modes.momentum_trip_speed_fraction", "must be in [0, 1] (0 = off)"));
        }
        if trip > 0.0 && !(recover.is_finite() && recover >= 0.0 && recover < trip) {
            return Err(bad(
                "modes.momentum_recover_speed_fraction",
                "must be >= 0 and below momentum_trip_speed_fraction",
            ));
        }
        for (key, v, hi) in [
            ("modes.momentum_keepup_fraction", m.momentum_keepup_fraction, 1.0),
            ("modes.gimbal_singularity_min", m.gimbal_singularity_min, 2.0),
            ("modes.slow_fdir_persistence_s", m.slow_fdir_persistence_s, 1.0e7),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(bad(key, format!("must be in [0, {hi}] (0 = off)")));
            }
        }
        if m.momentum_keepup_fraction > 0.0 && self.actuators.wheels.is_none() {
            return Err(bad("modes.momentum_keepup_fraction", "monitors wheel momentum: needs [actuators.wheels]"));
        }
        if trip > 0.0 && self.actuators.wheels.is_none() {
            return Err(bad("modes.momentum_trip_speed_fraction", "monitors wheel speeds: needs [actuators.wheels]"));
        }
        Ok(())
    }

    /// Each `[modes.<mode>]` table present (the initial mode's must be).
    fn validate_mode_slots(&self, m: &ModesSpec, initial: Mode) -> Result<()> {
        let n_families = [
            self.actuators.cmg.is_some(),
            self.actuators.wheels.is_some(),
            self.actuators.magnetorquers.is_some(),
            self.actuators.thrusters.is_some(),
        ]
        .iter()
        .filter(|x| **x)
        .count();
        for (mode, spec) in m.slots() {
            let Some(spec) = spec else {
                if mode == initial {
                    return Err(bad("modes.initial", format!("no [modes.{}]", mode.name())));
                }
                continue;
            };
            self.validate_mode_spec(mode, spec, n_families)?;
        }
        Ok(())
    }

    /// The flight code's own checks of the built mode table: each mode's law parameters
    /// and the mode manager's thresholds.
    fn validate_mode_table(&self, m: &ModesSpec) -> Result<()> {
        let table = self.mode_table()?.ok_or_else(|| bad("modes", "missing"))?;
        for (mode, p) in &table.slots {
            let key = format!("modes.{}", mode.name());
            let spec = m.slots().into_iter().find(|(md, _)| md == mode).and_then(|(_, sp)| sp);
            let target = ModeSpec::pointing_key(spec, *mode, self);
            let law = spec.map(|s| &s.controller);
            p.validate().map_err(|e| self.param_refusal(e, &format!("{key}.controller"), law, &target))?;
        }
        table
            .manager
            .validate()
            .map_err(|e| bad("modes", format!("the flight code refused the mode-manager thresholds: {e}")))?;
        Ok(())
    }

    /// One `[modes.<mode>]` table (`n_families`: actuator families present).
    fn validate_mode_spec(&self, mode: Mode, spec: &ModeSpec, n_families: usize) -> Result<()> {
        let key = format!("modes.{}", mode.name());
        match spec.actuator.as_deref() {
            None if n_families != 1 => {
                return Err(bad(
                    &format!("{key}.actuator"),
                    "required with several actuator families: name the one this mode's law commands \
                     (\"wheels\", \"magnetorquers\", \"cmg\" or \"thrusters\")",
                ));
            }
            None => {}
            Some(f @ ("cmg" | "wheels" | "magnetorquers" | "thrusters")) => {
                let present = match f {
                    "cmg" => self.actuators.cmg.is_some(),
                    "wheels" => self.actuators.wheels.is_some(),
                    "magnetorquers" => self.actuators.magnetorquers.is_some(),
                    _ => self.actuators.thrusters.is_some(),
                };
                if !present {
                    return Err(bad(&format!("{key}.actuator"), format!("no [actuators.{f}]")));
                }
            }
            Some(other) => {
                return Err(bad(
                    &format!("{key}.actuator"),
                    format!("unknown family {other:?} (known: \"cmg\", \"wheels\", \"magnetorquers\", \"thrusters\")"),
                ));
            }
        }
        if matches!(spec.controller, Controller::None) {
            return Err(bad(&format!("{key}.controller"), "a mode needs a control law"));
        }
        if spec.target.is_some() && spec.guidance.is_some() {
            return Err(bad(&format!("{key}.guidance"), "give target or guidance, not both"));
        }
        if let Some(g) = &spec.guidance {
            if matches!(mode, Mode::Manoeuvre | Mode::Hold) {
                return Err(bad(
                    &format!("{key}.guidance"),
                    "manoeuvre and hold point at the mission pointing ([target] or [guidance])",
                ));
            }
            g.resolve(&format!("{key}.guidance"), self.orbit.is_some())?;
        }
        if let Some(t) = &spec.target {
            if matches!(mode, Mode::Manoeuvre | Mode::Hold) {
                return Err(bad(&format!("{key}.target"), "manoeuvre and hold point at [target]"));
            }
            t.validate(&format!("{key}.target"))?;
            if t.frame == RefFrame::Lvlh && self.orbit.is_none() {
                return Err(bad(&format!("{key}.target.frame"), "needs an [orbit]"));
            }
        }
        self.validate_controller(&spec.controller, &format!("{key}.controller"))?;
        Ok(())
    }

    pub(super) fn validate_commands(&self) -> Result<()> {
        let mut last = f64::NEG_INFINITY;
        for (k, c) in self.commands.iter().enumerate() {
            let key = format!("commands[{k}]");
            if !(c.at_s.is_finite() && c.at_s >= last && c.at_s >= 0.0) {
                return Err(bad(&key, "at_s must be finite, >= 0 and non-decreasing"));
            }
            last = c.at_s;
            if !self.closed_loop() {
                return Err(bad(&key, "commands go to the flight code: needs a controller or [modes]"));
            }
            self.validate_command_pointing(c, &key)?;
            match (c.mode.as_deref(), &self.modes) {
                (None, _) => {
                    if c.target.is_none() && c.guidance.is_none() {
                        return Err(bad(&key, "give a target (or guidance) and/or a mode"));
                    }
                    if c.lock {
                        return Err(bad(&format!("{key}.lock"), "needs a mode"));
                    }
                }
                (Some(_), None) => return Err(bad(&format!("{key}.mode"), "needs [modes]")),
                (Some("auto"), Some(_)) => {
                    if c.lock {
                        return Err(bad(&format!("{key}.lock"), "\"auto\" cannot be locked"));
                    }
                }
                (Some(m), Some(spec)) => {
                    let mode =
                        parse_mode(m).ok_or_else(|| bad(&format!("{key}.mode"), format!("unknown mode {m:?}")))?;
                    if spec.slots().iter().all(|(x, s)| *x != mode || s.is_none()) {
                        return Err(bad(&format!("{key}.mode"), format!("no [modes.{m}]")));
                    }
                }
            }
        }
        Ok(())
    }

    /// A command's new pointing: a `target` in the frame of `[target]`, or a `guidance`
    /// with `[guidance]`.
    fn validate_command_pointing(&self, c: &CommandSpec, key: &str) -> Result<()> {
        if let Some(t) = &c.target {
            let Some(mission) = &self.target else {
                return Err(bad(&format!("{key}.target"), "needs [target] (with [guidance]: give guidance)"));
            };
            t.validate(&format!("{key}.target"))?;
            if t.frame != mission.frame {
                return Err(bad(&format!("{key}.target.frame"), "must be the frame of [target]"));
            }
        }
        if let Some(g) = &c.guidance {
            if self.guidance.is_none() {
                return Err(bad(&format!("{key}.guidance"), "needs [guidance] (with [target]: give target)"));
            }
            if c.target.is_some() {
                return Err(bad(&format!("{key}.guidance"), "give target or guidance, not both"));
            }
            g.resolve(&format!("{key}.guidance"), self.orbit.is_some())?;
        }
        Ok(())
    }

    /// The mode table to upload (`None` without `[modes]`).
    pub fn mode_table(&self) -> Result<Option<ModeTable>> {
        let Some(m) = &self.modes else {
            return Ok(None);
        };
        let mut slots = Vec::new();
        let mut mask = 0u8;
        for (mode, spec) in m.slots() {
            if let Some(spec) = spec {
                let key = format!("modes.{}", mode.name());
                let guidance = match (&spec.target, &spec.guidance) {
                    (Some(t), _) => fixed_guidance(t),
                    (None, Some(g)) => g.resolve(&format!("{key}.guidance"), self.orbit.is_some())?.params,
                    (None, None) => self.mission_guidance()?,
                };
                let mut p = self
                    .params_for(&spec.controller, spec.actuator.as_deref(), guidance)
                    .with_context(|| key.clone())?;
                p.momentum = self.momentum_params(Some(mode), &p.actuator);
                slots.push((mode, p));
                mask |= 1 << mode.index();
            }
        }
        let deg = |x: f64| x.to_radians() as f32;
        let t = m.thresholds()?;
        let manager = ModeManagerParams {
            slots: mask,
            initial: parse_mode(&m.initial).ok_or_else(|| bad("modes.initial", "unknown mode"))?,
            detumble_enter_rate_rad_s: deg(t.detumble_enter_rate_deg_s),
            detumble_exit_rate_rad_s: deg(t.detumble_exit_rate_deg_s),
            stabilise_exit_error_rad: deg(t.stabilise_exit_error_deg),
            stabilise_exit_rate_rad_s: deg(t.stabilise_exit_rate_deg_s),
            hold_enter_error_rad: deg(t.hold_enter_error_deg),
            hold_enter_rate_rad_s: deg(t.hold_enter_rate_deg_s),
            hold_exit_error_rad: deg(t.hold_exit_error_deg),
            dwell_s: t.dwell_s as f32,
            trigger_persistence_s: t.trigger_persistence_s as f32,
            momentum_trip_fraction: m.momentum_trip_speed_fraction as f32,
            momentum_recover_fraction: m.momentum_recover_speed_fraction as f32,
            momentum_keepup_fraction: m.momentum_keepup_fraction as f32,
            gimbal_singularity_min: m.gimbal_singularity_min as f32,
            slow_fdir_persistence_s: m.slow_fdir_persistence_s as f32,
        };
        Ok(Some(ModeTable { slots, manager }))
    }

    /// The link messages of a command, in order.
    pub fn command_messages(&self, c: &CommandSpec) -> Vec<acs_flight::link::HostMsg> {
        use acs_flight::link::HostMsg;
        let mut v = Vec::new();
        if let Some(t) = &c.target {
            let q = t.quaternion();
            v.push(HostMsg::SetTarget { target_q_xyzw: [q.i as f32, q.j as f32, q.k as f32, q.w as f32] });
        }
        // Validated with the scenario: a refusal here cannot happen.
        if let Some(g) = c.guidance.as_ref().and_then(|g| g.resolve("commands.guidance", self.orbit.is_some()).ok()) {
            v.push(HostMsg::SetPointing(g.params));
        }
        match c.mode.as_deref() {
            Some("auto") => v.push(HostMsg::CommandMode(ModeRequest::Auto)),
            Some(m) => {
                if let Some(mode) = parse_mode(m) {
                    v.push(HostMsg::CommandMode(if c.lock {
                        ModeRequest::Lock(mode)
                    } else {
                        ModeRequest::Enter(mode)
                    }));
                }
            }
            None => {}
        }
        v
    }
}
