//! `[momentum]`: magnetic unloading of the stored wheel (CMG) momentum by the flight
//! code (`acs_flight::control::momentum`), see docs/momentum.md.
//!
//! ```toml
//! [momentum]
//! enabled = true              # default true
//! gain_per_s = 0.002          # cross-product law gain k
//! deadband_nms = 2.0e-5       # no unloading below this |h - target|
//! target_nms = [0, 0, 0]      # commanded stored momentum, body axes
//! # Optional, defaults from the scenario (what the spacecraft knows on board):
//! # max_dipole_am2 = [...]          ([actuators.magnetorquers] max_dipole_am2)
//! # residual_dipole_am2 = [...]     ([spacecraft] residual_dipole_am2)
//! # mag_coupling_t_per_am2 = [...]  ([sensors.magnetometer] coupling_t_per_am2)
//! # modes = ["hold"]                (default: every mode on wheels or CMGs)
//! # Thruster dump instead (needs [actuators.thrusters] beside the wheels or CMGs):
//! # method = "thrusters"            ("magnetic" default)
//! # dump_gain_per_s = 0.05          k_dump: tau_dump = -k_dump h_err
//! # dump_torque_max_nm = 0.3        cap on |tau_dump|
//! # dump_start_nms = 1.0            a dump starts above this |h - target|
//! # dump_stop_nms = 0.05            and ends below this (< dump_start_nms)
//! ```

use super::{Scenario, bad, finite};
use acs_flight::params::Mode;
use acs_flight::params::{ActuatorParams, MomentumParams, NO_THRUSTERS, UnloadMethod};
use anyhow::Result;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MomentumSpec {
    #[serde(default = "yes")]
    pub enabled: bool,
    pub gain_per_s: f64,
    #[serde(default)]
    pub deadband_nms: f64,
    #[serde(default)]
    pub target_nms: [f64; 3],
    #[serde(default)]
    pub max_dipole_am2: Option<[f64; 3]>,
    #[serde(default)]
    pub residual_dipole_am2: Option<[f64; 3]>,
    #[serde(default)]
    pub mag_coupling_t_per_am2: Option<[[f64; 3]; 3]>,
    /// Modes that unload (names as in `[modes]`); default: every mode on wheels or CMGs.
    #[serde(default)]
    pub modes: Option<Vec<String>>,
    /// "magnetic" (default) or "thrusters".
    #[serde(default = "magnetic")]
    pub method: String,
    #[serde(default)]
    pub dump_gain_per_s: f64,
    #[serde(default)]
    pub dump_torque_max_nm: f64,
    #[serde(default)]
    pub dump_start_nms: f64,
    #[serde(default)]
    pub dump_stop_nms: f64,
}

fn magnetic() -> String {
    "magnetic".into()
}

impl MomentumSpec {
    /// The thruster dump is selected.
    pub fn dumps(&self) -> bool {
        self.method == "thrusters"
    }
}

fn yes() -> bool {
    true
}

impl Scenario {
    /// `[momentum]`: every value checked, errors naming the key.
    pub(super) fn validate_momentum(&self) -> Result<()> {
        let Some(m) = &self.momentum else {
            return Ok(());
        };
        if !matches!(m.method.as_str(), "magnetic" | "thrusters") {
            return Err(bad("momentum.method", "must be \"magnetic\" or \"thrusters\""));
        }
        if !(m.gain_per_s.is_finite() && m.gain_per_s >= 0.0 && m.gain_per_s <= 10.0)
            || (!m.dumps() && m.gain_per_s == 0.0)
        {
            return Err(bad("momentum.gain_per_s", "must be in (0, 10] 1/s"));
        }
        if !(m.deadband_nms.is_finite() && m.deadband_nms >= 0.0) {
            return Err(bad("momentum.deadband_nms", "must be >= 0"));
        }
        finite("momentum.target_nms", &m.target_nms)?;
        if m.dumps() {
            self.validate_dump(m)?;
        } else if self.actuators.magnetorquers.is_none() {
            return Err(bad("momentum", "magnetic unloading needs [actuators.magnetorquers]"));
        }
        if self.actuators.wheels.is_none() && self.actuators.cmg.is_none() {
            return Err(bad("momentum", "needs [actuators.wheels] or [actuators.cmg] (stored momentum)"));
        }
        if let Some(d) = m.max_dipole_am2
            && !d.iter().all(|x| x.is_finite() && *x > 0.0)
        {
            return Err(bad("momentum.max_dipole_am2", "must be > 0 per axis"));
        }
        finite("momentum.residual_dipole_am2", &m.residual_dipole_am2.unwrap_or_default())?;
        let c = m.mag_coupling_t_per_am2.unwrap_or_default();
        if !c.as_flattened().iter().all(|x| x.is_finite() && x.abs() <= 1e-2) {
            return Err(bad("momentum.mag_coupling_t_per_am2", "must be finite, |c| <= 1e-2 T per A m2"));
        }
        for name in m.modes.iter().flatten() {
            if super::modes::parse_mode(name).is_none() {
                return Err(bad("momentum.modes", format!("unknown mode {name:?}")));
            }
            if self.modes.is_none() {
                return Err(bad("momentum.modes", "needs [modes]"));
            }
        }
        Ok(())
    }

