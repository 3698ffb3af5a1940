//! Injected faults (issue 42): the typed fault of one `[[faults]]` entry (one enum per unit
//! kind), the time window it acts in, and its names in the summary. Parsed and checked
//! against the spacecraft by `scenario::faults`; applied by the plant (a seized wheel), the
//! sensors (gyro, star tracker, magnetometer, tachometers) and the actuation (wheel torque, torquer
//! rods, CMG gimbals and rotors, thruster valves). docs/scenario.md `[[faults]]`.

use serde::Serialize;

/// Most `[[faults]]` entries of a scenario: the truth column `fault_active` is a bitmask of
/// them, exact in an f64.
pub const MAX_FAULTS: usize = 32;

/// When a fault acts: from `onset_s` (inclusive) until `end_s` (exclusive; `None`: to the
/// end of the run).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    pub onset_s: f64,
    pub end_s: Option<f64>,
}

impl Window {
    pub fn active(&self, t_s: f64) -> bool {
        t_s >= self.onset_s && self.end_s.is_none_or(|e| t_s < e)
    }

    /// Length of `[t0_s, t1_s]` inside the window, s.
    pub fn overlap_s(&self, t0_s: f64, t1_s: f64) -> f64 {
        let hi = self.end_s.map_or(t1_s, |e| t1_s.min(e));
        (hi - t0_s.max(self.onset_s)).max(0.0)
    }
}

/// A reaction wheel's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WheelFault {
    /// Rotor seized from the body's point of view: no axial torque between rotor and body
    /// (motor, friction and speed loop all gone), so its absolute momentum is frozen.
    Stuck,
    /// The torque command reaches the motor multiplied by this gain, in [0, 1].
    TorqueGain(f64),
    /// The motor is commanded to its full torque, of this sign (±1), whatever the command.
    Runaway { sign: f64 },
    /// The tachometer repeats the reading of its first sample in the window.
    TachStuck,
    /// The wheel's friction (viscous and Coulomb, the motor model's) multiplied by this
    /// factor (>= 1).
    Friction { factor: f64 },
    /// The wheel's power is off: the motor delivers no torque (its command is zero) and the
    /// tachometer reads 0.
    PowerOff,
    /// The tachometer's white noise σ multiplied by this factor (>= 1): an independent
    /// normal of σ √(factor² − 1) added to each reading.
    TachNoise { factor: f64 },
}

/// A gyro axis's fault (the axis of the triad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GyroFault {
    /// The axis repeats its first reading in the window (its angle increment is that rate
    /// times the interval).
    Stuck,
    /// A bias step added to the axis's rate (and to its angle increment over the part of
    /// the interval inside the window), rad/s.
    BiasStep { rad_s: f64 },
    /// The axis's white rate noise σ (and its angle random walk) multiplied by this factor
    /// (>= 1): an independent normal of σ √(factor² − 1) added to each sample.
    Noise { factor: f64 },
    /// The axis's rate clamps at ± this bound, rad/s (its angle increment at ± the bound
    /// times the interval).
    Saturation { rad_s: f64 },
}

/// The star tracker's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrackerFault {
    /// The reported attitude is turned 180° about the boresight: `q_meas ⊗ R(b, π)`.
    Flip,
    /// The reported attitude repeats the first sample in the window; the time tags stay
    /// fresh (the validity is the current sample's).
    Frozen,
}

/// A magnetometer axis's fault (the axis of the sensor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MagFault {
    /// The axis repeats its first reading in the window.
    Stuck,
    /// A constant field added to the axis's reading, T.
    Bias { t: f64 },
}

/// A coarse sun sensor head's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CssFault {
    /// The head reads 0, what a head that sees nothing reads without noise (an unused
    /// head, or any head in eclipse).
    Dead,
}

/// The GNSS receiver's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GnssFault {
    /// The reported position is offset by this many m along the true radial direction
    /// (outward from the Earth's centre at the sample; negative: inward).
    PositionJump { m: f64 },
    /// The reported velocity is offset by this many m/s along the true velocity's direction
    /// (negative: against it); the position is unaffected.
    VelocityJump { m_s: f64 },
}

/// A magnetorquer rod's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RodFault {
    /// The rod's circuit is open: it produces no dipole.
    Open,
    /// The rod's polarity is reversed: it produces the negative of the realised dipole.
    Reversed,
}

/// A control moment gyro's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CmgFault {
    /// The gimbal is seized: its angle stays at its value at the onset (rate 0 whatever
    /// the command).
    GimbalStuck,
    /// The rotor's momentum decays as `exp(-(t - onset)/tau)` while in force (its lost
    /// momentum goes to the body: the total is conserved); it keeps what is left after.
    RotorSpinDown { tau_s: f64 },
}

