//! `[[faults]]`: time-tagged faults injected into the plant and the sensors (issue 42),
//! parsed into the typed [`crate::faults::TimedFault`] once, against the scenario's
//! spacecraft (a unit it does not have is refused), every refusal naming the key
//! (`faults[i].unit`, `faults[i].magnitude`, …, the campaign's key-path spelling).

use super::{Scenario, bad};
use crate::faults::{
    CmgFault, CssFault, Fault, GnssFault, GyroFault, MAX_FAULTS, MagFault, RodFault, ThrusterFault, TimedFault,
    TrackerFault, WheelFault, Window,
};
use crate::plant::wheel::Fidelity;
use acs_flight::validation::MAX_RATE_RAD_S;
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// Largest gyro bias step, rad/s (57 deg/s: beyond it the fault is a saturation, not a bias).
pub const MAX_GYRO_BIAS_STEP_RAD_S: f64 = 1.0;

/// Largest gyro noise factor (the faulty axis's σ is at most this many times its own).
pub const MAX_GYRO_NOISE_FACTOR: f64 = 1000.0;

/// Largest GNSS position jump, m (beyond it the fix is not on the same planet).
pub const MAX_GNSS_JUMP_M: f64 = 1.0e7;

/// Largest GNSS velocity jump, m/s (the flight code refuses |v| ≥ 20 km/s anyway).
pub const MAX_GNSS_VELOCITY_JUMP_M_S: f64 = 1.0e4;

/// Largest wheel friction factor.
pub const MAX_FRICTION_FACTOR: f64 = 100.0;

/// Largest tachometer noise factor (the faulty tachometer's σ is at most this many times
/// its own).
pub const MAX_TACH_NOISE_FACTOR: f64 = 1000.0;

/// Largest magnetometer bias, T: the flight code's field limit (`MAX_FIELD_T`, as
/// `sensors.magnetometer.bias_t`); beyond it every reading is refused on board anyway.
pub const MAX_MAG_BIAS_T: f64 = acs_flight::validation::MAX_FIELD_T as f64;

/// Shortest and longest CMG rotor spin-down time constant, s: below 1 s the rotor's momentum
/// goes to the body as an impulse more than a spin-down; beyond 1e7 s (four months) it
/// does not decay within any run.
pub const MIN_SPIN_DOWN_TAU_S: f64 = 1.0;
pub const MAX_SPIN_DOWN_TAU_S: f64 = 1.0e7;

/// One `[[faults]]` entry as written.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// When the fault starts, s (>= 0).
    pub onset_s: f64,
    /// "wheel.N", "gyro.x|y|z", "star_tracker", "magnetorquer.N", "magnetometer.x|y|z",
    /// "css.N", "gnss", "cmg.N", "thruster.N" (N 0-based).
    pub unit: String,
    /// The fault, among those the unit's kind has.
    pub kind: String,
    /// The kind's size, for the kinds that take one.
    #[serde(default)]
    pub magnitude: Option<f64>,
    /// When the fault ends, s (> onset_s; absent: never).
    #[serde(default)]
    pub end_s: Option<f64>,
}

impl Scenario {
    /// The `[[faults]]` list, typed and checked against this spacecraft.
    pub fn faults(&self) -> Result<Vec<TimedFault>> {
        if self.faults.len() > MAX_FAULTS {
            return Err(bad("faults", format!("{} entries: at most {MAX_FAULTS}", self.faults.len())));
        }
        self.faults.iter().enumerate().map(|(i, f)| self.fault(f, &format!("faults[{i}]"))).collect()
    }

    fn fault(&self, f: &FaultSpec, key: &str) -> Result<TimedFault> {
        if !(f.onset_s.is_finite() && f.onset_s >= 0.0) {
            return Err(bad(&format!("{key}.onset_s"), format!("must be finite and >= 0 (got {})", f.onset_s)));
        }
        if let Some(e) = f.end_s
            && !(e.is_finite() && e > f.onset_s)
        {
            return Err(bad(
                &format!("{key}.end_s"),
                format!("must be finite and > onset_s = {} (got {e})", f.onset_s),
            ));
        }
        let fault = self.fault_of(f, key)?;
        Ok(TimedFault { window: Window { onset_s: f.onset_s, end_s: f.end_s }, fault })
    }

