//! Attitude-determination parameters (`HostMsg::ConfigureEstimation`): one set for the
//! whole spacecraft — the estimator runs every step whatever the mode, so it is not part
//! of a mode's [`FlightParams`](super::FlightParams).
//!
//! Parsed once at the edge: [`EstimationParams::validate`] refuses a bad set with the
//! offending field (`ParamField::Estimation`), and the flight code only ever runs a
//! validated one.

use super::{ParamError, ParamField, ParamReason};
use crate::types::MAX_CSS_HEADS;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Six heads on the faces of a cube, ±x ±y ±z (body axes): the default head set.
pub const CUBE_FACES: [[f32; 3]; MAX_CSS_HEADS] =
    [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];

/// Largest noise figure or sigma accepted, rad (or rad/s, rad/√s …): about half a turn.
pub const MAX_NOISE_FIGURE: f32 = 3.2;

/// Where the attitude the laws use comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AttitudeSource {
    /// The attitude sensor's quaternion as measured, the gyro as measured (the laboratory
    /// rigs of the source papers: an AHRS hands over its attitude). The default.
    Sensor,
    /// The on-board MEKF (gyro + star tracker + Sun + field, [`crate::estimation::mekf`]);
    /// the laws get its attitude and the bias-corrected rate.
    Mekf,
}

/// Noise model and limits of the attitude determination (SI units, rad).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EstimationParams {
    pub source: AttitudeSource,
    /// Gyro angle random walk σv, rad/√s.
    pub gyro_arw_rad_sqrt_s: f32,
    /// Gyro rate random walk σu, rad/s^1.5.
    pub gyro_rrw_rad_s_sqrt_s: f32,
    /// 1σ of a fresh initialisation (tracker or TRIAD), per axis, rad.
    pub initial_attitude_sigma_rad: f32,
    /// Initial 1σ of the gyro bias, rad/s.
    pub initial_bias_sigma_rad_s: f32,
    /// Star tracker 1σ noise about the cross-boresight axes and about the boresight, rad.
    pub tracker_sigma_cross_rad: f32,
    pub tracker_sigma_about_rad: f32,
    /// Star tracker boresight, body axes (unit).
    pub tracker_boresight_body: [f32; 3],
    /// Fine sun sensor (`SensorFrame::sun_dir`) 1σ, rad; 0 = do not use it.
    pub sun_sensor_sigma_rad: f32,
    /// Coarse-sun-sensor heads: outward normals (unit, body axes) of the first
    /// `css_count`, the lit threshold (fraction of the full-Sun output), and the 1σ of the
    /// Sun direction they give, rad (0 = do not use it in the filter).
    pub css_normals_body: [[f32; 3]; MAX_CSS_HEADS],
    pub css_count: u8,
    pub css_lit_threshold: f32,
    pub css_sigma_rad: f32,
    /// Magnetometer direction 1σ, rad (sensor noise and field-model error together);
    /// 0 = do not use it.
    pub magnetometer_sigma_rad: f32,
    /// Degree of the on-board field model (1 … 12, [`crate::models::magnetic`]).
    pub field_model_degree: u8,
    /// Fine attitude is declared lost when the largest per-axis 1σ exceeds this, rad
    /// (the mode manager then leaves the pointing modes for sun-safe).
    pub lost_attitude_sigma_rad: f32,
    /// Consecutive tracker rejections after which the filter is declared diverged and
    /// re-initialised from the next tracker (or TRIAD) solution.
    pub max_consecutive_rejections: u16,
    /// A sensor whose newest sample is older than this is lost (frame time − sample time),
    /// s, > 0: the configurations that need it refuse the step (`Status::BAD_INPUT`) and
    /// the mode manager counts the input as lost (protocol 13; before, only a cleared valid
    /// bit did).
    pub max_sample_age_s: f32,
    /// Shortest time between two fused samples of the coarse vector sensors (coarse sun
    /// sensors, magnetometer), s, ≥ 0 (0: every sample). Their errors (Earth albedo, few
    /// lit heads, field-model error) are correlated over minutes, not white: fusing every
    /// sample would count one error many times and make the filter overconfident. Spacing
    /// the updates by about the errors' correlation time keeps its covariance honest
    /// (docs/estimation-timing.md).
    pub coarse_update_interval_s: f32,
    /// Oldest sample fused, s before the filter's newest time, > 0: an older sample is
    /// refused as too old. It bounds the replay of a late sample (one propagation and the
    /// stored updates per history node it passes, ≈ 4,000 instructions each on the
    /// Cortex-M4F) and so the worst step; it must cover the slowest sensor's latency
    /// (a star tracker's 50–300 ms). The history's depth (`HISTORY_DEPTH` nodes: control
    /// steps plus samples) bounds it too.
    pub max_sample_latency_s: f32,
    /// Most history nodes a late sample may re-run, 1 … `HISTORY_DEPTH − 1`: a sample that
    /// would replay more is refused as too old. With `max_sample_latency_s` it bounds the
    /// step's worst case however close the frames come (≈ 4,000–5,500 instructions per
    /// node on the Cortex-M4F); it must cover the control steps within the latency plus
    /// the samples fused in it.
    pub max_replayed_nodes: u8,
    /// The star-tracker monitor (protocol 21; `None`: off): a tracker it declares failed
    /// is no longer fused (docs/fdir.md "Star tracker").
    pub tracker_fdir: Option<super::fdir::TrackerFdirParams>,
    /// The gyro monitor (protocol 21; `None`: off): a stuck axis reads 0 from then on
    /// (docs/fdir.md "Gyro").
    pub gyro_fdir: Option<super::fdir::GyroFdirParams>,
    /// The magnetometer monitor (protocol 23; `None`: off; needs the MEKF source): a
    /// magnetometer it declares failed is no longer used (docs/fdir.md "Magnetometer").
    pub magnetometer_fdir: Option<super::fdir::MagnetometerFdirParams>,
    /// The GNSS monitor (protocol 24; `None`: off): fixes inconsistent with the last
    /// accepted one are not taken, and a receiver it declares failed is no longer used
    /// (docs/fdir.md "GNSS").
    pub gnss_fdir: Option<super::fdir::GnssFdirParams>,
}

