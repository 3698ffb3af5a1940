//! The sensor suite: every sensor of a scenario, each sampling the truth on its own clock,
//! and the flight code's [`SensorFrame`] assembled from what has arrived at each control
//! step.
//!
//! Two halves. [`SensorSuite::sample_due`] is offered the true state at every
//! dynamics-substep boundary (and at t = 0); each sensor whose grid point has come
//! ([`super::clock`]) samples there, the reading is time-tagged with the time the truth
//! was sampled (µs, `(t·1e6).round()`), and queued until `tag + latency`
//! ([`super::latency`]). [`SensorSuite::frame`] then builds the frame of control step
//! `t_k`: per sensor, the newest sample available at `t_k`, its tag in
//! `frame.sampled_at.<sensor>_us`; without a new one the previous is held with its old tag;
//! before the first, the sensor is not valid. The gyro also delivers its angle increment
//! `gyro_angle_rad` = ∫ω_measured dt since the previous frame's gyro sample, over
//! `gyro_interval_us`: the true body rate is integrated over the substeps (trapezoid rule on
//! the substep boundaries, error O(h²) per interval) and the gyro's error model applied to
//! the integral ([`Gyro::angle_increment`]); several gyro samples in one frame add up.
//! Encoders, tachometers and the ideal GNSS fix (no `[sensors.gnss]`) are read at the frame
//! time.

use super::clock::{SampleTiming, Sampled};
use super::css::{CoarseSunSensors, CssGeometry, CssModel, MAX_CSS_HEADS};
use super::encoders::Encoders;
use super::faults::{GyroNoise, SensorFaults, TachNoise};
use super::gnss::{GnssModel, GnssReceiver};
use super::gyro::{Gyro, GyroModel};
use super::latency::SampleQueue;
use super::magnetometer::{Magnetometer, MagnetometerModel};
use super::noise::sensor_sub_rng;
use super::star_tracker::{AttitudeSensor, AttitudeSensorModel, ExclusionGeometry};
use super::sun_sensor::{SunSensor, SunSensorModel};
use crate::attitude::{Quat, Vec3, rotate_ref_to_body, to_xyzw};
use crate::environment::model::{EnvSnapshot, Environment};
use crate::environment::orbit::R_E;
use crate::environment::torques::{in_shadow_cylindrical, sun_position_eci};
use crate::plant::{Spacecraft, State};
use acs_flight::link::{SensorFrame, valid};

/// Noise stream index of each sensor model (stream 0, the scenario seed's own, is the
/// encoders'; see [`super::noise::sensor_rng`]).
const GYRO_STREAM: u32 = 1;
const ATTITUDE_STREAM: u32 = 2;
const MAGNETOMETER_STREAM: u32 = 3;
const SUN_STREAM: u32 = 4;
const CSS_STREAM: u32 = 5;
const GNSS_STREAM: u32 = 6;
/// The tachometers' extra noise of an injected `tach_noise` fault: sub-stream
/// [`FAULT_NOISE_SUB_STREAM`] of this index (the encoders' own stream is the seed's 0,
/// which has no sub-streams).
const ENCODER_FAULT_STREAM: u32 = 7;
/// Sub-stream of each sensor's stream for its sample-time jitter.
const JITTER_SUB_STREAM: u32 = 2;
/// Sub-streams (this and the next) of a sensor's stream for the extra noise of an injected
/// noise fault (the gyro's 3 is its increments' angle random walk).
const FAULT_NOISE_SUB_STREAM: u32 = 4;

/// Whole days and seconds of the day since J2000.0 (JD 2451545.0) for a Julian date.
pub fn j2000_days_seconds(jd: f64) -> (i32, f32) {
    let d = jd - 2_451_545.0;
    let days = d.floor();
    (days as i32, ((d - days) * 86_400.0) as f32)
}

/// A time in µs on the flight clock (the frames' and the tags' unit).
fn micros(t_s: f64) -> u64 {
    (t_s * 1e6).round() as u64
}

/// One sensor's samples on their way to the frames: in flight (queued until their
/// arrival), arrived since the last frame (merged: the newest, with the gyro's angle
/// increments added up, so the queue holds only what is still in flight), and the newest
/// delivered to a frame (held).
#[derive(Clone, Debug)]
pub struct Channel<T> {
    pub queue: SampleQueue<T>,
    /// How an arrived sample combines with the ones before it since the last frame.
    merge: fn(T, T) -> T,
    /// Arrived since the last frame: (first tag, newest tag, merged reading).
    arrived: Option<(u64, u64, T)>,
    /// The newest sample delivered: (tag µs, reading).
    held: Option<(u64, T)>,
}

/// The newer sample replaces the older (every sensor but the gyro).
fn newest<T>(_: T, newer: T) -> T {
    newer
}

impl<T: Copy> Channel<T> {
    fn new(timing: &SampleTiming, merge: fn(T, T) -> T) -> Self {
        Self { queue: SampleQueue::new(timing.latency_s, timing.rate_hz), merge, arrived: None, held: None }
    }

    /// Moves the samples that have arrived by `now_us` out of the queue.
    fn settle(&mut self, now_us: u64) {
        while let Some(p) = self.queue.pop_available(now_us) {
            self.arrived = Some(match self.arrived {
                None => (p.tag_us, p.tag_us, p.value),
                Some((first, _, v)) => (first, p.tag_us, (self.merge)(v, p.value)),
            });
        }
    }

    /// A sample of the truth at `tag_us` (tags increasing).
    fn push(&mut self, tag_us: u64, value: T) {
        self.settle(tag_us);
        self.queue.push(tag_us, value);
    }

