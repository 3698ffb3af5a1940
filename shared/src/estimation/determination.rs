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
//!    ([`super::css`]); with `tracker_fdir`, the star-tracker monitor
//!    ([`crate::fdir::tracker`]) judges a fresh tracker sample against the Sun and the
//!    field, and a tracker it declared failed is not used from then on (before all
//!    this, with `gyro_fdir`, the gyro monitor ([`crate::fdir::gyro`]) reads a stuck axis
//!    as 0);
//! 4. attitude:
//!    - `AttitudeSource::Sensor`: the attitude sensor's quaternion and the gyro as measured;
//!    - `AttitudeSource::Mekf` ([`super::mekf`]): propagate the history
//!      ([`super::history`]) to the gyro sample's time with the increment's mean rate
//!      (pieces of at most `MAX_PROPAGATION_DT_S`, at most `MAX_PROPAGATION_PIECES`; a
//!      longer gap restarts the filter), stopping at each sample that waited for the gyro
//!      ([`super::waiting`]) to fuse it at its own time, then fuse each new sample at its
//!      own time: the star tracker (covariance from the cross/about-boresight σ), the Sun
//!      and the field (unit-vector updates); a sample newer than the gyro's waits. Without
//!      a filter it initialises from the tracker, else from TRIAD on (Sun, field)
//!      ([`super::triad`]).
//!      `max_consecutive_rejections` tracker rejections in a row mean divergence (the
//!      tracker keeps disagreeing): the filter restarts from the next fix.
//!      The attitude is *available* to the laws while the largest per-axis 1σ is within
//!      `lost_attitude_sigma_rad`; the rate is the gyro minus the estimated bias.
//!
//! No heap, no panics; every loop is bounded by a constant.

use super::css::{CssHeads, sun_vector};
use super::history::{FuseOutcome, FuseRefusal, Measurement, MekfHistory, MekfHistorySlot, SensorTrack, span_s};
use super::mekf::{Mekf, MekfConfig, MekfError};
use super::navigation::{NavSolution, Navigation};
use super::references::References;
use super::status::{EstimateFlags, EstimateStatus, FilterStatus, FusionCounts, SampleAges};
use super::triad::triad;
use super::waiting::{MAX_WAITING, Pushed, WaitQueue, Waiting};
use crate::fdir::bias::{BiasStep, BiasStepMonitor};
use crate::fdir::gnss::{GnssMonitor, Verdict};
use crate::fdir::gyro::GyroMonitor;
use crate::fdir::magnetometer::MagnetometerMonitor;
use crate::fdir::tracker::{TrackerMonitor, Witness, flip_visible, witness_angle_rad};
use crate::math::{Quat, Vec3, f32m};
use crate::models::sun::in_eclipse;
use crate::params::{AttitudeSource, EstimationParams, ParamError};
use crate::types::{GyroRate, SensorSamples, StarTrackerAttitude, Valid};
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
    /// Sensors whose newest sample is older than `max_sample_age_s` (or from the future):
    /// lost, whatever their valid bit says.
    pub stale: Valid,
    /// What the stage reports about the step (packed for the wire by `Fsw::step`).
    pub status: EstimateStatus,
}

/// One sensor's bookkeeping: the time of the newest sample seen (a sample repeated with
/// the same time is the same sample, held: not fused again) and the history's track.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Track {
    seen_us: Option<u64>,
    fusion: SensorTrack,
}

impl Track {
    /// True the first time a sample with this time is seen.
    fn fresh(&mut self, t_us: u64) -> bool {
        let fresh = self.seen_us != Some(t_us);
        self.seen_us = Some(t_us);
        fresh
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Tracks {
    star_tracker: Track,
    sun_sensor: Track,
    css: Track,
    magnetometer: Track,
}

impl Tracks {
    const EMPTY: Self =
        Self { star_tracker: Track::EMPTY, sun_sensor: Track::EMPTY, css: Track::EMPTY, magnetometer: Track::EMPTY };
}

/// `params.max_sample_age_s` in µs.
const fn sample_age_us(params: &EstimationParams) -> u64 {
    // Validated: 0 < max_sample_age_s ≤ 3600, so the product fits.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let us = (params.max_sample_age_s * 1.0e6) as u64;
    us
}

/// The estimation stage's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Determination {
    params: EstimationParams,
    mekf_cfg: MekfConfig,
    css: CssHeads,
    /// The MEKF and its short history of past states (delayed fusion), started in place.
    history: MekfHistorySlot,
    /// Samples newer than the history's now, waiting for the gyro ([`super::waiting`]).
    waiting: WaitQueue,
    nav: Navigation,
    references: References,
    /// The previous gyro rate sample (trapezoid propagation without an increment).
    last_gyro: Option<Vec3>,
    tracks: Tracks,
    consecutive_rejections: u16,
    resets: u16,
    /// Counters kept across filter restarts.
    accepted: u32,
    rejected: u32,
    fusion: FusionCounts,
    /// `params.max_sample_age_s` in µs.
    max_sample_age_us: u64,
    /// The star-tracker monitor (with `params.tracker_fdir`).
    tracker_monitor: TrackerMonitor,
    /// The gyro monitor (with `params.gyro_fdir`).
    gyro_monitor: GyroMonitor,
    /// The gyro bias-step monitor (with `params.gyro_fdir.bias_step`).
    bias_monitor: BiasStepMonitor,
    /// The time of the last tracker sample a witness vouched for ([`Self::monitor_tracker`]).
    tracker_vouched_us: Option<u64>,
    /// The magnetometer monitor (with `params.magnetometer_fdir`).
    mag_monitor: MagnetometerMonitor,
    /// The GNSS monitor (with `params.gnss_fdir`).
    gnss_monitor: GnssMonitor,
    /// The on-board model's field at the last step, ECI, T (`None`: none yet).
    model_field_eci_t: Option<Vec3>,
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

/// Age of a sample at `now_us`, s (−1 without one; negative for one from the future).
fn age_s(now_us: u64, sample_us: Option<u64>) -> f32 {
    match sample_us {
        None => -1.0,
        Some(t) if t <= now_us => span_s(t, now_us).unwrap_or(0.0),
        Some(t) => -span_s(now_us, t).unwrap_or(0.0),
    }
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
            history: MekfHistorySlot::idle(mekf_config(&params)),
            waiting: WaitQueue::EMPTY,
            nav: Navigation::new(),
            references: References::new(),
            last_gyro: None,
            tracks: Tracks::EMPTY,
            consecutive_rejections: 0,
            resets: 0,
            accepted: 0,
            rejected: 0,
            max_sample_age_us: sample_age_us(&params),
            fusion: FusionCounts::ZERO,
            tracker_monitor: TrackerMonitor::new(),
            gyro_monitor: GyroMonitor::new(),
            bias_monitor: BiasStepMonitor::new(),
            tracker_vouched_us: None,
            mag_monitor: MagnetometerMonitor::new(),
            model_field_eci_t: None,
            gnss_monitor: GnssMonitor::new(),
        }
    }

