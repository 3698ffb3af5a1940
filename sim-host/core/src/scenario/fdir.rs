//! `[fdir]`: the flight code's fault detection, isolation and recovery (docs/scenario.md
//! "[fdir]", docs/fdir.md). Today one monitor, `[fdir.wheels]`: the reaction-wheel torque
//! residual with isolation rotor/tachometer and the wheel dropped from the allocation;
//! `[fdir.star_tracker]`: the estimation stage's tracker monitor (frozen, or contradicted
//! by the Sun and the field) and the tracker dropped from the estimation; `[fdir.gyro]`:
//! a stuck gyro axis, read as 0 from then on, and (`bias_step`) a gyro bias step, after
//! which the filter restarts with the step added to its bias.
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

use super::estimation::EstimationSpec;
use super::{Scenario, bad, finite};
use acs_flight::params::ActuatorParams;
use acs_flight::params::EstimationParams;
use acs_flight::params::fdir::{
    FdirParams, GnssFdirParams, GyroFdirParams, KOfN, MagnetometerFdirParams, TrackerFdirParams, WheelFdirParams,
    WheelResidualNoise,
};
use anyhow::Result;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FdirSpec {
    #[serde(default)]
    pub wheels: Option<WheelFdirSpec>,
    #[serde(default)]
    pub star_tracker: Option<TrackerFdirSpec>,
    #[serde(default)]
    pub gyro: Option<GyroFdirSpec>,
    #[serde(default)]
    pub magnetometer: Option<MagnetometerFdirSpec>,
    #[serde(default)]
    pub gnss: Option<GnssFdirSpec>,
}

/// `[fdir.gnss]`: the estimation stage's GNSS monitor (docs/fdir.md "GNSS"): each fix
/// against the last accepted one propagated to its time (σ from `[sensors.gnss]`
/// `position_noise_m` and `velocity_noise_m_s`; without the table the ideal fix: 0).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GnssFdirSpec {
    /// The acceleration the flight's two-body propagation leaves out, m/s² (J2 and drag in
    /// LEO: ≤ 0.02).
    #[serde(default = "default_gnss_model_accel")]
    pub model_accel_m_s2: f64,
    /// Residual / σ per fix (χ²₃ tail: 5 → 1.5e-5).
    #[serde(default = "default_gnss_threshold_sigma")]
    pub threshold_sigma: f64,
    #[serde(default = "default_tracker_k")]
    pub k: u8,
    #[serde(default = "default_tracker_n")]
    pub n: u8,
}

fn default_gnss_model_accel() -> f64 {
    0.02
}
fn default_gnss_threshold_sigma() -> f64 {
    5.0
}

impl GnssFdirSpec {
    /// The flight's parameters, with the simulated receiver's noise (position m, velocity
    /// m/s per axis).
    fn params(&self, position_sigma_m: f64, velocity_sigma_m_s: f64) -> Result<GnssFdirParams> {
        let k = "fdir.gnss";
        finite(&format!("{k}.model_accel_m_s2"), &[self.model_accel_m_s2])?;
        if self.model_accel_m_s2 < 0.0 {
            return Err(bad(&format!("{k}.model_accel_m_s2"), "must be ≥ 0"));
        }
        let t = self.threshold_sigma;
        if !(t.is_finite() && t > 0.0) {
            return Err(bad(&format!("{k}.threshold_sigma"), format!("{t}: must be > 0")));
        }
        let window = KOfN { k: self.k, n: self.n };
        if !window.valid() {
            return Err(bad(&format!("{k}.k"), "need 1 ≤ k ≤ n ≤ 32"));
        }
        let p = GnssFdirParams {
            position_sigma_m: position_sigma_m as f32,
            velocity_sigma_m_s: velocity_sigma_m_s as f32,
            model_accel_m_s2: self.model_accel_m_s2 as f32,
            threshold_sigma: t as f32,
            window,
        };
        p.validate().map_err(|e| bad(k, format!("refused by the flight code: {e:?}")))?;
        Ok(p)
    }
}

