//! Configuration of the flight software: single parameter sets, mode tables, targets.

use super::{Configured, Fsw};
use crate::allocation::family::{Actuators, ThrusterSet};
use crate::control::{AttitudeLaw, Law};
use crate::estimation::determination::Determination;
use crate::guidance::Guidance;
use crate::math::{Vec3, quat_from_xyzw, quat_normalized};
use crate::modes::ModeManager;
use crate::params::{
    EstimationParams, FlightParams, GuidanceParams, MODE_COUNT, Mode, ModeManagerParams, ModeRequest, ParamError,
    ParamField, ParamReason, Pointing, TargetFrame,
};
use crate::types::Valid;

/// Why a mode command or a mode-table operation was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeError {
    /// No mode table is armed.
    NotArmed,
    /// The requested mode has no parameter set in the armed table.
    NoSuchMode,
}

/// Why [`Fsw::freeze_adaptation`] changed nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FreezeError {
    /// No parameter set (or armed mode table) in force.
    NotConfigured,
    /// The law in force does not adapt.
    NotAdaptive,
}

impl Configured {
    /// Validate `p` and build its runtime form; returns it with the checksum of `p`.
    fn build(p: &FlightParams) -> Result<(Self, u32), ParamError> {
        p.validate()?;
        let checksum = p.checksum()?;
        let dt_s = 1.0 / p.control_rate_hz;
        let law = Law::from_params(&p.controller)?;
        let actuators = Actuators::from_params(&p.actuator, dt_s)?;
        let guidance = Guidance::new(&p.guidance, &p.manoeuvre);
        let attitude = if law.needs_attitude() { Valid::ATTITUDE } else { Valid::empty() };
        let required = Valid::RATE | attitude | actuators.required();
        let needs_navigation = guidance.needs_navigation();
        let dump = match p.momentum.dumps() {
            true => Some(
                ThrusterSet::new(&p.momentum.dump_thrusters, dt_s)
                    .map_err(|_| ParamError { field: ParamField::MomentumDump, reason: ParamReason::OutOfRange })?,
            ),
            false => None,
        };
        let inertia = p.inertia();
        let cfg = Self { params: *p, inertia, law, dt_s, guidance, actuators, required, needs_navigation, dump };
        Ok((cfg, checksum))
    }
}

impl Fsw {
    /// Validate and adopt a single parameter set (no mode manager); returns its checksum.
    /// On rejection the previous configuration (if any) stays in force.
    pub fn configure(&mut self, p: &FlightParams) -> Result<u32, ParamError> {
        let (cfg, checksum) = Configured::build(p)?;
        self.slots = [const { None }; MODE_COUNT];
        if let Some(s) = self.slots.get_mut(0) {
            *s = Some(cfg);
        }
        self.active = 0;
        self.table = false;
        self.manager = None;
        self.reset_law_state();
        Ok(checksum)
    }

    /// Validate and store the parameter set of one mode of a mode table; returns its
    /// checksum. A first call after a single `configure` starts a new table (the single
    /// set stops commanding until the table is armed). Replacing the active mode's set
    /// while armed takes effect at the next step with fresh law state.
    pub fn configure_mode(&mut self, mode: Mode, p: &FlightParams) -> Result<u32, ParamError> {
        let (cfg, checksum) = Configured::build(p)?;
        // An armed table runs at one control rate.
        if self.manager.is_some() && self.slots.iter().flatten().any(|o| o.dt_s != cfg.dt_s) {
            return Err(ParamError { field: ParamField::ControlRate, reason: ParamReason::OutOfRange });
        }
        if !self.table {
            self.slots = [const { None }; MODE_COUNT];
            self.manager = None;
            self.table = true;
        }
        if let Some(s) = self.slots.get_mut(mode.index()) {
            *s = Some(cfg);
        }
        if self.manager.is_some() && self.active == mode.index() {
            self.reset_law_state();
        }
        Ok(checksum)
    }

    /// Arm the uploaded mode table; returns the checksum of `p`. Slots outside `p.slots`
    /// are dropped; every slot inside must be uploaded and all share one control rate.
    pub fn arm_modes(&mut self, p: &ModeManagerParams) -> Result<u32, ParamError> {
        let bad = |reason| ParamError { field: ParamField::ModeTable, reason };
        p.validate()?;
        let checksum = p.checksum()?;
        if !self.table {
            return Err(bad(ParamReason::OutOfRange));
        }
        let mut configured = [false; MODE_COUNT];
        let mut dt_s = None;
        for (i, (slot, c)) in self.slots.iter().zip(configured.iter_mut()).enumerate() {
            if p.slots & (1 << i) == 0 {
                continue;
            }
            let Some(cfg) = slot else {
                return Err(bad(ParamReason::OutOfRange));
            };
            if dt_s.is_some_and(|d| d != cfg.dt_s) {
                return Err(ParamError { field: ParamField::ControlRate, reason: ParamReason::OutOfRange });
            }
            dt_s = Some(cfg.dt_s);
            *c = true;
        }
        let mgr = ModeManager::new(*p, configured, dt_s.unwrap_or(0.0)).ok_or(bad(ParamReason::OutOfRange))?;
        for (slot, used) in self.slots.iter_mut().zip(configured) {
            if !used {
                *slot = None;
            }
        }
        self.active = p.initial.index();
        self.manager = Some(mgr);
        self.reset_law_state();
        Ok(checksum)
    }