    /// A fresh stage for validated parameters.
    pub fn new(params: &EstimationParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self::bare(*params))
    }

    /// In place, the stage [`new`](Self::new) gives for `params` (validated; on refusal
    /// nothing changes). The history's storage (about 10 kB) is kept, not rebuilt: a new
    /// stage by value cost the firmware's link task 28 kB of stack in temporaries (elf-check
    /// stm32). Every field is named, so a new one cannot be forgotten; the test
    /// `reconfiguring_in_place_is_a_new_stage` holds it equal to [`bare`](Self::bare).
    pub fn reconfigure(&mut self, params: &EstimationParams) -> Result<(), ParamError> {
        params.validate()?;
        let Self {
            params: p,
            mekf_cfg,
            css,
            history,
            waiting,
            nav,
            references,
            last_gyro,
            tracks,
            consecutive_rejections,
            resets,
            accepted,
            rejected,
            fusion,
            max_sample_age_us,
            tracker_monitor,
            gyro_monitor,
            bias_monitor,
            tracker_vouched_us,
            mag_monitor,
            model_field_eci_t,
            gnss_monitor,
        } = self;
        *p = *params;
        *mekf_cfg = mekf_config(params);
        *css = css_heads(params);
        history.stop();
        *waiting = WaitQueue::EMPTY;
        *nav = Navigation::new();
        *references = References::new();
        *last_gyro = None;
        *tracks = Tracks::EMPTY;
        (*consecutive_rejections, *resets, *accepted, *rejected) = (0, 0, 0, 0);
        *fusion = FusionCounts::ZERO;
        *max_sample_age_us = sample_age_us(params);
        *tracker_monitor = TrackerMonitor::new();
        *gyro_monitor = GyroMonitor::new();
        *bias_monitor = BiasStepMonitor::new();
        *tracker_vouched_us = None;
        *mag_monitor = MagnetometerMonitor::new();
        *gnss_monitor = GnssMonitor::new();
        *model_field_eci_t = None;
        Ok(())
    }

    pub fn params(&self) -> &EstimationParams {
        &self.params
    }

    /// The running filter (at the newest gyro time), if any.
    pub fn mekf(&self) -> Option<&Mekf> {
        self.history.get().map(|h| h.filter())
    }

    /// The running filter's history (its nodes: test oracles), if any.
    pub fn history(&self) -> Option<&MekfHistory> {
        self.history.get()
    }

    /// Restart everything (a new configuration).
    pub fn reset(&mut self) {
        *self = Self::bare(self.params);
    }

    /// Drop samples from the future (later than the step's time): counted, never used.
    fn drop_future(&mut self, s: &SensorSamples) -> SensorSamples {
        let mut s = *s;
        let now = s.time_us;
        let mut future = 0u32;
        let mut keep = |t: u64| {
            let ok = t <= now;
            future = future.saturating_add(u32::from(!ok));
            ok
        };
        s.gyro = s.gyro.filter(|x| keep(x.time_us));
        s.star_tracker = s.star_tracker.filter(|x| keep(x.time_us));
        s.sun_sensor = s.sun_sensor.filter(|x| keep(x.time_us));
        s.css = s.css.filter(|x| keep(x.time_us));
        s.magnetometer = s.magnetometer.filter(|x| keep(x.time_us));
        s.gnss = s.gnss.filter(|x| keep(x.time_us));
        self.fusion.from_the_future = self.fusion.from_the_future.saturating_add(future);
        s
    }

    /// Sensors whose newest sample is older than `max_sample_age_s`.
    fn stale(&self, s: &SensorSamples) -> Valid {
        // In µs on the flight clock (no float conversion per sensor).
        let max_us = self.max_sample_age_us;
        let old = |t: Option<u64>| t.is_some_and(|t| s.time_us.saturating_sub(t) > max_us);
        let mut v = Valid::empty();
        v.set(Valid::RATE, old(s.gyro.map(|x| x.time_us)));
        v.set(Valid::ATTITUDE, old(s.star_tracker.map(|x| x.time_us)));
        v.set(Valid::SUN, old(s.sun_sensor.map(|x| x.time_us)));
        v.set(Valid::CSS, old(s.css.map(|x| x.time_us)));
        v.set(Valid::MAG, old(s.magnetometer.map(|x| x.time_us)));
        v
    }

    /// One step of the stage on the step's typed samples.
    pub fn step(&mut self, samples: &SensorSamples) -> Estimate {
        let s = &self.drop_future(samples);
        let gyro_checked = self.monitor_gyro(s);
        let s = gyro_checked.as_ref().unwrap_or(s);
        let stale = self.stale(s);
        let gyro = s.gyro.filter(|_| !stale.contains(Valid::RATE));
        let fix = self.monitor_gnss(s);
        let nav = self.nav.update(s.time_us, fix.as_ref());
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
        let without_magnetometer = self.monitor_magnetometer(s, field_eci);
        let s = without_magnetometer.as_ref().unwrap_or(s);
        let v = self.vectors(s, sun_eci, field_eci);
        let without_tracker = self.monitor_tracker(s, &v, eclipse);
        let s = without_tracker.as_ref().unwrap_or(s);
        let out = match self.params.source {
            AttitudeSource::Sensor => MekfOutput {
                attitude: s.star_tracker.map(|x| x.q_ib).filter(|_| !stale.contains(Valid::ATTITUDE)),
                rate_rad_s: gyro.map(|g| g.rate_rad_s),
                filter: None,
            },
            AttitudeSource::Mekf => self.mekf_step(s.time_us, gyro.as_ref(), s, &v),
        };
        let (attitude, rate) = (out.attitude, out.rate_rad_s);
        let mut status = self.status(s, attitude, out.filter.as_ref());
        status.flags.set(EstimateFlags::NAVIGATION, nav.is_some());
        status.flags.set(EstimateFlags::ECLIPSE, eclipse);
        status.flags.set(EstimateFlags::SUN_SEEN, v.sun_body.is_some());
        Estimate {
            source: self.params.source,
            attitude,
            rate_rad_s: rate,
            nav,
            sun_body: v.sun_body,
            eclipse,
            stale,
            status,
        }
    }

    /// The star-tracker monitor (with `tracker_fdir`; [`crate::fdir::tracker`]): judges a
    /// fresh tracker sample against the Sun (outside eclipse) and the field before it is
    /// fused. Once the tracker is declared failed its samples are dropped (the returned
    /// copy; `None`: use the samples as they are), and when it is declared, a filter the
    /// witnesses contradict (it re-started from the bad tracker) is stopped, to restart
    /// from TRIAD on the Sun and the field (docs/fdir.md "Star tracker").
    fn monitor_tracker(&mut self, s: &SensorSamples, v: &Vectors, eclipse: bool) -> Option<SensorSamples> {
        let p = self.params.tracker_fdir?;
        let sun = match (v.sun_body, v.sun_eci.as_ref().and_then(unit)) {
            (Some(body), Some(reference)) if !eclipse => Some(Witness { body, reference }),
            _ => None,
        };
        let field = match (v.mag_body, v.field_eci.as_ref().and_then(unit)) {
            (Some((body, _)), Some(reference)) => Some(Witness { body, reference }),
            _ => None,
        };
        let witnesses = [sun, field];
        let filter = self.history.get().map(|h| h.filter().attitude());
        let declared = s.star_tracker.is_some_and(|x| {
            let declared = self.tracker_monitor.judge(&p, x.time_us, &x.q_ib, &witnesses, filter.as_ref());
            // Vouched for: the witnesses agree with it, and one of them would have shown a
            // flip by twice the threshold (a witness's own error cannot hide it; docs/fdir.md
            // "Star tracker").
            let b = Vec3::from(self.params.tracker_boresight_body);
            if self.tracker_monitor.corroborates(x.time_us)
                && witnesses.iter().flatten().any(|w| flip_visible(&b, &w.body, p.witness_max_rad))
            {
                self.tracker_vouched_us = Some(x.time_us);
            }
            declared
        });
        if declared {
            let max = p.witness_max_rad;
            let contradicted =
                filter.is_some_and(|f| witnesses.iter().flatten().any(|w| !(witness_angle_rad(&f, w) <= max)));
            if contradicted {
                self.lose();
            }
        }
        self.tracker_monitor.failed()?;
        Some(SensorSamples { star_tracker: None, ..*s })
    }

    /// The gyro monitor (with `gyro_fdir`; [`crate::fdir::gyro`]): judges a fresh gyro
    /// sample; once an axis is declared stuck, the returned copy reads it as 0 (`None`:
    /// use the samples as they are).
    fn monitor_gyro(&mut self, s: &SensorSamples) -> Option<SensorSamples> {
        let (p, g) = (self.params.gyro_fdir?, s.gyro?);
        let checked = self.gyro_monitor.judge(&p, &g);
        (self.gyro_monitor.failed_axes() != 0).then_some(SensorSamples { gyro: Some(checked), ..*s })
    }

    /// The magnetometer monitor (with `magnetometer_fdir`; [`crate::fdir::magnetometer`]):
    /// judges a fresh sample against the model's field magnitude `model_t` (T, at the
    /// step; the field moves nanotesla in a sample's latency); once it is declared failed,
    /// the magnetometer is dropped from the estimation (the returned copy; `None`: use the
    /// samples as they are).
    /// `field_eci`: the model's direction at the step (`None`: no model field).
    fn monitor_magnetometer(&mut self, s: &SensorSamples, field_eci: Option<Vec3>) -> Option<SensorSamples> {
        let p = self.params.magnetometer_fdir?;
        // Only with the monitor on: the magnitude's interpolation costs the step.
        let model_t = field_eci.and_then(|_| self.references.field_magnitude_t(s.time_us));
        if let Some(x) = s.magnetometer {
            self.mag_monitor.judge(&p, x.time_us, &x.field_body_t, model_t);
        }
        if !self.mag_monitor.failed() {
            return None;
        }
        // The laws' substitute (`Fsw`): only once the magnetometer has failed.
        self.model_field_eci_t = field_eci.zip(model_t).map(|(d, m)| d * m);
        Some(SensorSamples { magnetometer: None, ..*s })
    }

    /// The on-board model's field at the last step's time, ECI, T (`None` without
    /// navigation, the MEKF source or an evaluated bracket yet).
    pub fn model_field_eci_t(&self) -> Option<Vec3> {
        self.model_field_eci_t
    }

    /// The GNSS monitor (with `gnss_fdir`; [`crate::fdir::gnss`]): the step's fix if the
    /// navigation may take it (consistent with the last accepted fix, or no monitor).
    fn monitor_gnss(&mut self, s: &SensorSamples) -> Option<crate::types::GnssFix> {
        let g = s.gnss?;
        let Some(p) = self.params.gnss_fdir else { return Some(g) };
        // The propagation only when judged: a fix held over two frames is judged once.
        let predicted = if self.gnss_monitor.judges(g.time_us) { self.nav.predict_fix(g.time_us) } else { None };
        match self.gnss_monitor.judge(&p, g.time_us, (&g.pos_eci_m, &g.vel_eci_m_s), predicted.as_ref()) {
            Verdict::Take => Some(g),
            Verdict::Refuse => None,
        }
    }

    /// The GNSS monitor's state (telemetry).
    pub fn gnss_monitor(&self) -> &GnssMonitor {
        &self.gnss_monitor
    }

    /// The magnetometer monitor's state (telemetry).
    pub fn magnetometer_monitor(&self) -> &MagnetometerMonitor {
        &self.mag_monitor
    }

    /// The gyro bias-step monitor's state (telemetry).
    pub fn bias_monitor(&self) -> &BiasStepMonitor {
        &self.bias_monitor
    }

    /// The filter's divergence rule restarts it on the tracker (`max_consecutive_rejections`
    /// rejections in a row): without the star-tracker monitor always; with it, only when a
    /// witness vouches for this tracker sample, or the witnesses agree with it and it is
    /// within `witness_max_rad` of the filter (a drift, e.g. an undeclared gyro bias step; a
    /// flip is 180° away) — a flip no witness can see (eclipse, the field near the
    /// boresight) must not become the filter's attitude. Otherwise the filter goes on with
    /// the gyro, its σ grows, and the pointing modes lose their input.
    fn may_restart_on_tracker(&self, s: &SensorSamples) -> bool {
        let Some(p) = self.params.tracker_fdir else { return true };
        let Some(x) = s.star_tracker else { return false };
        let near_the_filter = || {
            let f = self.history.get().map(|h| h.filter().attitude());
            // |q_f · q_t| = cos(angle / 2): the angle between the two attitudes.
            f.is_some_and(|f| libm::fabsf(f.coords.dot(&x.q_ib.coords)) >= f32m::cos(0.5 * p.witness_max_rad))
        };
        self.tracker_vouched_us == Some(x.time_us)
            || (self.tracker_monitor.corroborates(x.time_us) && near_the_filter())
    }

    /// The star-tracker monitor's state (telemetry).
    pub fn tracker_monitor(&self) -> &TrackerMonitor {
        &self.tracker_monitor
    }

    /// The gyro monitor's state (telemetry, the mode inputs).
    pub fn gyro_monitor(&self) -> &GyroMonitor {
        &self.gyro_monitor
    }

    /// The ground re-enables the star tracker and the gyro axes the monitors declared
    /// failed.
    pub fn clear_sensor_faults(&mut self) {
        self.tracker_monitor.clear();
        self.gyro_monitor.clear();
        self.bias_monitor.clear();
        self.mag_monitor.clear();
        self.gnss_monitor.clear();
    }

    /// The measured vectors of the step and their reference directions.
    fn vectors(&self, s: &SensorSamples, sun_eci: Option<Vec3>, field_eci: Option<Vec3>) -> Vectors {
        let fine_sun = s
            .sun_sensor
            .filter(|_| self.params.sun_sensor_sigma_rad > 0.0)
            .and_then(|x| unit(&x.dir_body).map(|d| (d, x.time_us)));
        let coarse_sun = s
            .css
            .filter(|_| self.params.css_count > 0)
            .and_then(|x| sun_vector(&self.css, &x.output).ok().map(|c| (c.dir_body, x.time_us)));
        let sun = fine_sun.or(coarse_sun);
        let sun_sigma = if fine_sun.is_some() { self.params.sun_sensor_sigma_rad } else { self.params.css_sigma_rad };
        Vectors {
            sun_body: sun.map(|x| x.0),
            sun_time_us: sun.map_or(0, |x| x.1),
            sun_is_fine: fine_sun.is_some(),
            sun_eci,
            sun_sigma,
            mag_body: s.magnetometer.and_then(|x| unit(&x.field_body_t).map(|d| (d, x.time_us))),
            field_eci,
        }
    }

    /// The step's report: estimate and covariance (`filter`: the MEKF at the step's
    /// time), counters, sample ages.
    fn status(&self, s: &SensorSamples, attitude: Option<Quat>, filter: Option<&Mekf>) -> EstimateStatus {
        let mut flags = EstimateFlags::empty();
        flags.set(EstimateFlags::ATTITUDE, attitude.is_some());
        flags.set(EstimateFlags::MEKF, filter.is_some());
        // ≤ MAX_WAITING (16).
        let waiting = u16::try_from(self.waiting.len()).unwrap_or(u16::MAX);
        let mut st = EstimateStatus {
            q_est: attitude,
            filter: None,
            accepted: self.accepted,
            rejected: self.rejected,
            resets: self.resets,
            flags,
            sample_age_s: SampleAges {
                gyro: age_s(s.time_us, s.gyro.map(|x| x.time_us)),
                star_tracker: age_s(s.time_us, s.star_tracker.map(|x| x.time_us)),
                sun: age_s(s.time_us, s.sun_sensor.map(|x| x.time_us).or(s.css.map(|x| x.time_us))),
                magnetometer: age_s(s.time_us, s.magnetometer.map(|x| x.time_us)),
            },
            fusion: FusionCounts { waiting, ..self.fusion },
        };
        if let Some(m) = filter {
            st.q_est = Some(m.attitude());
            let h = m.health();
            // Filled in place (no copy of the 21 values on the step's hot path).
            let f = st.filter.insert(FilterStatus {
                bias_rad_s: m.bias_rad_s(),
                covariance_upper: [0.0; 21],
                since_update_s: h.since_update_s,
                last_nis: h.last_nis,
            });
            let p = m.covariance();
            // Row-major upper triangle: (0,0), (0,1), …, (0,5), (1,1), …, (5,5).
            let upper = (0..6usize).flat_map(|i| (i..6usize).map(move |j| (i, j)));
            for (dst, ij) in f.covariance_upper.iter_mut().zip(upper) {
                if let Some(v) = p.get(ij) {
                    *dst = *v;
                }
            }
        }
        st
    }

    /// Stop the filter; the samples waiting for it can no longer be fused (counted).
    fn lose(&mut self) {
        if self.history.stop() {
            self.resets = self.resets.saturating_add(1);
        }
        self.consecutive_rejections = 0;
        let dropped = u32::try_from(self.waiting.clear()).unwrap_or(u32::MAX);
        self.fusion.dropped_waiting = self.fusion.dropped_waiting.saturating_add(dropped);
    }

    /// Count a filter outcome: accepted / gate-rejected.
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

    /// The MEKF path of the stage: propagate the history to the gyro's time,
    /// (re)initialise, fuse each new sample at its own time, and the attitude (predicted
    /// to the step's time) and rate the laws may use.
    fn mekf_step(&mut self, now_us: u64, gyro: Option<&GyroRate>, s: &SensorSamples, v: &Vectors) -> MekfOutput {
        let Some(g) = gyro else {
            // No gyro, no propagation: the attitude cannot be carried forward.
            self.last_gyro = None;
            self.lose();
            return MekfOutput { attitude: None, rate_rad_s: None, filter: None };
        };
        if !self.history.is_running() {
            self.initialise_mekf(g, s, v);
        }
        self.propagate_history(g);
        if let Some((x, step)) = self.fuse_new(s, v) {
            match step.axis.filter(|_| step.erratic) {
                // Not a step but an erratic axis (crate::fdir::bias): failed, read as 0.
                Some(axis) => self.gyro_monitor.fail_erratic(axis),
                None => self.restart_on_bias_step(&x, &step),
            }
        }
        if self.consecutive_rejections >= self.params.max_consecutive_rejections && self.may_restart_on_tracker(s) {
            self.lose();
        }
        let Some(h) = self.history.get() else {
            return MekfOutput { attitude: None, rate_rad_s: Some(g.rate_rad_s), filter: None };
        };
        let mut m = *h.filter();
        // The gyro may lag the step (its own latency): predict to the step's time.
        if let Some(dt) = span_s(h.now_us(), now_us).filter(|dt| *dt > 0.0) {
            let predicted = m.rate_rad_s(&g.rate_rad_s);
            let mut ahead = m;
            if ahead.propagate(&(predicted + m.bias_rad_s()), dt).is_ok() {
                // One rate sample (white noise σv/√T over its interval T) held over dt > T:
                // the attitude error grows as σv dt/√T, not as the model's σv √dt.
                if let Some(t) = g.increment.map(|i| i.interval_s).filter(|t| dt > *t) {
                    let sv = self.params.gyro_arw_rad_sqrt_s;
                    let _ = ahead.add_attitude_variance(sv * sv * (dt * dt / t - dt));
                }
                m = ahead;
            }
        }
        let p = m.covariance();
        let var = |i: usize| p.get((i, i)).copied().unwrap_or(f32::INFINITY);
        let worst = var(0).max(var(1)).max(var(2));
        let lost = self.params.lost_attitude_sigma_rad;
        let fine = worst.is_finite() && worst <= lost * lost;
        MekfOutput {
            attitude: fine.then(|| m.attitude()),
            rate_rad_s: Some(m.rate_rad_s(&g.rate_rad_s)),
            filter: Some(m),
        }
    }

    /// Carry the history from its newest time to the gyro sample's time with the
    /// increment's mean rate (without an increment: the mean of the previous and this
    /// rate sample, the trapezoid), in pieces of at most `MAX_PROPAGATION_DT_S`, stopping
    /// at each waiting sample the gyro has now caught up with (in time order) to fuse it
    /// there. A held gyro sample (same time) propagates nothing; one older than the
    /// history is counted out of order; a gap beyond `MAX_PROPAGATION_PIECES` pieces or a
    /// failed propagation loses the filter.
    fn propagate_history(&mut self, g: &GyroRate) {
        // The rate over the interval without an increment: the mean of its two end
        // readings. The readings are instantaneous samples and the torque is held over the
        // step, so the rate is ~linear in between: the trapezoid integrates that exactly.
        let rate = match (g.increment, self.last_gyro) {
            (Some(inc), _) => inc.angle_rad / inc.interval_s,
            (None, Some(a)) => (a + g.rate_rad_s) * 0.5,
            (None, None) => g.rate_rad_s,
        };
        let Some(h) = self.history.get() else {
            self.last_gyro = Some(g.rate_rad_s);
            return;
        };
        let now = h.now_us();
        if g.time_us <= now {
            if g.time_us < now {
                self.fusion.out_of_order = self.fusion.out_of_order.saturating_add(1);
            }
            return;
        }
        self.last_gyro = Some(g.rate_rad_s);
        let span = span_s(now, g.time_us).unwrap_or(f32::INFINITY);
        if libm::ceilf(span / MAX_PROPAGATION_DT_S) > MAX_PROPAGATION_PIECES as f32 || span.is_nan() {
            self.lose();
            return;
        }
        // Each round takes one waiting sample (or ends the step): at most MAX_WAITING + 1.
        for _ in 0..=MAX_WAITING {
            let due = self.waiting.pop_due(g.time_us);
            let stop_us = due.map_or(g.time_us, |(_, w)| w.t_us);
            if !self.propagate_to(&rate, stop_us, due) {
                self.lose();
                return;
            }
            if due.is_none() {
                return;
            }
        }
    }

    /// Carry the history from now to `stop_us` with `rate` in equal pieces of at most
    /// `MAX_PROPAGATION_DT_S` (within the step checked by the caller: ≤ 16); with `due`, the
    /// last piece ends at that waiting sample, which is fused there. False: a propagation
    /// failed.
    fn propagate_to(&mut self, rate: &Vec3, stop_us: u64, due: Option<(usize, Waiting)>) -> bool {
        let Some(h) = self.history.get_mut() else { return false };
        let now = h.now_us();
        let span_us = stop_us.saturating_sub(now);
        if span_us > 0 || due.is_none() {
            let span = span_s(now, stop_us).unwrap_or(f32::INFINITY);
            // Integral, 1 … 16 (the whole step was checked by the caller).
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let n = (libm::ceilf(span / MAX_PROPAGATION_DT_S) as u64).max(1);
            let at = |i: u64| now.saturating_add(span_us.saturating_mul(i).checked_div(n).unwrap_or(span_us));
            // With a sample, its own node ends the last piece (`History::fuse_ahead`).
            let pieces = if due.is_some() { n.saturating_sub(1) } else { n };
            if span_us > 0 && !(1..=pieces).all(|i| h.propagate_rate(rate, at(i)).is_ok()) {
                return false;
            }
        }
        let Some((index, w)) = due else { return true };
        let Some(sensor) = Sensor::from_index(index) else { return true };
        let track = self.tracks.fusion_mut(sensor);
        match h.fuse_ahead(track, rate, w.t_us, &w.measurement) {
            Err(_) => false,
            Ok(r) => {
                if self.record(sensor, false, r).is_some() {
                    self.fusion.fused_after_wait = self.fusion.fused_after_wait.saturating_add(1);
                }
                true
            }
        }
    }

    /// Start a filter on the tracker, else on TRIAD (Sun and field; the Sun first: the more
    /// accurate vector is TRIAD's exact one); none without either. A tracker sample taken
    /// within the gyro's current increment starts the filter at its own time and is fused
    /// there (the increment's mean rate carries it to the gyro's time, as for any sample
    /// within a step); an older one, or TRIAD, starts it at the gyro's time and is consumed
    /// by the start (the initial σ covers its age: one increment's mean rate held over a
    /// longer span would claim a drift it cannot know).
    fn initialise_mekf(&mut self, g: &GyroRate, s: &SensorSamples, v: &Vectors) {
        let gyro_us = g.time_us;
        let span_us = g.increment.map_or(0, |inc| {
            // ≤ 2^32 µs (the wire's u32 interval): the conversion is exact enough.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let us = libm::roundf(inc.interval_s * 1.0e6) as u64;
            us
        });
        let tracker = s.star_tracker;
        let at_its_time = tracker.filter(|x| x.time_us <= gyro_us && gyro_us.saturating_sub(x.time_us) <= span_us);
        let q0 = tracker.map(|x| x.q_ib).or_else(|| match (v.sun_body, v.mag_body, v.sun_eci, v.field_eci) {
            (Some(sb), Some((mb, _)), Some(sr), Some(mr)) => triad(&sb, &mb, &sr, &mr).ok(),
            _ => None,
        });
        let Some(m) = q0.and_then(|q| Mekf::new(self.mekf_cfg, q, Vec3::zeros()).ok()) else {
            return;
        };
        self.consecutive_rejections = 0;
        // Samples seen before this start are history: only later ones are fused.
        self.tracks = Tracks::default();
        if let Some(x) = at_its_time {
            self.history.start(m, x.time_us);
            // A filter started on this sample agrees with it: no bias step to judge.
            let _ = self.fuse_tracker(x);
            return;
        }
        self.history.start(m, gyro_us);
        if let Some(x) = tracker {
            self.tracks.star_tracker.fresh(x.time_us);
            return;
        }
        if v.sun_body.is_some() {
            self.sun_track(v.sun_is_fine).fresh(v.sun_time_us);
        }
        if let Some((_, t)) = v.mag_body {
            self.tracks.magnetometer.fresh(t);
        }
    }

    /// A coarse vector sample of `sensor` at `t_us` may be fused: at least
    /// `coarse_update_interval_s` after the sensor's last fused or waiting one (the
    /// errors' decorrelation interval).
    fn coarse_due(&self, sensor: Sensor, t_us: u64) -> bool {
        let fused = self.tracks.fusion(sensor).last_fused_us;
        let last = fused.max(self.waiting.newest_us(sensor.index()));
        last.and_then(|last| span_s(last, t_us)).is_none_or(|dt| dt >= self.params.coarse_update_interval_s)
    }

    fn sun_track(&mut self, fine: bool) -> &mut Track {
        if fine { &mut self.tracks.sun_sensor } else { &mut self.tracks.css }
    }

    /// Fuse every sample first seen this step at its own time: tracker, Sun, field. A
    /// bias step the tracker's sample declared comes back with the sample.
    fn fuse_new(&mut self, s: &SensorSamples, v: &Vectors) -> Option<(StarTrackerAttitude, BiasStep)> {
        self.history.get()?;
        let bias_step = s.star_tracker.and_then(|x| self.fuse_tracker(x).map(|b| (x, b)));
        if let (Some(b), Some(r)) = (v.sun_body, v.sun_eci)
            && v.sun_sigma > 0.0
            && self.sun_track(v.sun_is_fine).fresh(v.sun_time_us)
            && (v.sun_is_fine || self.coarse_due(Sensor::Css, v.sun_time_us))
        {
            let sensor = if v.sun_is_fine { Sensor::FineSun } else { Sensor::Css };
            let m = Measurement::Vector { body: b, reference: r, sigma_rad: v.sun_sigma };
            self.fuse(sensor, v.sun_time_us, &m);
        }
        if let (Some((b, t)), Some(r)) = (v.mag_body, v.field_eci)
            && self.params.magnetometer_sigma_rad > 0.0
            && self.tracks.magnetometer.fresh(t)
            && self.coarse_due(Sensor::Magnetometer, t)
        {
            let m = Measurement::Vector { body: b, reference: r, sigma_rad: self.params.magnetometer_sigma_rad };
            self.fuse(Sensor::Magnetometer, t, &m);
        }
        bias_step
    }

    /// Fuse a tracker sample at its time if it is new; with the bias-step test, judge it
    /// and return a step it declares.
    fn fuse_tracker(&mut self, x: StarTrackerAttitude) -> Option<BiasStep> {
        if !self.tracks.star_tracker.fresh(x.time_us) {
            return None;
        }
        let r_rad2 = self.tracker_noise_rad2();
        let r = self.fuse(Sensor::StarTracker, x.time_us, &Measurement::Attitude { q_meas: x.q_ib, r_rad2 });
        self.judge_bias(&x, r)
    }

    /// The tracker's noise covariance in body axes, rad²: `c² I + (a² − c²) b bᵀ`
    /// (`c`, `a`: its 1σ across and about its boresight `b`).
    fn tracker_noise_rad2(&self) -> Matrix3<f32> {
        let b = Vec3::from(self.params.tracker_boresight_body);
        let (c2, a2) = (
            self.params.tracker_sigma_cross_rad * self.params.tracker_sigma_cross_rad,
            self.params.tracker_sigma_about_rad * self.params.tracker_sigma_about_rad,
        );
        Matrix3::identity() * c2 + b * b.transpose() * (a2 - c2)
    }

    /// The bias-step test ([`crate::fdir::bias`]) on a tracker sample the filter judged,
    /// a witness vouched for, and with no gyro axis declared stuck. A rejected update leaves
    /// the filter as it was, so its innovation is formed from the filter at the history's now
    /// (a sample fused in the past adds the rate times its age, the same for every sample at
    /// a steady rate, so the slope keeps it out), and only then.
    fn judge_bias(&mut self, x: &StarTrackerAttitude, r: Option<Result<f32, MekfError>>) -> Option<BiasStep> {
        let window = self.params.gyro_fdir.and_then(|g| g.bias_step)?;
        let rejected = match r? {
            Ok(_) => false,
            Err(MekfError::Rejected { .. }) => true,
            Err(_) => return None,
        };
        // A gyro axis declared stuck reads 0: its innovations are the body's rate, not a
        // bias step (the axis is already declared and handled).
        // Agreement is enough here (no flip-visibility): a flip's innovation is constant, so
        // its slope is no step (bias.rs).
        if !self.tracker_monitor.corroborates(x.time_us) || self.gyro_monitor.failed_axes() != 0 {
            return None;
        }
        let innovation = match (rejected, self.history.get()) {
            (false, _) => None,
            (true, None) => return None,
            (true, Some(h)) => {
                let f = h.filter();
                let y = attitude_innovation_rad(&f.attitude(), &x.q_ib);
                // Its 1σ per body axis: the filter's attitude σ and the tracker's.
                let (p, r) = (f.covariance(), self.tracker_noise_rad2());
                let var = |v: Option<&f32>| v.copied().unwrap_or(0.0);
                Some((y, Vec3::from_fn(|i, _| f32m::sqrt(var(p.get((i, i))) + var(r.get((i, i)))))))
            }
        };
        self.bias_monitor.judge(&window, x.time_us, innovation)
    }

    /// The bias-step recovery ([`crate::fdir::bias`]): a new filter on the tracker's
    /// attitude with the bias estimate plus the step, its bias σ raised to 3σ of the
    /// step's error (the slope's, from the tracker's larger noise), instead of waiting for
    /// `max_consecutive_rejections` and restarting with a zero bias. The sample is fused
    /// by the start when it is at the history's now, else consumed by it.
    fn restart_on_bias_step(&mut self, x: &StarTrackerAttitude, step: &BiasStep) {
        let Some(h) = self.history.get() else { return };
        let (now, bias) = (h.now_us(), h.filter().bias_rad_s() + step.rate_rad_s);
        let noise_rad = self.params.tracker_sigma_cross_rad.max(self.params.tracker_sigma_about_rad);
        let mut cfg = self.mekf_cfg;
        let slope_3sigma = 3.0 * noise_rad * step.slope_sigma_per_rad;
        cfg.initial_bias_sigma_rad_s = cfg.initial_bias_sigma_rad_s.max(slope_3sigma);
        let Ok(m) = Mekf::new(cfg, x.q_ib, bias) else { return };
        self.lose();
        self.tracks = Tracks::default();
        self.history.start(m, now);
        if x.time_us == now {
            // Judged already: the monitor skips a repeated time tag.
            let _ = self.fuse_tracker(*x);
        } else {
            self.tracks.star_tracker.fresh(x.time_us);
        }
    }

    /// Fuse one sample at `t_us` through the history; counts the outcome. A sample taken
    /// after the history's now (the gyro lags it) waits for the gyro instead. `None`:
    /// refused, or waiting.
    fn fuse(&mut self, sensor: Sensor, t_us: u64, m: &Measurement) -> Option<Result<f32, MekfError>> {
        let h = self.history.get_mut()?;
        let now = h.now_us();
        if t_us > now {
            self.wait(sensor, t_us, m);
            return None;
        }
        // Beyond the latency horizon or the replay cap: refused before any replay (bounds
        // the step's cost however close the frames come).
        if span_s(t_us, now).is_some_and(|age| age > self.params.max_sample_latency_s)
            || h.nodes_after(t_us) > usize::from(self.params.max_replayed_nodes)
        {
            self.fusion.too_old = self.fusion.too_old.saturating_add(1);
            return None;
        }
        let r = h.fuse_at(self.tracks.fusion_mut(sensor), t_us, m);
        self.record(sensor, t_us < now, r)
    }

    /// Queue a sample taken after the history's now until the gyro reaches it.
    fn wait(&mut self, sensor: Sensor, t_us: u64, m: &Measurement) {
        let f = &mut self.fusion;
        let c = if !m.is_finite() {
            &mut f.bad_input
        } else {
            match self.waiting.push(sensor.index(), Waiting { t_us, measurement: *m }) {
                Pushed::Queued => return,
                Pushed::Full => &mut f.dropped_waiting,
                Pushed::OutOfOrder => &mut f.out_of_order,
            }
        };
        *c = c.saturating_add(1);
    }

    /// Count what the history did with a sample (`late`: fused before now, replayed);
    /// a tracker's gate rejections in a row are counted for the divergence check.
    fn record(
        &mut self,
        sensor: Sensor,
        late: bool,
        r: Result<FuseOutcome, FuseRefusal>,
    ) -> Option<Result<f32, MekfError>> {
        let f = &mut self.fusion;
        let result = match r {
            Ok(outcome) => {
                let c = if late { &mut f.fused_late } else { &mut f.fused_now };
                *c = c.saturating_add(1);
                let replayed = u16::try_from(outcome.replayed_nodes).unwrap_or(u16::MAX);
                f.max_replayed_nodes = f.max_replayed_nodes.max(replayed);
                outcome.result
            }
            Err(reason) => {
                let c = match reason {
                    FuseRefusal::TooOld => &mut f.too_old,
                    FuseRefusal::FromTheFuture => &mut f.from_the_future,
                    FuseRefusal::Repeated => &mut f.out_of_order,
                    FuseRefusal::NonFiniteInput | FuseRefusal::ReplayFailed => &mut f.bad_input,
                };
                *c = c.saturating_add(1);
                return None;
            }
        };
        self.count(result);
        if sensor == Sensor::StarTracker {
            match result {
                Ok(_) => self.consecutive_rejections = 0,
                Err(MekfError::Rejected { .. }) => {
                    self.consecutive_rejections = self.consecutive_rejections.saturating_add(1);
                }
                Err(_) => {}
            }
        }
        Some(result)
    }
}

