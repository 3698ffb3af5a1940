//! A scenario resolved once into the typed values a run consumes (issue 9, "parse, don't
//! validate"): the [`Clock`], the plant, the actuator models and what the flight side
//! receives, each built by the one function that checks its tables.

use super::{AttitudeSpec, Clock, Controller, InertiaChange, ModeTable, OpenLoopRow, RefFrame, Scenario};
use crate::attitude::Quat;
use crate::environment::frames::{EarthOrientation, EarthRotation};
use crate::environment::guidance::{TruthGuidance, TruthPointing, TruthSet};
use crate::environment::model::EnvSnapshot;
use crate::plant::magnetorquers::MagnetorquerSet;
use crate::plant::thrusters::ThrusterSet;
use crate::plant::{Spacecraft, State};
use crate::recorder::columns::Layout;
use crate::sensors::SensorSuite;
use acs_flight::link::HostMsg;
use acs_flight::math::EulerSeq;
use acs_flight::params::{EstimationParams, FlightParams, MAX_THRUSTERS, MODE_COUNT};
use anyhow::Result;

/// What the flight side receives before the first step of a closed-loop run.
#[derive(Clone, Debug)]
pub enum Upload {
    /// One parameter set (`[controller]`, with its LQR/LQG design done).
    Params(Box<FlightParams>),
    /// The mode table (`[modes]`).
    Modes(ModeTable),
}

/// The attitude target at the start of the run (with `[guidance]`: the frame of the Euler
/// angles only, LVLH with an orbit, else inertial; the truth gives the target).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetConfig {
    /// Relative to its frame.
    pub q_rel: Quat,
    /// The sequence of the Euler angles reported against it.
    pub seq: EulerSeq,
    /// The frame is LVLH (else inertial).
    pub lvlh: bool,
}

impl TargetConfig {
    /// The scenario's target: its `[target]`, else (with `[guidance]` or none) the identity
    /// in LVLH when there is an orbit, in the inertial frame otherwise, Euler sequence 3-2-1.
    pub fn of(sc: &Scenario) -> Self {
        match &sc.target {
            Some(t) => {
                TargetConfig { q_rel: t.quaternion(), seq: t.euler_sequence.into(), lvlh: t.frame == RefFrame::Lvlh }
            }
            None => TargetConfig { q_rel: Quat::identity(), seq: EulerSeq::Zyx321, lvlh: sc.orbit.is_some() },
        }
    }
}

/// A ground command, resolved: when it is sent, its link messages in order, and the new
/// target it sets (relative to the target's frame) or the truth of its new pointing.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundCommand {
    pub at_s: f64,
    pub messages: Vec<HostMsg>,
    pub target: Option<Quat>,
    pub pointing: Option<TruthSet>,
}

/// A scenario whose every subsystem has been checked and built once; a run reads nothing
/// else.
pub struct Resolved {
    /// The scenario's name (reported in the summary).
    pub name: String,
    pub clock: Clock,
    /// Control and dynamics (RK4) rates, Hz, as reported in the summary.
    pub control_rate_hz: f64,
    pub dynamics_rate_hz: f64,
    /// `None`: open loop (the flight code does not run).
    pub upload: Option<Upload>,
    /// Attitude determination sent after the upload (`None`: the flight code's default,
    /// the sensor's attitude as measured).
    pub estimation: Option<EstimationParams>,
    /// The plant (body, CMGs, wheels, environment, rig) before its first step.
    pub craft: Spacecraft,
    /// The environment at t = 0 (`None` without one) and the initial state of the plant.
    pub snap0: Option<EnvSnapshot>,
    pub initial: State,
    pub thrusters: Option<ThrusterSet>,
    /// Thrusters the flight side and the recorded columns see (at most `MAX_THRUSTERS`).
    pub n_thrusters: usize,
    pub magnetorquers: MagnetorquerSet,
    pub sensors: SensorSuite,
    pub target: TargetConfig,
    /// The truth of the pointing (`[guidance]` only).
    pub truth: Option<TruthGuidance>,
    pub inertia_change: Option<InertiaChange>,
    /// The open-loop command table (empty without `[open_loop]`).
    pub open_loop: Vec<OpenLoopRow>,
    /// The timed ground commands, in order.
    pub commands: Vec<GroundCommand>,
    /// The recorded columns.
    pub layout: Layout,
    /// `[manoeuvre]` keep-out cones, for the truth's margin columns (with an orbit).
    pub keepout: Vec<crate::recorder::keepout::Cone>,
    /// `[manoeuvre] keepout_enforced_from_s`: a truth violation from then fails the run.
    pub keepout_enforced_from_s: f64,
    /// Momentum FDIR trip (wheel speed fraction), for the summary (`None`: off).
    pub momentum_trip: Option<f64>,
    /// The keep-up and gimbal monitors are on (`[modes] slow_fdir_persistence_s` > 0).
    pub slow_fdir: bool,
    /// Settle bound and pointing-performance windows (`[performance]`).
    pub performance: super::Performance,
    /// The injected faults (`[[faults]]`; empty: none).
    pub faults: Vec<crate::faults::TimedFault>,
    /// `[[timeline]]`, checked (empty: none), and whether a missed segment is allowed.
    pub timeline: Vec<super::TimelineEntry>,
    pub allow_missed_segments: bool,
    /// `[fdir]` is on: the flight's FDIR events are recorded and a false alarm fails the run.
    pub fdir: bool,
    /// The body rate the `control_lost` verdict calls a tumble, deg/s (`[modes]
    /// detumble_enter_rate_deg_s`, else `recorder::control_lost::CONTROL_LOST_RATE_DEG_S`).
    pub tumble_rate_deg_s: f64,
    /// The degraded-hold bound of the `pointing_degraded` verdict, deg (`[performance]
    /// degraded_hold_error_deg`, else `[modes] hold_enter_error_deg`, else the settle bound).
    pub degraded_hold_error_deg: f64,
}

