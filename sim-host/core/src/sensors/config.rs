//! The `[sensors]` table of a scenario: the sensor suite's own configuration.

use super::clock::SampleTiming;
use super::gyro::GyroSpec;
use serde::{Deserialize, Serialize};

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
    #[serde(default)]
    pub gyro: Option<GyroSensorSpec>,
    #[serde(default)]
    pub star_tracker: Option<StarTrackerSpec>,
    #[serde(default)]
    pub magnetometer: Option<MagnetometerSensorSpec>,
    #[serde(default)]
    pub sun: Option<SunSensorSpecToml>,
    /// Coarse sun sensors (`css_output`); none without the table.
    #[serde(default)]
    pub css: Option<CssSpecToml>,
    /// GNSS receiver; without the table the frame carries the ideal orbit state and time on
    /// every frame (when the scenario has an orbit).
    #[serde(default)]
    pub gnss: Option<GnssSpecToml>,
}

/// Rate gyro: angle random walk, rate (bias) random walk, constant bias, scale factor,
/// misalignment, saturation, quantisation.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GyroSensorSpec {
    /// Sample rate (default: the control rate).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// The gyro's own latency on top of the suite's `latency_s`, s, exact (default 0).
    #[serde(default)]
    pub latency_s: f64,
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

impl Sensors {
    /// The gyro model's specification (SI units, per axis) from this table: the
    /// `[sensors.gyro]` table when there is one, else the legacy white rate noise
    /// `rate_noise_rad_s` and bias `rate_bias_rad_s`. The one place where the file's form
    /// ([`GyroSensorSpec`]: ppm, degrees, scalars, optional rate) becomes the model's.
    pub fn gyro_model(&self, control_rate_hz: f64) -> GyroSpec {
        match &self.gyro {
            Some(g) => g.model(control_rate_hz),
            // White noise of σ per sample at the control rate: ARW = σ / √rate.
            None => GyroSpec {
                rate_hz: control_rate_hz,
                arw_rad_sqrt_s: [self.rate_noise_rad_s / control_rate_hz.sqrt(); 3],
                rrw_rad_s_sqrt_s: [0.0; 3],
                bias_rad_s: self.rate_bias_rad_s,
                scale_factor: [0.0; 3],
                misalignment_rad: [0.0; 3],
                saturation_rad_s: None,
                quantisation_rad_s: 0.0,
                bias_instability_rad_s: 0.0,
                bias_correlation_s: 0.0,
            },
        }
    }
}

impl GyroSensorSpec {
    /// The model's specification: the same quantities in SI units, the same value on
    /// each axis; `control_rate_hz` is the rate when the table gives none.
    pub fn model(&self, control_rate_hz: f64) -> GyroSpec {
        GyroSpec {
            rate_hz: self.rate_hz.unwrap_or(control_rate_hz),
            arw_rad_sqrt_s: [self.arw_rad_sqrt_s; 3],
            rrw_rad_s_sqrt_s: [self.rrw_rad_s_sqrt_s; 3],
            bias_rad_s: self.bias_rad_s,
            scale_factor: [self.scale_factor_ppm * 1e-6; 3],
            misalignment_rad: self.misalignment_deg.map(f64::to_radians),
            saturation_rad_s: self.saturation_rad_s,
            quantisation_rad_s: self.quantisation_rad_s,
            bias_instability_rad_s: self.bias_instability_rad_s,
            bias_correlation_s: self.bias_correlation_s.unwrap_or(0.0),
        }
    }
}

/// Attitude sensor (star tracker / AHRS): small-rotation noise and bias per axis.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StarTrackerSpec {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
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
    /// The tracker's own latency on top of the suite's `latency_s`, s, exact (exposure →
    /// delivery; default 0).
    #[serde(default)]
    pub latency_s: f64,
    /// Intervals [start, end] (s, closed) without a solution (a tracker switched off, a
    /// blinding not modelled by the exclusion angles).
    #[serde(default)]
    pub outages_s: Vec<[f64; 2]>,
}

/// Magnetometer: noise, bias, misalignment, and the field of the torquers (T per A m²,
/// row-major).
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MagnetometerSensorSpec {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// Exposure → delivery, s, exact (not rounded to control steps; default 0).
    #[serde(default)]
    pub latency_s: f64,
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
pub struct SunSensorSpecToml {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// Exposure → delivery, s, exact (not rounded to control steps; default 0).
    #[serde(default)]
    pub latency_s: f64,
    #[serde(default)]
    pub noise_deg: f64,
    pub boresight_body: [f64; 3],
    pub fov_half_angle_deg: f64,
}

/// Coarse sun sensors: cosine heads with noise, eclipse and an optional Earth albedo term.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CssSpecToml {
    /// Sample rate (default: the control rate).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// Exposure → delivery, s, exact (not rounded to control steps; default 0).
    #[serde(default)]
    pub latency_s: f64,
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
pub struct GnssSpecToml {
    /// Fix rate (default: the control rate).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// Offset of the sample grid from t = 0, s, in [0, 1/rate) (default 0).
    #[serde(default)]
    pub phase_s: f64,
    /// Timing jitter of each sample: uniform on ±this, s, < half the period (default 0).
    #[serde(default)]
    pub jitter_s: f64,
    /// Fix validity time → delivery, s, exact (default 0).
    #[serde(default)]
    pub latency_s: f64,
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

/// Which sensor's sample clock ([`Sensors::timing`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampled {
    Gyro,
    StarTracker,
    Magnetometer,
    Sun,
    Css,
    Gnss,
}

impl Sampled {
    pub const ALL: [Sampled; 6] =
        [Sampled::Gyro, Sampled::StarTracker, Sampled::Magnetometer, Sampled::Sun, Sampled::Css, Sampled::Gnss];

    /// The sensor's table key (`sensors.<key>`).
    pub fn key(self) -> &'static str {
        match self {
            Sampled::Gyro => "gyro",
            Sampled::StarTracker => "star_tracker",
            Sampled::Magnetometer => "magnetometer",
            Sampled::Sun => "sun",
            Sampled::Css => "css",
            Sampled::Gnss => "gnss",
        }
    }
}

impl Sensors {
    /// `(rate_hz, phase_s, jitter_s, own latency_s)` as written in the sensor's table
    /// (`None`: no table).
    pub fn timing_keys(&self, which: Sampled) -> Option<(Option<f64>, f64, f64, f64)> {
        match which {
            Sampled::Gyro => self.gyro.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s)),
            Sampled::StarTracker => self.star_tracker.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s)),
            Sampled::Magnetometer => {
                self.magnetometer.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s))
            }
            Sampled::Sun => self.sun.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s)),
            Sampled::Css => self.css.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s)),
            Sampled::Gnss => self.gnss.as_ref().map(|x| (x.rate_hz, x.phase_s, x.jitter_s, x.latency_s)),
        }
    }

    /// A sensor's sample grid and delivery delay: its table's keys (defaults: the control
    /// rate, no phase, no jitter, no delay), the suite's `latency_s` added for the gyro and
    /// the star tracker (the attitude and rate measurements).
    pub fn timing(&self, which: Sampled, control_rate_hz: f64) -> SampleTiming {
        let (rate, phase_s, jitter_s, latency_s) = self.timing_keys(which).unwrap_or((None, 0.0, 0.0, 0.0));
        let suite = if matches!(which, Sampled::Gyro | Sampled::StarTracker) { self.latency_s } else { 0.0 };
        SampleTiming { rate_hz: rate.unwrap_or(control_rate_hz), phase_s, jitter_s, latency_s: suite + latency_s }
    }
}