/// `[fdir.magnetometer]`: the estimation stage's magnetometer monitor (docs/fdir.md
/// "Magnetometer"): the measured field's magnitude against the on-board model (σ from
/// `[sensors.magnetometer] noise_t` and `model_sigma_t`), and a stuck axis.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MagnetometerFdirSpec {
    /// 1σ error of the on-board model's field magnitude against the truth, T.
    #[serde(default = "default_model_sigma_t")]
    pub model_sigma_t: f64,
    /// |residual| / σ per sample (two-sided tail: 5 → 5.7e-7).
    #[serde(default = "default_mag_threshold_sigma")]
    pub threshold_sigma: f64,
    #[serde(default = "default_tracker_k")]
    pub k: u8,
    #[serde(default = "default_tracker_n")]
    pub n: u8,
    /// Stuck: an axis repeating more than this many times in a row (≥ 1).
    #[serde(default = "default_max_repeats")]
    pub max_repeats: u16,
}

fn default_model_sigma_t() -> f64 {
    2.0e-7
}
fn default_mag_threshold_sigma() -> f64 {
    5.0
}

impl MagnetometerFdirSpec {
    /// The flight's parameters, with the simulated magnetometer's noise `noise_t`.
    fn params(&self, noise_t: f64) -> Result<MagnetometerFdirParams> {
        let k = "fdir.magnetometer";
        finite(&format!("{k}.model_sigma_t"), &[self.model_sigma_t])?;
        if self.model_sigma_t < 0.0 || self.model_sigma_t + noise_t <= 0.0 {
            return Err(bad(&format!("{k}.model_sigma_t"), "must be ≥ 0, and with the sensor's noise_t > 0"));
        }
        let t = self.threshold_sigma;
        if !(t.is_finite() && t > 0.0) {
            return Err(bad(&format!("{k}.threshold_sigma"), format!("{t}: must be > 0")));
        }
        let window = window_and_repeats(k, self.k, self.n, self.max_repeats)?;
        let p = MagnetometerFdirParams {
            noise_t: noise_t as f32,
            model_sigma_t: self.model_sigma_t as f32,
            threshold_sigma: t as f32,
            window,
            max_repeats: self.max_repeats,
        };
        p.validate().map_err(|e| bad(k, format!("refused by the flight code: {e:?}")))?;
        Ok(p)
    }
}

/// `[fdir.gyro]`: the estimation stage's stuck-axis monitor (docs/fdir.md "Gyro").
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GyroFdirSpec {
    /// An axis repeating its rate more than this many times in a row is stuck (≥ 1).
    #[serde(default = "default_max_repeats")]
    pub max_repeats: u16,
    /// The bias-step test (docs/fdir.md "Gyro bias step"): `k` of the last `n`
    /// corroborated tracker samples rejected by the filter's gate declare a step
    /// (2 ≤ k ≤ n ≤ 32); needs `[fdir.star_tracker]`. Absent: off.
    #[serde(default)]
    pub bias_step: Option<BiasStepSpec>,
}

/// `[fdir.gyro] bias_step = { k = 3, n = 4 }`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct BiasStepSpec {
    pub k: u8,
    pub n: u8,
}

impl GyroFdirSpec {
    fn params(&self) -> Result<GyroFdirParams> {
        if self.max_repeats == 0 {
            return Err(bad("fdir.gyro.max_repeats", "must be ≥ 1"));
        }
        let bias_step = self.bias_step.map(|b| KOfN { k: b.k, n: b.n });
        if bias_step.is_some_and(|w| !(w.valid() && w.k >= 2)) {
            return Err(bad("fdir.gyro.bias_step", "need 2 ≤ k ≤ n ≤ 32 (the step is a slope: two samples at least)"));
        }
        Ok(GyroFdirParams { max_repeats: self.max_repeats, bias_step })
    }
}

/// `[fdir.star_tracker]`: the estimation stage's tracker monitor (docs/fdir.md "Star
/// tracker"): frozen output, or an attitude the Sun and the field contradict.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TrackerFdirSpec {
    /// A witness (measured Sun, measured field) farther than this from where the
    /// tracker's attitude puts it is an exceedance, deg, in (0, 180).
    #[serde(default = "default_witness_max_deg")]
    pub witness_max_deg: f64,
    #[serde(default = "default_tracker_k")]
    pub k: u8,
    #[serde(default = "default_tracker_n")]
    pub n: u8,
    /// Frozen: all four quaternion components repeated more than this many times (≥ 1).
    #[serde(default = "default_max_repeats")]
    pub max_repeats: u16,
}

fn default_witness_max_deg() -> f64 {
    20.0
}
fn default_tracker_k() -> u8 {
    3
}
fn default_tracker_n() -> u8 {
    4
}
fn default_max_repeats() -> u16 {
    3
}