    /// At the frame of `now_us`: the sample held now (the newest arrived, else the one held
    /// before) and, when new samples arrived, the tag of the first of them.
    fn deliver(&mut self, now_us: u64) -> (Option<(u64, T)>, Option<u64>) {
        self.settle(now_us);
        let first_new = self.arrived.take().map(|(first, tag, v)| {
            self.held = Some((tag, v));
            first
        });
        (self.held, first_new)
    }

    /// The sample held at the frame of `now_us`.
    fn deliver_newest(&mut self, now_us: u64) -> Option<(u64, T)> {
        self.deliver(now_us).0
    }
}

/// One gyro sample: the rate, and the angle increment since the previous sample (zero
/// over zero time for the first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroSample {
    pub rate_rad_s: [f64; 3],
    pub angle_rad: [f64; 3],
}

impl GyroSample {
    /// The newer sample, with the angle increments since the older's interval began.
    fn merge(older: Self, newer: Self) -> Self {
        Self { angle_rad: (Vec3::from(older.angle_rad) + Vec3::from(newer.angle_rad)).into(), ..newer }
    }
}

/// A GNSS fix with its receiver time (days and seconds since J2000.0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixSample {
    pub pos_m: [f64; 3],
    pub vel_m_s: [f64; 3],
    pub j2000: (i32, f32),
}

/// The true body rate integrated since the gyro's last sample (trapezoid rule on the
/// boundaries offered to [`SensorSuite::sample_due`]).
#[derive(Clone, Debug, Default)]
struct RateIntegral {
    /// The last boundary offered: (t, ω).
    last: Option<(f64, Vec3)>,
    angle_rad: Vec3,
    /// Time of the gyro's last sample.
    last_sample_t_s: Option<f64>,
}

impl RateIntegral {
    fn offer(&mut self, t_s: f64, w: &Vec3) {
        if let Some((t0, w0)) = self.last {
            self.angle_rad += (w0 + w) * (0.5 * (t_s - t0));
        }
        self.last = Some((t_s, *w));
    }
}

/// Everything a [`SensorSuite`] is built from: the seed, each sensor model's
/// specification and sample timing (the scenario's `[sensors]` table in SI units).
#[derive(Clone, Debug)]
pub struct SuiteSpec {
    /// The scenario's sensor seed (every sensor's noise stream derives from it).
    pub seed: u64,
    /// 1σ gimbal-angle encoder noise, rad.
    pub gimbal_noise_rad: f64,
    /// 1σ wheel tachometer noise, rad/s.
    pub wheel_speed_noise_rad_s: f64,
    pub gyro: GyroModel,
    pub attitude: AttitudeSensorModel,
    pub magnetometer: MagnetometerModel,
    pub sun: Option<SunSensorModel>,
    pub css: Option<CssModel>,
    /// `None`: the ideal fix on every frame.
    pub gnss: Option<GnssModel>,
    /// Each sensor's sample grid and delay, in [`Sampled::ALL`] order.
    pub timings: [SampleTiming; 6],
    /// Intervals [start, end] (s, closed) without a star-tracker solution.
    pub tracker_outages_s: Vec<[f64; 2]>,
}

impl SuiteSpec {
    /// The sample grid and delay of one sensor.
    pub fn timing(&self, which: Sampled) -> SampleTiming {
        self.timings[which as usize]
    }
}

#[derive(Clone)]
pub struct SensorSuite {
    /// Stream 0: encoders and tachometers.
    encoders: Encoders,
    gyro: Gyro,
    attitude: AttitudeSensor,
    mag: Magnetometer,
    sun: Option<SunSensor>,
    css: Option<CoarseSunSensors>,
    /// `None`: ideal fix on every frame (the default without `[sensors.gnss]`).
    gnss: Option<GnssReceiver>,
    rate_integral: RateIntegral,
    pub gyro_channel: Channel<GyroSample>,
    pub attitude_channel: Channel<(Quat, bool)>,
    pub mag_channel: Channel<[f64; 3]>,
    pub sun_channel: Channel<([f64; 3], bool)>,
    pub css_channel: Channel<[f64; MAX_CSS_HEADS]>,
    pub gnss_channel: Channel<FixSample>,
    /// `[sensors.star_tracker] outages_s`.
    tracker_outages: Vec<[f64; 2]>,
    /// The sensor faults of `[[faults]]` (none: [`Self::set_faults`] not called).
    faults: SensorFaults,
    /// The scenario's sensor seed (the faults' noise streams derive from it).
    seed: u64,
}

