//! The `[estimation]` table: the flight software's attitude determination (sent once per
//! run as `HostMsg::ConfigureEstimation`, for every mode). Scenario units are degrees and
//! deg/h where engineers think in them; they become the flight code's SI
//! [`EstimationParams`] here, once, and the flight code validates them again.
//!
//! Absent: the laws get the attitude sensor's quaternion and the gyro as measured (the
//! laboratory rigs of the source papers).

use acs_flight::params::{AttitudeSource, EstimationParams, MAX_NOISE_FIGURE};
use acs_flight::types::MAX_CSS_HEADS;
use anyhow::{Result, anyhow, bail};
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

/// `p` with every probed scalar at zero (to find whether zero is accepted).
fn zeroed(p: &EstimationParams) -> EstimationParams {
    EstimationParams {
        gyro_arw_rad_sqrt_s: 0.0,
        gyro_rrw_rad_s_sqrt_s: 0.0,
        initial_attitude_sigma_rad: 0.0,
        initial_bias_sigma_rad_s: 0.0,
        tracker_sigma_cross_rad: 0.0,
        tracker_sigma_about_rad: 0.0,
        sun_sensor_sigma_rad: 0.0,
        css_lit_threshold: 0.0,
        css_sigma_rad: 0.0,
        magnetometer_sigma_rad: 0.0,
        lost_attitude_sigma_rad: 0.0,
        ..*p
    }
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
    /// A sensor whose newest sample is older than this is lost, s (> 0, ≤ 3600).
    #[serde(default = "max_sample_age_s")]
    pub max_sample_age_s: f64,
    /// Shortest time between fused coarse-sun-sensor or magnetometer samples, s (≥ 0;
    /// default 0: every sample): about the correlation time of their errors.
    #[serde(default)]
    pub coarse_update_interval_s: f64,
    /// Oldest sample fused, s before the filter's newest time ((0, 60]; default 0.5): an
    /// older one is refused as too old. Bounds the flight step's worst case.
    #[serde(default = "max_sample_latency_s")]
    pub max_sample_latency_s: f64,
    /// Most history nodes a late sample may re-run (1 … 31; default 8): bounds the flight
    /// step's worst case with `max_sample_latency_s`.
    #[serde(default = "max_replayed_nodes")]
    pub max_replayed_nodes: u8,
}

fn max_replayed_nodes() -> u8 {
    EstimationParams::SENSOR.max_replayed_nodes
}

fn max_sample_latency_s() -> f64 {
    f64::from(EstimationParams::SENSOR.max_sample_latency_s)
}

