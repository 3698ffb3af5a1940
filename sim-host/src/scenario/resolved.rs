//! A scenario resolved once into the typed values a run consumes (issue 9, "parse, don't
//! validate"): the [`Clock`], the plant, the actuator models and what the flight side
//! receives, each built by the one function that checks its tables.

use super::{Clock, Controller, InertiaChange, ModeTable, OpenLoopRow, RefFrame, Scenario};
use crate::attitude::Quat;
use crate::columns::Layout;
use crate::plant::Spacecraft;
use crate::plant::magnetorquers::MagnetorquerSet;
use crate::plant::thrusters::ThrusterSet;
use crate::sensors::SensorSuite;
use acs_flight::math::EulerSeq;
use acs_flight::params::{FlightParams, MAX_THRUSTERS};
use anyhow::Result;

/// What the flight side receives before the first step of a closed-loop run.
#[derive(Clone, Debug)]
pub enum Upload {
    /// One parameter set (`[controller]`, with its LQR/LQG design done).
    Params(Box<FlightParams>),
    /// The mode table (`[modes]`).
    Modes(ModeTable),
}

/// The attitude target at the start of the run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetConfig {
    /// Relative to its frame.
    pub q_rel: Quat,
    /// The sequence of the Euler angles reported against it.
    pub seq: EulerSeq,
    /// The frame is LVLH (else inertial).
    pub lvlh: bool,
}

/// A scenario whose every subsystem has been checked and built once.
pub struct Resolved<'a> {
    /// The schema, for what is used as given (name, rates, initial state, ground
    /// commands); checked when it was loaded.
    pub scenario: &'a Scenario,
    pub clock: Clock,
    /// `None`: open loop (the flight code does not run).
    pub upload: Option<Upload>,
    /// The plant (body, CMGs, wheels, environment, rig) before its first step.
    pub craft: Spacecraft,
    pub thrusters: Option<ThrusterSet>,
    /// Thrusters the flight side and the recorded columns see (at most `MAX_THRUSTERS`).
    pub n_thrusters: usize,
    pub magnetorquers: MagnetorquerSet,
    pub sensors: SensorSuite,
    pub target: TargetConfig,
    pub inertia_change: Option<InertiaChange>,
    /// The open-loop command table (empty without `[open_loop]`).
    pub open_loop: Vec<OpenLoopRow>,
    /// The recorded columns.
    pub layout: Layout,
}

impl<'a> TryFrom<&'a Scenario> for Resolved<'a> {
    type Error = anyhow::Error;

    fn try_from(sc: &'a Scenario) -> Result<Self> {
        let upload = if sc.closed_loop() {
            Some(match sc.mode_table()? {
                Some(table) => Upload::Modes(table),
                None => Upload::Params(Box::new(sc.flight_params()?)),
            })
        } else {
            None
        };
        let craft = sc.spacecraft()?;
        let thrusters = sc.thruster_set();
        let n_thrusters = thrusters.as_ref().map_or(0, |t| t.thrusters.len()).min(MAX_THRUSTERS);
        let target = TargetConfig {
            q_rel: sc.target.quaternion(),
            seq: sc.target.euler_sequence.into(),
            lvlh: sc.target.frame == RefFrame::Lvlh,
        };
        Ok(Self {
            scenario: sc,
            clock: Clock::try_from(sc)?,
            upload,
            layout: layout(sc, craft.wheels.len(), n_thrusters),
            craft,
            thrusters,
            n_thrusters,
            magnetorquers: sc.magnetorquer_set(),
            sensors: SensorSuite::new(&sc.sensors, sc.timing.control_rate_hz),
            target,
            inertia_change: sc.spacecraft.inertia_change.clone(),
            open_loop: sc.open_loop.as_ref().map_or_else(Vec::new, |o| o.commands.clone()),
        })
    }
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
    }
}