/// The star tracker's innovation against the attitude `q_est`: `2 vec(q̂⁻¹ ⊗ q_meas)` on
/// the short way round (the MEKF's own, [`super::mekf`]), rad, body axes.
fn attitude_innovation_rad(q_est: &Quat, q_meas: &Quat) -> Vec3 {
    let e = q_est.conjugate() * q_meas;
    let v = e.imag() * 2.0;
    if e.w < 0.0 { -v } else { v }
}

/// What the MEKF path gives the step: the attitude the laws may use, the corrected rate
/// and the filter predicted to the step's time (its telemetry).
struct MekfOutput {
    attitude: Option<Quat>,
    rate_rad_s: Option<Vec3>,
    filter: Option<Mekf>,
}

/// The sensors the MEKF fuses, in the order of [`super::waiting::WAITING_SENSORS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sensor {
    StarTracker,
    FineSun,
    Css,
    Magnetometer,
}

impl Sensor {
    const ALL: [Self; 4] = [Self::StarTracker, Self::FineSun, Self::Css, Self::Magnetometer];

    const fn index(self) -> usize {
        self as usize
    }

    fn from_index(i: usize) -> Option<Self> {
        Self::ALL.get(i).copied()
    }
}

impl Tracks {
    fn track(&self, sensor: Sensor) -> &Track {
        match sensor {
            Sensor::StarTracker => &self.star_tracker,
            Sensor::FineSun => &self.sun_sensor,
            Sensor::Css => &self.css,
            Sensor::Magnetometer => &self.magnetometer,
        }
    }