/// A sensor monitor's `k` of `n` window and stuck-output repeat count under the table `key`,
/// checked naming the key.
fn window_and_repeats(key: &str, k: u8, n: u8, max_repeats: u16) -> Result<KOfN> {
    let window = KOfN { k, n };
    if !window.valid() {
        return Err(bad(&format!("{key}.k"), "need 1 ≤ k ≤ n ≤ 32"));
    }
    if max_repeats == 0 {
        return Err(bad(&format!("{key}.max_repeats"), "must be ≥ 1"));
    }
    Ok(window)
}

impl TrackerFdirSpec {
    fn params(&self) -> Result<TrackerFdirParams> {
        let k = "fdir.star_tracker";
        let w = self.witness_max_deg;
        if !(w.is_finite() && w > 0.0 && w < 180.0) {
            return Err(bad(&format!("{k}.witness_max_deg"), format!("{w}: must be in (0, 180)")));
        }
        let window = window_and_repeats(k, self.k, self.n, self.max_repeats)?;
        Ok(TrackerFdirParams { witness_max_rad: w.to_radians() as f32, window, max_repeats: self.max_repeats })
    }
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

    /// The estimation stage's parameters of `[estimation]` `e`, with `[fdir.star_tracker]`.
    pub fn estimation_params(&self, e: &EstimationSpec) -> Result<EstimationParams> {
        let mut p = e.params(self.sensors.css.as_ref().map(|c| &c.normals_body[..]))?;
        p.tracker_fdir = match self.fdir.as_ref().and_then(|f| f.star_tracker.as_ref()) {
            Some(t) => Some(t.params()?),
            None => None,
        };
        p.gyro_fdir = match self.fdir.as_ref().and_then(|f| f.gyro.as_ref()) {
            Some(g) => Some(g.params()?),
            None => None,
        };
        p.magnetometer_fdir = match self.fdir.as_ref().and_then(|f| f.magnetometer.as_ref()) {
            Some(m) => Some(m.params(self.magnetometer_noise_t())?),
            None => None,
        };
        p.gnss_fdir = match self.fdir.as_ref().and_then(|f| f.gnss.as_ref()) {
            Some(g) => Some(g.params(self.gnss_noise().0, self.gnss_noise().1)?),
            None => None,
        };
        Ok(p)
    }

    /// The simulated GNSS receiver's noise per axis, position m and velocity m/s (0, 0:
    /// the ideal fix without `[sensors.gnss]`).
    fn gnss_noise(&self) -> (f64, f64) {
        self.sensors.gnss.as_ref().map_or((0.0, 0.0), |g| (g.position_noise_m, g.velocity_noise_m_s))
    }

    /// The simulated magnetometer's noise per axis, T (0 without one).
    fn magnetometer_noise_t(&self) -> f64 {
        self.sensors.magnetometer.as_ref().map_or(0.0, |m| m.noise_t)
    }

