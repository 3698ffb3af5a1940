//! The report step of `Fsw::step`: status from the law and the allocation, and the wire
//! [`ActuatorCommand`].

use crate::allocation::AllocStatus;
use crate::allocation::family::{Allocation, Commands};
use crate::control::LawOutput;
use crate::link::ActuatorCommand;
use crate::math::{Vec3, norm};
use crate::modes::ModeManager;
use crate::types::Status;

/// One step's outcome before it is packed for the wire.
#[derive(Clone, Copy, Debug)]
pub struct Report<'a> {
    pub out: &'a LawOutput,
    pub alloc: &'a Allocation,
    pub status: Status,
    pub law_telemetry: [f32; 3],
}

/// Status bits of an allocation outcome.
pub fn alloc_status(s: AllocStatus) -> Status {
    match s {
        AllocStatus::Ok => Status::empty(),
        AllocStatus::Scaled => Status::RATE_SCALED,
        AllocStatus::Singular => Status::SINGULAR,
        AllocStatus::Infeasible | AllocStatus::NonFinite | AllocStatus::IterationCap | AllocStatus::InternalError => {
            Status::ALLOC_FALLBACK
        }
    }
}

impl<'a> Report<'a> {
    /// `flags`: what the step found before allocating (`LAW_FAULT`).
    pub fn new(out: &'a LawOutput, alloc: &'a Allocation, flags: Status, law_telemetry: [f32; 3]) -> Self {
        let mut status = flags | alloc.flags | alloc_status(alloc.status);
        if out.limited {
            status |= Status::TORQUE_LIMITED;
        }
        if alloc.unrealised != 0 {
            status |= Status::UNREALISED;
        }
        let (realised, demand) = (Vec3::from(alloc.realised), alloc.demand_nm);
        // Relative test: cubesat torques are ~1e-7 N m, so no absolute floor above round-off.
        if norm(&(realised - demand)) > 0.01 * norm(&demand) + 1e-12 {
            status |= Status::TORQUE_SHORTFALL;
        }
        Self { out, alloc, status, law_telemetry }
    }

    /// The realised torque the LQG estimator propagates next step (zero if not finite).
    pub fn torque_for_estimator(&self) -> Vec3 {
        let realised = Vec3::from(self.alloc.realised);
        if realised.iter().all(|x| x.is_finite()) { realised } else { Vec3::zeros() }
    }

    /// The wire command answering sensor frame `seq`.
    pub fn command(&self, seq: u32) -> ActuatorCommand {
        let a = self.alloc;
        let mut cmd = ActuatorCommand {
            seq,
            torque_demand_nm: a.demand_nm.into(),
            torque_realised_nm: a.realised,
            attitude_error_rad: self.out.error_angle_rad,
            alloc_iterations: a.iterations,
            law_telemetry: self.law_telemetry,
            saturated: a.sat_low | a.sat_high,
            status: self.status.bits(),
            ..Default::default()
        };
        match a.commands {
            Commands::Cmg { gimbal_rate_rad_s, singularity_measure, alpha } => {
                cmd.gimbal_rate_cmd_rad_s = gimbal_rate_rad_s;
                cmd.singularity_measure = singularity_measure;
                cmd.steering_alpha = alpha;
            }
            Commands::Wheels { torque_nm } => cmd.wheel_torque_cmd_nm = torque_nm,
            Commands::Magnetorquers { dipole_am2 } => cmd.dipole_cmd_am2 = dipole_am2,
            Commands::Thrusters { level, on } => {
                cmd.thruster_level = level;
                cmd.thruster_on = on;
            }
        }
        cmd
    }
}

/// Mode in force, why, and how many transitions so far.
pub fn mode_telemetry(cmd: &mut ActuatorCommand, mgr: &ModeManager) {
    cmd.mode = mgr.mode.code();
    cmd.mode_reason = mgr.reason as u8;
    cmd.mode_transitions = mgr.transitions;
    cmd.momentum_events = mgr.momentum_events;
    cmd.momentum_keepup_events = mgr.keepup_events;
    cmd.gimbal_events = mgr.gimbal_events;
    if mgr.momentum_alarm() || mgr.slow_alarm() {
        cmd.status |= Status::MOMENTUM_SATURATION.bits();
    }
}
