//! The sensor suite: every sensor of a scenario, sampled together into the flight code's
//! [`SensorFrame`] at each control step.
//!
//! The suite is the bridge between the truth (plant state, environment snapshot) and the
//! sensor models: it delays the attitude and rate (suite latency, then the star tracker's
//! own), works out the Sun and Earth geometry the models need, calls each model's sample
//! step at `t` in a fixed order and writes its reading and validity bit into the frame.

use super::config::Sensors as SensorSpec;
use super::css::{CoarseSunSensors, CssGeometry, CssSpec};
use super::encoders::Encoders;
use super::gnss::{GnssReceiver, GnssSpec};
use super::gyro::{Gyro, GyroSpec};
use super::latency::DelayLine;
use super::magnetometer::{Magnetometer, MagnetometerSpec};
use super::star_tracker::{AttitudeSensor, AttitudeSensorSpec, ExclusionGeometry};
use super::sun_sensor::{SunSensor, SunSensorSpec};
use crate::attitude::{Quat, Vec3, rotate_ref_to_body, to_xyzw};
use crate::environment::frames::EarthRotation;
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

/// Julian date (UT1) at simulation time `t_s` for the Sun ephemeris.
fn julian_date(env_model: &Environment, t_s: f64) -> f64 {
    (match env_model.earth {
        EarthRotation::Gmst { jd_ut1_epoch } => jd_ut1_epoch,
        EarthRotation::Simple { .. } => 2_451_545.0,
    }) + t_s / 86_400.0
}

/// Whole days and seconds of the day since J2000.0 (JD 2451545.0) for a Julian date.
pub fn j2000_days_seconds(jd: f64) -> (i32, f32) {
    let d = jd - 2_451_545.0;
    let days = d.floor();
    (days as i32, ((d - days) * 86_400.0) as f32)
}

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
    /// Latency of the attitude and rate measurements in control steps: the true attitude
    /// and rate of `latency_s` ago.
    latency: DelayLine<(Quat, Vec3)>,
    /// The star tracker's own extra delay, control steps, on the (suite-delayed) true
    /// attitude and rate.
    tracker_latency: DelayLine<(Quat, Vec3)>,
    /// `[sensors.star_tracker] outages_s`.
    tracker_outages: Vec<[f64; 2]>,
}

impl SensorSuite {
    /// `control_rate_hz`: default sample rate of sensors that do not give one.
    pub fn new(s: &SensorSpec, control_rate_hz: f64) -> Self {
        let seed = s.seed;
        let steps = |latency_s: f64| (latency_s * control_rate_hz).round() as usize;
        // Built in this order (the optional sensors first) so that a bad table fails on
        // the same check as before.
        let sun = SunSensorSpec::from_config(s, control_rate_hz).map(|x| SunSensor::new(x, seed, SUN_STREAM));
        let css = CssSpec::from_config(s, control_rate_hz).map(|c| CoarseSunSensors::new(c, seed, CSS_STREAM));
        let gnss = GnssSpec::from_config(s, control_rate_hz).map(|g| GnssReceiver::new(g, seed, GNSS_STREAM));
        Self {
            encoders: Encoders::new(seed, s.gimbal_noise_deg.to_radians(), s.wheel_speed_noise_rad_s),
            gyro: Gyro::new(GyroSpec::from_config(s, control_rate_hz), seed, GYRO_STREAM),
            attitude: AttitudeSensor::new(AttitudeSensorSpec::from_config(s, control_rate_hz), seed, ATTITUDE_STREAM),
            mag: Magnetometer::new(MagnetometerSpec::from_config(s, control_rate_hz), seed, MAGNETOMETER_STREAM),
            sun,
            css,
            gnss,
            latency: DelayLine::new(steps(s.latency_s)),
            tracker_latency: DelayLine::new(s.star_tracker.as_ref().map_or(0, |a| steps(a.latency_s))),
            tracker_outages: s.star_tracker.as_ref().map_or_else(Vec::new, |a| a.outages_s.clone()),
        }
    }

