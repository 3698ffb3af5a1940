//! Driving a run from outside, for an analysis that needs more than "fly it to the end"
//! (`sim-host margins`, docs/margins.md): [`Probe`] wraps a [`Simulation`] and adds what
//! such an analysis does to it between control steps: fork it at an operating point,
//! inject signals into the loop ([`LoopInjection`]), freeze the field or the law's
//! adaptation, fly past the scenario's end, read the last step and the plant's commands.
//! An ordinary run ([`crate::runner`]) has none of this; everything here is the analysis's
//! whole view of a run.

use super::Simulation;
use crate::attitude::{Quat, Vec3, error_angle_and_vector, rotate_ref_to_body};
use crate::environment::model::{FieldSource, FrozenField};
use crate::link::FlightLink;
use crate::plant::magnetorquers::MagnetorquerSet;
use crate::plant::{MAX_GIMBALS, MAX_WHEELS, Spacecraft, State};
use crate::recorder::series::Recorder;
use crate::recorder::summary::Failure;
use crate::scenario::Resolved;
use acs_flight::link::{ActuatorCommand, FswMsg, SensorFrame, valid};
use anyhow::{Result, bail};

/// Signals added to the loop at every control step while set
/// ([`Probe::set_injection`]): the loop broken for a frequency-response measurement
/// (`sim-host margins`, docs/margins.md). A run without one is untouched: nothing is added,
/// not even zeros.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopInjection {
    /// Added to each wheel's motor-torque command the plant receives (on the rotor), N m.
    pub wheel_torque_nm: [f64; MAX_WHEELS],
    /// Added to each gimbal-rate command the plant receives, rad/s.
    pub gimbal_rate_rad_s: [f64; MAX_GIMBALS],
    /// Added to each magnetorquer's dipole command (before the rods' delay, limits and dead
    /// band), A m².
    pub dipole_am2: [f64; 3],
    /// A small rotation (rotation vector, body axes, rad) applied to the attitude sample
    /// of the frame, `q_meas ⊗ exp(θ/2)`, when the frame carries one.
    pub attitude_rad: [f64; 3],
    /// The loop broken open at the actuator input: the plant's wheel-torque and
    /// gimbal-rate commands are the injection alone; the flight's command is computed and
    /// reported ([`Probe::last_step`]) but not applied (docs/margins.md, "Open-loop
    /// measurement"); the same for the dipole commands.
    pub replace_commands: bool,
}

impl LoopInjection {
    pub(super) fn add_to_commands(
        &self,
        wheel_torque_nm: &mut [f64; MAX_WHEELS],
        gimbal_rate_rad_s: &mut [f64; MAX_GIMBALS],
    ) {
        for (u, d) in wheel_torque_nm.iter_mut().zip(self.wheel_torque_nm) {
            *u += d;
        }
        for (u, d) in gimbal_rate_rad_s.iter_mut().zip(self.gimbal_rate_rad_s) {
            *u += d;
        }
    }

    pub(super) fn add_to_dipole(&self, dipole_am2: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| dipole_am2[i] + self.dipole_am2[i])
    }

    pub(super) fn add_to_frame(&self, frame: &mut SensorFrame) {
        if frame.valid & valid::ATTITUDE == 0 {
            return;
        }
        let [x, y, z, w] = frame.q_ib_xyzw.map(f64::from);
        let q = Quat::new(w, x, y, z) * Quat::from_imag(Vec3::from(self.attitude_rad) * 0.5).exp();
        let q = q.normalize();
        frame.q_ib_xyzw = [q.i, q.j, q.k, q.w].map(|c| c as f32);
    }
}

/// The actuator commands of the last control step as the plant receives them: the flight's
/// command with a loop injection added (or the injection alone, open loop), before the
/// actuators' delays and limits ([`Probe::plant_commands`]; `sim-host margins` checks
/// them against the limits during its experiments).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlantCommands {
    /// Per wheel, motor torque, N m.
    pub wheel_torque_nm: [f64; MAX_WHEELS],
    /// Per gimbal, rate, rad/s.
    pub gimbal_rate_rad_s: [f64; MAX_GIMBALS],
    /// Per rod, dipole, A m² (zero without magnetorquers).
    pub dipole_am2: [f64; 3],
}

/// A run driven from outside by an analysis (module doc).
pub struct Probe<'a>(Simulation<'a>);

impl<'a> Probe<'a> {
    /// Opens the flight side and starts the run, as [`Simulation::new`].
    pub fn new(cfg: Resolved, link: &'a mut dyn FlightLink) -> Result<Self> {
        Simulation::new(cfg, link).map(Self)
    }

    /// One control step ([`Simulation::step`]).
    pub fn step(&mut self, rec: &mut dyn Recorder) -> Result<()> {
        self.0.step(rec)
    }

    /// Control steps done so far.
    pub fn steps_done(&self) -> u64 {
        self.0.steps_done()
    }

    /// Whether every control step has run, or the run diverged.
    pub fn finished(&self) -> bool {
        self.0.finished()
    }

    /// The divergence that stopped the run, if any.
    pub fn failure(&self) -> Option<&Failure> {
        self.0.failure()
    }

    /// The plant's state now (at the next control step's time).
    pub fn state(&self) -> &State {
        self.0.state()
    }

    /// The scenario's duration (as extended by [`Self::extend_to`]), s.
    pub fn sim_time_s(&self) -> f64 {
        self.0.sim_time_s()
    }