impl TryFrom<&Scenario> for Resolved {
    type Error = anyhow::Error;

    fn try_from(sc: &Scenario) -> Result<Self> {
        let upload = if sc.closed_loop() {
            Some(match sc.mode_table()? {
                Some(table) => Upload::Modes(table),
                None => Upload::Params(Box::new(sc.flight_params()?)),
            })
        } else {
            None
        };
        let estimation = match &sc.estimation {
            Some(e) if sc.closed_loop() => Some(sc.estimation_params(e)?),
            _ => None,
        };
        let mut craft = sc.spacecraft()?;
        let snap0 = craft.env_at(0.0)?;
        let initial = sc.initial_state(&craft, snap0.as_ref());
        let thrusters = sc.thruster_set();
        let n_thrusters = thrusters.as_ref().map_or(0, |t| t.thrusters.len()).min(MAX_THRUSTERS);
        let target = TargetConfig::of(sc);
        let has_orbit = sc.orbit.is_some();
        let commands = sc
            .commands
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let pointing = c.guidance.as_ref().map(|g| g.resolve(&format!("commands[{k}].guidance"), has_orbit));
                Ok(GroundCommand {
                    at_s: c.at_s,
                    messages: sc.command_messages(c),
                    target: c.target.as_ref().map(AttitudeSpec::quaternion),
                    pointing: pointing.transpose()?.map(|g| g.truth()),
                })
            })
            .collect::<Result<_>>()?;
        let truth = truth_guidance(sc, &craft)?;
        Ok(Self {
            name: sc.name.clone(),
            clock: Clock::try_from(sc)?,
            control_rate_hz: sc.timing.control_rate_hz,
            dynamics_rate_hz: sc.timing.control_rate_hz * sc.timing.dynamics_substeps as f64,
            upload,
            estimation,
            layout: layout(sc, craft.wheels.len(), n_thrusters),
            keepout: keepout_cones(sc),
            keepout_enforced_from_s: sc.manoeuvre.as_ref().map_or(0.0, |m| m.keepout_enforced_from_s),
            craft,
            snap0,
            initial,
            thrusters,
            n_thrusters,
            magnetorquers: sc.magnetorquer_set(),
            sensors: SensorSuite::new(&sc.sensors.suite_spec(sc.timing.control_rate_hz)),
            target,
            truth,
            inertia_change: sc.spacecraft.inertia_change.clone(),
            open_loop: sc.open_loop.as_ref().map_or_else(Vec::new, |o| o.commands.clone()),
            commands,
            momentum_trip: sc.modes.as_ref().map(|m| m.momentum_trip_speed_fraction).filter(|f| *f > 0.0),
            slow_fdir: sc.modes.as_ref().is_some_and(|m| m.slow_fdir_persistence_s > 0.0),
            performance: sc.performance()?,
            faults: sc.faults()?,
            timeline: sc.timeline_entries()?,
            allow_missed_segments: sc.performance.allow_missed_segments,
            fdir: sc.fdir.is_some(),
            tumble_rate_deg_s: sc
                .modes
                .as_ref()
                .and_then(|m| m.detumble_enter_rate_deg_s)
                .unwrap_or(crate::recorder::control_lost::CONTROL_LOST_RATE_DEG_S),
            degraded_hold_error_deg: sc
                .performance
                .degraded_hold_error_deg
                .or(sc.modes.as_ref().and_then(|m| m.hold_enter_error_deg))
                .unwrap_or(sc.performance.settle_bound_deg),
        })
    }
}