    /// The gyro's true additive bias now (constant + random walk), rad/s: the truth the
    /// flight MEKF's bias estimate is scored against.
    pub fn gyro_bias_rad_s(&self) -> Vec3 {
        Vec3::from(self.gyro.bias_rad_s())
    }

    /// Measure the true state at time `t_s`. `rod_dipole_am2`: the torquers' dipole now
    /// (magnetometer coupling).
    pub fn sample(
        &mut self,
        seq: u32,
        t_s: f64,
        s: &State,
        craft: &Spacecraft,
        env: Option<&EnvSnapshot>,
        rod_dipole_am2: &[f64; 3],
    ) -> SensorFrame {
        let mut f = SensorFrame::empty(seq, (t_s * 1e6).round() as u64);
        // Latency: measure the state of `latency_s` (whole steps) ago (before the first
        // sample that old exists, the initial state: the sensor's first output held).
        let (q_meas, w_meas) = self.latency.delay((s.q, s.w));
        self.measure_attitude(&mut f, t_s, (q_meas, w_meas), craft, env);
        self.measure_rate(&mut f, t_s, &w_meas);
        self.measure_gimbals(&mut f, s, craft);
        self.measure_wheels(&mut f, s, craft);
        if let Some(e) = env {
            if let Some(b) = e.b_ref_t {
                self.measure_field(&mut f, t_s, &s.q, &b, rod_dipole_am2);
            }
            if let (Some(orbit), Some(env_model)) = (e.orbit, craft.env.as_ref()) {
                self.measure_gnss(&mut f, t_s, orbit, env_model);
                self.measure_css(&mut f, t_s, &s.q, &orbit.0, env_model);
                self.measure_sun(&mut f, t_s, &s.q, &orbit.0, env_model);
            }
        }
        f
    }

    /// Star tracker on the suite-delayed attitude and rate `delayed`, behind its own
    /// latency; not valid in an outage or when the model says so.
    fn measure_attitude(
        &mut self,
        f: &mut SensorFrame,
        t_s: f64,
        delayed: (Quat, Vec3),
        craft: &Spacecraft,
        env: Option<&EnvSnapshot>,
    ) {
        let (q_att, w_att) = self.tracker_latency.delay(delayed);
        let geometry = self.exclusion_geometry(t_s, craft, env);
        let att = self.attitude.update_with(t_s, &q_att, &w_att, geometry.as_ref());
        f.q_ib_xyzw = to_xyzw(&att.q_ib).map(|x| x as f32);
        if att.valid && !self.tracker_outages.iter().any(|[a, b]| (*a..=*b).contains(&t_s)) {
            f.valid |= valid::ATTITUDE;
        }
    }

    /// Where the Sun and the Earth are for the tracker's exclusion rules: `None` without a
    /// rule, an orbit or an environment model (rules not applied).
    fn exclusion_geometry(&self, t_s: f64, craft: &Spacecraft, env: Option<&EnvSnapshot>) -> Option<ExclusionGeometry> {
        if !self.attitude.spec.has_exclusion() {
            return None;
        }
        let (Some((r, _)), Some(m)) = (env.and_then(|e| e.orbit), craft.env.as_ref()) else {
            return None;
        };
        let rs = sun_position_eci(julian_date(m, t_s));
        Some(ExclusionGeometry {
            sun_ref: (rs - r).normalize(),
            nadir_ref: -r.normalize(),
            earth_half_angle_rad: (R_E / r.norm()).min(1.0).asin(),
        })
    }