    fn fusion(&self, sensor: Sensor) -> &SensorTrack {
        &self.track(sensor).fusion
    }

    fn fusion_mut(&mut self, sensor: Sensor) -> &mut SensorTrack {
        let t = match sensor {
            Sensor::StarTracker => &mut self.star_tracker,
            Sensor::FineSun => &mut self.sun_sensor,
            Sensor::Css => &mut self.css,
            Sensor::Magnetometer => &mut self.magnetometer,
        };
        &mut t.fusion
    }
}

struct Vectors {
    sun_body: Option<Vec3>,
    /// Time of the sample the Sun direction comes from, and whether it is the fine sensor.
    sun_time_us: u64,
    sun_is_fine: bool,
    sun_eci: Option<Vec3>,
    sun_sigma: f32,
    /// Measured field direction and its sample time.
    mag_body: Option<(Vec3, u64)>,
    field_eci: Option<Vec3>,
}

impl Track {
    const EMPTY: Self = Self { seen_us: None, fusion: SensorTrack { last_fused_us: None, fused: 0, refused: 0 } };
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
    use crate::math::quat_to_xyzw;
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
        assert_eq!(hit.status.rejected, before.status.rejected + 1);
        let e = crate::math::rotation_angle(&crate::math::attitude_error(&hit.attitude.unwrap(), &q));
        assert!(e < 1.0e-5, "{e}");
        assert!(hit.status.filter.map_or(0.0, |f| f.last_nis) > crate::estimation::mekf::CHI2_3DOF_999);
        // One outlier is not divergence: no restart.
        assert_eq!(hit.status.resets, 0);
    }

    /// A stage used hard (filter restarted, history full, counters up) and reconfigured
    /// in place is the stage `new` builds, and stays the same to the bit (Debug prints
    /// each f32 exactly) through restarts that reuse the old nodes' storage; a refused set
    /// changes nothing.
    #[test]
    fn reconfiguring_in_place_is_a_new_stage() {
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        let moved = q * quat_from_euler([0.0, 10f32.to_radians(), 0.0], EulerSeq::Zyx321);
        let script = |d: &mut Determination, k0: u32| -> Vec<String> {
            (k0..k0 + 120)
                .map(|k| format!("{:?}", d.step(&frame(k, if (k / 20) % 2 == 0 { &q } else { &moved }))))
                .collect()
        };
        let mut used =
            Determination::new(&EstimationParams { max_consecutive_rejections: 5, ..mekf_params() }).unwrap();
        script(&mut used, 0);
        assert!(used.resets >= 2 && used.history().is_some_and(|h| h.len() > 1), "resets {}", used.resets);
        let p = EstimationParams { max_consecutive_rejections: 3, tracker_sigma_cross_rad: 2.0e-4, ..mekf_params() };
        let refused = EstimationParams { max_sample_age_s: -1.0, ..p };
        let before = used.clone();
        assert!(used.reconfigure(&refused).is_err());
        assert_eq!(used, before);
        used.reconfigure(&p).unwrap();
        let mut fresh = Determination::new(&p).unwrap();
        assert_eq!(used, fresh);
        assert_eq!(script(&mut used, 1000), script(&mut fresh, 1000));
        assert!(fresh.resets >= 2, "the script restarts the filter on the reused storage");
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
        assert_eq!(last.status.resets, 1);
        let e = crate::math::rotation_angle(&crate::math::attitude_error(&last.attitude.unwrap(), &moved));
        assert!(e < 1.0e-3, "{e}");
    }

    #[test]
    fn a_sample_older_than_max_sample_age_is_a_lost_input_whatever_its_valid_bit() {
        // The tracker keeps sending its last sample (valid bit set) with its old time:
        // lost once older than 3 s, for the sensor source and for the check of a frame.
        let p = EstimationParams { max_sample_age_s: 3.0, ..EstimationParams::SENSOR };
        let mut d = Determination::new(&p).unwrap();
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        let frozen_at_us = 1_000_000;
        for k in 10..=50u32 {
            let mut f = SensorFrame {
                q_ib_xyzw: quat_to_xyzw(&q),
                valid: valid::ATTITUDE | valid::RATE,
                ..SensorFrame::empty(k, u64::from(k) * 100_000)
            };
            f.sampled_at.star_tracker_us = frozen_at_us;
            let e = d.step(&sensor_samples(&f));
            let age_s = (u64::from(k) * 100_000 - frozen_at_us) as f32 * 1e-6;
            assert!((e.status.sample_age_s.star_tracker - age_s).abs() < 1e-6);
            assert_eq!(e.status.sample_age_s.gyro, 0.0);
            let lost = age_s > 3.0;
            assert_eq!(e.stale.contains(Valid::ATTITUDE), lost, "k = {k}");
            assert_eq!(e.attitude.is_none(), lost, "k = {k}");
            let checked = crate::fsw::check::check_frame(&f, Valid::ATTITUDE | Valid::RATE, false, &e);
            assert_eq!(checked.is_err(), lost, "k = {k}");
        }
    }

    #[test]
    fn samples_from_the_future_are_refused_and_counted() {
        let mut d = Determination::new(&mekf_params()).unwrap();
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        for k in 0..20 {
            d.step(&frame(k, &q));
        }
        let mut f = SensorFrame {
            q_ib_xyzw: quat_to_xyzw(&q),
            valid: valid::ATTITUDE | valid::RATE,
            ..SensorFrame::empty(20, 2_000_000)
        };
        f.sampled_at.star_tracker_us = 2_000_001;
        let e = d.step(&sensor_samples(&f));
        assert_eq!(e.status.fusion.from_the_future, 1);
        // Every tracker sample fused once (the first where it started the filter).
        assert_eq!(e.status.fusion.fused_now + e.status.fusion.fused_late, 20);
        // The same sample time again is the same (held) sample: fused once, not refused.
        let before = e.status.fusion;
        let mut g = SensorFrame { seq: 21, time_us: 2_100_000, ..f };
        g.sampled_at =
            crate::link::SampleTimes { star_tracker_us: 2_000_000, ..crate::link::SampleTimes::all(2_100_000) };
        let e1 = d.step(&sensor_samples(&g));
        let e2 = d.step(&sensor_samples(&SensorFrame { seq: 22, time_us: 2_200_000, ..g }));
        assert_eq!(e1.status.fusion.fused_late, before.fused_late + 1);
        assert_eq!(e2.status.fusion, e1.status.fusion);
    }

    /// A slewing body (0.01 rad/s about x) seen by a gyro whose samples reach the frames
    /// `gyro_lag` frames late, and a tracker on time every frame (frames 100 ms apart).
    fn lagging_gyro_frame(k: u32, gyro_lag: u32, tracker: bool) -> SensorSamples {
        let w = 0.01f32;
        // A rotation about x at w from 0.3 rad: its body rate is w about x.
        let q_at = |t_s: f32| {
            let half = 0.5 * (0.3 + w * t_s);
            crate::math::quat_from_xyzw([libm::sinf(half), 0.0, 0.0, libm::cosf(half)])
        };
        let t_us = u64::from(k) * 100_000;
        let g = k.saturating_sub(gyro_lag);
        let mut f = SensorFrame {
            q_ib_xyzw: quat_to_xyzw(&q_at(k as f32 * 0.1)),
            rate_rad_s: [w, 0.0, 0.0],
            gyro_angle_rad: [w * 0.1, 0.0, 0.0],
            gyro_interval_us: 100_000,
            valid: valid::RATE | if tracker { valid::ATTITUDE } else { 0 },
            ..SensorFrame::empty(k, t_us)
        };
        f.sampled_at.gyro_us = u64::from(g) * 100_000;
        sensor_samples(&f)
    }

    #[test]
    fn a_sample_newer_than_a_lagging_gyro_waits_and_is_fused_at_its_own_time() {
        // Issue 37: the gyro one frame late. Each tracker sample waits one step for the gyro,
        // then is fused at its own time; the filter is then bit for bit the filter that had
        // the gyro on time, one step earlier (the same propagations and updates).
        let mut lagging = Determination::new(&mekf_params()).unwrap();
        let mut on_time = Determination::new(&mekf_params()).unwrap();
        let mut on_time_filters = Vec::new();
        for k in 0..50 {
            on_time.step(&lagging_gyro_frame(k, 0, true));
            on_time_filters.push(*on_time.mekf().unwrap());
        }
        let mut e = None;
        for k in 0..50 {
            e = Some(lagging.step(&lagging_gyro_frame(k, 1, true)));
            if k >= 2 {
                // At frame k the lagging filter is at frame k − 1's time.
                assert_eq!(lagging.mekf(), Some(&on_time_filters[k as usize - 1]), "frame {k}");
            }
        }
        let f = e.unwrap().status.fusion;
        // Sample 0 started the filter (at the gyro's time); 1 … 48 waited and were fused;
        // 49 waits for the next gyro sample.
        assert_eq!((f.fused_now, f.fused_after_wait, f.waiting, f.fused_late), (49, 48, 1, 0), "{f:?}");
        assert_eq!((f.from_the_future, f.too_old, f.dropped_waiting, f.out_of_order, f.bad_input), (0, 0, 0, 0, 0));
    }

    #[test]
    fn a_gyro_lagging_beyond_the_wait_queue_refuses_what_does_not_fit_counted() {
        // The gyro 6 frames late, the tracker every frame: 6 samples would wait, 4 may. The
        // 4 waiting are fused as the gyro reaches them, the ones that found the queue full
        // are refused (counted): 4 of every 6 fused.
        let mut d = Determination::new(&mekf_params()).unwrap();
        let mut e = None;
        for k in 0..40 {
            e = Some(d.step(&lagging_gyro_frame(k, 6, true)));
        }
        let f = e.unwrap().status.fusion;
        assert_eq!(usize::from(f.waiting), super::super::waiting::WAITING_PER_SENSOR);
        // Every sample is accounted for: one started the filter, the others fused after a
        // wait, dropped from the full queue, or still waiting.
        assert_eq!(1 + f.fused_after_wait + f.dropped_waiting + u32::from(f.waiting), 40, "{f:?}");
        assert!(f.fused_after_wait >= 20 && f.dropped_waiting >= 10, "{f:?}");
        assert_eq!(f.fused_now, f.fused_after_wait + 1);
        // The filter stops (no gyro): the waiting samples can no longer be fused, counted.
        let mut none = lagging_gyro_frame(40, 6, true);
        none.gyro = None;
        let f2 = d.step(&none).status.fusion;
        assert_eq!((f2.waiting, f2.dropped_waiting), (0, f.dropped_waiting + u32::from(f.waiting)));
    }

    #[test]
    fn a_late_sample_that_would_replay_more_than_the_cap_is_refused_as_too_old() {
        // Frames 10 ms apart: a tracker sample 20 frames back is within the 0.5 s horizon
        // but would re-run 20 nodes, more than the 8 allowed: refused, counted, nothing
        // replayed; one 5 frames back is fused late, replaying 5 nodes.
        let mut d = Determination::new(&EstimationParams { max_replayed_nodes: 8, ..mekf_params() }).unwrap();
        let q = quat_from_euler([0.3, -0.2, 0.1], EulerSeq::Zyx321);
        let at = |k: u32, tracker_us: Option<u64>| {
            let mut f = SensorFrame {
                q_ib_xyzw: quat_to_xyzw(&q),
                valid: valid::RATE,
                ..SensorFrame::empty(k, u64::from(k) * 10_000)
            };
            if let Some(t) = tracker_us {
                f.valid |= valid::ATTITUDE;
                f.sampled_at.star_tracker_us = t;
            }
            sensor_samples(&f)
        };
        d.step(&at(0, Some(0)));
        for k in 1..40 {
            d.step(&at(k, None));
        }
        let e = d.step(&at(40, Some(200_000)));
        assert_eq!(e.status.fusion.too_old, 1);
        assert_eq!(e.status.fusion.max_replayed_nodes, 0);
        let e = d.step(&at(41, Some(360_000)));
        assert_eq!((e.status.fusion.too_old, e.status.fusion.fused_late), (1, 1));
        assert_eq!(e.status.fusion.max_replayed_nodes, 5);
    }
}
