//! The `[sensors]` table of a scenario: the shortcut noises and one table per sensor
//! model, each with the same four timing keys ([`SampleTimingSpec`]).
//!
//! The tables are the file's form (degrees, ppm, scalars, optional rates); [`model`] turns
//! them into the sensor models' specifications ([`crate::sensors`], SI units per axis),
//! and [`validate`] refuses impossible values naming the key.

use crate::sensors::clock::{SampleTiming, Sampled};
use serde::de::{DeserializeOwned, Error as _};
use serde::{Deserialize, Deserializer, Serialize};

mod model;
mod validate;

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Sensors {
    #[serde(default)]
    pub seed: u64,
    /// 1σ attitude noise per axis (small rotation), deg. Paper 000's AHRS: ~2 deg.
    #[serde(default)]
    pub attitude_noise_deg: f64,
    /// 1σ white rate noise per axis, rad/s.
    #[serde(default)]
    pub rate_noise_rad_s: f64,
    /// Constant rate bias, rad/s.
    #[serde(default)]
    pub rate_bias_rad_s: [f64; 3],
    /// 1σ gimbal-angle encoder noise, deg.
    #[serde(default)]
    pub gimbal_noise_deg: f64,
    /// 1σ magnetometer noise per axis, T.
    #[serde(default)]
    pub magnetometer_noise_t: f64,
    /// 1σ wheel tachometer noise, rad/s.
    #[serde(default)]
    pub wheel_speed_noise_rad_s: f64,
    /// Transport delay of the attitude and rate measurements, s, exact (paper 000 names the
    /// rig's latency): added to the gyro's and the star tracker's own `latency_s`; a sample
    /// of the truth at t reaches the first frame at or after t + latency. 0 = none.
    #[serde(default)]
    pub latency_s: f64,
    /// Detailed models (replace the shortcuts above when given).
    #[serde(default, deserialize_with = "timed")]
    pub gyro: Option<GyroSpec>,
    #[serde(default, deserialize_with = "timed")]
    pub star_tracker: Option<StarTrackerSpec>,
    #[serde(default, deserialize_with = "timed")]
    pub magnetometer: Option<MagnetometerSpec>,
    #[serde(default, deserialize_with = "timed")]
    pub sun: Option<SunSensorSpec>,
    /// Coarse sun sensors (`css_output`); none without the table.
    #[serde(default, deserialize_with = "timed")]
    pub css: Option<CssSpec>,
    /// GNSS receiver; without the table the frame carries the ideal orbit state and time on
    /// every frame (when the scenario has an orbit).
    #[serde(default, deserialize_with = "timed")]
    pub gnss: Option<GnssSpec>,
}

/// Rate gyro: angle random walk, rate (bias) random walk, constant bias, scale factor,
/// misalignment, saturation, quantisation.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GyroSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    /// Angle random walk, rad/√s (= rad/s/√Hz; the spelling of `[estimation]`'s
    /// `gyro_arw_rad_sqrt_s`). Deprecated spelling `arw_rad_s_rthz` still read.
    #[serde(default, alias = "arw_rad_s_rthz")]
    pub arw_rad_sqrt_s: f64,
    /// Rate random walk (bias drift), rad/s/√s. Deprecated spelling `rrw_rad_s2_rthz`.
    #[serde(default, alias = "rrw_rad_s2_rthz")]
    pub rrw_rad_s_sqrt_s: f64,
    #[serde(default)]
    pub bias_rad_s: [f64; 3],
    #[serde(default)]
    pub scale_factor_ppm: f64,
    /// Triad misalignment vs body: small rotation vector, degrees (default 0).
    #[serde(default)]
    pub misalignment_deg: [f64; 3],
    /// Output range ±this per axis, rad/s (default: unlimited).
    #[serde(default)]
    pub saturation_rad_s: Option<f64>,
    /// Output LSB, rad/s (default 0: continuous).
    #[serde(default)]
    pub quantisation_rad_s: f64,
    /// Bias instability: 1σ of a first-order Gauss–Markov bias per axis, rad/s (default 0:
    /// none). Needs `bias_correlation_s`.
    #[serde(default)]
    pub bias_instability_rad_s: f64,
    /// Correlation time of the Gauss–Markov bias, s (> 0; required with
    /// `bias_instability_rad_s` > 0).
    #[serde(default)]
    pub bias_correlation_s: Option<f64>,
}

