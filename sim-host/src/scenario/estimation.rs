//! The `[estimation]` table: the flight software's attitude determination (sent once per
//! run as `HostMsg::ConfigureEstimation`, for every mode). Scenario units are degrees and
//! deg/h where engineers think in them; they become the flight code's SI
//! [`EstimationParams`] here, once, and the flight code validates them again.
//!
//! Absent: the laws get the attitude sensor's quaternion and the gyro as measured (the
//! laboratory rigs of the source papers).

use acs_flight::params::{AttitudeSource, EstimationParams, MAX_CSS_HEADS};
use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SourceSpec {
    Sensor,
    #[default]
    Mekf,
}

fn d(x: f64) -> f32 {
    x.to_radians() as f32
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EstimationSpec {
    #[serde(default)]
    pub source: SourceSpec,
    /// Gyro noise model the filter assumes: angle random walk, rad/√s, and rate random
    /// walk, rad/s^1.5 (usually the `[sensors.gyro]` figures).
    pub gyro_arw_rad_sqrt_s: f64,
    pub gyro_rrw_rad_s_sqrt_s: f64,
    /// 1σ of a fresh initialisation per axis, deg.
    #[serde(default = "initial_attitude_sigma_deg")]
    pub initial_attitude_sigma_deg: f64,
    /// Initial 1σ of the gyro bias, deg/h.
    #[serde(default = "initial_bias_sigma_deg_h")]
    pub initial_bias_sigma_deg_h: f64,
    /// Star tracker 1σ about its cross-boresight axes and about its boresight, deg, and
    /// the boresight in body axes.
    pub tracker_sigma_cross_deg: f64,
    pub tracker_sigma_about_deg: f64,
    #[serde(default = "z_axis")]
    pub tracker_boresight_body: [f64; 3],
    /// Fine sun sensor 1σ, deg (absent: not used).
    #[serde(default)]
    pub sun_sensor_sigma_deg: Option<f64>,
    /// Coarse sun sensors: head normals (default: `[sensors.css] normals_body`), lit
    /// threshold, and the 1σ the filter gives their Sun direction, deg (absent: the heads
    /// only serve sun-safe and initialisation).
    #[serde(default)]
    pub css_normals_body: Option<Vec<[f64; 3]>>,
    #[serde(default = "lit_threshold")]
    pub css_lit_threshold: f64,
    #[serde(default)]
    pub css_sigma_deg: Option<f64>,
    /// Magnetometer direction 1σ (noise and field-model error), deg (absent: not used).
    #[serde(default)]
    pub magnetometer_sigma_deg: Option<f64>,
    #[serde(default = "degree")]
    pub field_model_degree: u8,
    /// The fine attitude is lost above this per-axis 1σ, deg.
    #[serde(default = "lost_deg")]
    pub lost_attitude_sigma_deg: f64,
    #[serde(default = "rejections")]
    pub max_consecutive_rejections: u16,
}

fn initial_attitude_sigma_deg() -> f64 {
    5.0
}
fn initial_bias_sigma_deg_h() -> f64 {
    10.0
}
fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}
fn lit_threshold() -> f64 {
    0.05
}
fn degree() -> u8 {
    12
}
fn lost_deg() -> f64 {
    1.0
}
fn rejections() -> u16 {
    20
}

impl EstimationSpec {
    /// The flight parameters; `css_heads`: the sensor suite's head normals (the default
    /// for `css_normals_body`). Errors name the key.
    pub fn params(&self, css_heads: Option<&[[f64; 3]]>) -> Result<EstimationParams> {
        let heads: &[[f64; 3]] = match (&self.css_normals_body, css_heads) {
            (Some(h), _) => h,
            (None, Some(h)) => h,
            (None, None) => &[],
        };
        if heads.len() > MAX_CSS_HEADS {
            bail!("estimation.css_normals_body: at most {MAX_CSS_HEADS} heads");
        }
        let mut normals = EstimationParams::SENSOR.css_normals_body;
        for (dst, n) in normals.iter_mut().zip(heads) {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if !(len.is_finite() && len > 0.0) {
                bail!("estimation.css_normals_body: a head normal is zero or not finite");
            }
            *dst = n.map(|x| (x / len) as f32);
        }
        let b = self.tracker_boresight_body;
        let bl = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        if !(bl.is_finite() && bl > 0.0) {
            bail!("estimation.tracker_boresight_body: must be a non-zero direction");
        }
        let p = EstimationParams {
            source: match self.source {
                SourceSpec::Sensor => AttitudeSource::Sensor,
                SourceSpec::Mekf => AttitudeSource::Mekf,
            },
            gyro_arw_rad_sqrt_s: self.gyro_arw_rad_sqrt_s as f32,
            gyro_rrw_rad_s_sqrt_s: self.gyro_rrw_rad_s_sqrt_s as f32,
            initial_attitude_sigma_rad: d(self.initial_attitude_sigma_deg),
            initial_bias_sigma_rad_s: d(self.initial_bias_sigma_deg_h / 3600.0),
            tracker_sigma_cross_rad: d(self.tracker_sigma_cross_deg),
            tracker_sigma_about_rad: d(self.tracker_sigma_about_deg),
            tracker_boresight_body: b.map(|x| (x / bl) as f32),
            sun_sensor_sigma_rad: self.sun_sensor_sigma_deg.map_or(0.0, d),
            css_normals_body: normals,
            css_count: heads.len() as u8,
            css_lit_threshold: self.css_lit_threshold as f32,
            css_sigma_rad: self.css_sigma_deg.map_or(0.0, d),
            magnetometer_sigma_rad: self.magnetometer_sigma_deg.map_or(0.0, d),
            field_model_degree: self.field_model_degree,
            lost_attitude_sigma_rad: d(self.lost_attitude_sigma_deg),
            max_consecutive_rejections: self.max_consecutive_rejections,
        };
        // The flight code's own validation, with the scenario's key names.
        if let Err(e) = p.validate() {
            bail!(
                "estimation: the flight code refuses these values ({e:?}): noise figures must be finite, >= 0 and < 180 deg, sigmas > 0, field_model_degree 1..=12, css_lit_threshold in (0, 1), max_consecutive_rejections > 0"
            );
        }
        Ok(p)
    }
}
