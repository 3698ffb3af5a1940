//! The estimation stage of `Fsw::step`: navigation, on-board reference models and attitude
//! determination, run every step whatever the mode.
//!
//! Per step (typed [`SensorSamples`] at `time_us`, never the wire frame):
//! 1. navigation ([`super::navigation`]): GNSS fix or the last one propagated → position,
//!    velocity, time, LVLH;
//! 2. reference models ([`crate::models`]) at the rate they change ([`super::references`]):
//!    Sun direction (Almanac, re-evaluated every `SUN_INTERVAL_S`), eclipse (cylindrical
//!    shadow, every step), Earth's field (WMM2025 to `field_model_degree`, rotated by GMST;
//!    only with the MEKF) evaluated at nodes `FIELD_NODE_INTERVAL_S` apart, spread over
//!    the steps, and interpolated in between;
//! 3. measured Sun: the fine sun sensor if valid, else the coarse sun sensors
//!    ([`super::css`]);
//! 4. attitude:
//!    - `AttitudeSource::Sensor`: the attitude sensor's quaternion and the gyro as measured;
//!    - `AttitudeSource::Mekf` ([`super::mekf`]): propagate with the mean of the previous
//!      and the current gyro reading (trapezoid) over the elapsed time (pieces of at most `MAX_PROPAGATION_DT_S`, at most
//!      `MAX_PROPAGATION_PIECES`; a longer gap restarts the filter), then the star tracker
//!      update (covariance from the cross/about-boresight σ), then the Sun and the field
//!      as sequential unit-vector updates. Without a filter it initialises from the
//!      tracker, else from TRIAD on (Sun, field) ([`super::triad`]).
//!      `max_consecutive_rejections` tracker rejections in a row mean divergence (the
//!      tracker keeps disagreeing): the filter restarts from the next fix.
//!      The attitude is *available* to the laws while the largest per-axis 1σ is within
//!      `lost_attitude_sigma_rad`; the rate is the gyro minus the estimated bias.
//!
//! No heap, no panics; every loop is bounded by a constant.

use super::css::{CssHeads, sun_vector};
use super::mekf::{Mekf, MekfConfig, MekfError};
use super::navigation::{NavSolution, Navigation};
use super::references::References;
use super::triad::triad;
use crate::link::{EstimateTelemetry, estimate_flags};
use crate::math::{Quat, Vec3, quat_to_xyzw};
use crate::models::sun::in_eclipse;
use crate::params::{AttitudeSource, EstimationParams, ParamError};
use crate::types::SensorSamples;
use nalgebra::Matrix3;

/// Longest single MEKF propagation, s.
pub const MAX_PROPAGATION_DT_S: f32 = 1.0;
/// Most propagation pieces per step (a gap longer than this many `MAX_PROPAGATION_DT_S`
/// restarts the filter instead).
pub const MAX_PROPAGATION_PIECES: u32 = 16;

/// What the estimation stage hands the rest of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub source: AttitudeSource,
    /// Attitude `q_ib` the laws may use (`None`: not available).
    pub attitude: Option<Quat>,
    /// Body rate, rad/s (bias-corrected with the MEKF); `None` without a valid gyro.
    pub rate_rad_s: Option<Vec3>,
    pub nav: Option<NavSolution>,
    /// Measured Sun direction, body axes (unit), if seen.
    pub sun_body: Option<Vec3>,
    /// The models put the spacecraft in the Earth's shadow (false without navigation).
    pub eclipse: bool,
    pub telemetry: EstimateTelemetry,
}

/// The estimation stage's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Determination {
    params: EstimationParams,
    mekf_cfg: MekfConfig,
    css: CssHeads,
    mekf: Option<Mekf>,
    nav: Navigation,
    references: References,
    last_time_us: Option<u64>,
    last_gyro: Option<Vec3>,
    consecutive_rejections: u16,
    resets: u16,
    /// Counters kept across filter restarts.
    accepted: u32,
    rejected: u32,
}

impl Default for Determination {
    fn default() -> Self {
        Self::sensor_only()
    }
}

/// A direction, or `None` for a zero or non-finite vector (TRIAD's normalisation).
fn unit(v: &Vec3) -> Option<Vec3> {
    super::triad::unit(v).ok()
}

impl Determination {
    /// The stage with the default parameters (the attitude sensor as measured; valid,
    /// tested).
    pub const fn sensor_only() -> Self {
        Self::bare(EstimationParams::SENSOR)
    }