    /// The typed fault of an entry: its unit (present on this spacecraft), its kind (one
    /// the unit has) and its magnitude (where the kind takes one, in range).
    fn fault_of(&self, f: &FaultSpec, key: &str) -> Result<Fault> {
        let unit_key = format!("{key}.unit");
        let (name, index) = match f.unit.split_once('.') {
            Some((n, i)) => (n, Some(i)),
            None => (f.unit.as_str(), None),
        };
        let kind_err = |known: &str| {
            bad(&format!("{key}.kind"), format!("{:?} is not a fault of {} (known: {known})", f.kind, f.unit))
        };
        let m = Magnitude { value: f.magnitude, key: format!("{key}.magnitude"), kind: &f.kind };
        match name {
            "wheel" => {
                let params = self.wheel_params()?;
                let index = self.unit_index(index, params.len(), &unit_key, "wheel", "[actuators.wheels]")?;
                let kind = match f.kind.as_str() {
                    "stuck" => m.none(WheelFault::Stuck)?,
                    "tach_stuck" => m.none(WheelFault::TachStuck)?,
                    "torque_gain" => WheelFault::TorqueGain(m.within(0.0, 1.0, "a gain in [0, 1]")?),
                    "runaway" => WheelFault::Runaway { sign: m.sign()? },
                    "power_off" => m.none(WheelFault::PowerOff)?,
                    "friction" => {
                        if params.get(index).is_none_or(|p| p.fidelity != Fidelity::Accurate) {
                            let why = format!(
                                "{}: the ideal wheel model has no friction to scale (model = \"accurate\" has)",
                                f.unit
                            );
                            return Err(bad(&format!("{key}.kind"), why));
                        }
                        let factor = m.within(1.0, MAX_FRICTION_FACTOR, "a factor on the wheel's friction")?;
                        self.friction_step_ok(params.get(index), factor, key)?;
                        WheelFault::Friction { factor }
                    }
                    "tach_noise" => WheelFault::TachNoise {
                        factor: m.within(1.0, MAX_TACH_NOISE_FACTOR, "a factor on the tachometer's noise σ")?,
                    },
                    _ => {
                        return Err(kind_err(
                            "\"stuck\", \"torque_gain\", \"runaway\", \"tach_stuck\", \"power_off\", \"tach_noise\", \
                             \"friction\"",
                        ));
                    }
                };
                Ok(Fault::Wheel { index, kind })
            }
            "gyro" => {
                let axis = axis_of(index, &unit_key, &f.unit, "gyro")?;
                let kind = match f.kind.as_str() {
                    "stuck" => m.none(GyroFault::Stuck)?,
                    "bias_step" => GyroFault::BiasStep {
                        rad_s: m.within(-MAX_GYRO_BIAS_STEP_RAD_S, MAX_GYRO_BIAS_STEP_RAD_S, "a rate step in rad/s")?,
                    },
                    "noise" => GyroFault::Noise {
                        factor: m.within(1.0, MAX_GYRO_NOISE_FACTOR, "a factor on the axis's noise σ")?,
                    },
                    // The flight code refuses rates beyond its limit: a larger bound clamps nothing.
                    "saturation" => GyroFault::Saturation {
                        rad_s: m.within(0.0, f64::from(MAX_RATE_RAD_S), "the axis's output bound in rad/s")?,
                    },
                    _ => return Err(kind_err("\"stuck\", \"bias_step\", \"noise\", \"saturation\"")),
                };
                Ok(Fault::Gyro { axis, kind })
            }
            "star_tracker" if index.is_none() => Ok(Fault::StarTracker(match f.kind.as_str() {
                "flip" => m.none(TrackerFault::Flip)?,
                "frozen" => m.none(TrackerFault::Frozen)?,
                _ => return Err(kind_err("\"flip\", \"frozen\"")),
            })),
            "magnetometer" => {
                // Every spacecraft flies one (`[sensors.magnetometer]` or the ideal default).
                let axis = axis_of(index, &unit_key, &f.unit, "magnetometer")?;
                let kind = match f.kind.as_str() {
                    "stuck" => m.none(MagFault::Stuck)?,
                    "bias" => MagFault::Bias { t: m.within(-MAX_MAG_BIAS_T, MAX_MAG_BIAS_T, "a field in T")? },
                    _ => return Err(kind_err("\"stuck\", \"bias\"")),
                };
                Ok(Fault::Magnetometer { axis, kind })
            }
            "css" => {
                let n = self.sensors.css.as_ref().map_or(0, |c| c.normals_body.len());
                let index = self.unit_index(index, n, &unit_key, "css", "[sensors.css]")?;
                let kind = match f.kind.as_str() {
                    "dead" => m.none(CssFault::Dead)?,
                    _ => return Err(kind_err("\"dead\"")),
                };
                Ok(Fault::Css { index, kind })
            }
            // A GNSS fix exists only in orbit (ideal without `[sensors.gnss]`).
            "gnss" if index.is_none() => {
                if self.orbit.is_none() {
                    return Err(bad(&unit_key, "the spacecraft has no GNSS fix (no [orbit])".to_string()));
                }
                Ok(Fault::Gnss(match f.kind.as_str() {
                    "position_jump" => GnssFault::PositionJump {
                        m: m.within(-MAX_GNSS_JUMP_M, MAX_GNSS_JUMP_M, "an offset in m along the radial")?,
                    },
                    "velocity_jump" => GnssFault::VelocityJump {
                        m_s: m.within(
                            -MAX_GNSS_VELOCITY_JUMP_M_S,
                            MAX_GNSS_VELOCITY_JUMP_M_S,
                            "an offset in m/s along the velocity",
                        )?,
                    },
                    _ => return Err(kind_err("\"position_jump\", \"velocity_jump\"")),
                }))
            }
            "magnetorquer" => {
                let n = self.actuators.magnetorquers.as_ref().map_or(0, |_| self.magnetorquer_set().rods.len());
                let index = self.unit_index(index, n, &unit_key, "magnetorquer", "[actuators.magnetorquers]")?;
                let kind = match f.kind.as_str() {
                    "open" => m.none(RodFault::Open)?,
                    "reversed" => m.none(RodFault::Reversed)?,
                    _ => return Err(kind_err("\"open\", \"reversed\"")),
                };
                Ok(Fault::Magnetorquer { index, kind })
            }
            "cmg" | "thruster" => self.momentum_or_thrust_fault(name, index, f, key, &m),
            _ => Err(bad(
                &unit_key,
                format!(
                    "unknown unit {:?} (known: \"wheel.N\", \"gyro.x|y|z\", \"star_tracker\", \"magnetorquer.N\", \
                     \"magnetometer.x|y|z\", \"css.N\", \"gnss\", \"cmg.N\", \"thruster.N\")",
                    f.unit
                ),
            )),
        }
    }