/// Attitude sensor (star tracker / AHRS): small-rotation noise and bias per axis.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StarTrackerSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    #[serde(default)]
    pub noise_deg: f64,
    #[serde(default)]
    pub bias_deg: [f64; 3],
    /// Body rate above which the tracker loses lock (attitude invalid), deg/s.
    #[serde(default)]
    pub max_rate_deg_s: Option<f64>,
    /// 1σ noise about each cross-boresight axis, deg (default: `noise_deg`).
    #[serde(default)]
    pub noise_cross_deg: Option<f64>,
    /// 1σ noise about the boresight, deg (default: `noise_deg`).
    #[serde(default)]
    pub noise_about_deg: Option<f64>,
    /// Boresight in body axes (default body z).
    #[serde(default)]
    pub boresight_body: Option<[f64; 3]>,
    /// Sun exclusion half-angle about the boresight, deg (default: none).
    #[serde(default)]
    pub sun_exclusion_deg: Option<f64>,
    /// Earth-limb exclusion angle about the boresight, deg (default: none).
    #[serde(default)]
    pub earth_exclusion_deg: Option<f64>,
    /// Intervals [start, end] (s, closed) without a solution (a tracker switched off, a
    /// blinding not modelled by the exclusion angles).
    #[serde(default)]
    pub outages_s: Vec<[f64; 2]>,
}

/// Magnetometer: noise, bias, misalignment, and the field of the torquers (T per A m²,
/// row-major).
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MagnetometerSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    /// 1σ white noise per axis, T.
    #[serde(default)]
    pub noise_t: f64,
    /// Constant bias, T, sensor axes: the spacecraft's own field at the sensor (hard iron,
    /// residual dipole) plus any sensor offset.
    #[serde(default)]
    pub bias_t: [f64; 3],
    #[serde(default)]
    pub coupling_t_per_am2: [[f64; 3]; 3],
    /// Sensor axes vs body: small rotation vector, degrees (default 0), applied to the
    /// Earth's field before the coupling, bias and noise.
    #[serde(default)]
    pub misalignment_deg: [f64; 3],
}

/// Sun sensor: angular noise, field of view around a boresight, eclipse.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SunSensorSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    #[serde(default)]
    pub noise_deg: f64,
    pub boresight_body: [f64; 3],
    pub fov_half_angle_deg: f64,
}

/// Coarse sun sensors: cosine heads with noise, eclipse and an optional Earth albedo term.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CssSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    /// Outward normals of the heads in body axes, 1 to 6 (normalised); the order is the
    /// `css_output` index.
    pub normals_body: Vec<[f64; 3]>,
    /// 1σ white noise of each head's normalised output (1 = Sun along the normal).
    #[serde(default)]
    pub noise: f64,
    /// Earth albedo coefficient (default 0: off; ~0.3 for the Earth).
    #[serde(default)]
    pub albedo: f64,
}

/// GNSS receiver: fixes at its rate, white noise, outages.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    /// `rate_hz`, `phase_s`, `jitter_s`, `latency_s` (read by [`timed`]).
    #[serde(flatten, skip_deserializing)]
    pub timing: SampleTimingSpec,
    /// 1σ white noise per axis of the position, m.
    #[serde(default)]
    pub position_noise_m: f64,
    /// 1σ white noise per axis of the velocity, m/s.
    #[serde(default)]
    pub velocity_noise_m_s: f64,
    /// Intervals `[start, end]` of simulation time, s (closed), without a fix.
    #[serde(default)]
    pub outages_s: Vec<[f64; 2]>,
}

/// The timing keys of every sensor table: its sample grid and its own delivery delay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SampleTimingSpec {
    /// Sample rate, Hz (default: the control rate).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// Exposure (or fix validity) → delivery, s, exact, not rounded to control steps
    /// (default 0); the gyro's and the star tracker's add to the suite's `latency_s`.
    #[serde(default)]
    pub latency_s: f64,
}

/// The keys of [`SampleTimingSpec`], as written in a sensor table.
const TIMING_KEYS: [&str; 4] = ["rate_hz", "phase_s", "jitter_s", "latency_s"];