/// A thruster's fault (its valve; unknown to the flight code, unlike
/// `actuators.thrusters.failures`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ThrusterFault {
    /// No thrust whatever the command.
    StuckClosed,
    /// Full thrust (`thrust_n`, valve fully open) whatever the command.
    StuckOpen,
}

/// One unit's fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// Wheel `index` (0-based, the order of `[actuators.wheels]`).
    Wheel {
        index: usize,
        kind: WheelFault,
    },
    /// Gyro axis `axis` (0, 1, 2 = x, y, z).
    Gyro {
        axis: usize,
        kind: GyroFault,
    },
    StarTracker(TrackerFault),
    /// Magnetometer axis `axis` (0, 1, 2 = x, y, z, the sensor's axes).
    Magnetometer {
        axis: usize,
        kind: MagFault,
    },
    /// Coarse sun sensor head `index` (0-based, the order of `normals_body`).
    Css {
        index: usize,
        kind: CssFault,
    },
    Gnss(GnssFault),
    /// Torquer rod `index` (0-based, the order of `[actuators.magnetorquers]`).
    Magnetorquer {
        index: usize,
        kind: RodFault,
    },
    /// CMG `index` (0-based, the order of the cluster's units: the pyramid's 1 to 4).
    Cmg {
        index: usize,
        kind: CmgFault,
    },
    /// Thruster `index` (0-based, the order of `[actuators.thrusters]`: `thruster.0` is
    /// `failures`' thruster 1).
    Thruster {
        index: usize,
        kind: ThrusterFault,
    },
}

/// A fault and its window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedFault {
    pub window: Window,
    pub fault: Fault,
}

const AXES: [&str; 3] = ["x", "y", "z"];

impl Fault {
    /// The unit as the scenario names it (`wheel.2`, `gyro.x`, `star_tracker`, …).
    pub fn unit(&self) -> String {
        match self {
            Fault::Wheel { index, .. } => format!("wheel.{index}"),
            Fault::Gyro { axis, .. } => format!("gyro.{}", AXES.get(*axis).copied().unwrap_or("?")),
            Fault::StarTracker(_) => "star_tracker".into(),
            Fault::Magnetometer { axis, .. } => {
                format!("magnetometer.{}", AXES.get(*axis).copied().unwrap_or("?"))
            }
            Fault::Magnetorquer { index, .. } => format!("magnetorquer.{index}"),
            Fault::Css { index, .. } => format!("css.{index}"),
            Fault::Gnss(_) => "gnss".into(),
            Fault::Cmg { index, .. } => format!("cmg.{index}"),
            Fault::Thruster { index, .. } => format!("thruster.{index}"),
        }
    }

    /// The kind as the scenario names it.
    pub fn kind(&self) -> &'static str {
        match self {
            Fault::Wheel { kind: WheelFault::Stuck, .. }
            | Fault::Gyro { kind: GyroFault::Stuck, .. }
            | Fault::Magnetometer { kind: MagFault::Stuck, .. } => "stuck",
            Fault::Wheel { kind: WheelFault::TorqueGain(_), .. } => "torque_gain",
            Fault::Wheel { kind: WheelFault::Runaway { .. }, .. } => "runaway",
            Fault::Wheel { kind: WheelFault::TachStuck, .. } => "tach_stuck",
            Fault::Wheel { kind: WheelFault::PowerOff, .. } => "power_off",
            Fault::Wheel { kind: WheelFault::Friction { .. }, .. } => "friction",
            Fault::Wheel { kind: WheelFault::TachNoise { .. }, .. } => "tach_noise",
            Fault::Gyro { kind: GyroFault::BiasStep { .. }, .. } => "bias_step",
            Fault::Gyro { kind: GyroFault::Noise { .. }, .. } => "noise",
            Fault::Gyro { kind: GyroFault::Saturation { .. }, .. } => "saturation",
            Fault::Magnetometer { kind: MagFault::Bias { .. }, .. } => "bias",
            Fault::StarTracker(TrackerFault::Flip) => "flip",
            Fault::StarTracker(TrackerFault::Frozen) => "frozen",
            Fault::Magnetorquer { kind: RodFault::Open, .. } => "open",
            Fault::Css { kind: CssFault::Dead, .. } => "dead",
            Fault::Gnss(GnssFault::PositionJump { .. }) => "position_jump",
            Fault::Gnss(GnssFault::VelocityJump { .. }) => "velocity_jump",
            Fault::Magnetorquer { kind: RodFault::Reversed, .. } => "reversed",
            Fault::Cmg { kind: CmgFault::GimbalStuck, .. } => "gimbal_stuck",
            Fault::Cmg { kind: CmgFault::RotorSpinDown { .. }, .. } => "rotor_spin_down",
            Fault::Thruster { kind: ThrusterFault::StuckClosed, .. } => "stuck_closed",
            Fault::Thruster { kind: ThrusterFault::StuckOpen, .. } => "stuck_open",
        }
    }

    /// The magnitude the kind takes (`None`: the kind takes none).
    pub fn magnitude(&self) -> Option<f64> {
        match self {
            Fault::Wheel { kind: WheelFault::TorqueGain(g), .. } => Some(*g),
            Fault::Wheel { kind: WheelFault::Runaway { sign }, .. } => Some(*sign),
            Fault::Wheel { kind: WheelFault::TachNoise { factor } | WheelFault::Friction { factor }, .. } => {
                Some(*factor)
            }
            Fault::Gyro { kind: GyroFault::BiasStep { rad_s } | GyroFault::Saturation { rad_s }, .. } => Some(*rad_s),
            Fault::Gyro { kind: GyroFault::Noise { factor }, .. } => Some(*factor),
            Fault::Magnetometer { kind: MagFault::Bias { t }, .. } => Some(*t),
            Fault::Gnss(GnssFault::PositionJump { m }) => Some(*m),
            Fault::Gnss(GnssFault::VelocityJump { m_s }) => Some(*m_s),
            Fault::Cmg { kind: CmgFault::RotorSpinDown { tau_s }, .. } => Some(*tau_s),
            _ => None,
        }
    }
}

