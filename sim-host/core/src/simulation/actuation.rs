//! Magnetorquers, thrusters and the actuator delays between the flight's command and the
//! plant's input (a loop injection, [`super::probe::LoopInjection`], added on the way).

use super::probe::{LoopInjection, PlantCommands};
use crate::attitude::Vec3;
use crate::faults::{Fault, RodFault, ThrusterFault, TimedFault, WheelFault};
use crate::plant::delay::DelayLine;
use crate::plant::magnetorquers::MagnetorquerSet;
use crate::plant::thrusters::{Failure, InjectedFailure, ThrusterSet, ThrusterState};
use crate::plant::{Input, MAX_GIMBALS, MAX_WHEELS};
use acs_flight::link::ActuatorCommand;

/// Magnetorquers and thrusters: command → what the plant receives.
#[derive(Clone)]
pub(super) struct Actuation {
    pub(super) mtq: MagnetorquerSet,
    pub(super) thrusters: Option<ThrusterSet>,
    pub(super) thr_state: ThrusterState,
    pub(super) n_thr: usize,
    pub(super) rod_dipole: [f64; 3],
    /// `[actuators.magnetorquers] delay_s` as whole control periods.
    pub(super) mtq_delay: DelayLine<3>,
    /// `[actuators.wheels] torque_delay_s` as whole dynamics steps.
    pub(super) wheel_delay: DelayLine<MAX_WHEELS>,
    /// `[actuators.cmg] rate_delay_s` as whole control periods.
    pub(super) gimbal_delay: DelayLine<MAX_GIMBALS>,
    /// The wheel torque commands of this control period (before `wheel_delay`).
    pub(super) wheel_cmd: [f64; MAX_WHEELS],
    /// The gimbal-rate and dipole commands of this control period as the plant receives
    /// them (a loop injection added; before the delays and limits): what
    /// [`super::probe::Probe::plant_commands`] reports.
    pub(super) gimbal_cmd: [f64; MAX_GIMBALS],
    pub(super) dipole_cmd: [f64; 3],
    /// The actuator faults of `[[faults]]`: wheel torque gain and runaway, torquer rods.
    faults: Vec<TimedFault>,
    /// Each wheel's full torque (a runaway's), N m.
    wheel_max_torque_nm: [f64; MAX_WHEELS],
}

impl Actuation {
    pub(super) fn new(
        mtq: MagnetorquerSet,
        thrusters: Option<ThrusterSet>,
        n_thr: usize,
        wheel_delay: DelayLine<MAX_WHEELS>,
        gimbal_delay: DelayLine<MAX_GIMBALS>,
    ) -> Self {
        Self {
            mtq_delay: DelayLine::new(mtq.delay_steps),
            mtq,
            thrusters,
            thr_state: ThrusterState::new(n_thr),
            n_thr,
            rod_dipole: [0.0; 3],
            wheel_delay,
            gimbal_delay,
            wheel_cmd: [0.0; MAX_WHEELS],
            gimbal_cmd: [0.0; MAX_GIMBALS],
            dipole_cmd: [0.0; 3],
            faults: Vec::new(),
            wheel_max_torque_nm: [0.0; MAX_WHEELS],
        }
    }

    /// Injects the actuator faults among `list` (wheel torque gain and runaway, torquer
    /// rods, thruster valves; a seized wheel and the CMGs' faults are the plant's);
    /// `max_torque_nm`: each wheel's full torque.
    pub(super) fn set_faults(&mut self, list: &[TimedFault], max_torque_nm: impl Iterator<Item = f64>) {
        self.faults = list
            .iter()
            .filter(|f| match f.fault {
                Fault::Wheel { kind, .. } => {
                    matches!(kind, WheelFault::TorqueGain(_) | WheelFault::Runaway { .. } | WheelFault::PowerOff)
                }
                Fault::Magnetorquer { .. } => true,
                _ => false,
            })
            .copied()
            .collect();
        for (d, t) in self.wheel_max_torque_nm.iter_mut().zip(max_torque_nm) {
            *d = t;
        }
        if let Some(set) = &mut self.thrusters {
            set.injected = list
                .iter()
                .filter_map(|f| match f.fault {
                    Fault::Thruster { index, kind } => Some(InjectedFailure {
                        index,
                        window: f.window,
                        failure: match kind {
                            ThrusterFault::StuckClosed => Failure::Off,
                            ThrusterFault::StuckOpen => Failure::StuckOn,
                        },
                    }),
                    _ => None,
                })
                .collect();
        }
    }