    /// A copy of this run in its current state, flying against `link` (which must hold a
    /// copy of this run's flight side: [`Self::fork_link`]). Stepping the copy does
    /// not touch this run: `sim-host margins` flies to an operating point once and forks
    /// an experiment and its unexcited twin from there.
    pub fn fork<'b>(&self, link: &'b mut dyn FlightLink) -> Probe<'b> {
        let s = &self.0;
        Probe(Simulation {
            name: s.name.clone(),
            control_rate_hz: s.control_rate_hz,
            dynamics_rate_hz: s.dynamics_rate_hz,
            commands: s.commands.clone(),
            link,
            info: s.info.clone(),
            craft: s.craft.clone(),
            state: s.state,
            snap: s.snap,
            snap_ready: s.snap_ready,
            sensors: s.sensors.clone(),
            inertia_change: s.inertia_change.clone(),
            open_loop: s.open_loop.clone(),
            act: s.act.clone(),
            target: s.target.clone(),
            next_command: s.next_command,
            metrics: s.metrics.clone(),
            errors: s.errors.clone(),
            pointing: s.pointing.clone(),
            performance: s.performance,
            estimation: s.estimation.clone(),
            layout: s.layout.clone(),
            momentum: s.momentum.clone(),
            slow_fdir: s.slow_fdir,
            keepout: s.keepout.clone(),
            columns: s.columns.clone(),
            row: s.row.clone(),
            k: s.k,
            clock: s.clock,
            failure: s.failure.clone(),
            t_end: s.t_end,
            injection: s.injection,
            last_step: s.last_step,
            truth: s.truth.clone(),
            truth_row: s.truth_row,
            segments: s.segments.clone(),
            pointing_id: s.pointing_id,
            faults: s.faults.clone(),
            fdir: s.fdir.clone(),
            control: s.control.clone(),
            timeline: s.timeline.clone(),
        })
    }

    /// A copy of the link with the flight side in its current state ([`FlightLink::fork`]);
    /// `None` when the link cannot be copied (QEMU, TCP, serial).
    pub fn fork_link(&self) -> Option<Box<dyn FlightLink>> {
        self.0.link.fork()
    }

    /// Fly on past the scenario's duration, to `steps` control steps in all (the plant,
    /// the flight code and the ground commands as they are; nothing else changes).
    pub fn extend_to(&mut self, steps: u64) {
        self.0.clock.steps = self.0.clock.steps.max(steps);
    }

    /// Freezes the magnetic field from now on at its value now, constant in the frame the
    /// target is given in (LVLH or inertial): the loop of a magnetic law at an orbit
    /// instant (docs/margins.md, "Magnetorquer loops"). Between control steps only:
    /// the field of the coming step is the one the sensors have already sampled.
    /// `None` (nothing changed) without a field.
    pub fn freeze_field(&mut self) -> Option<FrozenField> {
        let snap = self.0.snap?;
        let frozen = self.0.craft.env.as_mut()?.freeze_field(&snap, self.0.target.lvlh)?;
        self.0.craft.clear_env_cache();
        Some(frozen)
    }

    /// The field frozen by [`Self::freeze_field`], if it was.
    pub fn frozen_field(&self) -> Option<FrozenField> {
        match self.0.craft.env.as_ref().map(|e| &e.field) {
            Some(FieldSource::Frozen(f)) => Some(*f),
            _ => None,
        }
    }

    /// The true attitude error of the state now against the target in the frame of the last
    /// environment snapshot, deg: before the first step, exactly what step 0 records (an
    /// operating point at t = 0 has no step to read it from).
    pub fn attitude_error_now_deg(&self) -> f64 {
        let q_cmd = self.0.target.frame(self.0.snap.as_ref()) * self.0.target.q_rel;
        error_angle_and_vector(&self.0.state.q, &q_cmd).0.to_degrees()
    }

    /// The field in body axes now (at the next control step's time), T.
    pub fn field_body_t(&self) -> Option<Vec3> {
        self.0.snap.and_then(|s| s.b_ref_t).map(|b| rotate_ref_to_body(&self.0.state.q, &b))
    }

    /// Adds `injection` to the loop at every following control step (`None`: stop).
    pub fn set_injection(&mut self, injection: Option<LoopInjection>) {
        self.0.injection = injection;
    }

    /// Freezes (`true`) or resumes the flight law's adaptation through the link
    /// (`FreezeAdaptation`: the law keeps its state, unlike a parameter upload); the same
    /// message in-process and over QEMU. `Ok(true)`: the law in force adapts (DMCS) and
    /// obeyed; `Ok(false)`: nothing adapts (the flight side refused with `NotAdaptive`, or
    /// an open-loop run: no flight law), nothing changed; `Err` for any other reply.
    pub fn freeze_adaptation(&mut self, frozen: bool) -> Result<bool> {
        if self.0.info.is_none() {
            return Ok(false);
        }
        match self.0.link.request(&acs_flight::link::HostMsg::FreezeAdaptation { frozen })? {
            FswMsg::Ack => Ok(true),
            FswMsg::Error(acs_flight::link::LinkError::NotAdaptive) => Ok(false),
            other => bail!("FreezeAdaptation {{ frozen: {frozen} }} refused: {other:?}"),
        }
    }

    /// The commands of the last control step as the plant received them ([`PlantCommands`]).
    pub fn plant_commands(&self) -> PlantCommands {
        self.0.act.plant_commands()
    }

    /// The last control step's flight command and its true attitude error (deg).
    pub fn last_step(&self) -> Option<&(ActuatorCommand, f64)> {
        self.0.last_step.as_ref()
    }

    /// The spacecraft model (inertia, actuators).
    pub fn craft(&self) -> &Spacecraft {
        &self.0.craft
    }

    /// The magnetorquer rods and their limits (empty: none).
    pub fn magnetorquers(&self) -> &MagnetorquerSet {
        &self.0.act.mtq
    }

    /// The control period, s.
    pub fn control_period_s(&self) -> f64 {
        self.0.clock.dt
    }
}