    /// A CMG's (`name` "cmg") or a thruster's fault: its index below the number the
    /// spacecraft has, its kind, its magnitude.
    /// A friction fault scales the Dahl model's level, and with it the wheel's fastest
    /// dynamics: the dynamics step must stay inside the scaled wheel's RK4 stability limit
    /// (the un-faulted wheel's is checked by `validate_wheel_step`); a larger factor
    /// diverged the integrator within a second of the onset (issue 42's friction campaign).
    fn friction_step_ok(&self, p: Option<&crate::plant::wheel::WheelParams>, factor: f64, key: &str) -> Result<()> {
        let Some(p) = p else { return Ok(()) };
        let q = crate::plant::wheel::WheelParams {
            viscous_nms: p.viscous_nms * factor,
            coulomb_nm: p.coulomb_nm * factor,
            ..p.clone()
        };
        let rate_hz = self.timing.control_rate_hz * f64::from(self.timing.dynamics_substeps.max(1));
        let (h_s, h_max) = (1.0 / rate_hz, q.max_stable_step_s());
        if h_s.is_finite() && h_s > h_max {
            let need = (1.0 / (self.timing.control_rate_hz * h_max)).ceil();
            return Err(bad(
                &format!("{key}.magnitude"),
                format!(
                    "friction x {factor} makes the wheel faster than the dynamics step resolves ({h_s:.5} s > its RK4 \
                     limit {h_max:.5} s): use timing.dynamics_substeps >= {need} or a smaller factor"
                ),
            ));
        }
        Ok(())
    }