    /// `[fdir]` checked naming the key.
    pub fn validate_fdir(&self) -> Result<()> {
        if let Some(t) = self.fdir.as_ref().and_then(|f| f.star_tracker.as_ref()) {
            t.params()?;
            if self.estimation.is_none() || self.sensors.star_tracker.is_none() {
                return Err(bad(
                    "fdir.star_tracker",
                    "the monitor runs in the estimation stage: needs [estimation] and [sensors.star_tracker]",
                ));
            }
        }
        if let Some(g) = self.fdir.as_ref().and_then(|f| f.gyro.as_ref()) {
            g.params()?;
            if self.estimation.is_none() {
                return Err(bad("fdir.gyro", "the monitor runs in the estimation stage: needs [estimation]"));
            }
            let tracker_monitor = self.fdir.as_ref().is_some_and(|f| f.star_tracker.is_some());
            if g.bias_step.is_some() && !tracker_monitor {
                return Err(bad(
                    "fdir.gyro.bias_step",
                    "needs [fdir.star_tracker]: its witnesses tell a gyro step from a wrong tracker",
                ));
            }
        }
        if let Some(m) = self.fdir.as_ref().and_then(|f| f.magnetometer.as_ref()) {
            let mekf = self.estimation.as_ref().is_some_and(|e| e.source == super::estimation::SourceSpec::Mekf);
            if !mekf || self.sensors.magnetometer.is_none() {
                return Err(bad(
                    "fdir.magnetometer",
                    "the monitor runs in the estimation stage against its field model: needs [estimation] source = \"mekf\" and [sensors.magnetometer]",
                ));
            }
            m.params(self.magnetometer_noise_t())?;
        }
        if let Some(g) = self.fdir.as_ref().and_then(|f| f.gnss.as_ref()) {
            if self.orbit.is_none() {
                return Err(bad("fdir.gnss", "the monitor judges the navigation's fixes: needs [orbit]"));
            }
            g.params(self.gnss_noise().0, self.gnss_noise().1)?;
        }
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

#[cfg(test)]
mod tests {
    use super::super::Scenario;

    fn every_monitor() -> String {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../campaigns/base-3u-every-monitor.toml");
        std::fs::read_to_string(path).unwrap()
    }

    /// `[fdir.magnetometer]` is checked naming the key: a bad window, a zero repeat count,
    /// a negative model σ, and the monitor without the MEKF (its field model runs only
    /// there) are refused; the shipped table becomes the flight's parameters.
    #[test]
    fn the_magnetometer_monitor_is_checked_naming_the_key() {
        let text = every_monitor();
        let sc = Scenario::from_toml(&text).unwrap();
        let e = sc.estimation.as_ref().unwrap();
        let p = sc.estimation_params(e).unwrap().magnetometer_fdir.unwrap();
        assert_eq!((p.window.k, p.window.n, p.max_repeats, p.noise_t), (3, 4, 3, 1.0e-7));
        for (from, to, key) in [
            ("k = 3\nn = 4\nmax_repeats = 3\n", "k = 5\nn = 4\nmax_repeats = 3\n", "fdir.magnetometer.k"),
            ("k = 3\nn = 4\nmax_repeats = 3\n", "k = 3\nn = 4\nmax_repeats = 0\n", "fdir.magnetometer.max_repeats"),
            ("model_sigma_t = 2.0e-7", "model_sigma_t = -1.0", "fdir.magnetometer.model_sigma_t"),
            ("source = \"mekf\"", "source = \"sensor\"", "fdir.magnetometer"),
        ] {
            // The last table of the file is the magnetometer's: edit there only.
            let at = text.rfind("[fdir.magnetometer]").unwrap();
            let edited = format!("{}{}", &text[..at], text[at..].replacen(from, to, 1));
            let edited = if key == "fdir.magnetometer" { text.replacen(from, to, 1) } else { edited };
            assert_ne!(edited, text, "{key}: the edit applies");
            let err = Scenario::from_toml(&edited).map(|_| ()).unwrap_err().to_string();
            assert!(err.contains(key), "{key}: {err}");
        }
    }

    /// `[fdir.gnss]` is checked naming the key: a negative model acceleration, a zero
    /// threshold, a bad window, and the monitor without `[orbit]` are refused; the shipped
    /// table takes the receiver's noise.
    #[test]
    fn the_gnss_monitor_is_checked_naming_the_key() {
        let text = every_monitor();
        let sc = Scenario::from_toml(&text).unwrap();
        let e = sc.estimation.as_ref().unwrap();
        let p = sc.estimation_params(e).unwrap().gnss_fdir.unwrap();
        assert_eq!((p.position_sigma_m, p.velocity_sigma_m_s, p.window.k, p.window.n), (5.0, 0.05, 3, 4));
        // The last table of the file is the GNSS monitor's: edit there only.
        let at = text.rfind("\n[fdir.gnss]\n").unwrap();
        for (from, to, key) in [
            ("model_accel_m_s2 = 0.02", "model_accel_m_s2 = -0.1", "fdir.gnss.model_accel_m_s2"),
            ("threshold_sigma = 5.0", "threshold_sigma = 0.0", "fdir.gnss.threshold_sigma"),
            ("k = 3\nn = 4", "k = 5\nn = 4", "fdir.gnss.k"),
        ] {
            let edited = format!("{}{}", &text[..at], text[at..].replacen(from, to, 1));
            assert_ne!(edited, text, "{key}: the edit applies");
            let err = Scenario::from_toml(&edited).map(|_| ()).unwrap_err().to_string();
            assert!(err.contains(key), "{key}: {err}");
        }
        let start = text.find("[orbit]").unwrap();
        let end = start + text[start..].find("\n\n").unwrap();
        let no_orbit = format!("{}{}", &text[..start], &text[end..]);
        let err = Scenario::from_toml(&no_orbit).map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("fdir.gnss") || err.contains("orbit"), "{err}");
    }
}