fn max_sample_age_s() -> f64 {
    f64::from(EstimationParams::SENSOR.max_sample_age_s)
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

/// One scalar of the set: its key, the value as written, and how to copy the converted
/// value from a full set into a probe.
type Probe = (&'static str, f64, fn(&mut EstimationParams, &EstimationParams));

impl EstimationSpec {
    fn probes(&self) -> [Probe; 11] {
        let opt = |x: Option<f64>| x.unwrap_or(0.0);
        [
            ("gyro_arw_rad_sqrt_s", self.gyro_arw_rad_sqrt_s, |q, p| q.gyro_arw_rad_sqrt_s = p.gyro_arw_rad_sqrt_s),
            ("gyro_rrw_rad_s_sqrt_s", self.gyro_rrw_rad_s_sqrt_s, |q, p| {
                q.gyro_rrw_rad_s_sqrt_s = p.gyro_rrw_rad_s_sqrt_s
            }),
            ("initial_attitude_sigma_deg", self.initial_attitude_sigma_deg, |q, p| {
                q.initial_attitude_sigma_rad = p.initial_attitude_sigma_rad
            }),
            ("initial_bias_sigma_deg_h", self.initial_bias_sigma_deg_h, |q, p| {
                q.initial_bias_sigma_rad_s = p.initial_bias_sigma_rad_s
            }),
            ("tracker_sigma_cross_deg", self.tracker_sigma_cross_deg, |q, p| {
                q.tracker_sigma_cross_rad = p.tracker_sigma_cross_rad
            }),
            ("tracker_sigma_about_deg", self.tracker_sigma_about_deg, |q, p| {
                q.tracker_sigma_about_rad = p.tracker_sigma_about_rad
            }),
            ("sun_sensor_sigma_deg", opt(self.sun_sensor_sigma_deg), |q, p| {
                q.sun_sensor_sigma_rad = p.sun_sensor_sigma_rad
            }),
            ("css_lit_threshold", self.css_lit_threshold, |q, p| q.css_lit_threshold = p.css_lit_threshold),
            ("css_sigma_deg", opt(self.css_sigma_deg), |q, p| q.css_sigma_rad = p.css_sigma_rad),
            ("magnetometer_sigma_deg", opt(self.magnetometer_sigma_deg), |q, p| {
                q.magnetometer_sigma_rad = p.magnetometer_sigma_rad
            }),
            ("lost_attitude_sigma_deg", self.lost_attitude_sigma_deg, |q, p| {
                q.lost_attitude_sigma_rad = p.lost_attitude_sigma_rad
            }),
        ]
    }

    /// The key of the value the flight code refuses in `p`: each value is tried alone in
    /// the flight code's default set, so its validation stays the one source of truth (the
    /// range quoted is the flight code's [`MAX_NOISE_FIGURE`] in the key's unit).
    fn refused_key(&self, p: &EstimationParams) -> Option<anyhow::Error> {
        let ok = |q: &EstimationParams| q.validate().is_ok();
        for (key, value, copy) in self.probes() {
            let mut q = EstimationParams::SENSOR;
            copy(&mut q, p);
            if !ok(&q) {
                let max = f64::from(MAX_NOISE_FIGURE);
                let upper = match key {
                    "css_lit_threshold" => "1)".to_string(),
                    "initial_bias_sigma_deg_h" => format!("{:.4}]", max.to_degrees() * 3600.0),
                    k if k.ends_with("_deg") => format!("{:.4}]", max.to_degrees()),
                    _ => format!("{max}]"),
                };
                // An open lower bound when zero is refused too.
                copy(&mut q, &zeroed(p));
                let lower = if ok(&q) { "[0" } else { "(0" };
                return Some(anyhow!("estimation.{key} = {value}: out of range {lower}, {upper}"));
            }
        }
        if !(1..=12).contains(&self.field_model_degree) {
            return Some(anyhow!("estimation.field_model_degree = {}: out of range 1..=12", self.field_model_degree));
        }
        if self.max_consecutive_rejections == 0 {
            return Some(anyhow!("estimation.max_consecutive_rejections = 0: must be >= 1"));
        }
        if !(self.max_sample_age_s > 0.0 && self.max_sample_age_s <= 3600.0) {
            return Some(anyhow!("estimation.max_sample_age_s = {}: out of range (0, 3600]", self.max_sample_age_s));
        }
        if !(self.max_sample_latency_s > 0.0 && self.max_sample_latency_s <= 60.0) {
            return Some(anyhow!(
                "estimation.max_sample_latency_s = {}: out of range (0, 60]",
                self.max_sample_latency_s
            ));
        }
        let limit = acs_flight::params::MAX_REPLAYED_NODES_LIMIT;
        if self.max_replayed_nodes == 0 || self.max_replayed_nodes > limit {
            return Some(anyhow!(
                "estimation.max_replayed_nodes = {}: out of range 1..={limit}",
                self.max_replayed_nodes
            ));
        }
        if !(0.0..=86_400.0).contains(&self.coarse_update_interval_s) {
            return Some(anyhow!(
                "estimation.coarse_update_interval_s = {}: out of range [0, 86400]",
                self.coarse_update_interval_s
            ));
        }
        None
    }

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
            max_sample_age_s: self.max_sample_age_s as f32,
            coarse_update_interval_s: self.coarse_update_interval_s as f32,
            max_sample_latency_s: self.max_sample_latency_s as f32,
            max_replayed_nodes: self.max_replayed_nodes,
            // `[fdir.star_tracker]`'s and `[fdir.gyro]`'s (`Scenario::estimation_params`).
            tracker_fdir: None,
            gyro_fdir: None,
            magnetometer_fdir: None,
            gnss_fdir: None,
        };
        // The flight code's own validation, with the scenario's key names.
        if let Err(e) = p.validate() {
            return Err(self.refused_key(&p).unwrap_or_else(|| {
                anyhow!("estimation: the flight code refuses this set ({e}) (css_normals_body must be unit directions)")
            }));
        }
        Ok(p)
    }
}