    /// The wheel faults in force at `t_s` on the commands as the motors receive them (held
    /// over the control period: the fault takes effect at the first control step at or
    /// after its onset), in list order.
    fn wheel_faults(&mut self, t_s: f64) {
        for f in self.faults.iter().filter(|f| f.window.active(t_s)) {
            let Fault::Wheel { index, kind } = f.fault else { continue };
            let (Some(cmd), Some(max)) = (self.wheel_cmd.get_mut(index), self.wheel_max_torque_nm.get(index)) else {
                continue;
            };
            match kind {
                WheelFault::TorqueGain(g) => *cmd *= g,
                WheelFault::Runaway { sign } => *cmd = sign * max,
                WheelFault::PowerOff => *cmd = 0.0,
                WheelFault::Stuck
                | WheelFault::TachStuck
                | WheelFault::TachNoise { .. }
                | WheelFault::Friction { .. } => {}
            }
        }
    }

    /// The rods' realised dipoles at `t_s` with the rod faults in force.
    fn rod_faults(&self, t_s: f64, realised: &mut [f64]) {
        for f in self.faults.iter().filter(|f| f.window.active(t_s)) {
            let Fault::Magnetorquer { index, kind } = f.fault else { continue };
            if let Some(m) = realised.get_mut(index) {
                *m = match kind {
                    RodFault::Open => 0.0,
                    RodFault::Reversed => -*m,
                };
            }
        }
    }

    /// The plant input held over the control period (thruster torque: see [`Self::thruster_torque`];
    /// wheel torques over its first dynamics step, the later ones: [`Self::wheel_torques`]).
    /// A loop injection is added to the commands as the plant receives them (before the
    /// wheels' torque delay and the gimbal-rate delay, which stay inside the loop).
    /// Injected faults in force at `t_s` act on the wheel commands and the rods' dipoles.
    pub(super) fn input(
        &mut self,
        t_s: f64,
        cmd: &ActuatorCommand,
        injection: Option<&LoopInjection>,
    ) -> (Input, [f64; 3]) {
        let mut input = Input::default();
        for (d, s) in input.gimbal_rate_cmd_rad_s.iter_mut().zip(cmd.gimbal_rate_cmd_rad_s) {
            *d = s as f64;
        }
        for (d, s) in self.wheel_cmd.iter_mut().zip(cmd.wheel_torque_cmd_nm).take(MAX_WHEELS) {
            *d = s as f64;
        }
        if let Some(inj) = injection {
            if inj.replace_commands {
                self.wheel_cmd = [0.0; MAX_WHEELS];
                input.gimbal_rate_cmd_rad_s = [0.0; MAX_GIMBALS];
            }
            inj.add_to_commands(&mut self.wheel_cmd, &mut input.gimbal_rate_cmd_rad_s);
        }
        self.wheel_faults(t_s);
        // A drive the flight switched off applies no torque, whatever its fault.
        for (i, c) in self.wheel_cmd.iter_mut().enumerate() {
            if cmd.wheel_power_off & (1u8.checked_shl(i as u32).unwrap_or(0)) != 0 {
                *c = 0.0;
            }
        }
        self.gimbal_cmd = input.gimbal_rate_cmd_rad_s;
        input.gimbal_rate_cmd_rad_s = self.gimbal_delay.push(input.gimbal_rate_cmd_rad_s);
        input.wheel_torque_cmd_nm = self.wheel_torques();
        let dipole_cmd = cmd.dipole_cmd_am2.map(|x| x as f64);
        if !self.mtq.rods.is_empty() {
            let applied = match injection {
                Some(inj) => inj.add_to_dipole(if inj.replace_commands { [0.0; 3] } else { dipole_cmd }),
                None => dipole_cmd,
            };
            self.dipole_cmd = applied;
            let acting = self.mtq_delay.push(applied);
            let mut realised = self.mtq.realised(&acting);
            self.rod_faults(t_s, &mut realised);
            self.rod_dipole = self.mtq.rod_dipole_am2(&realised);
        }
        input.dipole_am2 = self.rod_dipole.into();
        input.dipole_am2 += Vec3::from(self.mtq.residual_dipole_am2);
        (input, dipole_cmd)
    }

    /// The wheel torque commands acting over the next dynamics step (after the delay).
    pub(super) fn wheel_torques(&mut self) -> [f64; MAX_WHEELS] {
        self.wheel_delay.push(self.wheel_cmd)
    }

    /// Torque of the thrusters over the dynamics step `[t0, t0 + h)` (advances the valves).
    pub(super) fn thruster_torque(&mut self, mask: u32, t0: f64, h: f64) -> Vec3 {
        match &self.thrusters {
            Some(set) => set.wrench(&set.step(&mut self.thr_state, mask, t0, h)).1.into(),
            None => Vec3::zeros(),
        }
    }

    /// The commands of this control period as the plant receives them.
    pub(super) fn plant_commands(&self) -> PlantCommands {
        PlantCommands {
            wheel_torque_nm: self.wheel_cmd,
            gimbal_rate_rad_s: self.gimbal_cmd,
            dipole_am2: self.dipole_cmd,
        }
    }
}