impl SensorSuite {
    /// Samples each sensor's latency queue dropped at its cap, by sensor (0 in a
    /// consistent configuration: see [`SampleQueue`]).
    pub fn samples_dropped(&self) -> [(&'static str, u64); 6] {
        [
            ("gyro", self.gyro_channel.queue.dropped),
            ("star tracker", self.attitude_channel.queue.dropped),
            ("magnetometer", self.mag_channel.queue.dropped),
            ("sun sensor", self.sun_channel.queue.dropped),
            ("coarse sun sensors", self.css_channel.queue.dropped),
            ("gnss", self.gnss_channel.queue.dropped),
        ]
    }

    /// The suite of `spec` (built from a scenario by `Sensors::suite_spec`).
    pub fn new(spec: &SuiteSpec) -> Self {
        let seed = spec.seed;
        let timing = |w: Sampled| spec.timing(w);
        // Built in this order (the optional sensors first) so that a bad table fails on
        // the same check as before.
        let sun = spec.sun.map(|x| SunSensor::new(x, seed, SUN_STREAM));
        let css = spec.css.clone().map(|c| CoarseSunSensors::new(c, seed, CSS_STREAM));
        let gnss = spec.gnss.clone().map(|g| GnssReceiver::new(g, seed, GNSS_STREAM));
        let mut suite = Self {
            encoders: Encoders::new(seed, spec.gimbal_noise_rad, spec.wheel_speed_noise_rad_s),
            gyro: Gyro::new(spec.gyro, seed, GYRO_STREAM),
            attitude: AttitudeSensor::new(spec.attitude, seed, ATTITUDE_STREAM),
            mag: Magnetometer::new(spec.magnetometer, seed, MAGNETOMETER_STREAM),
            sun,
            css,
            gnss,
            rate_integral: RateIntegral::default(),
            gyro_channel: Channel::new(&timing(Sampled::Gyro), GyroSample::merge),
            attitude_channel: Channel::new(&timing(Sampled::StarTracker), newest),
            mag_channel: Channel::new(&timing(Sampled::Magnetometer), newest),
            sun_channel: Channel::new(&timing(Sampled::Sun), newest),
            css_channel: Channel::new(&timing(Sampled::Css), newest),
            gnss_channel: Channel::new(&timing(Sampled::Gnss), newest),
            tracker_outages: spec.tracker_outages_s.clone(),
            faults: SensorFaults::default(),
            seed,
        };
        suite.set_grids(spec);
        suite
    }

    /// Each clock's phase and jitter (its jitter from the sensor's sub-stream 2).
    fn set_grids(&mut self, s: &SuiteSpec) {
        for (which, stream) in [
            (Sampled::Gyro, GYRO_STREAM),
            (Sampled::StarTracker, ATTITUDE_STREAM),
            (Sampled::Magnetometer, MAGNETOMETER_STREAM),
            (Sampled::Sun, SUN_STREAM),
            (Sampled::Css, CSS_STREAM),
            (Sampled::Gnss, GNSS_STREAM),
        ] {
            let t = s.timing(which);
            let rng = sensor_sub_rng(s.seed, stream, JITTER_SUB_STREAM);
            let clock = match which {
                Sampled::Gyro => Some(&mut self.gyro.clock),
                Sampled::StarTracker => Some(&mut self.attitude.clock),
                Sampled::Magnetometer => Some(&mut self.mag.clock),
                Sampled::Sun => self.sun.as_mut().map(|x| &mut x.clock),
                Sampled::Css => self.css.as_mut().map(|x| &mut x.clock),
                Sampled::Gnss => self.gnss.as_mut().map(|x| &mut x.clock),
            };
            if let Some(c) = clock {
                c.set_grid(t.phase_s, t.jitter_s, rng);
            }
        }
    }

    /// The gyro's true additive bias now (constant + random walk, and an injected bias
    /// step in force), rad/s: the truth the flight MEKF's bias estimate is scored against.
    pub fn gyro_bias_rad_s(&self) -> Vec3 {
        Vec3::from(self.gyro.bias_rad_s()) + Vec3::from(self.faults.bias_step_rad_s())
    }

    /// Injects the sensor faults among `list` (`[[faults]]`; the others are ignored here).
    pub fn set_faults(&mut self, list: &[crate::faults::TimedFault]) {
        let g = &self.gyro.spec;
        let noise = GyroNoise {
            rate_sigma_rad_s: g.arw_rad_sqrt_s.map(|n| n * g.rate_hz.sqrt()),
            arw_rad_sqrt_s: g.arw_rad_sqrt_s,
            rate_rng: sensor_sub_rng(self.seed, GYRO_STREAM, FAULT_NOISE_SUB_STREAM),
            angle_rng: sensor_sub_rng(self.seed, GYRO_STREAM, FAULT_NOISE_SUB_STREAM + 1),
        };
        let tach = TachNoise {
            sigma_rad_s: self.encoders.wheel_sigma_rad_s(),
            rng: sensor_sub_rng(self.seed, ENCODER_FAULT_STREAM, FAULT_NOISE_SUB_STREAM),
        };
        self.faults = SensorFaults::new(list).with_gyro_noise(noise).with_tach_noise(tach);
    }

    /// Whether a sensor that reads the environment (magnetometer, sun sensors, GNSS
    /// receiver, a star tracker with exclusion rules) samples at `t_s`: the caller builds
    /// the environment snapshot only then.
    pub fn needs_env_at(&self, t_s: f64) -> bool {
        self.mag.clock.is_due(t_s)
            || (self.attitude.spec.has_exclusion() && self.attitude.clock.is_due(t_s))
            || self.sun.as_ref().is_some_and(|x| x.clock.is_due(t_s))
            || self.css.as_ref().is_some_and(|x| x.clock.is_due(t_s))
            || self.gnss.as_ref().is_some_and(|x| x.clock.is_due(t_s))
    }

    /// Offers the true state at `t_s` (a dynamics-substep boundary, or t = 0; times
    /// increasing): the sensors due sample it and queue the reading. `env`: the environment
    /// at `t_s` when [`Self::needs_env_at`] said so; `rod_dipole_am2`: the torquers' dipole
    /// now (magnetometer coupling).
    pub fn sample_due(
        &mut self,
        t_s: f64,
        s: &State,
        craft: &Spacecraft,
        env: Option<&EnvSnapshot>,
        rod_dipole_am2: &[f64; 3],
    ) {
        self.rate_integral.offer(t_s, &s.w);
        if self.gyro.clock.is_due(t_s) {
            self.sample_gyro(t_s, &s.w);
        }
        if self.attitude.clock.is_due(t_s) {
            self.sample_attitude(t_s, s, craft, env);
        }
        if self.mag.clock.is_due(t_s) {
            match env.and_then(|e| e.b_ref_t) {
                Some(b) => {
                    let mut m = self.mag.update(t_s, &rotate_ref_to_body(&s.q, &b).into(), rod_dipole_am2).b_body_t;
                    self.faults.magnetometer(t_s, &mut m);
                    self.mag_channel.push(micros(t_s), m);
                }
                // No field to measure: the grid point passes without a sample.
                None => _ = self.mag.clock.due(t_s),
            }
        }
        let orbit = env.and_then(|e| e.orbit);
        match (orbit, craft.env.as_ref()) {
            (Some(o), Some(m)) => self.sample_orbit_sensors(t_s, &s.q, o, m),
            // Without an orbit the Sun and GNSS sensors have nothing to see.
            _ => {
                for c in [
                    self.sun.as_mut().map(|x| &mut x.clock),
                    self.css.as_mut().map(|x| &mut x.clock),
                    self.gnss.as_mut().map(|x| &mut x.clock),
                ]
                .into_iter()
                .flatten()
                {
                    c.due(t_s);
                }
            }
        }
    }

    /// The gyro's rate sample and its angle increment since its previous sample.
    fn sample_gyro(&mut self, t_s: f64, w: &Vec3) {
        let mut rate = self.gyro.update(t_s, &(*w).into()).rate_rad_s;
        let ri = &mut self.rate_integral;
        let (mut angle_rad, interval_s) = match ri.last_sample_t_s {
            Some(t0) => (self.gyro.angle_increment(&ri.angle_rad.into(), t_s - t0), t_s - t0),
            None => ([0.0; 3], 0.0),
        };
        ri.angle_rad = Vec3::zeros();
        ri.last_sample_t_s = Some(t_s);
        self.faults.gyro(t_s, interval_s, &mut rate, &mut angle_rad);
        self.gyro_channel.push(micros(t_s), GyroSample { rate_rad_s: rate, angle_rad });
    }

    /// Star tracker on the true attitude and rate at `t_s`; not valid in an outage (at the
    /// exposure time) or when the model says so.
    fn sample_attitude(&mut self, t_s: f64, s: &State, craft: &Spacecraft, env: Option<&EnvSnapshot>) {
        let geometry = self.exclusion_geometry(t_s, craft, env);
        let att = self.attitude.update_with(t_s, &s.q, &s.w, geometry.as_ref());
        let valid = att.valid && !self.tracker_outages.iter().any(|[a, b]| (*a..=*b).contains(&t_s));
        let mut q_ib = att.q_ib;
        self.faults.tracker(t_s, &self.attitude.boresight(), &mut q_ib);
        self.attitude_channel.push(micros(t_s), (q_ib, valid));
    }

    /// Where the Sun and the Earth are for the tracker's exclusion rules: `None` without a
    /// rule, an orbit or an environment model (rules not applied).
    fn exclusion_geometry(&self, t_s: f64, craft: &Spacecraft, env: Option<&EnvSnapshot>) -> Option<ExclusionGeometry> {
        if !self.attitude.spec.has_exclusion() {
            return None;
        }
        exclusion_geometry(t_s, craft, env)
    }

    /// The sensors that need the orbit: fine and coarse sun sensors, GNSS receiver (each
    /// when fitted and due).
    fn sample_orbit_sensors(&mut self, t_s: f64, q: &Quat, (r, v): (Vec3, Vec3), env_model: &Environment) {
        let tag = micros(t_s);
        let rs = sun_position_eci(env_model.julian_date(t_s));
        let eclipse = in_shadow_cylindrical(&r, &rs);
        if let Some(sun) = self.sun.as_mut().filter(|x| x.clock.is_due(t_s)) {
            let rd = sun.update(t_s, q, &(rs - r).normalize().into(), eclipse);
            self.sun_channel.push(tag, (rd.sun_body, rd.valid));
        }
        if let Some(css) = self.css.as_mut().filter(|x| x.clock.is_due(t_s)) {
            let g = CssGeometry { sun_ref: (rs - r).normalize(), r_m: r, eclipse };
            let mut out = css.update(t_s, q, &g).output;
            self.faults.css(t_s, &mut out);
            self.css_channel.push(tag, out);
        }
        if let Some(g) = self.gnss.as_mut().filter(|x| x.clock.is_due(t_s))
            && let Some(fix) = g.update(t_s, &r.into(), &v.into())
        {
            let j2000 = j2000_days_seconds(env_model.julian_date(t_s));
            let (mut pos_m, mut vel_m_s) = (fix.pos_m, fix.vel_m_s);
            self.faults.gnss(t_s, (&r, &v), &mut pos_m, &mut vel_m_s);
            self.gnss_channel.push(tag, FixSample { pos_m, vel_m_s, j2000 });
        }
    }

    /// [`Self::sample_due`] then [`Self::frame`] at one time (a suite offered the truth only
    /// at the control steps).
    pub fn sample(
        &mut self,
        seq: u32,
        t_s: f64,
        s: &State,
        craft: &Spacecraft,
        env: Option<&EnvSnapshot>,
        rod_dipole_am2: &[f64; 3],
    ) -> SensorFrame {
        self.sample_due(t_s, s, craft, env, rod_dipole_am2);
        self.frame(seq, t_s, s, craft, env)
    }

    /// The frame of the control step at `t_s`: each sensor's newest sample available then
    /// (with its tag), the encoders and tachometers on the state `s` now, and the ideal
    /// GNSS fix from `env` without a receiver model.
    pub fn frame(
        &mut self,
        seq: u32,
        t_s: f64,
        s: &State,
        craft: &Spacecraft,
        env: Option<&EnvSnapshot>,
    ) -> SensorFrame {
        let now = micros(t_s);
        let mut f = SensorFrame::empty(seq, now);
        self.deliver_gyro(&mut f, now);
        if let Some((tag, (q, ok))) = self.attitude_channel.deliver_newest(now) {
            f.q_ib_xyzw = to_xyzw(&q).map(|x| x as f32);
            f.sampled_at.star_tracker_us = tag;
            f.valid |= if ok { valid::ATTITUDE } else { 0 };
        }
        if let Some((tag, b)) = self.mag_channel.deliver_newest(now) {
            f.mag_field_t = b.map(|x| x as f32);
            f.sampled_at.magnetometer_us = tag;
            f.valid |= valid::MAG;
        }
        if let Some((tag, (d, ok))) = self.sun_channel.deliver_newest(now) {
            f.sampled_at.sun_sensor_us = tag;
            if ok {
                f.sun_dir = d.map(|x| x as f32);
                f.valid |= valid::SUN;
            }
        }
        if let Some((tag, out)) = self.css_channel.deliver_newest(now) {
            f.css_output = out.map(|x| x as f32);
            f.sampled_at.css_us = tag;
            f.valid |= valid::CSS;
        }
        self.deliver_gnss(&mut f, now, t_s, craft, env);
        self.measure_gimbals(&mut f, s, craft);
        self.measure_wheels(&mut f, t_s, s, craft);
        f
    }

    /// The gyro's newest rate sample and the sum of the increments arrived since the
    /// previous frame's gyro sample (interval: from that sample's tag, or the first
    /// sample's, to the newest's; none without a new sample).
    fn deliver_gyro(&mut self, f: &mut SensorFrame, now: u64) {
        let since = self.gyro_channel.held.map(|(tag, _)| tag);
        let (held, first_new) = self.gyro_channel.deliver(now);
        if let Some((tag, g)) = held {
            f.rate_rad_s = g.rate_rad_s.map(|x| x as f32);
            f.sampled_at.gyro_us = tag;
            f.valid |= valid::RATE;
            if let Some(start) = first_new.map(|first| since.unwrap_or(first)) {
                f.gyro_angle_rad = g.angle_rad.map(|x| x as f32);
                f.gyro_interval_us = u32::try_from(tag - start).unwrap_or(u32::MAX);
            }
        }
    }

    /// GNSS fix: with a receiver model, its newest fix (held, with its validity time);
    /// without one the ideal orbit state and time of every frame.
    fn deliver_gnss(&mut self, f: &mut SensorFrame, now: u64, t_s: f64, craft: &Spacecraft, env: Option<&EnvSnapshot>) {
        let fix = match self.gnss {
            Some(_) => self.gnss_channel.deliver_newest(now),
            None => match (env.and_then(|e| e.orbit), craft.env.as_ref()) {
                (Some((r, v)), Some(m)) => {
                    let (mut pos_m, mut vel_m_s) = (r.into(), v.into());
                    self.faults.gnss(t_s, (&r, &v), &mut pos_m, &mut vel_m_s);
                    Some((now, FixSample { pos_m, vel_m_s, j2000: j2000_days_seconds(m.julian_date(t_s)) }))
                }
                _ => None,
            },
        };
        if let Some((tag, x)) = fix {
            f.gnss_pos_m = x.pos_m.map(|x| x as f32);
            f.gnss_vel_m_s = x.vel_m_s.map(|x| x as f32);
            (f.gnss_j2000_days, f.gnss_j2000_s) = x.j2000;
            f.sampled_at.gnss_us = tag;
            f.valid |= valid::GNSS;
        }
    }

    /// Gimbal encoders (up to four gimbals), when the craft has CMGs.
    fn measure_gimbals(&mut self, f: &mut SensorFrame, s: &State, craft: &Spacecraft) {
        if let Some(c) = &craft.cmg {
            for i in 0..c.len().min(4) {
                f.gimbal_angle_rad[i] = self.encoders.gimbal_angle(s.gimbal_rad[i]) as f32;
            }
            f.valid |= valid::GIMBALS;
        }
    }

    /// Wheel tachometers: each wheel's speed relative to the body, when the craft has
    /// wheels.
    fn measure_wheels(&mut self, f: &mut SensorFrame, t_s: f64, s: &State, craft: &Spacecraft) {
        if !craft.wheels.is_empty() {
            let w: [f64; 3] = s.w.into();
            for (i, p) in craft.wheels.iter().enumerate().take(f.wheel_speed_rad_s.len()) {
                let rel = s.wheels[i].h_abs_nms / p.inertia_kgm2 - Vec3::from(p.spin_axis).dot(&Vec3::from(w));
                let read = self.encoders.wheel_speed(rel);
                f.wheel_speed_rad_s[i] = self.faults.tach(t_s, i, read) as f32;
            }
            f.valid |= valid::WHEELS;
        }
    }
}

/// Where the Sun and the Earth are seen from the spacecraft at `t_s` (the tracker's
/// exclusion rules, the keep-out columns): `None` without an orbit or an environment model.
pub fn exclusion_geometry(t_s: f64, craft: &Spacecraft, env: Option<&EnvSnapshot>) -> Option<ExclusionGeometry> {
    let (Some((r, _)), Some(m)) = (env.and_then(|e| e.orbit), craft.env.as_ref()) else {
        return None;
    };
    let rs = sun_position_eci(m.julian_date(t_s));
    // The visible cap (half-angle acos(R_E / r) about the zenith) meets the lit hemisphere
    // (90° about the Sun) unless their centres are more than the sum apart.
    let cap_rad = (R_E / r.norm()).min(1.0).acos();
    let zenith_sun_rad = r.normalize().dot(&rs.normalize()).clamp(-1.0, 1.0).acos();
    Some(ExclusionGeometry {
        sun_ref: (rs - r).normalize(),
        nadir_ref: -r.normalize(),
        earth_half_angle_rad: (R_E / r.norm()).min(1.0).asin(),
        earth_lit: zenith_sun_rad < std::f64::consts::FRAC_PI_2 + cap_rad,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quat;
    use crate::environment::frames::EarthRotation;
    use crate::plant::MAX_GIMBALS;
    use crate::scenario::{CssSpec, GnssSpec, SampleTimingSpec, Sensors as SensorSpec, StarTrackerSpec};

    /// The suite of a scenario's `[sensors]` table.
    fn suite(spec: &SensorSpec, control_rate_hz: f64) -> SensorSuite {
        SensorSuite::new(&spec.suite_spec(control_rate_hz))
    }

    fn state() -> State {
        State {
            q: Quat::identity(),
            w: Vec3::new(0.01, 0.02, 0.03),
            gimbal_rad: [0.0; MAX_GIMBALS],
            gimbal_rate_rad_s: [0.0; MAX_GIMBALS],
            wheels: Default::default(),
            cmg_rotor_scale: crate::plant::NOMINAL_ROTORS,
        }
    }

    fn craft() -> Spacecraft {
        Spacecraft::new(nalgebra::Matrix3::identity(), None).unwrap()
    }

    #[test]
    fn ideal_sensors_return_the_truth() {
        let mut s = suite(&SensorSpec::default(), 100.0);
        let f = s.sample(3, 1.5, &state(), &craft(), None, &[0.0; 3]);
        assert_eq!(f.q_ib_xyzw, [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(f.rate_rad_s, [0.01, 0.02, 0.03]);
        assert_eq!(f.time_us, 1_500_000);
        assert_eq!(f.valid, valid::ATTITUDE | valid::RATE);
    }

    /// Flies 10 steps at 100 Hz with rate and yaw growing by step and checks that frame k
    /// carries the rate of step k − `rate_lag` and the attitude of step k − `attitude_lag`
    /// (the first state before that), the timestamp staying the sample time.
    fn check_lags(spec: &SensorSpec, rate_lag: u32, attitude_lag: u32) {
        let mut s = suite(spec, 100.0);
        let c = craft();
        for k in 0..10u32 {
            let mut st = state();
            st.w = Vec3::new(k as f64, 0.0, 0.0);
            st.q = crate::attitude::quat_from_euler([0.0, 0.0, k as f64 * 0.1], acs_flight::math::EulerSeq::Zyx321);
            let f = s.sample(k, k as f64 * 0.01, &st, &c, None, &[0.0; 3]);
            assert_eq!(f.rate_rad_s[0], k.saturating_sub(rate_lag) as f32, "step {k}");
            let yaw = 2.0 * (f.q_ib_xyzw[2] as f64).atan2(f.q_ib_xyzw[3] as f64);
            assert!((yaw - k.saturating_sub(attitude_lag) as f64 * 0.1).abs() < 1e-6, "step {k}: yaw {yaw}");
            assert_eq!(f.time_us, k as u64 * 10_000);
        }
    }

    #[test]
    fn latency_delays_attitude_and_rate_by_whole_steps() {
        // 0.03 s at 100 Hz = 3 steps for both.
        check_lags(&SensorSpec { latency_s: 0.03, ..Default::default() }, 3, 3);
    }

    #[test]
    fn tracker_latency_delays_only_the_attitude() {
        // Suite latency 0.01 s (1 step) plus tracker latency 0.02 s (2 steps).
        let spec = SensorSpec {
            latency_s: 0.01,
            star_tracker: Some(StarTrackerSpec {
                timing: SampleTimingSpec { latency_s: 0.02, ..Default::default() },
                ..Default::default()
            }),
            ..Default::default()
        };
        check_lags(&spec, 1, 3);
    }

    #[test]
    fn noise_statistics_and_determinism() {
        let spec = SensorSpec {
            seed: 42,
            attitude_noise_deg: 2.0,
            rate_noise_rad_s: 1e-3,
            rate_bias_rad_s: [1e-4, 0.0, 0.0],
            ..Default::default()
        };
        let (mut a, mut b) = (suite(&spec, 100.0), suite(&spec, 100.0));
        let n = 20_000;
        let (mut sum_ang2, mut sum_w, mut sum_w2) = (0.0, 0.0, 0.0);
        let c = craft();
        for k in 0..n {
            let t = k as f64 * 0.01;
            let fa = a.sample(k, t, &state(), &c, None, &[0.0; 3]);
            assert_eq!(fa, b.sample(k, t, &state(), &c, None, &[0.0; 3]), "same seed, same bits");
            let q = Quat::new(
                fa.q_ib_xyzw[3] as f64,
                fa.q_ib_xyzw[0] as f64,
                fa.q_ib_xyzw[1] as f64,
                fa.q_ib_xyzw[2] as f64,
            );
            let ang = 2.0 * q.imag().norm().atan2(q.w);
            sum_ang2 += ang * ang;
            let e = fa.rate_rad_s[0] as f64 - 0.01;
            sum_w += e;
            sum_w2 += e * e;
        }
        // Rotation angle² of a 3-axis N(0, σ²) small rotation has mean 3σ².
        let rms = (sum_ang2 / n as f64 / 3.0).sqrt().to_degrees();
        assert!((rms - 2.0).abs() < 0.05, "per-axis rms {rms} deg");
        // Bias shows in the mean (1e-4 ± 3 σ/√n), the white noise in the spread (σ = 1e-3 per sample).
        let mean = sum_w / n as f64;
        assert!((mean - 1e-4).abs() < 3.0 * 1e-3 / (n as f64).sqrt(), "{mean}");
        let sd = (sum_w2 / n as f64 - mean * mean).sqrt();
        assert!((sd - 1e-3).abs() < 0.03e-3, "{sd}");
    }

    fn env_craft() -> Spacecraft {
        use crate::environment::model::{Environment, FieldSource};
        use crate::environment::torques::{Disturbances, HarmonicTorque};
        let mut c = craft();
        c.env = Some(Environment {
            orbit: None,
            earth: EarthRotation::Simple { theta0_rad: 0.0 },
            field: FieldSource::None,
            disturbances: Disturbances {
                inertia: nalgebra::Matrix3::identity(),
                gravity_gradient: false,
                drag: None,
                srp: None,
                residual_dipole_am2: Vec3::zeros(),
                external: HarmonicTorque::default(),
            },
        });
        c
    }

    #[test]
    fn gnss_fixes_at_its_rate_outside_outages_and_ideal_without_a_table() {
        let c = env_craft();
        let (r, v) = (Vec3::new(7.0e6, 0.0, 0.0), Vec3::new(0.0, 7.5e3, 0.0));
        let snap = |t: f64| EnvSnapshot { t_s: t, orbit: Some((r, v)), ..Default::default() };
        // Control 10 Hz for 200 s (frames t = 0 … 199.9); receiver 1 Hz; no fix in
        // [50.5, 60.5] (t = 51 … 60). Truth: 1 Hz × 200 s − 10 = 190 fixes, each on a
        // whole second.
        let gnss = GnssSpec {
            timing: SampleTimingSpec { rate_hz: Some(1.0), ..Default::default() },
            position_noise_m: 3.0,
            velocity_noise_m_s: 0.01,
            outages_s: vec![[50.5, 60.5]],
        };
        let mut s = suite(&SensorSpec { seed: 5, gnss: Some(gnss), ..Default::default() }, 10.0);
        let mut fixes: Vec<(u32, SensorFrame)> = Vec::new();
        for k in 0..2000u32 {
            let t = k as f64 / 10.0;
            let f = s.sample(k, t, &state(), &c, Some(&snap(t)), &[0.0; 3]);
            // A new fix carries a new validity time; between fixes the last one is held
            // with its old time (always valid once the first has come).
            assert!(f.valid & valid::GNSS != 0, "frame {k}: the first fix is at t = 0");
            match fixes.last() {
                Some((_, last)) if last.sampled_at.gnss_us == f.sampled_at.gnss_us => {
                    assert_eq!((f.gnss_pos_m, f.gnss_vel_m_s), (last.gnss_pos_m, last.gnss_vel_m_s), "held");
                }
                _ => {
                    assert_eq!(f.sampled_at.gnss_us, f.time_us, "a fix is delivered at its own time");
                    fixes.push((k, f));
                }
            }
        }
        println!("gnss: {} fixes in 200 s at 1 Hz with a 10 s outage", fixes.len());
        assert_eq!(fixes.len(), 190);
        for (k, f) in &fixes {
            assert_eq!(k % 10, 0, "fix off the 1 Hz grid at frame {k}");
            assert!(!(505..=605).contains(k), "fix inside the outage at frame {k}");
            let (days, secs) = j2000_days_seconds(2_451_545.0 + *k as f64 / 10.0 / 86_400.0);
            assert_eq!((f.gnss_j2000_days, f.gnss_j2000_s), (days, secs));
            // 3 m noise: within 6σ (f32 on the wire: 0.5 m steps at 7000 km).
            assert!((f.gnss_pos_m[0] as f64 - r.x).abs() < 18.0);
        }
        // Noisy: the rms position error is near 3 m (190 × 3 samples: ±10 % is > 4σ).
        let rms = (fixes
            .iter()
            .flat_map(|(_, f)| (0..3).map(move |i| (f.gnss_pos_m[i] as f64 - [r.x, r.y, r.z][i]).powi(2)))
            .sum::<f64>()
            / (3 * fixes.len()) as f64)
            .sqrt();
        println!("gnss suite: position rms error {rms:.3} m (σ = 3 m)");
        assert!((rms / 3.0 - 1.0).abs() < 0.1, "{rms}");
        // Without the table: the ideal state on every frame.
        let mut s = suite(&SensorSpec::default(), 10.0);
        for k in 0..20u32 {
            let t = k as f64 / 10.0;
            let f = s.sample(k, t, &state(), &c, Some(&snap(t)), &[0.0; 3]);
            assert!(f.valid & valid::GNSS != 0);
            assert_eq!(f.gnss_pos_m, [7.0e6, 0.0, 0.0]);
            assert_eq!(f.gnss_vel_m_s, [0.0, 7.5e3, 0.0]);
        }
    }

    #[test]
    fn css_valid_with_an_orbit_even_in_eclipse() {
        let c = env_craft();
        let t = 1000.0;
        // Independent Sun direction: the ephemeris at J2000 + t (the Simple epoch).
        let sun = sun_position_eci(2_451_545.0 + t / 86_400.0).normalize();
        let css = CssSpec {
            timing: SampleTimingSpec::default(),
            normals_body: vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]],
            noise: 0.0,
            albedo: 0.0,
        };
        let spec = SensorSpec { css: Some(css), ..Default::default() };
        let frame = |r: Option<Vec3>| {
            let mut s = suite(&spec, 10.0);
            let e = EnvSnapshot { t_s: t, orbit: r.map(|r| (r, Vec3::zeros())), ..Default::default() };
            s.sample(0, t, &state(), &c, Some(&e), &[0.0; 3])
        };
        // Sunlit (on the Sun side): the cosine law on the spacecraft → Sun direction.
        let r_day = sun * 7.0e6;
        let f = frame(Some(r_day));
        assert!(f.valid & valid::CSS != 0);
        let s_sc = (sun_position_eci(2_451_545.0 + t / 86_400.0) - r_day).normalize();
        for (i, want) in [s_sc.x, s_sc.y, s_sc.z, -s_sc.x].into_iter().enumerate() {
            assert!((f.css_output[i] as f64 - want.max(0.0)).abs() < 1e-7, "{i}: {:?}", f.css_output);
        }
        assert_eq!(&f.css_output[4..], &[0.0, 0.0]);
        // In the shadow (behind the Earth): all zeros, still valid.
        let f = frame(Some(-sun * 7.0e6));
        assert!(f.valid & valid::CSS != 0);
        assert_eq!(f.css_output, [0.0; 6]);
        // No orbit: not valid.
        assert_eq!(frame(None).valid & valid::CSS, 0);
    }

    #[test]
    fn tracker_exclusion_uses_the_orbit_sun_and_earth() {
        use nalgebra::UnitQuaternion;
        let c = env_craft();
        // Over the subsolar point at 7000 km: the Earth below lit, the Sun not behind it.
        let t = 100.0;
        let r = sun_position_eci(2_451_545.0 + t / 86_400.0).normalize() * 7.0e6;
        let env = EnvSnapshot { t_s: t, orbit: Some((r, Vec3::zeros())), ..Default::default() };
        // Independent Sun direction: the ephemeris at J2000 + t (the Simple epoch).
        let sun = (sun_position_eci(2_451_545.0 + t / 86_400.0) - r).normalize();
        let point = |d: &Vec3| UnitQuaternion::rotation_between(&Vec3::z(), d).unwrap().into_inner();
        let run = |st: StarTrackerSpec, d: &Vec3, e: Option<&EnvSnapshot>| {
            let spec = SensorSpec { star_tracker: Some(st), ..Default::default() };
            let mut s = suite(&spec, 10.0);
            let mut x = state();
            x.q = point(d);
            s.sample(0, t, &x, &c, e, &[0.0; 3]).valid & valid::ATTITUDE != 0
        };
        let sun_rule = StarTrackerSpec { sun_exclusion_deg: Some(30.0), ..Default::default() };
        // Boresight 29° / 31° from the Sun (turned about an axis normal to it).
        let n = sun.cross(&Vec3::x()).normalize();
        let off = |deg: f64| UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(n), deg.to_radians()) * sun;
        assert!(!run(sun_rule.clone(), &off(29.0), Some(&env)));
        assert!(run(sun_rule.clone(), &off(31.0), Some(&env)));
        assert!(run(sun_rule, &off(0.0), None), "no orbit: no rule");
        // Earth at 7000 km: angular radius ρ = asin(R_E / r) = 65.7°; a boresight turned θ
        // from nadir is θ − ρ from the limb; at nadir it is on the Earth.
        let earth_rule = StarTrackerSpec { earth_exclusion_deg: Some(20.0), ..Default::default() };
        let rho = (crate::environment::orbit::R_E / r.norm()).asin().to_degrees();
        let nadir = -r.normalize();
        let axis = nalgebra::Unit::new_normalize(nadir.cross(&Vec3::z()));
        let from_nadir = |deg: f64| UnitQuaternion::from_axis_angle(&axis, deg.to_radians()) * nadir;
        assert!(!run(earth_rule.clone(), &nadir, Some(&env)));
        assert!(!run(earth_rule.clone(), &from_nadir(rho + 19.9), Some(&env)));
        assert!(run(earth_rule.clone(), &from_nadir(rho + 20.1), Some(&env)));
        assert!(run(earth_rule, &-nadir, Some(&env)));
    }

    #[test]
    fn tracker_sees_only_a_lit_earth_and_an_unocculted_sun() {
        use nalgebra::UnitQuaternion;
        // The spacecraft at 7000 km, φ from the subsolar direction ŝ (Earth centre → Sun)
        // in a plane through it. Closed forms: some of the visible cap (half-angle
        // acos(R_E / r) about the zenith) is lit while φ < 90° + acos(R_E / r); the Sun is
        // behind the Earth (the Sun–nadir angle 180° − φ below the disc's asin(R_E / r))
        // once φ > 180° − asin(R_E / r), up to the Sun's parallax (4.7e-5 rad), well inside
        // the ±0.01° probes.
        let c = env_craft();
        let t = 100.0;
        let s_hat = sun_position_eci(2_451_545.0 + t / 86_400.0).normalize();
        let p_hat = s_hat.cross(&Vec3::z()).normalize();
        let r_m = 7.0e6;
        let ratio = crate::environment::orbit::R_E / r_m;
        let at = |phi_deg: f64| {
            let (sn, cs) = phi_deg.to_radians().sin_cos();
            (s_hat * cs + p_hat * sn) * r_m
        };
        let point = |d: &Vec3| UnitQuaternion::rotation_between(&Vec3::z(), d).unwrap().into_inner();
        let valid = |st: &StarTrackerSpec, r: Vec3, boresight: &Vec3| {
            let env = EnvSnapshot { t_s: t, orbit: Some((r, Vec3::zeros())), ..Default::default() };
            let spec = SensorSpec { star_tracker: Some(st.clone()), ..Default::default() };
            let mut s = suite(&spec, 10.0);
            let mut x = state();
            x.q = point(boresight);
            s.sample(0, t, &x, &c, Some(&env), &[0.0; 3]).valid & valid::ATTITUDE != 0
        };
        let earth_rule = StarTrackerSpec { earth_exclusion_deg: Some(20.0), ..Default::default() };
        let dark_from = 90.0 + ratio.acos().to_degrees();
        for (phi, expect) in [(0.0, false), (dark_from - 0.01, false), (dark_from + 0.01, true), (180.0, true)] {
            let r = at(phi);
            assert_eq!(valid(&earth_rule, r, &-r.normalize()), expect, "nadir boresight, φ = {phi}");
        }
        let sun_rule = StarTrackerSpec { sun_exclusion_deg: Some(30.0), ..Default::default() };
        let hidden_from = 180.0 - ratio.asin().to_degrees();
        for (phi, expect) in [(90.0, false), (hidden_from - 0.01, false), (hidden_from + 0.01, true), (180.0, true)] {
            let r = at(phi);
            let sun = (sun_position_eci(2_451_545.0 + t / 86_400.0) - r).normalize();
            assert_eq!(valid(&sun_rule, r, &sun), expect, "boresight on the Sun, φ = {phi}");
        }
    }
}