    /// Rate gyro on the suite-delayed body rate; always valid.
    fn measure_rate(&mut self, f: &mut SensorFrame, t_s: f64, w_meas: &Vec3) {
        let g = self.gyro.update(t_s, &(*w_meas).into());
        f.rate_rad_s = g.rate_rad_s.map(|x| x as f32);
        f.valid |= valid::RATE;
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
    fn measure_wheels(&mut self, f: &mut SensorFrame, s: &State, craft: &Spacecraft) {
        if !craft.wheels.is_empty() {
            let w: [f64; 3] = s.w.into();
            for (i, p) in craft.wheels.iter().enumerate().take(f.wheel_speed_rad_s.len()) {
                let rel = s.wheels[i].h_abs_nms / p.inertia_kgm2 - Vec3::from(p.spin_axis).dot(&Vec3::from(w));
                f.wheel_speed_rad_s[i] = self.encoders.wheel_speed(rel) as f32;
            }
            f.valid |= valid::WHEELS;
        }
    }

    /// Magnetometer on the true (undelayed) field `b_ref_t` seen in body axes.
    fn measure_field(&mut self, f: &mut SensorFrame, t_s: f64, q: &Quat, b_ref_t: &Vec3, rod_dipole_am2: &[f64; 3]) {
        let m = self.mag.update(t_s, &rotate_ref_to_body(q, b_ref_t).into(), rod_dipole_am2);
        f.mag_field_t = m.b_body_t.map(|x| x as f32);
        f.valid |= valid::MAG;
    }

    /// GNSS fix: position, velocity, time. Without a receiver model: ideal, every frame;
    /// with one: noisy, at its rate, none in an outage.
    fn measure_gnss(&mut self, f: &mut SensorFrame, t_s: f64, (r, v): (Vec3, Vec3), env_model: &Environment) {
        let fix = match self.gnss.as_mut() {
            None => Some(([r.x, r.y, r.z], [v.x, v.y, v.z])),
            Some(g) => g.update(t_s, &r.into(), &v.into()).map(|x| (x.pos_m, x.vel_m_s)),
        };
        if let Some((pos, vel)) = fix {
            let jd = julian_date(env_model, t_s);
            let (days, seconds) = j2000_days_seconds(jd);
            f.gnss_pos_m = pos.map(|x| x as f32);
            f.gnss_vel_m_s = vel.map(|x| x as f32);
            f.gnss_j2000_days = days;
            f.gnss_j2000_s = seconds;
            f.valid |= valid::GNSS;
        }
    }

    /// Coarse sun sensors, when fitted: zeros in eclipse are a valid measurement.
    fn measure_css(&mut self, f: &mut SensorFrame, t_s: f64, q: &Quat, r: &Vec3, env_model: &Environment) {
        if let Some(css) = self.css.as_mut() {
            let rs = sun_position_eci(julian_date(env_model, t_s));
            let g = CssGeometry { sun_ref: (rs - r).normalize(), r_m: *r, eclipse: in_shadow_cylindrical(r, &rs) };
            let rd = css.update(t_s, q, &g);
            for (o, x) in f.css_output.iter_mut().zip(rd.output) {
                *o = x as f32;
            }
            f.valid |= valid::CSS;
        }
    }

    /// Sun sensor, when fitted: valid outside eclipse with the Sun in its field of view.
    fn measure_sun(&mut self, f: &mut SensorFrame, t_s: f64, q: &Quat, r: &Vec3, env_model: &Environment) {
        if let Some(sun) = self.sun.as_mut() {
            let rs = sun_position_eci(julian_date(env_model, t_s));
            let eclipse = in_shadow_cylindrical(r, &rs);
            let rd = sun.update(t_s, q, &(rs - r).normalize().into(), eclipse);
            if rd.valid {
                f.sun_dir = rd.sun_body.map(|x| x as f32);
                f.valid |= valid::SUN;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quat;
    use crate::plant::MAX_GIMBALS;
    use crate::sensors::config;

    fn state() -> State {
        State {
            q: Quat::identity(),
            w: Vec3::new(0.01, 0.02, 0.03),
            gimbal_rad: [0.0; MAX_GIMBALS],
            gimbal_rate_rad_s: [0.0; MAX_GIMBALS],
            wheels: Default::default(),
        }
    }

    fn craft() -> Spacecraft {
        Spacecraft::new(nalgebra::Matrix3::identity(), None).unwrap()
    }

    #[test]
    fn ideal_sensors_return_the_truth() {
        let mut s = SensorSuite::new(&SensorSpec::default(), 100.0);
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
        let mut s = SensorSuite::new(spec, 100.0);
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
            star_tracker: Some(config::StarTrackerSpec { latency_s: 0.02, ..Default::default() }),
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
        let (mut a, mut b) = (SensorSuite::new(&spec, 100.0), SensorSuite::new(&spec, 100.0));
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
        let gnss = config::GnssSpecToml {
            rate_hz: Some(1.0),
            position_noise_m: 3.0,
            velocity_noise_m_s: 0.01,
            outages_s: vec![[50.5, 60.5]],
        };
        let mut s = SensorSuite::new(&SensorSpec { seed: 5, gnss: Some(gnss), ..Default::default() }, 10.0);
        let mut fixes = Vec::new();
        for k in 0..2000u32 {
            let t = k as f64 / 10.0;
            let f = s.sample(k, t, &state(), &c, Some(&snap(t)), &[0.0; 3]);
            if f.valid & valid::GNSS != 0 {
                fixes.push((k, f));
            } else {
                assert_eq!(f.gnss_pos_m, [0.0; 3], "no fix, no data");
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
        let mut s = SensorSuite::new(&SensorSpec::default(), 10.0);
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
        let css = config::CssSpecToml {
            rate_hz: None,
            normals_body: vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]],
            noise: 0.0,
            albedo: 0.0,
        };
        let spec = SensorSpec { css: Some(css), ..Default::default() };
        let frame = |r: Option<Vec3>| {
            let mut s = SensorSuite::new(&spec, 10.0);
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
        use config::StarTrackerSpec;
        use nalgebra::UnitQuaternion;
        let c = env_craft();
        let (t, r) = (100.0, Vec3::new(0.0, 7.0e6, 0.0));
        let env = EnvSnapshot { t_s: t, orbit: Some((r, Vec3::zeros())), ..Default::default() };
        // Independent Sun direction: the ephemeris at J2000 + t (the Simple epoch).
        let sun = (sun_position_eci(2_451_545.0 + t / 86_400.0) - r).normalize();
        let point = |d: &Vec3| UnitQuaternion::rotation_between(&Vec3::z(), d).unwrap().into_inner();
        let run = |st: StarTrackerSpec, d: &Vec3, e: Option<&EnvSnapshot>| {
            let spec = SensorSpec { star_tracker: Some(st), ..Default::default() };
            let mut s = SensorSuite::new(&spec, 10.0);
            let mut x = state();
            x.q = point(d);
            s.sample(0, t, &x, &c, e, &[0.0; 3]).valid & valid::ATTITUDE != 0
        };
        let sun_rule = StarTrackerSpec { sun_exclusion_deg: Some(30.0), ..Default::default() };
        // Boresight 29° / 31° from the Sun (turned about an axis normal to it).
        let n = sun.cross(&Vec3::z()).normalize();
        let off = |deg: f64| UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(n), deg.to_radians()) * sun;
        assert!(!run(sun_rule.clone(), &off(29.0), Some(&env)));
        assert!(run(sun_rule.clone(), &off(31.0), Some(&env)));
        assert!(run(sun_rule, &off(0.0), None), "no orbit: no rule");
        // Earth at 7000 km: angular radius ρ = asin(R_E / r) = 65.7°; a boresight turned θ
        // from nadir (within the x-y plane) is θ − ρ from the limb; at nadir it is on the Earth.
        let earth_rule = StarTrackerSpec { earth_exclusion_deg: Some(20.0), ..Default::default() };
        let rho = (crate::environment::orbit::R_E / r.norm()).asin().to_degrees();
        let nadir = -r.normalize();
        let from_nadir = |deg: f64| UnitQuaternion::from_axis_angle(&Vec3::z_axis(), deg.to_radians()) * nadir;
        assert!(!run(earth_rule.clone(), &nadir, Some(&env)));
        assert!(!run(earth_rule.clone(), &from_nadir(rho + 19.9), Some(&env)));
        assert!(run(earth_rule.clone(), &from_nadir(rho + 20.1), Some(&env)));
        assert!(run(earth_rule, &-nadir, Some(&env)));
    }
}