    const fn bare(params: EstimationParams) -> Self {
        Self {
            params,
            mekf_cfg: mekf_config(&params),
            css: css_heads(&params),
            mekf: None,
            nav: Navigation::new(),
            references: References::new(),
            last_time_us: None,
            last_gyro: None,
            consecutive_rejections: 0,
            resets: 0,
            accepted: 0,
            rejected: 0,
        }
    }

    /// A fresh stage for validated parameters.
    pub fn new(params: &EstimationParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self::bare(*params))
    }

    pub fn params(&self) -> &EstimationParams {
        &self.params
    }

    /// The running filter, if any.
    pub fn mekf(&self) -> Option<&Mekf> {
        self.mekf.as_ref()
    }

    /// Restart everything (a new configuration).
    pub fn reset(&mut self) {
        *self = Self::bare(self.params);
    }

    /// One step of the stage on the step's typed samples.
    pub fn step(&mut self, s: &SensorSamples) -> Estimate {
        let gyro = s.gyro.map(|g| g.rate_rad_s);
        let nav = self.nav.update(s.time_us, s.gnss.as_ref());
        let sun_eci = nav.map(|n| self.references.sun_eci(&n.time));
        let eclipse = match (nav, sun_eci) {
            (Some(n), Some(s)) => in_eclipse(&n.r_m, &s),
            _ => false,
        };
        // The field model (the costliest model) only feeds the MEKF.
        let field_eci = match nav.filter(|_| self.params.source == AttitudeSource::Mekf) {
            Some(n) => {
                let degree = usize::from(self.params.field_model_degree);
                self.references.field_eci(s.time_us, &self.nav, &n, degree)
            }
            None => {
                self.references.clear_field();
                None
            }
        };
        // Measured vectors.
        let fine_sun = s.sun_sensor.filter(|_| self.params.sun_sensor_sigma_rad > 0.0).and_then(|x| unit(&x.dir_body));
        let coarse_sun = s
            .css
            .filter(|_| self.params.css_count > 0)
            .and_then(|x| sun_vector(&self.css, &x.output).ok().map(|c| c.dir_body));
        let sun_body = fine_sun.or(coarse_sun);
        let sun_sigma = if fine_sun.is_some() { self.params.sun_sensor_sigma_rad } else { self.params.css_sigma_rad };
        let mag_body = s.magnetometer.and_then(|x| unit(&x.field_body_t));
        let tracker = s.star_tracker.map(|x| x.q_ib);

        let mut t = EstimateTelemetry::default();
        if nav.is_some() {
            t.flags |= estimate_flags::NAVIGATION;
        }
        if eclipse {
            t.flags |= estimate_flags::ECLIPSE;
        }
        if sun_body.is_some() {
            t.flags |= estimate_flags::SUN_SEEN;
        }
        let (attitude, rate) = match self.params.source {
            AttitudeSource::Sensor => {
                self.last_time_us = Some(s.time_us);
                (tracker, gyro)
            }
            AttitudeSource::Mekf => {
                let vectors = Vectors { sun_body, sun_eci, sun_sigma, mag_body, field_eci };
                self.mekf_step(s.time_us, gyro, tracker, &vectors)
            }
        };
        if let Some(q) = attitude {
            t.q_est_xyzw = quat_to_xyzw(&q);
            t.flags |= estimate_flags::ATTITUDE;
        }
        if let Some(m) = &self.mekf {
            t.flags |= estimate_flags::MEKF;
            t.q_est_xyzw = quat_to_xyzw(&m.attitude());
            t.bias_est_rad_s = m.bias_rad_s().into();
            let p = m.covariance();
            // Row-major upper triangle: (0,0), (0,1), …, (0,5), (1,1), …, (5,5).
            let upper = (0..6usize).flat_map(|i| (i..6usize).map(move |j| (i, j)));
            for (dst, ij) in t.covariance_upper.iter_mut().zip(upper) {
                if let Some(v) = p.get(ij) {
                    *dst = *v;
                }
            }
            let h = m.health();
            t.since_update_s = h.since_update_s;
            t.last_nis = h.last_nis;
        }
        t.accepted = self.accepted;
        t.rejected = self.rejected;
        t.resets = self.resets;
        Estimate { source: self.params.source, attitude, rate_rad_s: rate, nav, sun_body, eclipse, telemetry: t }
    }

    fn lose(&mut self) {
        if self.mekf.take().is_some() {
            self.resets = self.resets.saturating_add(1);
        }
        self.consecutive_rejections = 0;
    }

    fn count(&mut self, r: Result<f32, MekfError>) -> bool {
        match r {
            Ok(_) => {
                self.accepted = self.accepted.saturating_add(1);
                true
            }
            Err(MekfError::Rejected { .. }) => {
                self.rejected = self.rejected.saturating_add(1);
                false
            }
            Err(_) => false,
        }
    }

    /// The MEKF path of the stage: propagate over the elapsed time, (re)initialise, update,
    /// and the attitude and rate the laws may use.
    fn mekf_step(
        &mut self,
        time_us: u64,
        gyro: Option<Vec3>,
        tracker: Option<Quat>,
        v: &Vectors,
    ) -> (Option<Quat>, Option<Vec3>) {
        let elapsed_us = self.last_time_us.and_then(|t0| time_us.checked_sub(t0));
        self.last_time_us = Some(time_us);
        // The rate over the interval: the mean of its two end readings. The readings are
        // instantaneous samples and the torque is held over the step, so the rate is
        // ~linear in between: the trapezoid integrates that exactly, where the previous
        // reading alone is off by ½ α dt² (0.24° per 0.5 s step at the cubesat's 0.033
        // rad/s² about z: hundreds of tracker σ, every slew start rejected the tracker).
        let held = match (self.last_gyro, gyro) {
            (Some(a), Some(b)) => Some((a + b) * 0.5),
            (a, b) => a.or(b),
        };
        self.last_gyro = gyro;
        let Some(w) = gyro else {
            // No gyro, no propagation: the attitude cannot be carried forward.
            self.lose();
            return (None, None);
        };
        self.propagate_mekf(elapsed_us, held);
        if self.mekf.is_none() {
            self.initialise_mekf(tracker, v);
        }
        let Some(mut m) = self.mekf else {
            return (None, Some(w));
        };
        self.update_mekf(&mut m, tracker, v);
        self.mekf = Some(m);
        if self.consecutive_rejections >= self.params.max_consecutive_rejections {
            self.lose();
            return (None, Some(w));
        }
        let p = m.covariance();
        let var = |i: usize| p.get((i, i)).copied().unwrap_or(f32::INFINITY);
        let worst = var(0).max(var(1)).max(var(2));
        let lost = self.params.lost_attitude_sigma_rad;
        let fine = worst.is_finite() && worst <= lost * lost;
        (fine.then(|| m.attitude()), Some(m.rate_rad_s(&w)))
    }

    /// Propagate the running filter (if any) over the elapsed time with the held rate, in
    /// pieces of at most `MAX_PROPAGATION_DT_S`; a gap beyond `MAX_PROPAGATION_PIECES`
    /// pieces or a failed propagation loses the filter.
    fn propagate_mekf(&mut self, elapsed_us: Option<u64>, held: Option<Vec3>) {
        if let (Some(m), Some(us), Some(wh)) = (self.mekf.as_mut(), elapsed_us, held) {
            #[allow(clippy::cast_precision_loss)]
            let dt_s = us as f32 * 1.0e-6;
            let pieces = libm::ceilf(dt_s / MAX_PROPAGATION_DT_S);
            let ok = if dt_s <= 0.0 {
                true
            } else if pieces <= MAX_PROPAGATION_PIECES as f32 {
                // Integral and ≤ 16, checked above.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let n = pieces as u32;
                let h = dt_s / pieces;
                (0..n).all(|_| m.propagate(&wh, h).is_ok())
            } else {
                false
            };
            if !ok {
                self.lose();
            }
        }
    }

    /// Start a filter: on the tracker, else TRIAD on Sun and field (the Sun first: the
    /// more accurate vector is TRIAD's exact one); none without either.
    fn initialise_mekf(&mut self, tracker: Option<Quat>, v: &Vectors) {
        let q0 = tracker.or_else(|| match (v.sun_body, v.mag_body, v.sun_eci, v.field_eci) {
            (Some(sb), Some(mb), Some(sr), Some(mr)) => triad(&sb, &mb, &sr, &mr).ok(),
            _ => None,
        });
        self.mekf = q0.and_then(|q| Mekf::new(self.mekf_cfg, q, Vec3::zeros()).ok());
        self.consecutive_rejections = 0;
    }

    /// The measurement updates of one step: tracker, Sun, field (each gated; a rejection
    /// changes nothing but the counters).
    fn update_mekf(&mut self, m: &mut Mekf, tracker: Option<Quat>, v: &Vectors) {
        if let Some(q) = tracker {
            let b = Vec3::from(self.params.tracker_boresight_body);
            let (c2, a2) = (
                self.params.tracker_sigma_cross_rad * self.params.tracker_sigma_cross_rad,
                self.params.tracker_sigma_about_rad * self.params.tracker_sigma_about_rad,
            );
            let r = Matrix3::identity() * c2 + b * b.transpose() * (a2 - c2);
            let res = m.update_attitude(&q, &r);
            if self.count(res) {
                self.consecutive_rejections = 0;
            } else if matches!(res, Err(MekfError::Rejected { .. })) {
                self.consecutive_rejections = self.consecutive_rejections.saturating_add(1);
            }
        }
        if let (Some(b), Some(r)) = (v.sun_body, v.sun_eci)
            && v.sun_sigma > 0.0
        {
            let res = m.update_vector(&b, &r, v.sun_sigma);
            self.count(res);
        }
        if let (Some(b), Some(r)) = (v.mag_body, v.field_eci)
            && self.params.magnetometer_sigma_rad > 0.0
        {
            let res = m.update_vector(&b, &r, self.params.magnetometer_sigma_rad);
            self.count(res);
        }
    }
}