    /// The thruster-dump keys.
    fn validate_dump(&self, m: &MomentumSpec) -> Result<()> {
        if !(m.dump_gain_per_s.is_finite() && m.dump_gain_per_s > 0.0 && m.dump_gain_per_s <= 10.0) {
            return Err(bad("momentum.dump_gain_per_s", "must be in (0, 10] 1/s"));
        }
        if !(m.dump_torque_max_nm.is_finite() && m.dump_torque_max_nm > 0.0 && m.dump_torque_max_nm <= 1e4) {
            return Err(bad("momentum.dump_torque_max_nm", "must be in (0, 1e4] N m"));
        }
        if !(m.dump_start_nms.is_finite() && m.dump_start_nms > 0.0 && m.dump_start_nms <= 1e6) {
            return Err(bad("momentum.dump_start_nms", "must be in (0, 1e6] N m s"));
        }
        if !(m.dump_stop_nms.is_finite() && m.dump_stop_nms >= 0.0 && m.dump_stop_nms < m.dump_start_nms) {
            return Err(bad("momentum.dump_stop_nms", "must be >= 0 and below momentum.dump_start_nms"));
        }
        if self.actuators.thrusters.is_none() {
            return Err(bad("momentum.method", "\"thrusters\" needs [actuators.thrusters]"));
        }
        Ok(())
    }

    /// The momentum parameters of one uploaded set (`mode`: its slot, `None` for a
    /// single `[controller]`). The magnetometer correction travels in every set.
    pub fn momentum_params(&self, mode: Option<Mode>, actuator: &ActuatorParams) -> MomentumParams {
        let Some(m) = &self.momentum else {
            return MomentumParams::OFF;
        };
        let f = |v: [f64; 3]| v.map(|x| x as f32);
        let stores = matches!(actuator, ActuatorParams::Wheels(_) | ActuatorParams::Cmg { .. });
        let listed = match (&m.modes, mode) {
            (Some(list), Some(mode)) => list.iter().any(|n| n == mode.name()),
            _ => true,
        };
        let rods = self.actuators.magnetorquers.as_ref().map_or([0.0; 3], |r| r.max_dipole_am2);
        // Checked at load (`magnetorquer_flight_params`): a bad list never gets here.
        let failed_rods_mask =
            self.actuators.magnetorquers.as_ref().and_then(|r| r.masked_rods_mask().ok()).unwrap_or(0);
        let coupling = m
            .mag_coupling_t_per_am2
            .unwrap_or_else(|| self.sensors.magnetometer.as_ref().map_or([[0.0; 3]; 3], |s| s.coupling_t_per_am2));
        MomentumParams {
            enabled: m.enabled && stores && listed,
            gain_per_s: m.gain_per_s as f32,
            deadband_nms: m.deadband_nms as f32,
            target_nms: f(m.target_nms),
            max_dipole_am2: f(m.max_dipole_am2.unwrap_or(rods)),
            residual_dipole_am2: f(m.residual_dipole_am2.unwrap_or(self.spacecraft.residual_dipole_am2)),
            mag_coupling_t_per_am2: coupling.map(f),
            min_field_t: 1e-7,
            method: if m.dumps() { UnloadMethod::Thrusters } else { UnloadMethod::Magnetic },
            dump_gain_per_s: m.dump_gain_per_s as f32,
            dump_torque_max_nm: m.dump_torque_max_nm as f32,
            dump_start_nms: m.dump_start_nms as f32,
            dump_stop_nms: m.dump_stop_nms as f32,
            dump_thrusters: match self.actuator_params(Some("thrusters")) {
                Ok(ActuatorParams::Thrusters(t)) if m.dumps() => t,
                _ => NO_THRUSTERS,
            },
            failed_rods_mask,
        }
    }
}