    fn momentum_or_thrust_fault(
        &self,
        name: &str,
        index: Option<&str>,
        f: &FaultSpec,
        key: &str,
        m: &Magnitude,
    ) -> Result<Fault> {
        let unit_key = format!("{key}.unit");
        let kind_err = |known: &str| {
            bad(&format!("{key}.kind"), format!("{:?} is not a fault of {} (known: {known})", f.kind, f.unit))
        };
        if name == "cmg" {
            // The only layout, "pyramid4", has one unit per initial gimbal angle.
            let n = self.actuators.cmg.as_ref().map_or(0, |c| c.initial_gimbal_deg.len());
            let index = self.unit_index(index, n, &unit_key, "cmg", "[actuators.cmg]")?;
            let kind = match f.kind.as_str() {
                "gimbal_stuck" => m.none(CmgFault::GimbalStuck)?,
                "rotor_spin_down" => CmgFault::RotorSpinDown {
                    tau_s: m.within(MIN_SPIN_DOWN_TAU_S, MAX_SPIN_DOWN_TAU_S, "the rotor's time constant in s")?,
                },
                _ => return Err(kind_err("\"gimbal_stuck\", \"rotor_spin_down\"")),
            };
            return Ok(Fault::Cmg { index, kind });
        }
        let n = self.thruster_set().map_or(0, |s| s.thrusters.len());
        let index = self.unit_index(index, n, &unit_key, "thruster", "[actuators.thrusters]")?;
        let kind = match f.kind.as_str() {
            "stuck_closed" => m.none(ThrusterFault::StuckClosed)?,
            "stuck_open" => m.none(ThrusterFault::StuckOpen)?,
            _ => return Err(kind_err("\"stuck_closed\", \"stuck_open\"")),
        };
        Ok(Fault::Thruster { index, kind })
    }

    /// The 0-based index of a numbered unit, below the `n` the spacecraft has.
    fn unit_index(&self, index: Option<&str>, n: usize, key: &str, what: &str, table: &str) -> Result<usize> {
        if n == 0 {
            return Err(bad(key, format!("the spacecraft has no {what} (no {table})")));
        }
        let i: usize = index
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad(key, format!("a {what} is {what}.N, N in 0..{n} (0-based)")))?;
        if i >= n {
            return Err(bad(key, format!("{what}.{i}: the spacecraft has {n} ({what}.0 to {what}.{})", n - 1)));
        }
        Ok(i)
    }
}

/// The axis (0, 1, 2) of a `what.x|y|z` unit.
fn axis_of(index: Option<&str>, key: &str, unit: &str, what: &str) -> Result<usize> {
    match index {
        Some("x") => Ok(0),
        Some("y") => Ok(1),
        Some("z") => Ok(2),
        _ => Err(bad(key, format!("{unit:?}: a {what} axis is {what}.x, {what}.y or {what}.z"))),
    }
}

/// An entry's `magnitude`, checked for its kind.
struct Magnitude<'a> {
    value: Option<f64>,
    key: String,
    kind: &'a str,
}

impl Magnitude<'_> {
    /// A kind that takes no magnitude: refused when one is given.
    fn none<T>(&self, t: T) -> Result<T> {
        match self.value {
            None => Ok(t),
            Some(_) => Err(bad(&self.key, format!("kind {:?} takes no magnitude", self.kind))),
        }
    }

    fn within(&self, lo: f64, hi: f64, what: &str) -> Result<f64> {
        match self.value {
            Some(x) if x.is_finite() && (lo..=hi).contains(&x) => Ok(x),
            Some(x) => {
                Err(bad(&self.key, format!("{x} is out of range: kind {:?} takes {what} in [{lo}, {hi}]", self.kind)))
            }
            None => Err(bad(&self.key, format!("required by kind {:?} ({what})", self.kind))),
        }
    }

    fn sign(&self) -> Result<f64> {
        match self.value {
            Some(x) if x == 1.0 || x == -1.0 => Ok(x),
            Some(x) => Err(bad(&self.key, format!("{x}: kind {:?} takes the torque's sign, 1 or -1", self.kind))),
            None => Err(bad(&self.key, format!("required by kind {:?} (the torque's sign, 1 or -1)", self.kind))),
        }
    }
}