/// The faults of a run and when each first acted, for the truth column and the summary.
#[derive(Clone, Debug, Default)]
pub struct FaultLog {
    pub list: Vec<TimedFault>,
    /// The first control step (s) at which each entry was in force (`None`: not yet).
    injected_at_s: Vec<Option<f64>>,
}

/// One injected fault in `summary.json` `faults`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FaultRecord {
    pub unit: String,
    pub kind: &'static str,
    pub magnitude: Option<f64>,
    /// `onset_s` of the entry, s.
    pub onset_s: f64,
    pub end_s: Option<f64>,
    /// The first control step at which the fault was in force (`None`: the run ended
    /// before its onset), s.
    pub injected_at_s: Option<f64>,
    /// When the flight code detected it: the flight side's detection is not wired yet
    /// (issue 42), so always `None`.
    pub detected_at_s: Option<f64>,
}

impl FaultLog {
    pub fn new(list: Vec<TimedFault>) -> Self {
        let n = list.len();
        Self { list, injected_at_s: vec![None; n] }
    }

    /// Notes the entries in force at the control step at `t_s`.
    pub fn observe(&mut self, t_s: f64) {
        for (f, at) in self.list.iter().zip(self.injected_at_s.iter_mut()) {
            if at.is_none() && f.window.active(t_s) {
                *at = Some(t_s);
            }
        }
    }

    /// Whether any entry has been in force at a control step so far.
    pub fn any_injected(&self) -> bool {
        self.injected_at_s.iter().any(Option::is_some)
    }

    /// The summary's list (`None` without faults).
    pub fn records(&self) -> Option<Vec<FaultRecord>> {
        if self.list.is_empty() {
            return None;
        }
        let rec = |(f, at): (&TimedFault, &Option<f64>)| FaultRecord {
            unit: f.fault.unit(),
            kind: f.fault.kind(),
            magnitude: f.fault.magnitude(),
            onset_s: f.window.onset_s,
            end_s: f.window.end_s,
            injected_at_s: *at,
            detected_at_s: None,
        };
        Some(self.list.iter().zip(self.injected_at_s.iter()).map(rec).collect())
    }
}

/// The bitmask of the faults of `list` active at `t_s` (bit i: entry i).
pub fn active_mask(list: &[TimedFault], t_s: f64) -> u32 {
    list.iter().take(MAX_FAULTS).enumerate().filter(|(_, f)| f.window.active(t_s)).fold(0, |m, (i, _)| m | (1 << i))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_is_half_open_and_its_overlap_is_clipped() {
        let w = Window { onset_s: 2.0, end_s: Some(5.0) };
        assert!(!w.active(1.999) && w.active(2.0) && w.active(4.999) && !w.active(5.0));
        assert_eq!(w.overlap_s(1.0, 3.0), 1.0);
        assert_eq!(w.overlap_s(4.0, 6.0), 1.0);
        assert_eq!(w.overlap_s(0.0, 1.0), 0.0);
        let open = Window { onset_s: 2.0, end_s: None };
        assert!(open.active(1e9) && open.overlap_s(3.0, 4.5) == 1.5);
        let f = |o| TimedFault {
            window: Window { onset_s: o, end_s: None },
            fault: Fault::StarTracker(TrackerFault::Flip),
        };
        assert_eq!(active_mask(&[f(1.0), f(3.0), f(0.0)], 2.0), 0b101);
    }
}