/// Largest `max_replayed_nodes`: every node of the flight history but the one a late
/// sample is inserted after (`estimation::history::HISTORY_DEPTH` − 1, checked there at
/// compile time; a constant here so that the parameters do not depend on the estimators).
pub const MAX_REPLAYED_NODES_LIMIT: u8 = 31;

impl Default for EstimationParams {
    fn default() -> Self {
        Self::SENSOR
    }
}

impl EstimationParams {
    /// The default: the sensor's attitude as measured (what every scenario without an
    /// `[estimation]` table flies); the noise figures are a typical nanosatellite suite
    /// for when the source is switched to the MEKF.
    pub const SENSOR: Self = Self {
        source: AttitudeSource::Sensor,
        gyro_arw_rad_sqrt_s: 1.0e-4,
        gyro_rrw_rad_s_sqrt_s: 1.0e-6,
        initial_attitude_sigma_rad: 0.1,
        initial_bias_sigma_rad_s: 1.0e-3,
        tracker_sigma_cross_rad: 1.0e-4,
        tracker_sigma_about_rad: 1.0e-3,
        tracker_boresight_body: [0.0, 0.0, 1.0],
        sun_sensor_sigma_rad: 0.0,
        css_normals_body: CUBE_FACES,
        css_count: 0,
        css_lit_threshold: 0.05,
        css_sigma_rad: 0.0,
        magnetometer_sigma_rad: 0.0,
        field_model_degree: 12,
        lost_attitude_sigma_rad: 0.02,
        max_consecutive_rejections: 20,
        max_sample_age_s: 3.0,
        coarse_update_interval_s: 0.0,
        max_sample_latency_s: 0.5,
        max_replayed_nodes: 8,
        tracker_fdir: None,
        gyro_fdir: None,
        magnetometer_fdir: None,
        gnss_fdir: None,
    };
}

fn unit(v: &[f32; 3]) -> bool {
    let n2 = v.iter().map(|x| x * x).sum::<f32>();
    n2.is_finite() && (n2 - 1.0).abs() < 2.0e-3
}

