//! `[fdir]`: the flight code's fault detection, isolation and recovery (docs/scenario.md
//! "[fdir]", docs/fdir.md). Today one monitor, `[fdir.wheels]`: the reaction-wheel torque
//! residual with isolation rotor/tachometer and the wheel dropped from the allocation.
//!
//! ```toml
//! [fdir.wheels]
//! floor_nm = 2.0e-5        # the smallest torque error declared, N m
//! threshold_sigma = 5.0    # |r| / σ_r per sample (two-sided tail 5.7e-7)
//! k = 4                    # declared when k of the last n steps exceed
//! n = 6
//! ```
//! The set goes into every parameter set that flies wheels (the mission's and each
//! wheel mode's); a scenario with `[fdir.wheels]` but no wheels is refused naming the key.

use super::{Scenario, bad, finite};
use acs_flight::params::ActuatorParams;
use acs_flight::params::fdir::{FdirParams, KOfN, WheelFdirParams, WheelResidualNoise};
use anyhow::Result;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FdirSpec {
    #[serde(default)]
    pub wheels: Option<WheelFdirSpec>,
}

fn default_threshold_sigma() -> f64 {
    5.0
}
fn default_k() -> u8 {
    4
}
fn default_n() -> u8 {
    6
}
fn default_isolation_min_ratio() -> f64 {
    3.0
}

/// `[fdir.wheels]` (docs/fdir.md "Wiring" for every quantity).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WheelFdirSpec {
    /// Floor on the threshold, N m (≥ 0): the smallest torque error declared.
    pub floor_nm: f64,
    #[serde(default = "default_threshold_sigma")]
    pub threshold_sigma: f64,
    #[serde(default = "default_k")]
    pub k: u8,
    #[serde(default = "default_n")]
    pub n: u8,
    /// Tachometer white noise the flight assumes, rad/s (default: the simulated
    /// `sensors.wheel_speed_noise_rad_s`).
    #[serde(default)]
    pub tach_sigma_rad_s: Option<f64>,
    #[serde(default)]
    pub tach_lsb_rad_s: f64,
    /// Gyro rate noise per sample about one axis, rad/s.
    #[serde(default)]
    pub gyro_sigma_rad_s: f64,
    #[serde(default = "default_isolation_min_ratio")]
    pub isolation_min_ratio: f64,
    /// Unmodelled body torque in the isolation's mismatch, N m.
    #[serde(default)]
    pub body_torque_sigma_nm: f64,
}

impl Scenario {
    /// `[fdir]` for a parameter set flying `actuator` (off without `[fdir]`, and for the
    /// wheel monitor on a set without wheels).
    pub fn fdir_params(&self, actuator: &ActuatorParams) -> Result<FdirParams> {
        let Some(spec) = self.fdir.as_ref().and_then(|f| f.wheels.as_ref()) else { return Ok(FdirParams::OFF) };
        let ActuatorParams::Wheels(w) = actuator else { return Ok(FdirParams::OFF) };
        let p = spec.params(self.sensors.wheel_speed_noise_rad_s)?;
        p.validate(w.inertia_kgm2).map_err(|e| bad("fdir.wheels", format!("refused by the flight code: {e:?}")))?;
        Ok(FdirParams { wheel: Some(p) })
    }

    /// `[fdir]` checked naming the key.
    pub fn validate_fdir(&self) -> Result<()> {
        let Some(spec) = self.fdir.as_ref().and_then(|f| f.wheels.as_ref()) else { return Ok(()) };
        if self.actuators.wheels.is_none() {
            return Err(bad("fdir.wheels", "the spacecraft has no [actuators.wheels]"));
        }
        spec.params(self.sensors.wheel_speed_noise_rad_s).map(|_| ())
    }
}

impl WheelFdirSpec {
    fn params(&self, simulated_tach_sigma_rad_s: f64) -> Result<WheelFdirParams> {
        let k = "fdir.wheels";
        let nonneg = |name: &str, x: f64| -> Result<f32> {
            finite(&format!("{k}.{name}"), &[x])?;
            if x < 0.0 {
                return Err(bad(&format!("{k}.{name}"), "must be ≥ 0"));
            }
            Ok(x as f32)
        };
        if !(self.threshold_sigma.is_finite() && self.threshold_sigma > 0.0) {
            return Err(bad(&format!("{k}.threshold_sigma"), "must be > 0"));
        }
        if !(self.isolation_min_ratio.is_finite() && self.isolation_min_ratio > 0.0) {
            return Err(bad(&format!("{k}.isolation_min_ratio"), "must be > 0"));
        }
        let window = KOfN { k: self.k, n: self.n };
        if !window.valid() {
            return Err(bad(&format!("{k}.k"), "need 1 ≤ k ≤ n ≤ 32"));
        }
        Ok(WheelFdirParams {
            noise: WheelResidualNoise {
                tach_sigma_rad_s: nonneg(
                    "tach_sigma_rad_s",
                    self.tach_sigma_rad_s.unwrap_or(simulated_tach_sigma_rad_s),
                )?,
                tach_lsb_rad_s: nonneg("tach_lsb_rad_s", self.tach_lsb_rad_s)?,
                gyro_sigma_rad_s: nonneg("gyro_sigma_rad_s", self.gyro_sigma_rad_s)?,
            },
            threshold_sigma: self.threshold_sigma as f32,
            floor_nm: nonneg("floor_nm", self.floor_nm)?,
            window,
            isolation_min_ratio: self.isolation_min_ratio as f32,
            body_torque_sigma_nm: nonneg("body_torque_sigma_nm", self.body_torque_sigma_nm)?,
        })
    }
}
