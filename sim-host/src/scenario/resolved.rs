//! A scenario resolved once into the typed values a run consumes (issue 9, "parse, don't
//! validate"): the [`Clock`], the plant, the actuator models and what the flight side
//! receives, each built by the one function that checks its tables.

use super::{Clock, ModeTable, Scenario};
use crate::plant::Spacecraft;
use crate::plant::magnetorquers::MagnetorquerSet;
use crate::plant::thrusters::ThrusterSet;
use acs_flight::params::FlightParams;
use anyhow::Result;

/// What the flight side receives before the first step of a closed-loop run.
#[derive(Clone, Debug)]
pub enum Upload {
    /// One parameter set (`[controller]`, with its LQR/LQG design done).
    Params(Box<FlightParams>),
    /// The mode table (`[modes]`).
    Modes(ModeTable),
}

/// A scenario whose every subsystem has been checked and built once.
#[derive(Clone, Debug)]
pub struct Resolved<'a> {
    /// The schema, for what is used as given (name, ground commands, open-loop rows,
    /// recorded columns, sensors); checked when it was loaded.
    pub scenario: &'a Scenario,
    pub clock: Clock,
    /// `None`: open loop (the flight code does not run).
    pub upload: Option<Upload>,
    /// The plant (body, CMGs, wheels, environment, rig) before its first step.
    pub craft: Spacecraft,
    pub thrusters: Option<ThrusterSet>,
    pub magnetorquers: MagnetorquerSet,
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
        Ok(Self {
            scenario: sc,
            clock: Clock::try_from(sc)?,
            upload,
            craft: sc.spacecraft()?,
            thrusters: sc.thruster_set(),
            magnetorquers: sc.magnetorquer_set(),
        })
    }
}