/// A sensor table with its timing keys ([`timed`] fills them in).
trait Timed {
    fn timing_mut(&mut self) -> &mut SampleTimingSpec;
}

macro_rules! timed_tables {
    ($($t:ty),*) => {$(
        impl Timed for $t {
            fn timing_mut(&mut self) -> &mut SampleTimingSpec {
                &mut self.timing
            }
        }
    )*};
}
timed_tables!(GyroSpec, StarTrackerSpec, MagnetometerSpec, SunSensorSpec, CssSpec, GnssSpec);

/// Reads a sensor table: the four timing keys into [`SampleTimingSpec`], the rest into the
/// sensor's own struct, both refusing unknown keys.
///
/// Why not `#[serde(flatten)]`: serde's `flatten` cannot be combined with
/// `deny_unknown_fields` (the flattened struct sees every key of the table, so neither half
/// can refuse one), and the scenario format refuses unknown keys. So the table is read as a
/// TOML table, split by key name, and each half read with its own `deny_unknown_fields`; an
/// unknown key's message lists the timing keys too (`did you mean` and the docs coverage
/// test read that list). Writing back (`Serialize`) flattens, which serde allows.
fn timed<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
where
    D: Deserializer<'de>,
    T: DeserializeOwned + Timed,
{
    let mut own = toml::Table::deserialize(d)?;
    let mut timing = toml::Table::new();
    for k in TIMING_KEYS {
        if let Some(v) = own.remove(k) {
            timing.insert(k.to_owned(), v);
        }
    }
    let timing: SampleTimingSpec = reread(&timing).map_err(D::Error::custom)?;
    let mut spec: T = reread(&own).map_err(|e| D::Error::custom(with_timing_keys(&e)))?;
    *spec.timing_mut() = timing;
    Ok(Some(spec))
}

/// A table read again by the document parser, as the rest of the file is read (a
/// `toml::Value` is stricter about array lengths: an over-long array would be refused
/// here with another message instead of by `limits::exact_lengths`, naming its index).
fn reread<T: DeserializeOwned>(table: &toml::Table) -> Result<T, String> {
    let text = toml::to_string(table).map_err(|e| e.to_string())?;
    toml::from_str(&text).map_err(|e: toml::de::Error| e.message().to_owned())
}

/// serde's "unknown field `x`, expected one of `a`, …" for a sensor's own keys, with the
/// timing keys put in front of the list (every other message unchanged).
fn with_timing_keys(message: &str) -> String {
    let list = "expected one of ";
    match message.strip_prefix("unknown field `").and_then(|_| message.split_once(list)) {
        Some((head, rest)) => {
            let timing: Vec<String> = TIMING_KEYS.iter().map(|k| format!("`{k}`")).collect();
            format!("{head}{list}{}, {rest}", timing.join(", "))
        }
        None => message.to_owned(),
    }
}

impl Sensors {
    /// A sensor's timing keys as written in its table (`None`: no table).
    pub fn timing_keys(&self, which: Sampled) -> Option<SampleTimingSpec> {
        match which {
            Sampled::Gyro => self.gyro.as_ref().map(|x| x.timing),
            Sampled::StarTracker => self.star_tracker.as_ref().map(|x| x.timing),
            Sampled::Magnetometer => self.magnetometer.as_ref().map(|x| x.timing),
            Sampled::Sun => self.sun.as_ref().map(|x| x.timing),
            Sampled::Css => self.css.as_ref().map(|x| x.timing),
            Sampled::Gnss => self.gnss.as_ref().map(|x| x.timing),
        }
    }

    /// A sensor's sample grid and delivery delay: its table's keys (defaults: the control
    /// rate, no phase, no jitter, no delay), the suite's `latency_s` added for the gyro and
    /// the star tracker (the attitude and rate measurements).
    pub fn timing(&self, which: Sampled, control_rate_hz: f64) -> SampleTiming {
        let t = self.timing_keys(which).unwrap_or_default();
        let suite = if matches!(which, Sampled::Gyro | Sampled::StarTracker) { self.latency_s } else { 0.0 };
        SampleTiming {
            rate_hz: t.rate_hz.unwrap_or(control_rate_hz),
            phase_s: t.phase_s,
            jitter_s: t.jitter_s,
            latency_s: suite + t.latency_s,
        }
    }
}