    /// A ground mode command; returns the mode in force afterwards.
    pub fn command_mode(&mut self, r: ModeRequest) -> Result<Mode, ModeError> {
        let mgr = self.manager.as_mut().ok_or(ModeError::NotArmed)?;
        let before = mgr.mode;
        if !mgr.command(r) {
            return Err(ModeError::NoSuchMode);
        }
        let now = mgr.mode;
        if now != before {
            self.switch_slot(now.index());
        }
        Ok(now)
    }

    /// The armed mode manager, if any (mode, reason, transition count).
    pub fn mode_manager(&self) -> Option<&ModeManager> {
        self.manager.as_ref()
    }

    /// Freeze (`true`) or resume (`false`) the adaptation of the law in force, keeping
    /// its state (unlike a configuration, which restarts it). A mode switch or a new
    /// configuration starts the next law adapting. `Err`: no law in force, or one that
    /// does not adapt (nothing changed).
    pub fn freeze_adaptation(&mut self, frozen: bool) -> Result<(), FreezeError> {
        if !self.is_configured() {
            return Err(FreezeError::NotConfigured);
        }
        let Some(Some(cfg)) = self.slots.get_mut(self.active) else {
            return Err(FreezeError::NotConfigured);
        };
        if cfg.law.freeze_adaptation(frozen) { Ok(()) } else { Err(FreezeError::NotAdaptive) }
    }

    /// Hand over to slot `index` (a mode switch): fresh law state; its guidance takes
    /// over from the command in force, blended over its `transition_s`.
    pub(super) fn switch_slot(&mut self, index: usize) {
        let previous = self.active_cfg().and_then(|c| c.guidance.last());
        self.active = index;
        self.reset_law_state();
        if let Some(Some(cfg)) = self.slots.get_mut(index) {
            cfg.guidance.reset();
            cfg.guidance.continue_from(previous);
        }
    }

    /// Fresh state for the law that takes over (integrators, filters, estimator).
    pub(super) fn reset_law_state(&mut self) {
        if let Some(Some(cfg)) = self.slots.get_mut(self.active) {
            cfg.law.reset();
        }
        self.torque_last = Vec3::zeros();
        self.saturated_last = false;
        self.dumping = false;
    }

    /// Validate and adopt the attitude-determination parameters (every mode); the
    /// estimation stage restarts. On rejection the previous set stays in force.
    pub fn configure_estimation(&mut self, p: &EstimationParams) -> Result<u32, ParamError> {
        let checksum = p.checksum()?;
        self.determination.reconfigure(p)?;
        Ok(checksum)
    }

    /// The estimation stage (filter, navigation).
    pub fn determination(&self) -> &Determination {
        &self.determination
    }

    /// The parameter set in force.
    pub fn params(&self) -> Option<&FlightParams> {
        self.active_cfg().map(|c| &c.params)
    }

    pub(super) fn active_cfg(&self) -> Option<&Configured> {
        if self.table && self.manager.is_none() {
            return None;
        }
        self.slots.get(self.active).and_then(Option::as_ref)
    }

    pub fn is_configured(&self) -> bool {
        self.active_cfg().is_some()
    }

    /// Change the commanded attitude (the integral state is kept: the set point moved,
    /// the disturbance did not). With a mode table the manoeuvre and hold targets change
    /// (the mission target); detumble and stabilise keep theirs.
    pub fn set_target(&mut self, q_xyzw: [f32; 4]) -> Result<(), ParamError> {
        let bad = ParamError { field: ParamField::Target, reason: ParamReason::NotUnitQuaternion };
        let q = quat_from_xyzw(q_xyzw);
        if !q.coords.iter().all(|x| x.is_finite()) || (crate::math::norm(&q.coords) - 1.0).abs() > 1e-3 {
            return Err(bad);
        }
        quat_normalized(&q).ok_or(bad)?;
        let mut any = false;
        for i in 0..self.slots.len() {
            let mission = !self.table || i == Mode::Manoeuvre.index() || i == Mode::Hold.index();
            let Some(Some(cfg)) = self.slots.get(i).filter(|_| mission) else { continue };
            // A new fixed attitude in the frame of the fixed pointing in force (inertial when
            // the set pointed by two vectors).
            let frame = match cfg.params.guidance.pointing {
                Pointing::Fixed { frame, .. } => frame,
                Pointing::Align { .. } => TargetFrame::Inertial,
            };
            let g = GuidanceParams { pointing: Pointing::Fixed { q_xyzw, frame }, ..cfg.params.guidance };
            self.replace_guidance(i, &g);
            any = true;
        }
        if any { Ok(()) } else { Err(bad) }
    }

    /// A new pointing for the mission modes (`HostMsg::SetPointing`): validated, then
    /// blended in from the current command. On rejection nothing changes.
    pub fn set_pointing(&mut self, g: &GuidanceParams) -> Result<(), ParamError> {
        g.validate()?;
        let mut any = false;
        for i in 0..self.slots.len() {
            let mission = !self.table || i == Mode::Manoeuvre.index() || i == Mode::Hold.index();
            if mission && self.slots.get(i).is_some_and(Option::is_some) {
                self.replace_guidance(i, g);
                any = true;
            }
        }
        if any { Ok(()) } else { Err(ParamError { field: ParamField::Pointing, reason: ParamReason::OutOfRange }) }
    }

    /// Slot `i`'s pointing replaced (its parameters and its guidance), blended from the
    /// command in force; the navigation requirement follows the new pointing.
    fn replace_guidance(&mut self, i: usize, g: &GuidanceParams) {
        if let Some(Some(cfg)) = self.slots.get_mut(i) {
            cfg.params.guidance = *g;
            cfg.guidance.set_params(g);
            cfg.needs_navigation = cfg.guidance.needs_navigation();
        }
    }
}