struct Vectors {
    sun_body: Option<Vec3>,
    sun_eci: Option<Vec3>,
    sun_sigma: f32,
    mag_body: Option<Vec3>,
    field_eci: Option<Vec3>,
}

const fn mekf_config(p: &EstimationParams) -> MekfConfig {
    MekfConfig {
        gyro_arw_rad_sqrt_s: p.gyro_arw_rad_sqrt_s,
        gyro_rrw_rad_s_sqrt_s: p.gyro_rrw_rad_s_sqrt_s,
        initial_attitude_sigma_rad: p.initial_attitude_sigma_rad,
        initial_bias_sigma_rad_s: p.initial_bias_sigma_rad_s,
        max_dt_s: MAX_PROPAGATION_DT_S,
        gate_attitude: super::mekf::CHI2_3DOF_999,
        gate_vector: super::mekf::CHI2_2DOF_999,
    }
}

const fn css_heads(p: &EstimationParams) -> CssHeads {
    CssHeads { normals_body: p.css_normals_body, count: p.css_count, lit_threshold: p.css_lit_threshold }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{SensorFrame, valid};
    use crate::math::{EulerSeq, quat_from_euler};
    use crate::validation::sensor_samples;

    fn mekf_params() -> EstimationParams {
        EstimationParams {
            source: AttitudeSource::Mekf,
            initial_attitude_sigma_rad: 0.01,
            tracker_sigma_cross_rad: 1.0e-4,
            tracker_sigma_about_rad: 1.0e-4,
            ..EstimationParams::SENSOR
        }
    }

    fn frame(k: u32, q: &Quat) -> SensorSamples {
        sensor_samples(&SensorFrame {
            q_ib_xyzw: quat_to_xyzw(q),
            valid: valid::ATTITUDE | valid::RATE,
            ..SensorFrame::empty(k, u64::from(k) * 100_000)
        })
    }

    #[test]
    fn a_ten_degree_tracker_outlier_is_rejected_counted_and_changes_nothing() {
        let mut d = Determination::new(&mekf_params()).unwrap();
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        for k in 0..200 {
            d.step(&frame(k, &q));
        }
        let before = d.step(&frame(200, &q));
        let bad = q * quat_from_euler([10f32.to_radians(), 0.0, 0.0], EulerSeq::Zyx321);
        let hit = d.step(&frame(201, &bad));
        // Counted as rejected, and the estimate has not moved toward the outlier: still
        // within 1e-5 rad (f32 rounding of propagation at rest) of the truth.
        assert_eq!(hit.telemetry.rejected, before.telemetry.rejected + 1);
        let e = crate::math::rotation_angle(&crate::math::attitude_error(&hit.attitude.unwrap(), &q));
        assert!(e < 1.0e-5, "{e}");
        assert!(hit.telemetry.last_nis > crate::estimation::mekf::CHI2_3DOF_999);
        // One outlier is not divergence: no restart.
        assert_eq!(hit.telemetry.resets, 0);
    }

    #[test]
    fn a_tracker_that_keeps_disagreeing_restarts_the_filter_on_it() {
        let p = EstimationParams { max_consecutive_rejections: 5, ..mekf_params() };
        let mut d = Determination::new(&p).unwrap();
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        for k in 0..200 {
            d.step(&frame(k, &q));
        }
        // The tracker now reports a 10° different attitude every time (e.g. the filter
        // was wrong): after 5 rejections the filter restarts and then follows the tracker.
        let moved = q * quat_from_euler([0.0, 10f32.to_radians(), 0.0], EulerSeq::Zyx321);
        let mut last = None;
        for k in 200..210 {
            last = Some(d.step(&frame(k, &moved)));
        }
        let last = last.unwrap();
        assert_eq!(last.telemetry.resets, 1);
        let e = crate::math::rotation_angle(&crate::math::attitude_error(&last.attitude.unwrap(), &moved));
        assert!(e < 1.0e-3, "{e}");
    }
}