impl EstimationParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        let bad = |reason| Err(ParamError { field: ParamField::Estimation, reason });
        let scalars = [
            self.gyro_arw_rad_sqrt_s,
            self.gyro_rrw_rad_s_sqrt_s,
            self.initial_attitude_sigma_rad,
            self.initial_bias_sigma_rad_s,
            self.tracker_sigma_cross_rad,
            self.tracker_sigma_about_rad,
            self.sun_sensor_sigma_rad,
            self.css_lit_threshold,
            self.css_sigma_rad,
            self.magnetometer_sigma_rad,
            self.lost_attitude_sigma_rad,
        ];
        let vectors = self.tracker_boresight_body.iter().chain(self.css_normals_body.iter().flatten());
        if !scalars.iter().chain(vectors).all(|x| x.is_finite()) {
            return bad(ParamReason::NotFinite);
        }
        // Noise figures: ≥ 0 and below a radian (or a rad/s); those that scale a
        // covariance must be > 0.
        if !scalars.iter().all(|x| *x >= 0.0 && *x <= MAX_NOISE_FIGURE) {
            return bad(ParamReason::OutOfRange);
        }
        if !(self.max_sample_age_s.is_finite() && self.max_sample_age_s > 0.0 && self.max_sample_age_s <= 3600.0) {
            return bad(ParamReason::OutOfRange);
        }
        if !(self.max_sample_latency_s.is_finite()
            && self.max_sample_latency_s > 0.0
            && self.max_sample_latency_s <= 60.0)
        {
            return bad(ParamReason::OutOfRange);
        }
        if self.max_replayed_nodes == 0 || self.max_replayed_nodes > MAX_REPLAYED_NODES_LIMIT {
            return bad(ParamReason::OutOfRange);
        }
        if self.tracker_fdir.is_some_and(|t| t.validate().is_err())
            || self.gyro_fdir.is_some_and(|g| !g.valid(self.tracker_fdir.is_some()))
            || self.magnetometer_fdir.is_some_and(|m| m.validate().is_err() || self.source != AttitudeSource::Mekf)
            || self.gnss_fdir.is_some_and(|g| g.validate().is_err())
        {
            return bad(ParamReason::OutOfRange);
        }
        if !(self.coarse_update_interval_s.is_finite() && (0.0..=86_400.0).contains(&self.coarse_update_interval_s)) {
            return bad(ParamReason::OutOfRange);
        }
        let positive = [
            self.initial_attitude_sigma_rad,
            self.initial_bias_sigma_rad_s,
            self.tracker_sigma_cross_rad,
            self.tracker_sigma_about_rad,
            self.lost_attitude_sigma_rad,
        ];
        if !positive.iter().all(|x| *x > 0.0) || !unit(&self.tracker_boresight_body) {
            return bad(ParamReason::OutOfRange);
        }
        let heads = usize::from(self.css_count);
        if heads > MAX_CSS_HEADS || !self.css_normals_body.iter().take(heads).all(unit) {
            return bad(ParamReason::OutOfRange);
        }
        if !(self.css_lit_threshold > 0.0 && self.css_lit_threshold < 1.0) {
            return bad(ParamReason::OutOfRange);
        }
        if !(1..=12).contains(&self.field_model_degree) || self.max_consecutive_rejections == 0 {
            return bad(ParamReason::OutOfRange);
        }
        Ok(())
    }

    /// CRC of the serialised set (what `ParamsAccepted` echoes).
    pub fn checksum(&self) -> Result<u32, ParamError> {
        // Every monitor on, every option set: 190 B before the GNSS monitor's 19 (protocol 24).
        let mut buf = [0u8; 256];
        let used = postcard::to_slice(self, &mut buf)
            .map_err(|_| ParamError { field: ParamField::Estimation, reason: ParamReason::TooLarge })?;
        Ok(crate::checksum::CRC32.checksum(used))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_bad_values_name_the_field() {
        assert_eq!(EstimationParams::default().validate(), Ok(()));
        let e = |p: EstimationParams| p.validate().unwrap_err();
        let d = EstimationParams::default();
        assert_eq!(e(EstimationParams { gyro_arw_rad_sqrt_s: f32::NAN, ..d }).reason, ParamReason::NotFinite);
        assert_eq!(e(EstimationParams { tracker_sigma_cross_rad: 0.0, ..d }).reason, ParamReason::OutOfRange);
        assert_eq!(
            e(EstimationParams { tracker_boresight_body: [0.0, 0.0, 2.0], ..d }).reason,
            ParamReason::OutOfRange
        );
        assert_eq!(e(EstimationParams { css_count: 7, ..d }).reason, ParamReason::OutOfRange);
        let mut skew = d;
        skew.css_count = 2;
        skew.css_normals_body[1] = [0.5, 0.0, 0.0];
        assert_eq!(e(skew).field, ParamField::Estimation);
        assert_eq!(e(EstimationParams { field_model_degree: 13, ..d }).reason, ParamReason::OutOfRange);
        assert_eq!(e(EstimationParams { max_consecutive_rejections: 0, ..d }).reason, ParamReason::OutOfRange);
        // The largest encoding (every varint at its widest) fits the checksum buffer.
        let wide =
            EstimationParams { css_count: 255, field_model_degree: 255, max_consecutive_rejections: u16::MAX, ..d };
        assert!(wide.checksum().is_ok());
    }
}