/// The truth of a scenario's pointing, with `[guidance]` or `[modes]` (`None` otherwise):
/// the mission's (`[guidance]` or `[target]`), each mode's own (`target` or `guidance` of
/// `[modes.<mode>]`), the Earth orientation of `[orbit]`.
fn truth_guidance(sc: &Scenario, craft: &Spacecraft) -> Result<Option<TruthGuidance>> {
    let fixed = |label: String, t: &AttitudeSpec| TruthSet {
        label,
        main: TruthPointing::fixed(t.quaternion(), t.frame == RefFrame::Lvlh),
        gate: None,
    };
    let set = match (sc.mission_set()?, &sc.target) {
        (Some(g), _) => g.truth(),
        (None, Some(t)) if sc.modes.is_some() => fixed("target".into(), t),
        _ => return Ok(None),
    };
    let rotation = craft.env.as_ref().map_or(EarthRotation::Simple { theta0_rad: 0.0 }, |e| e.earth);
    let earth = match &sc.orbit {
        Some(o) => o.earth_orientation(rotation)?,
        None => EarthOrientation::of(rotation),
    };
    let mut modes = vec![None; MODE_COUNT];
    if let Some(m) = &sc.modes {
        for (mode, spec) in m.slots() {
            let key = format!("modes.{}", mode.name());
            let own = match spec.map(|s| (&s.target, &s.guidance)) {
                Some((Some(t), _)) => Some(fixed(format!("{key}.target"), t)),
                Some((None, Some(g))) => Some(g.resolve(&format!("{key}.guidance"), sc.orbit.is_some())?.truth()),
                _ => None,
            };
            if let Some(slot) = modes.get_mut(mode.index()) {
                *slot = own;
            }
        }
    }
    Ok(Some(TruthGuidance { mission: set, modes, earth }))
}

/// The columns a scenario records (see [`Layout`]).
pub fn layout(sc: &Scenario, n_wheels: usize, n_thrusters: usize) -> Layout {
    Layout {
        adaptive_gains: matches!(sc.controller, Some(Controller::Dmcs { .. })),
        mode: sc.modes.is_some(),
        flight_error: sc.closed_loop(),
        cmg: sc.actuators.cmg.is_some(),
        wheels: n_wheels,
        magnetorquers: sc.actuators.magnetorquers.is_some(),
        thrusters: n_thrusters,
        field: sc.orbit.is_some() || sc.environment.lab_field_t.is_some(),
        env_torques: has_environment(sc),
        estimation: sc.estimation.as_ref().is_some_and(|e| e.source == super::estimation::SourceSpec::Mekf),
        momentum: sc.momentum.is_some()
            || sc
                .modes
                .as_ref()
                .is_some_and(|m| m.momentum_trip_speed_fraction > 0.0 || m.slow_fdir_persistence_s > 0.0),
        eclipse: sc.orbit.is_some(),
        guidance: sc.guidance.is_some(),
        keepout: crate::recorder::keepout::column_names(&keepout_cones(sc)),
        faults: !sc.faults.is_empty(),
        timeline: sc.timeline.is_some(),
        fdir_wheels: if sc.fdir.as_ref().is_some_and(|f| f.wheels.is_some()) { n_wheels } else { 0 },
        fdir_magnetometer: sc.fdir.as_ref().is_some_and(|f| f.magnetometer.is_some()),
        fdir_gnss: sc.fdir.as_ref().is_some_and(|f| f.gnss.is_some()),
    }
}

/// The keep-out cones the truth records (none without an orbit or `[manoeuvre]` cones).
pub fn keepout_cones(sc: &Scenario) -> Vec<crate::recorder::keepout::Cone> {
    match (&sc.manoeuvre, &sc.orbit) {
        (Some(m), Some(_)) if !m.keepout.is_empty() => m.keepout.iter().map(cone_of).collect(),
        _ => Vec::new(),
    }
}

/// Whether any environment or rig torque can act (the torque breakdown is recorded then).
fn has_environment(sc: &Scenario) -> bool {
    sc.orbit.is_some()
        || sc.rig.is_some()
        || sc.environment.lab_field_t.is_some()
        || sc.spacecraft.harmonic_torque.is_some()
        || sc.spacecraft.external_torque_nm != [0.0; 3]
}

/// A `[[manoeuvre.keepout]]` entry as the recorder's margin columns use it (f64, unit
/// boresight, radians).
fn cone_of(s: &super::KeepOutSpec) -> crate::recorder::keepout::Cone {
    crate::recorder::keepout::Cone {
        name: s.name.clone(),
        boresight_body: crate::attitude::Vec3::from(s.boresight_body).normalize(),
        sun_half_angle_rad: s.sun_half_angle_deg.map(f64::to_radians),
        earth_margin_rad: s.earth_margin_deg.map(f64::to_radians),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::tests::MINIMAL;

    #[test]
    fn a_scenario_resolves_once_into_its_typed_parts() {
        let sc = Scenario::from_toml(MINIMAL).unwrap();
        let r = Resolved::try_from(&sc).unwrap();
        let Some(Upload::Params(p)) = &r.upload else { panic!("one parameter set") };
        assert_eq!(**p, sc.flight_params().unwrap());
        assert_eq!(r.clock, Clock::try_from(&sc).unwrap());
        assert!(r.craft.cmg.is_some() && r.thrusters.is_none() && r.n_thrusters == 0);
        assert!(r.layout.cmg && r.layout.flight_error && !r.layout.mode);
        assert!(!r.target.lvlh && r.inertia_change.is_none() && r.open_loop.is_empty());
        assert_eq!((r.name.as_str(), r.control_rate_hz, r.dynamics_rate_hz), ("t", 100.0, 100.0));
        assert!(r.commands.is_empty() && r.snap0.is_none() && r.initial.w == crate::attitude::Vec3::zeros());
    }
}
