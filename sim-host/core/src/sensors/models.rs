//! Sensor models with their own sample rates: rate gyro (ARW, bias random walk,
//! Gauss–Markov bias instability, constant bias, scale factor), attitude sensor (star
//! tracker / AHRS), magnetometer (misalignment, magnetorquer coupling), sun sensor (eclipse
//! and field of view), coarse sun sensors (cosine heads, eclipse, Earth albedo), GNSS
//! receiver (white position / velocity noise, outages).
//!
//! All sensors are **discrete**: call `update(t, truth…)` once per dynamics step boundary
//! (after the RK4 step, with the true state at `t`). A sample is taken when `t` reaches
//! the next point of the sensor's grid `k / rate_hz` (k = 0, 1, …; a step that skips a
//! grid point samples once, late, at `t`); between samples the last reading is held.
//! The sensors have no continuous state; the gyro's bias random walk is propagated
//! exactly (Wiener increment over the actual time between samples) at each sample.
//! Pure helpers: [`sun_in_body`], [`cylindrical_eclipse`].
//!
//! Noise: each sensor owns a ChaCha8 stream from [`sensor_rng`]`(scenario seed, sensor
//! index)`, so adding, removing or reordering other sensors leaves its noise unchanged.
//! Every sample draws a fixed number of normals whatever the parameters or validity, so
//! e.g. switching on the bias random walk or an eclipse does not shift the white noise.
//!
//! Conventions: Hamilton quaternions, `q_ib` rotates body → inertial; nalgebra's
//! `Quaternion` stores `[x, y, z, w]` (scalar last). Vectors are `[f64; 3]`, SI units.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

type Vec3 = Vector3<f64>;
pub type Quat = Quaternion<f64>;

/// Noise stream of sensor `index` in a scenario: the key comes from `scenario_seed`, the
/// ChaCha stream (nonce) is `index + 1`. Stream 0 is left to the simulator's existing
/// `SensorSuite`, which uses `ChaCha8Rng::seed_from_u64(seed)`.
pub fn sensor_rng(scenario_seed: u64, index: u32) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(scenario_seed);
    r.set_stream(u64::from(index) + 1);
    r
}

/// A second, independent stream owned by sensor `index` (for a noise source added to an
/// existing model, so that switching it on leaves the model's first stream untouched):
/// ChaCha stream `(sub << 32) | (index + 1)`, disjoint from every [`sensor_rng`] stream
/// for `sub >= 1`.
pub fn sensor_sub_rng(scenario_seed: u64, index: u32, sub: u32) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(scenario_seed);
    r.set_stream((u64::from(sub) << 32) | (u64::from(index) + 1));
    r
}

fn gauss3(rng: &mut ChaCha8Rng, sigma: &[f64; 3]) -> Vec3 {
    Vec3::from_fn(|i, _| {
        let n: f64 = StandardNormal.sample(rng);
        n * sigma[i]
    })
}

/// Small rotation `exp(θ/2)` of a rotation vector θ (rad).
fn small_rot(theta: &Vec3) -> Quat {
    UnitQuaternion::from_scaled_axis(*theta).into_inner()
}

/// Sample clock: grid `k / rate_hz` from t = 0.
#[derive(Clone, Debug, PartialEq)]
struct Clock {
    period_s: f64,
    next_k: u64,
    last_t_s: Option<f64>,
}

impl Clock {
    fn new(rate_hz: f64) -> Self {
        assert!(rate_hz > 0.0 && rate_hz.is_finite(), "sample rate must be > 0");
        Self { period_s: 1.0 / rate_hz, next_k: 0, last_t_s: None }
    }

    /// `Some(time since the previous sample)` (0 for the first) if a sample is due at `t`.
    fn due(&mut self, t: f64) -> Option<f64> {
        let tol = 1e-9 * self.period_s;
        if (self.next_k as f64) * self.period_s > t + tol {
            return None;
        }
        self.next_k = ((t + tol) / self.period_s).floor() as u64 + 1;
        let dt = self.last_t_s.map_or(0.0, |l| t - l);
        self.last_t_s = Some(t);
        Some(dt)
    }
}

// ---------------------------------------------------------------------------------- gyro

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GyroSpec {
    pub rate_hz: f64,
    /// Angle random walk N per axis, rad/s/√Hz (= rad/√s). Per-sample white noise σ =
    /// N √rate_hz; Allan deviation N / √τ.
    pub arw_rad_s_rthz: [f64; 3],
    /// Rate random walk K per axis, rad/s²/√Hz (= rad/s/√s): bias variance grows as K² t;
    /// Allan deviation K √(τ/3).
    pub rrw_rad_s2_rthz: [f64; 3],
    /// Constant bias, rad/s.
    pub bias_rad_s: [f64; 3],
    /// Scale-factor error per axis (dimensionless, 1e-3 = 1000 ppm).
    pub scale_factor: [f64; 3],
    /// Misalignment: the triad's axes are the body axes turned by this rotation vector
    /// (rad); the gyro senses `R(θ)ᵀ ω` (components of ω along its own axes). Zero: none.
    #[serde(default)]
    pub misalignment_rad: [f64; 3],
    /// Output range: each axis is clipped to ±this (rad/s). `None`: unlimited.
    #[serde(default)]
    pub saturation_rad_s: Option<f64>,
    /// Output LSB (rad/s): each axis is rounded to the nearest multiple. 0: continuous.
    #[serde(default)]
    pub quantisation_rad_s: f64,
    /// Bias instability: 1σ of a first-order Gauss–Markov bias per axis, rad/s (0: none).
    #[serde(default)]
    pub bias_instability_rad_s: f64,
    /// Correlation time τ of the Gauss–Markov bias, s (> 0 when the instability is on).
    #[serde(default)]
    pub bias_correlation_s: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GyroReading {
    pub t_s: f64,
    pub rate_rad_s: [f64; 3],
    /// False until the first sample.
    pub valid: bool,
}

/// Rate gyro: `ω_m = Q(clip((1 + s) ∘ R(θ)ᵀ ω + b0 + b_rw(t) + b_gm(t) + n))`, per axis:
/// misalignment R(θ), scale factor, biases and noise, then the output range (clip) and the
/// converter's LSB (round to nearest), in the order of the signal chain.
///
/// `b_gm` is a first-order Gauss–Markov process (bias instability) of stationary 1σ σ and
/// correlation time τ, propagated with its exact discretisation over the time Δt since the
/// previous sample, `b ← e^{−Δt/τ} b + σ √(1 − e^{−2Δt/τ}) n` (Maybeck, *Stochastic Models,
/// Estimation and Control* vol. 1, §4.11; Farrell & Barth, *GPS and INS*, §4.9). It
/// starts from its stationary distribution N(0, σ²) at the first sample and draws from its
/// own stream ([`sensor_sub_rng`] sub 1), so switching it on leaves ARW and RRW unchanged.
#[derive(Clone, Debug)]
pub struct Gyro {
    pub spec: GyroSpec,
    rng: ChaCha8Rng,
    gm_rng: ChaCha8Rng,
    clock: Clock,
    bias_rw: Vec3,
    bias_gm: Vec3,
    gm_started: bool,
    last: GyroReading,
}

impl Gyro {
    pub fn new(spec: GyroSpec, scenario_seed: u64, index: u32) -> Self {
        assert!(spec.saturation_rad_s.is_none_or(|s| s > 0.0), "gyro saturation must be > 0");
        assert!(spec.quantisation_rad_s >= 0.0 && spec.quantisation_rad_s.is_finite(), "gyro LSB must be >= 0");
        assert!(
            spec.bias_instability_rad_s == 0.0 || (spec.bias_instability_rad_s > 0.0 && spec.bias_correlation_s > 0.0),
            "gyro bias instability needs σ >= 0 and, when on, a correlation time > 0"
        );
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            gm_rng: sensor_sub_rng(scenario_seed, index, 1),
            bias_rw: Vec3::zeros(),
            bias_gm: Vec3::zeros(),
            gm_started: false,
            last: GyroReading::default(),
        }
    }

    /// Gauss–Markov bias update over `dt` (exact discretisation; the first call draws the
    /// stationary state). Three normals per sample while on.
    fn step_bias_instability(&mut self, dt: f64) {
        let sigma = self.spec.bias_instability_rad_s;
        if sigma <= 0.0 {
            return;
        }
        let n = gauss3(&mut self.gm_rng, &[1.0; 3]);
        if self.gm_started {
            let phi = (-dt / self.spec.bias_correlation_s).exp();
            self.bias_gm = self.bias_gm * phi + n * (sigma * (1.0 - phi * phi).max(0.0).sqrt());
        } else {
            self.bias_gm = n * sigma;
            self.gm_started = true;
        }
    }

    /// Discrete: true body rate at `t`; samples if due, returns the held reading.
    pub fn update(&mut self, t_s: f64, w_true_rad_s: &[f64; 3]) -> GyroReading {
        if let Some(dt) = self.clock.due(t_s) {
            // A noiseless gyro draws nothing (its stream is its own: no other sensor shifts).
            let noiseless = self.spec.arw_rad_s_rthz == [0.0; 3] && self.spec.rrw_rad_s2_rthz == [0.0; 3];
            let white = if noiseless {
                Vec3::zeros()
            } else {
                let sd = self.spec.rate_hz.sqrt();
                let white = gauss3(&mut self.rng, &self.spec.arw_rad_s_rthz.map(|n| n * sd));
                let sq = dt.sqrt();
                self.bias_rw += gauss3(&mut self.rng, &self.spec.rrw_rad_s2_rthz.map(|k| k * sq));
                white
            };
            self.step_bias_instability(dt);
            let mut w = Vec3::from(*w_true_rad_s);
            // Skipped when zero so that gyros without misalignment keep their exact bits.
            if self.spec.misalignment_rad != [0.0; 3] {
                w = UnitQuaternion::from_scaled_axis(Vec3::from(self.spec.misalignment_rad)).inverse() * w;
            }
            let sf = Vec3::from(self.spec.scale_factor);
            let mut m = w + w.component_mul(&sf) + Vec3::from(self.spec.bias_rad_s) + self.bias_rw + white;
            // Added only when on so that gyros without it keep their exact bits.
            if self.spec.bias_instability_rad_s > 0.0 {
                m += self.bias_gm;
            }
            if let Some(sat) = self.spec.saturation_rad_s {
                m = m.map(|x| x.clamp(-sat, sat));
            }
            let lsb = self.spec.quantisation_rad_s;
            if lsb > 0.0 {
                m = m.map(|x| (x / lsb).round() * lsb);
            }
            self.last = GyroReading { t_s, rate_rad_s: m.into(), valid: true };
        }
        self.last
    }

    pub fn reading(&self) -> GyroReading {
        self.last
    }

    /// Current total bias (constant + random walk + Gauss–Markov), rad/s — truth for
    /// estimator tests.
    pub fn bias_rad_s(&self) -> [f64; 3] {
        (Vec3::from(self.spec.bias_rad_s) + self.bias_rw + self.bias_gm).into()
    }

    /// Current Gauss–Markov (bias instability) part of the bias, rad/s.
    pub fn bias_instability_state_rad_s(&self) -> [f64; 3] {
        self.bias_gm.into()
    }
}

// ----------------------------------------------------------------------- attitude sensor

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttitudeSensorSpec {
    pub rate_hz: f64,
    /// 1σ small-rotation noise about each body axis, rad.
    pub noise_rad: [f64; 3],
    /// Constant misalignment, rotation vector in body axes, rad (zero = none).
    pub bias_rad: [f64; 3],
    /// Above this body rate the tracker loses its stars (the reading is invalid), rad/s;
    /// `None` = no limit.
    pub max_rate_rad_s: Option<f64>,
    /// Boresight, unit vector in body axes. `Some`: `noise_rad` is per axis of the tracker
    /// frame (x, y cross-boresight, z = boresight; the shortest-arc rotation from body z to
    /// the boresight) and the exclusion angles are measured from it. `None`: body axes,
    /// boresight body z.
    #[serde(default)]
    pub boresight_body: Option<[f64; 3]>,
    /// Invalid when the Sun is closer than this to the boresight, rad (`None`: no rule).
    #[serde(default)]
    pub sun_exclusion_rad: Option<f64>,
    /// Invalid when the Earth's limb is closer than this to the boresight (or the
    /// boresight is on the Earth), rad (`None`: no rule).
    #[serde(default)]
    pub earth_exclusion_rad: Option<f64>,
}

/// Where the bright bodies are, for the tracker's exclusion rules (inertial axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExclusionGeometry {
    /// Unit vector spacecraft → Sun.
    pub sun_ref: Vec3,
    /// Unit vector spacecraft → Earth's centre.
    pub nadir_ref: Vec3,
    /// Earth's angular radius seen from the spacecraft, asin(R_E / r), rad.
    pub earth_half_angle_rad: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeReading {
    pub t_s: f64,
    /// Measured `q_ib`.
    pub q_ib: Quat,
    pub valid: bool,
}

/// Star tracker / AHRS: `q_m = q_ib ⊗ exp(b/2) ⊗ exp(n/2)`, body-frame perturbations.
#[derive(Clone, Debug)]
pub struct AttitudeSensor {
    pub spec: AttitudeSensorSpec,
    rng: ChaCha8Rng,
    clock: Clock,
    last: AttitudeReading,
}

impl AttitudeSensor {
    pub fn new(spec: AttitudeSensorSpec, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: AttitudeReading { t_s: 0.0, q_ib: Quat::identity(), valid: false },
        }
    }

    /// Discrete: true `q_ib` (and body rate, for the rate limit) at `t`; samples if due,
    /// returns the held reading.
    pub fn update(&mut self, t_s: f64, q_ib_true: &Quat, rate_rad_s: &Vec3) -> AttitudeReading {
        self.update_with(t_s, q_ib_true, rate_rad_s, None)
    }

    /// Boresight in body axes (body z without `boresight_body`).
    pub fn boresight(&self) -> Vec3 {
        self.spec.boresight_body.map_or(Vec3::z(), |b| Vec3::from(b).normalize())
    }

    /// Angles boresight–Sun and boresight–Earth limb (negative: the boresight is on the
    /// Earth), rad, for a true attitude `q_ib`.
    pub fn exclusion_angles_rad(&self, q_ib: &Quat, g: &ExclusionGeometry) -> (f64, f64) {
        let b_ref = UnitQuaternion::from_quaternion(*q_ib) * self.boresight();
        let ang = |u: &Vec3| b_ref.dot(&u.normalize()).clamp(-1.0, 1.0).acos();
        (ang(&g.sun_ref), ang(&g.nadir_ref) - g.earth_half_angle_rad)
    }

    /// As [`Self::update`], with the Sun and Earth geometry for the exclusion rules
    /// (`None`: not known, rules not applied).
    pub fn update_with(
        &mut self,
        t_s: f64,
        q_ib_true: &Quat,
        rate_rad_s: &Vec3,
        geometry: Option<&ExclusionGeometry>,
    ) -> AttitudeReading {
        if self.clock.due(t_s).is_some() {
            let mut n = gauss3(&mut self.rng, &self.spec.noise_rad);
            if self.spec.boresight_body.is_some() {
                // Tracker frame → body: shortest arc z → boresight (identity if along z).
                let r = UnitQuaternion::rotation_between(&Vec3::z(), &self.boresight())
                    .unwrap_or_else(|| UnitQuaternion::from_scaled_axis(Vec3::x() * std::f64::consts::PI));
                n = r * n;
            }
            let q = q_ib_true.normalize() * small_rot(&Vec3::from(self.spec.bias_rad)) * small_rot(&n);
            let mut valid = self.spec.max_rate_rad_s.is_none_or(|m| rate_rad_s.norm() <= m);
            if let Some(g) = geometry {
                let (sun, limb) = self.exclusion_angles_rad(q_ib_true, g);
                valid &= self.spec.sun_exclusion_rad.is_none_or(|x| sun >= x);
                valid &= self.spec.earth_exclusion_rad.is_none_or(|x| limb >= x);
            }
            self.last = AttitudeReading { t_s, q_ib: q, valid };
        }
        self.last
    }

    pub fn reading(&self) -> AttitudeReading {
        self.last
    }
}

// -------------------------------------------------------------------------- magnetometer

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MagnetometerSpec {
    pub rate_hz: f64,
    /// 1σ white noise per axis, T.
    pub noise_t: [f64; 3],
    /// Constant bias per axis, T, in the magnetometer's axes: the spacecraft's own field at
    /// the sensor (hard iron; put the constant residual dipole's field here) plus any
    /// sensor offset.
    pub bias_t: [f64; 3],
    /// Field at the magnetometer per unit rod dipole, row-major 3×3, T per A m²:
    /// `B_err = C m_rods` with `m_rods` the rods' body dipole
    /// ([`crate::magnetorquers::MagnetorquerSet::rod_dipole_am2`]).
    pub coupling_t_per_am2: [[f64; 3]; 3],
    /// Misalignment: the sensor's axes are the body axes turned by this rotation vector
    /// (rad); it senses `R(θ)ᵀ B_body` (as the gyro's). Zero: none.
    #[serde(default)]
    pub misalignment_rad: [f64; 3],
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MagReading {
    pub t_s: f64,
    pub b_body_t: [f64; 3],
    pub valid: bool,
}

/// Magnetometer: `B_m = R(θ)ᵀ B_body + C m_rods + b + n`: the Earth's field seen along the
/// misaligned sensor axes, then the torquers' field (C as calibrated, in sensor axes), the
/// bias and the noise.
#[derive(Clone, Debug)]
pub struct Magnetometer {
    pub spec: MagnetometerSpec,
    rng: ChaCha8Rng,
    clock: Clock,
    last: MagReading,
}

impl Magnetometer {
    pub fn new(spec: MagnetometerSpec, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: MagReading::default(),
        }
    }

    /// Pure: noise-free reading for a true field and rod dipole.
    pub fn ideal(&self, b_body_t: &[f64; 3], rod_dipole_am2: &[f64; 3]) -> [f64; 3] {
        let c = Matrix3::from_row_slice(self.spec.coupling_t_per_am2.as_flattened());
        let mut b = Vec3::from(*b_body_t);
        // Skipped when zero so that magnetometers without misalignment keep their exact bits.
        if self.spec.misalignment_rad != [0.0; 3] {
            b = UnitQuaternion::from_scaled_axis(Vec3::from(self.spec.misalignment_rad)).inverse() * b;
        }
        (b + c * Vec3::from(*rod_dipole_am2) + Vec3::from(self.spec.bias_t)).into()
    }

    /// Discrete: true body field (T) and realised rod dipole (A m², body) at `t`.
    pub fn update(&mut self, t_s: f64, b_body_t: &[f64; 3], rod_dipole_am2: &[f64; 3]) -> MagReading {
        if self.clock.due(t_s).is_some() {
            let n = gauss3(&mut self.rng, &self.spec.noise_t);
            self.last = MagReading {
                t_s,
                b_body_t: (Vec3::from(self.ideal(b_body_t, rod_dipole_am2)) + n).into(),
                valid: true,
            };
        }
        self.last
    }

    pub fn reading(&self) -> MagReading {
        self.last
    }
}

// ---------------------------------------------------------------------------- sun sensor

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SunSensorSpec {
    pub rate_hz: f64,
    /// 1σ angular noise about each of the two axes normal to the sun line, rad
    /// (total angular error rms √2 σ).
    pub noise_rad: f64,
    /// Unit boresight, body.
    pub boresight_body: [f64; 3],
    /// Field-of-view cone half angle, rad (sun on the edge counts as inside).
    pub fov_half_angle_rad: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SunReading {
    pub t_s: f64,
    /// Measured unit sun vector, body; zero when invalid.
    pub sun_body: [f64; 3],
    /// False in eclipse, outside the field of view, or before the first sample.
    pub valid: bool,
}

/// Pure: unit sun direction in body axes, `R(q_ib)ᵀ s_i`.
pub fn sun_in_body(q_ib: &Quat, sun_inertial: &[f64; 3]) -> [f64; 3] {
    let s = Vec3::from(*sun_inertial).normalize();
    UnitQuaternion::from_quaternion(*q_ib).inverse_transform_vector(&s).into()
}

/// Pure: cylindrical Earth shadow. `r_m` satellite position and `sun_inertial` sun
/// direction in the same (Earth-centred) frame; Earth radius 6378.137 km.
pub fn cylindrical_eclipse(r_m: &[f64; 3], sun_inertial: &[f64; 3]) -> bool {
    const R_EARTH_M: f64 = 6_378_137.0;
    let (r, s) = (Vec3::from(*r_m), Vec3::from(*sun_inertial).normalize());
    let along = r.dot(&s);
    along < 0.0 && (r - s * along).norm() < R_EARTH_M
}

#[derive(Clone, Debug)]
pub struct SunSensor {
    pub spec: SunSensorSpec,
    rng: ChaCha8Rng,
    clock: Clock,
    last: SunReading,
}

impl SunSensor {
    pub fn new(spec: SunSensorSpec, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: SunReading::default(),
        }
    }

    /// Discrete: attitude, sun direction (inertial, any length) and eclipse flag at `t`.
    pub fn update(&mut self, t_s: f64, q_ib: &Quat, sun_inertial: &[f64; 3], in_eclipse: bool) -> SunReading {
        if self.clock.due(t_s).is_some() {
            let e = gauss3(&mut self.rng, &[self.spec.noise_rad; 3]);
            let s = Vec3::from(sun_in_body(q_ib, sun_inertial));
            let bore = Vec3::from(self.spec.boresight_body).normalize();
            let in_fov = s.dot(&bore).clamp(-1.0, 1.0).acos() <= self.spec.fov_half_angle_rad;
            let valid = !in_eclipse && in_fov;
            // Rotate by the noise component normal to the sun line.
            let e_perp = e - s * s.dot(&e);
            let m = UnitQuaternion::from_scaled_axis(e_perp) * s;
            self.last = SunReading { t_s, sun_body: if valid { m.normalize().into() } else { [0.0; 3] }, valid };
        }
        self.last
    }

    pub fn reading(&self) -> SunReading {
        self.last
    }
}

// ------------------------------------------------------------------- coarse sun sensors

/// Most heads a coarse sun sensor suite can have (`SensorFrame::css_output`).
pub const MAX_CSS_HEADS: usize = acs_flight::types::MAX_CSS_HEADS;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CssSpec {
    pub rate_hz: f64,
    /// Outward unit normals of the heads, body axes (1 … [`MAX_CSS_HEADS`]; normalised
    /// here); the order is the output index.
    pub normals_body: Vec<[f64; 3]>,
    /// 1σ white noise of each head's normalised output (1 = Sun along the normal).
    pub noise: f64,
    /// Earth albedo coefficient a (0: no albedo).
    pub albedo: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CssReading {
    pub t_s: f64,
    /// Normalised output per head (≥ 0), unused heads 0.
    pub output: [f64; MAX_CSS_HEADS],
    /// False before the first sample.
    pub valid: bool,
}

/// Where the Sun and the Earth are, for the coarse sun sensors (inertial axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CssGeometry {
    /// Unit vector spacecraft → Sun.
    pub sun_ref: Vec3,
    /// Spacecraft position from the Earth's centre, m.
    pub r_m: Vec3,
    /// In the Earth's shadow.
    pub eclipse: bool,
}

/// Coarse sun sensors: cosine-law photocells. Head i with outward normal nᵢ reads
///
/// `yᵢ = max(0, nᵢ·ŝ + a (R_E/r)² max(0, nᵢ·(−r̂)) max(0, ŝ·r̂) + εᵢ)`, ε ~ N(0, σ²),
///
/// all vectors in body axes, ŝ the unit spacecraft → Sun vector, r̂ the unit position
/// vector. The first term is the direct Sun (cosine law, 0 behind the head or in eclipse:
/// Wertz, *Spacecraft Attitude Determination and Control*, §7.1). The second is a crude
/// albedo model, an approximation: the sunlit Earth seen as one Lambertian source along
/// nadir whose irradiance, relative to the Sun's, is the albedo coefficient times the
/// solid-angle factor (R_E/r)², weighted by the head's cosine to nadir and by how sunlit
/// the sub-satellite point is (ŝ·r̂); it ignores the Earth's finite extent, the phase of
/// the lit crescent and the reflectivity's variation (for those see Bhanderi, *Spacecraft
/// Attitude Determination with Earth Albedo Corrected Sun Sensor Measurements*, 2005).
/// The noise is added last and the sum floored at 0 (a photocell does not read negative).
#[derive(Clone, Debug)]
pub struct CoarseSunSensors {
    pub spec: CssSpec,
    normals: Vec<Vec3>,
    rng: ChaCha8Rng,
    clock: Clock,
    last: CssReading,
}

impl CoarseSunSensors {
    pub fn new(spec: CssSpec, scenario_seed: u64, index: u32) -> Self {
        assert!(
            (1..=MAX_CSS_HEADS).contains(&spec.normals_body.len()),
            "coarse sun sensors need 1 to {MAX_CSS_HEADS} heads"
        );
        let normals = spec.normals_body.iter().map(|n| Vec3::from(*n).normalize()).collect();
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            normals,
            rng: sensor_rng(scenario_seed, index),
            last: CssReading::default(),
        }
    }

    /// Pure: noise-free outputs (direct + albedo) per head for attitude `q_ib`.
    pub fn ideal(&self, q_ib: &Quat, g: &CssGeometry) -> [f64; MAX_CSS_HEADS] {
        let q = UnitQuaternion::from_quaternion(*q_ib);
        let s_body = q.inverse_transform_vector(&g.sun_ref.normalize());
        let r = g.r_m.norm();
        let r_hat = g.r_m / r;
        let nadir_body = q.inverse_transform_vector(&-r_hat);
        let lit = g.sun_ref.normalize().dot(&r_hat).max(0.0);
        let scale = self.spec.albedo * (crate::environment::orbit::R_E / r).powi(2) * lit;
        let mut out = [0.0; MAX_CSS_HEADS];
        for (o, n) in out.iter_mut().zip(&self.normals) {
            let direct = if g.eclipse { 0.0 } else { n.dot(&s_body).max(0.0) };
            let albedo = if scale > 0.0 { scale * n.dot(&nadir_body).max(0.0) } else { 0.0 };
            *o = direct + albedo;
        }
        out
    }

    /// Discrete: attitude and geometry at `t`; samples if due (one normal per head),
    /// returns the held reading.
    pub fn update(&mut self, t_s: f64, q_ib: &Quat, g: &CssGeometry) -> CssReading {
        if self.clock.due(t_s).is_some() {
            let mut out = self.ideal(q_ib, g);
            for o in out.iter_mut().take(self.normals.len()) {
                let n: f64 = StandardNormal.sample(&mut self.rng);
                *o = (*o + n * self.spec.noise).max(0.0);
            }
            self.last = CssReading { t_s, output: out, valid: true };
        }
        self.last
    }

    pub fn heads(&self) -> usize {
        self.normals.len()
    }

    pub fn reading(&self) -> CssReading {
        self.last
    }
}

// ------------------------------------------------------------------------ GNSS receiver

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GnssSpec {
    pub rate_hz: f64,
    /// 1σ white noise per axis of the position fix, m.
    pub position_noise_m: f64,
    /// 1σ white noise per axis of the velocity fix, m/s.
    pub velocity_noise_m_s: f64,
    /// Intervals `[start, end]` (s, closed) without a fix.
    pub outages_s: Vec<[f64; 2]>,
}

/// One navigation fix (same frame as the truth given, inertial).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    pub t_s: f64,
    pub pos_m: [f64; 3],
    pub vel_m_s: [f64; 3],
}

/// GNSS receiver: a fix `r + n_r`, `v + n_v` (white, per axis) at each point of its sample
/// grid outside the outages, nothing otherwise (no hold: the flight code sees each fix
/// once). Six normals are drawn at every grid point, outage or not, so an outage does not
/// shift the later noise.
#[derive(Clone, Debug)]
pub struct GnssReceiver {
    pub spec: GnssSpec,
    rng: ChaCha8Rng,
    clock: Clock,
}

impl GnssReceiver {
    pub fn new(spec: GnssSpec, scenario_seed: u64, index: u32) -> Self {
        Self { clock: Clock::new(spec.rate_hz), spec, rng: sensor_rng(scenario_seed, index) }
    }

    /// True when `t_s` is inside an outage.
    pub fn in_outage(&self, t_s: f64) -> bool {
        self.spec.outages_s.iter().any(|[a, b]| (*a..=*b).contains(&t_s))
    }

    /// Discrete: true position and velocity at `t`; `Some(fix)` on a grid point outside
    /// the outages.
    pub fn update(&mut self, t_s: f64, r_m: &[f64; 3], v_m_s: &[f64; 3]) -> Option<GnssFix> {
        self.clock.due(t_s)?;
        let nr = gauss3(&mut self.rng, &[self.spec.position_noise_m; 3]);
        let nv = gauss3(&mut self.rng, &[self.spec.velocity_noise_m_s; 3]);
        if self.in_outage(t_s) {
            return None;
        }
        Some(GnssFix { t_s, pos_m: (Vec3::from(*r_m) + nr).into(), vel_m_s: (Vec3::from(*v_m_s) + nv).into() })
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    /// Overlapping Allan deviation of a rate series sampled at `tau0`, cluster size `m`.
    fn adev(rate: &[f64], tau0: f64, m: usize) -> f64 {
        let mut theta = vec![0.0; rate.len() + 1];
        for (k, w) in rate.iter().enumerate() {
            theta[k + 1] = theta[k] + w * tau0;
        }
        let n = theta.len();
        let tau = m as f64 * tau0;
        let s: f64 = (0..n - 2 * m)
            .map(|k| {
                let d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
                d * d
            })
            .sum();
        (s / (2.0 * tau * tau * (n - 2 * m) as f64)).sqrt()
    }

    /// Least-squares slope of log σ against log τ.
    fn slope(pts: &[(f64, f64)]) -> f64 {
        let l: Vec<(f64, f64)> = pts.iter().map(|(t, s)| (t.ln(), s.ln())).collect();
        let n = l.len() as f64;
        let (mx, my) = (l.iter().map(|p| p.0).sum::<f64>() / n, l.iter().map(|p| p.1).sum::<f64>() / n);
        l.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / l.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
    }

    fn gyro_spec() -> GyroSpec {
        GyroSpec {
            rate_hz: 10.0,
            arw_rad_s_rthz: [1e-3, 2e-3, 5e-4],
            rrw_rad_s2_rthz: [1e-4, 5e-5, 2e-4],
            bias_rad_s: [0.0; 3],
            scale_factor: [0.0; 3],
            misalignment_rad: [0.0; 3],
            saturation_rad_s: None,
            quantisation_rad_s: 0.0,
            bias_instability_rad_s: 0.0,
            bias_correlation_s: 0.0,
        }
    }

    #[test]
    fn gyro_allan_deviation() {
        // 8 independent gyros (sensor indices 0..8), 10⁵ s each at 10 Hz; Allan variances
        // averaged over the runs (long-τ estimates have few degrees of freedom).
        let spec = gyro_spec();
        let (f, n, runs) = (spec.rate_hz, 1_000_000, 8);
        let short_m = [1usize, 2, 4, 8]; // τ = 0.1 … 0.8 s (ARW region, τ ≪ √3 N/K ≥ 4 s)
        let long_m = [5000usize, 10000, 20000]; // τ = 500 … 2000 s (RRW region)
        let mut avar = [[0.0; 7]; 3];
        for run in 0..runs {
            let mut g = Gyro::new(spec, 7, run);
            let mut series = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for k in 0..n {
                let r = g.update(k as f64 / f, &[0.0; 3]);
                for a in 0..3 {
                    series[a][k] = r.rate_rad_s[a];
                }
            }
            for a in 0..3 {
                for (j, &m) in short_m.iter().chain(&long_m).enumerate() {
                    avar[a][j] += adev(&series[a], 1.0 / f, m).powi(2) / runs as f64;
                }
            }
        }
        for a in 0..3 {
            let (nn, kk) = (spec.arw_rad_s_rthz[a], spec.rrw_rad_s2_rthz[a]);
            let pts: Vec<(f64, f64)> =
                short_m.iter().chain(&long_m).zip(avar[a]).map(|(&m, v)| (m as f64 / f, v.sqrt())).collect();
            let (short, long) = pts.split_at(short_m.len());
            let (ss, sl) = (slope(short), slope(long));
            let arw_fit = short.iter().map(|(t, s)| s * t.sqrt()).sum::<f64>() / short.len() as f64;
            // RRW magnitude with the (small) white-noise share removed.
            let rrw_fit =
                long.iter().map(|(t, s)| ((s * s - nn * nn / t) * 3.0 / t).sqrt()).sum::<f64>() / long.len() as f64;
            println!(
                "axis {a}: short slope {ss:+.3}, N fit {arw_fit:.4e} (true {nn:.1e}, {:+.1}%); \
                 long slope {sl:+.3}, K fit {rrw_fit:.4e} (true {kk:.1e}, {:+.1}%)",
                100.0 * (arw_fit / nn - 1.0),
                100.0 * (rrw_fit / kk - 1.0)
            );
            assert!((ss + 0.5).abs() < 0.03, "ARW slope {ss}");
            assert!((arw_fit / nn - 1.0).abs() < 0.10, "ARW {arw_fit}");
            assert!((sl - 0.5).abs() < 0.1, "RRW slope {sl}");
            assert!((rrw_fit / kk - 1.0).abs() < 0.2, "RRW {rrw_fit}");
        }
    }

    #[test]
    fn bias_random_walk_variance_grows_linearly() {
        let mut spec = gyro_spec();
        spec.arw_rad_s_rthz = [0.0; 3];
        spec.bias_rad_s = [1.0, 2.0, 3.0];
        let (runs, checks) = (4000, [10usize, 100, 1000]); // sample counts at 10 Hz
        let mut sum2 = [[0.0; 3]; 3];
        for r in 0..runs {
            let mut g = Gyro::new(spec, 1234, r as u32);
            let mut ci = 0;
            for k in 0..=1000 {
                g.update(k as f64 / spec.rate_hz, &[0.0; 3]);
                if k == checks[ci] {
                    let b = g.bias_rad_s();
                    for a in 0..3 {
                        sum2[ci][a] += (b[a] - spec.bias_rad_s[a]).powi(2);
                    }
                    ci = (ci + 1).min(2);
                }
            }
        }
        for (ci, &k) in checks.iter().enumerate() {
            let t = k as f64 / spec.rate_hz;
            for a in 0..3 {
                let ratio = sum2[ci][a] / runs as f64 / (spec.rrw_rad_s2_rthz[a].powi(2) * t);
                println!("t = {t:6.1} s axis {a}: var / (K² t) = {ratio:.3}");
                // 4000 runs: 1σ of a variance estimate is √(2/4000) = 2.2 %.
                assert!((ratio - 1.0).abs() < 0.08, "{ratio}");
            }
        }
    }

    #[test]
    fn gyro_scale_factor_bias_and_hold() {
        let spec = GyroSpec {
            rate_hz: 4.0,
            arw_rad_s_rthz: [0.0; 3],
            rrw_rad_s2_rthz: [0.0; 3],
            bias_rad_s: [1e-3, 0.0, -1e-3],
            scale_factor: [0.01, -0.02, 0.0],
            misalignment_rad: [0.0; 3],
            saturation_rad_s: None,
            quantisation_rad_s: 0.0,
            bias_instability_rad_s: 0.0,
            bias_correlation_s: 0.0,
        };
        let mut g = Gyro::new(spec, 1, 0);
        let r = g.update(0.0, &[0.1, 0.1, 0.1]);
        assert!(r.valid);
        let want = [0.101 + 1e-3, 0.098, 0.1 - 1e-3];
        for a in 0..3 {
            assert!((r.rate_rad_s[a] - want[a]).abs() < 1e-15);
        }
        // Held until the next 0.25 s grid point (steps of 0.1 s: sample at 0.3).
        assert_eq!(g.update(0.1, &[0.0; 3]), r);
        assert_eq!(g.update(0.2, &[0.0; 3]), r);
        let r2 = g.update(0.3, &[0.0; 3]);
        assert_eq!((r2.t_s, r2.rate_rad_s), (0.3, [1e-3, 0.0, -1e-3]));
        assert_eq!(g.update(0.4, &[5.0; 3]), r2);
    }

    fn noiseless_gyro() -> GyroSpec {
        GyroSpec { arw_rad_s_rthz: [0.0; 3], rrw_rad_s2_rthz: [0.0; 3], ..gyro_spec() }
    }

    #[test]
    fn gyro_misalignment_rotates_a_known_rate() {
        // Triad turned 90° about body z: its x axis is body y, its y axis is body −x, so a
        // body rate (1, 2, 3) reads (2, −1, 3).
        let spec = GyroSpec { misalignment_rad: [0.0, 0.0, std::f64::consts::FRAC_PI_2], ..noiseless_gyro() };
        let r = Gyro::new(spec, 1, 0).update(0.0, &[1.0, 2.0, 3.0]);
        let want = [2.0, -1.0, 3.0];
        for a in 0..3 {
            assert!((r.rate_rad_s[a] - want[a]).abs() < 1e-15, "{:?}", r.rate_rad_s);
        }
        // Small misalignment θ: reading ≈ ω − θ × ω to first order, error O(|θ|² |ω|).
        let th = [1e-3, -2e-3, 0.5e-3];
        let spec = GyroSpec { misalignment_rad: th, ..noiseless_gyro() };
        let w = Vec3::new(0.1, -0.05, 0.2);
        let r = Gyro::new(spec, 1, 0).update(0.0, &w.into());
        let lin = w - Vec3::from(th).cross(&w);
        assert!((Vec3::from(r.rate_rad_s) - lin).norm() < 1e-5 * w.norm(), "{:?} vs {lin:?}", r.rate_rad_s);
        // A rotation preserves the magnitude exactly.
        assert!((Vec3::from(r.rate_rad_s).norm() - w.norm()).abs() < 1e-15);
    }

    #[test]
    fn gyro_saturation_clips_exactly() {
        let spec = GyroSpec { saturation_rad_s: Some(0.5), bias_rad_s: [0.1, 0.0, 0.0], ..noiseless_gyro() };
        let mut g = Gyro::new(spec, 1, 0);
        // Axis x: 0.45 + bias 0.1 exceeds the range; y, z inside / below it.
        let r = g.update(0.0, &[0.45, 0.3, -7.0]);
        assert_eq!(r.rate_rad_s, [0.5, 0.3, -0.5]);
        let r = g.update(1.0, &[0.39, -0.5, 0.5]);
        assert!((r.rate_rad_s[0] - 0.49).abs() < 1e-15);
        assert_eq!(&r.rate_rad_s[1..], &[-0.5, 0.5]);
    }

    #[test]
    fn gyro_quantisation_error_is_uniform_within_half_lsb() {
        // Noiseless gyro fed a ramp of golden-ratio × LSB steps (~62 000 LSBs): the
        // fractional part of ω/LSB is equidistributed: the error q(ω) − ω must stay in ±LSB/2 with
        // mean 0 and variance LSB²/12 (uniform quantisation noise).
        let lsb = 1e-4;
        let spec = GyroSpec { quantisation_rad_s: lsb, ..noiseless_gyro() };
        let mut g = Gyro::new(spec, 1, 0);
        let n = 100_000;
        let step = 0.618_033_988_749_895 * lsb;
        let (mut sum, mut sum2, mut max) = (0.0, 0.0, 0.0_f64);
        for k in 0..n {
            let w = -0.05 + k as f64 * step;
            let (w0, w1) = (w, 2.0 * w + 0.01);
            let r = g.update(k as f64 / spec.rate_hz, &[w0, w1, 0.0]);
            for (a, &wa) in [w0, w1].iter().enumerate() {
                let e = r.rate_rad_s[a] - wa;
                let lsbs = r.rate_rad_s[a] / lsb;
                assert!((lsbs - lsbs.round()).abs() < 1e-6, "not on the LSB grid: {lsbs}");
                sum += e;
                sum2 += e * e;
                max = max.max(e.abs());
            }
        }
        let m = 2.0 * n as f64;
        let (mean, var) = (sum / m, sum2 / m - (sum / m).powi(2));
        let ratio = var / (lsb * lsb / 12.0);
        println!(
            "quantisation: mean {:.2e} LSB, var / (LSB²/12) = {ratio:.4}, max |e| {:.4} LSB",
            mean / lsb,
            max / lsb
        );
        assert!(max <= 0.5 * lsb * (1.0 + 1e-9), "{max}");
        // Equidistributed (not random) fractional parts: deviations O(1/n), far below 1 %.
        assert!(mean.abs() < 0.01 * lsb, "{mean}");
        assert!((ratio - 1.0).abs() < 0.01, "{ratio}");
    }

    fn ideal_tracker() -> AttitudeSensorSpec {
        AttitudeSensorSpec {
            rate_hz: 5.0,
            noise_rad: [0.0; 3],
            bias_rad: [0.0; 3],
            max_rate_rad_s: None,
            boresight_body: None,
            sun_exclusion_rad: None,
            earth_exclusion_rad: None,
        }
    }

    #[test]
    fn tracker_noise_split_cross_and_about_boresight() {
        // Boresight (1, 1, 0)/√2. The error rotation's covariance, projected on the
        // boresight and on two perpendicular axes chosen here (body z and b × z, not the
        // model's own tracker axes), must be diag(cross², cross², about²).
        let (cross, about) = (2e-4, 1.5e-3);
        let b = Vec3::new(1.0, 1.0, 0.0).normalize();
        let spec = AttitudeSensorSpec {
            noise_rad: [cross, cross, about],
            boresight_body: Some([1.0, 1.0, 0.0]),
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 11, 2);
        let q_true = UnitQuaternion::from_euler_angles(-0.4, 0.7, 2.0);
        let axes = [Vec3::z(), b.cross(&Vec3::z()), b];
        let n = 20_000;
        let mut c = Matrix3::zeros();
        for k in 0..n {
            let r = s.update(k as f64 / 5.0, q_true.quaternion(), &Vec3::zeros());
            let e = (q_true.inverse() * UnitQuaternion::from_quaternion(r.q_ib)).scaled_axis();
            let et = Vec3::from_fn(|i, _| axes[i].dot(&e));
            c += et * et.transpose() / n as f64;
        }
        let want = [cross * cross, cross * cross, about * about];
        println!(
            "tracker covariance / expected diagonal: {:.4} {:.4} {:.4}",
            c[(0, 0)] / want[0],
            c[(1, 1)] / want[1],
            c[(2, 2)] / want[2]
        );
        for i in 0..3 {
            // 20 000 samples: 1σ of a variance estimate √(2/n) = 1 %; tolerance 4 %.
            assert!((c[(i, i)] / want[i] - 1.0).abs() < 0.04, "{i}: {}", c[(i, i)] / want[i]);
            for j in 0..i {
                // Correlation coefficient: 1σ = 1/√n = 0.7 %; tolerance 3 %.
                let rho = c[(i, j)] / (c[(i, i)] * c[(j, j)]).sqrt();
                assert!(rho.abs() < 0.03, "rho {i}{j} = {rho}");
            }
        }
    }

    #[test]
    fn tracker_sun_and_earth_exclusion() {
        // Boresight body z; the body turned by α about y puts it at (sin α, 0, cos α) in
        // inertial axes. Sun along inertial x: boresight–Sun angle |90° − α|. Earth centre
        // along −z with angular radius 60°: boresight–limb angle (180° − α) − 60°.
        let geo =
            ExclusionGeometry { sun_ref: Vec3::x(), nadir_ref: -Vec3::z(), earth_half_angle_rad: 60f64.to_radians() };
        let att = |deg: f64| UnitQuaternion::from_axis_angle(&Vec3::y_axis(), deg.to_radians()).into_inner();
        let sun_only = AttitudeSensorSpec { sun_exclusion_rad: Some(30f64.to_radians()), ..ideal_tracker() };
        let earth_only = AttitudeSensorSpec { earth_exclusion_rad: Some(20f64.to_radians()), ..ideal_tracker() };
        let mut k = 0.0;
        let mut flag = |spec: AttitudeSensorSpec, a: f64, g: Option<&ExclusionGeometry>| {
            let mut s = AttitudeSensor::new(spec, 1, 2);
            k += 1.0;
            s.update_with(k, &att(a), &Vec3::zeros(), g).valid
        };
        for (a, valid) in
            [(0.0, true), (59.99, true), (60.01, false), (90.0, false), (119.99, false), (120.01, true), (150.0, true)]
        {
            assert_eq!(flag(sun_only, a, Some(&geo)), valid, "sun, α = {a}");
        }
        // Limb angle 120° − α ≥ 20° ⇔ α ≤ 100°.
        for (a, valid) in [(0.0, true), (99.99, true), (100.01, false), (180.0, false)] {
            assert_eq!(flag(earth_only, a, Some(&geo)), valid, "earth, α = {a}");
        }
        // Unknown geometry: no rule applied.
        assert!(flag(sun_only, 90.0, None));
        // Closed-form angles, also for a boresight off body z (body x, identity attitude):
        // Sun at 25° from x in the x-y plane; Earth centre along −x.
        let s = AttitudeSensor::new(AttitudeSensorSpec { boresight_body: Some([2.0, 0.0, 0.0]), ..sun_only }, 1, 2);
        let g2 = ExclusionGeometry {
            sun_ref: Vec3::new(25f64.to_radians().cos(), 25f64.to_radians().sin(), 0.0),
            nadir_ref: -Vec3::x(),
            earth_half_angle_rad: 0.5,
        };
        let (sun, limb) = s.exclusion_angles_rad(&Quat::identity(), &g2);
        assert!((sun - 25f64.to_radians()).abs() < 1e-12 && (limb - (std::f64::consts::PI - 0.5)).abs() < 1e-12);
        let mut s = s;
        assert!(!s.update_with(0.0, &Quat::identity(), &Vec3::zeros(), Some(&g2)).valid);
    }

    #[test]
    fn attitude_sensor_noise_and_bias() {
        let q_true = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1).into_inner();
        // Bias only: exact.
        let bias = [0.01, -0.02, 0.005];
        let spec = AttitudeSensorSpec {
            rate_hz: 5.0,
            noise_rad: [0.0; 3],
            bias_rad: bias,
            max_rate_rad_s: Some(0.03),
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 3, 1);
        let r = s.update(0.0, &q_true, &Vec3::new(0.0, 0.02, 0.0));
        assert!(r.valid);
        let err =
            (UnitQuaternion::from_quaternion(q_true).inverse() * UnitQuaternion::from_quaternion(r.q_ib)).scaled_axis();
        assert!((err - Vec3::from(bias)).norm() < 1e-15);
        // Noise: per-axis rms of the body-frame error rotation.
        let sig = [1e-3, 2e-3, 4e-4];
        // Beyond its rate limit the tracker's reading is invalid.
        assert!(!s.update(1.0, &q_true, &Vec3::new(0.0, 0.02, 0.025)).valid);
        let spec = AttitudeSensorSpec {
            rate_hz: 5.0,
            noise_rad: sig,
            bias_rad: [0.0; 3],
            max_rate_rad_s: None,
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 3, 1);
        let n = 20_000;
        let mut ss = Vec3::zeros();
        for k in 0..n {
            let r = s.update(k as f64 / 5.0, &q_true, &Vec3::new(1.0, 0.0, 0.0));
            let e = (UnitQuaternion::from_quaternion(q_true).inverse() * UnitQuaternion::from_quaternion(r.q_ib))
                .scaled_axis();
            ss += e.component_mul(&e);
        }
        for a in 0..3 {
            let rms = (ss[a] / n as f64).sqrt();
            assert!((rms / sig[a] - 1.0).abs() < 0.03, "axis {a}: {rms}");
        }
    }

    #[test]
    fn magnetometer_sees_torquers_only_when_on() {
        use crate::plant::magnetorquers::MagnetorquerSet;
        let spec = MagnetometerSpec {
            rate_hz: 10.0,
            noise_t: [0.0; 3],
            bias_t: [0.0; 3],
            coupling_t_per_am2: [[2e-6, 0.0, 1e-7], [0.0, -3e-6, 0.0], [5e-7, 0.0, 1e-6]],
            misalignment_rad: [0.0; 3],
        };
        let rig = MagnetorquerSet::paper003_rig();
        let b = [20e-6, -5e-6, 40e-6];
        let mut m = Magnetometer::new(spec, 9, 2);
        // Off, and commanded inside the dead band (the rods produce nothing): truth.
        assert_eq!(m.update(0.0, &b, &rig.rod_dipole_am2(&rig.realised(&[0.0; 3]))).b_body_t, b);
        assert_eq!(m.update(0.1, &b, &rig.rod_dipole_am2(&rig.realised(&[1.0, -1.0, 1.5]))).b_body_t, b);
        // On: B + C m.
        let dip = rig.rod_dipole_am2(&rig.realised(&[5.0, 0.0, -3.0]));
        let r = m.update(0.2, &b, &dip).b_body_t;
        let want = [20e-6 + 10e-6 - 3e-7, -5e-6, 40e-6 + 2.5e-6 - 3e-6];
        for a in 0..3 {
            assert!((r[a] - want[a]).abs() < 1e-18, "{r:?}");
        }
        // Noise and bias statistics.
        let spec = MagnetometerSpec { noise_t: [1e-7, 2e-7, 5e-8], bias_t: [1e-6, 0.0, -1e-6], ..spec };
        let mut m = Magnetometer::new(spec, 9, 2);
        let n = 20_000;
        let (mut s1, mut s2) = (Vec3::zeros(), Vec3::zeros());
        for k in 0..n {
            let e = Vec3::from(m.update(k as f64 / 10.0, &b, &[0.0; 3]).b_body_t) - Vec3::from(b);
            s1 += e;
            s2 += e.component_mul(&e);
        }
        for a in 0..3 {
            let mean = s1[a] / n as f64;
            let sd = (s2[a] / n as f64 - mean * mean).sqrt();
            assert!((mean - spec.bias_t[a]).abs() < 4.0 * spec.noise_t[a] / (n as f64).sqrt());
            assert!((sd / spec.noise_t[a] - 1.0).abs() < 0.03);
        }
    }

    #[test]
    fn sun_sensor_validity() {
        let spec = SunSensorSpec {
            rate_hz: 2.0,
            noise_rad: 1e-3,
            boresight_body: [0.0, 0.0, 1.0],
            fov_half_angle_rad: 60f64.to_radians(),
        };
        let mut s = SunSensor::new(spec, 5, 3);
        let q = Quat::identity();
        // Sun along +z body: valid, close to truth.
        let r = s.update(0.0, &q, &[0.0, 0.0, 1.5e11], false);
        assert!(r.valid && (Vec3::from(r.sun_body) - Vec3::z()).norm() < 6e-3);
        // Eclipse.
        let r = s.update(0.5, &q, &[0.0, 0.0, 1.0], true);
        assert!(!r.valid && r.sun_body == [0.0; 3]);
        // 59° and 61° off boresight; sun behind.
        let dir = |deg: f64| [deg.to_radians().sin(), 0.0, deg.to_radians().cos()];
        assert!(s.update(1.0, &q, &dir(59.0), false).valid);
        assert!(!s.update(1.5, &q, &dir(61.0), false).valid);
        assert!(!s.update(2.0, &q, &[0.0, 0.0, -1.0], false).valid);
        // q_ib = 90° about x maps body z to inertial -y, so an inertial +y sun is body -z.
        let qx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2).into_inner();
        let sb = sun_in_body(&qx, &[0.0, 1.0, 0.0]);
        assert!((Vec3::from(sb) + Vec3::z()).norm() < 1e-15, "{sb:?}");
        // Angular noise: rms total angle ≈ √2 σ.
        let n = 20_000;
        let mut s2 = 0.0;
        for k in 0..n {
            let r = s.update(2.5 + k as f64 / 2.0, &q, &[0.0, 0.0, 1.0], false);
            s2 += Vec3::from(r.sun_body).angle(&Vec3::z()).powi(2);
        }
        let rms = (s2 / n as f64 / 2.0).sqrt();
        assert!((rms / 1e-3 - 1.0).abs() < 0.03, "{rms}");
        // Cylindrical shadow.
        let sun = [1.0, 0.0, 0.0];
        assert!(cylindrical_eclipse(&[-7.0e6, 0.0, 0.0], &sun));
        assert!(!cylindrical_eclipse(&[7.0e6, 0.0, 0.0], &sun));
        assert!(!cylindrical_eclipse(&[-7.0e6, 6.5e6, 0.0], &sun));
    }

    #[test]
    fn gyro_bias_instability_is_gauss_markov() {
        // σ = 1e-4 rad/s, τ = 20 s at 10 Hz; 8 gyros × 40 000 s (2000 τ each). Truth: a
        // stationary first-order Gauss–Markov process has variance σ² and autocorrelation
        // e^{−|lag|/τ}, so e^{−1} at lag τ.
        let (sigma, tau, f) = (1e-4, 20.0, 10.0);
        let spec = GyroSpec { bias_instability_rad_s: sigma, bias_correlation_s: tau, rate_hz: f, ..noiseless_gyro() };
        let (n, runs, lag) = (400_000usize, 8u32, (tau * f) as usize);
        let (mut s2, mut c_lag, mut m) = (0.0, 0.0, 0.0);
        let mut c_lag_n = 0.0;
        for run in 0..runs {
            let mut g = Gyro::new(spec, 99, run);
            let mut series = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for k in 0..n {
                let r = g.update(k as f64 / f, &[0.0; 3]);
                let b = g.bias_instability_state_rad_s();
                for a in 0..3 {
                    // Noise-free gyro at rest: the reading is the bias.
                    assert_eq!(r.rate_rad_s[a], b[a]);
                    series[a][k] = b[a];
                }
            }
            for x in &series {
                for k in 0..n {
                    s2 += x[k] * x[k];
                    m += 1.0;
                    if k + lag < n {
                        c_lag += x[k] * x[k + lag];
                        c_lag_n += 1.0;
                    }
                }
            }
        }
        let var = s2 / m;
        let rho = (c_lag / c_lag_n) / var;
        println!(
            "Gauss–Markov: var / σ² = {:.4}, autocorrelation at τ = {rho:.4} (e^-1 = 0.3679)",
            var / sigma.powi(2)
        );
        // Variance estimate of an AR(1) series: relative 1σ ≈ √(2τ/T) = √(2·20/960 000 s) = 0.6 %.
        assert!((var / sigma.powi(2) - 1.0).abs() < 0.04, "{var}");
        // Autocorrelation estimate: 1σ ≈ √(τ/T) ≈ 0.5 %; tolerance 0.02.
        assert!((rho - (-1.0f64).exp()).abs() < 0.02, "{rho}");
    }

    #[test]
    fn gyro_bias_instability_adds_to_an_unchanged_white_noise() {
        // Own stream: with the instability on, the reading is the same white noise and
        // random walk plus the Gauss–Markov state (to rounding).
        let base = gyro_spec();
        let on = GyroSpec { bias_instability_rad_s: 3e-4, bias_correlation_s: 5.0, ..base };
        let (mut a, mut b) = (Gyro::new(base, 5, 1), Gyro::new(on, 5, 1));
        for k in 0..1000 {
            let t = k as f64 / base.rate_hz;
            let (ra, rb) = (a.update(t, &[0.01, 0.0, -0.02]), b.update(t, &[0.01, 0.0, -0.02]));
            let gm = b.bias_instability_state_rad_s();
            assert!(gm.iter().all(|x| *x != 0.0));
            for i in 0..3 {
                assert!((rb.rate_rad_s[i] - ra.rate_rad_s[i] - gm[i]).abs() < 1e-15, "{k} {i}");
            }
        }
    }

    /// Independent rotation: Rodrigues' formula for the components of `v` in axes turned
    /// by the rotation vector `th` (i.e. R(θ)ᵀ v).
    fn rodrigues_transpose(th: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
        let ang = (th[0] * th[0] + th[1] * th[1] + th[2] * th[2]).sqrt();
        let k = [th[0] / ang, th[1] / ang, th[2] / ang];
        let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        let kxv = [k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]];
        let (s, c) = ang.sin_cos();
        [0, 1, 2].map(|i| v[i] * c - s * kxv[i] + (1.0 - c) * kv * k[i])
    }

    #[test]
    fn magnetometer_misalignment_rotates_the_field_exactly() {
        let b: [f64; 3] = [23e-6, -7e-6, 41e-6];
        let bn = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        for th_deg in [[0.0, 0.0, 90.0], [1.0, -2.0, 0.5], [30.0, 20.0, -45.0]] {
            let th = th_deg.map(f64::to_radians);
            let spec = MagnetometerSpec {
                rate_hz: 10.0,
                noise_t: [0.0; 3],
                bias_t: [0.0; 3],
                coupling_t_per_am2: [[0.0; 3]; 3],
                misalignment_rad: th,
            };
            let r = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[0.0; 3]).b_body_t;
            let want = rodrigues_transpose(&th, &b);
            let err = (0..3).map(|i| (r[i] - want[i]).powi(2)).sum::<f64>().sqrt() / bn;
            println!("magnetometer misalignment {th_deg:?} deg: relative error {err:.1e}");
            assert!(err < 1e-15, "{th_deg:?}: {r:?} vs {want:?}");
            // Bias and coupling come after the rotation (in sensor axes), unrotated.
            let spec =
                MagnetometerSpec { bias_t: [1e-6, 2e-6, -3e-6], coupling_t_per_am2: [[1e-6, 0.0, 0.0]; 3], ..spec };
            let r2 = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[2.0, 0.0, 0.0]).b_body_t;
            for i in 0..3 {
                assert!((r2[i] - (want[i] + spec.bias_t[i] + 2e-6)).abs() < 1e-15 * bn, "{r2:?}");
            }
        }
        // 90° about z: sensor x = body y, sensor y = body −x.
        let spec = MagnetometerSpec {
            rate_hz: 1.0,
            noise_t: [0.0; 3],
            bias_t: [0.0; 3],
            coupling_t_per_am2: [[0.0; 3]; 3],
            misalignment_rad: [0.0, 0.0, std::f64::consts::FRAC_PI_2],
        };
        let r = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[0.0; 3]).b_body_t;
        assert!((r[0] - b[1]).abs() < 1e-15 * bn && (r[1] + b[0]).abs() < 1e-15 * bn && r[2] == b[2], "{r:?}");
    }

    fn css_spec(noise: f64, albedo: f64) -> CssSpec {
        CssSpec {
            rate_hz: 10.0,
            normals_body: vec![
                [1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            noise,
            albedo,
        }
    }

    /// Independent body components of an inertial vector: Rᵀ v with R the direction cosine
    /// matrix of the unit quaternion (x, y, z, w) written out (Markley & Crassidis eq. 2.125).
    fn to_body(q: &[f64; 4], v: &Vec3) -> Vec3 {
        let [x, y, z, w] = *q;
        let r = Matrix3::new(
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        );
        r.transpose() * v
    }

    #[test]
    fn css_cosine_response_is_exact_for_random_attitudes() {
        let mut css = CoarseSunSensors::new(css_spec(0.0, 0.0), 1, 5);
        let mut rng = sensor_rng(2024, 77);
        let sun = Vec3::new(0.3, -0.8, 0.52).normalize();
        let g = CssGeometry { sun_ref: sun, r_m: Vec3::new(7.0e6, 0.0, 0.0), eclipse: false };
        let mut worst = 0.0_f64;
        for k in 0..2000 {
            let v = gauss3(&mut rng, &[1.0; 3]);
            let w: f64 = StandardNormal.sample(&mut rng);
            let nq = (v.norm_squared() + w * w).sqrt();
            let qv = [v.x / nq, v.y / nq, v.z / nq, w / nq];
            let r = css.update(k as f64 / 10.0, &Quat::new(qv[3], qv[0], qv[1], qv[2]), &g);
            assert!(r.valid);
            let s_b = to_body(&qv, &sun);
            for (i, n) in css.spec.normals_body.clone().iter().enumerate() {
                let want = Vec3::from(*n).normalize().dot(&s_b).max(0.0);
                worst = worst.max((r.output[i] - want).abs());
            }
        }
        println!("css cosine law: worst |error| {worst:.1e}");
        // Two rounding paths (nalgebra's quaternion rotation vs the DCM above): a few ulps.
        assert!(worst < 5e-15, "{worst}");
    }

    #[test]
    fn css_eclipse_and_albedo_closed_forms() {
        // Identity attitude, r along +x at 7000 km: nadir is body −x (head 1), zenith +x
        // (head 0). Sun at β from r̂ in the x-y plane. Closed forms: head 0 reads cos β
        // (direct only, it cannot see nadir); head 1 sees no Sun (β < 90°) and the albedo
        // a (R_E/r)² cos β; head 2 (+y) reads sin β directly plus nothing from nadir.
        let (a, r) = (0.3, 7.0e6);
        let css = CoarseSunSensors::new(css_spec(0.0, a), 1, 5);
        let q = Quat::identity();
        for beta_deg in [0.0, 30.0, 60.0, 89.0] {
            let beta = f64::to_radians(beta_deg);
            let g = CssGeometry {
                sun_ref: Vec3::new(beta.cos(), beta.sin(), 0.0),
                r_m: Vec3::new(r, 0.0, 0.0),
                eclipse: false,
            };
            let y = css.ideal(&q, &g);
            let albedo = a * (crate::environment::orbit::R_E / r).powi(2) * beta.cos();
            assert!((y[0] - beta.cos()).abs() < 1e-15, "{beta_deg}: {y:?}");
            assert!((y[1] - albedo).abs() < 1e-15 * albedo.max(1e-300), "{beta_deg}: {} vs {albedo}", y[1]);
            assert!((y[2] - beta.sin()).abs() < 1e-15, "{beta_deg}: {y:?}");
        }
        // Sub-satellite point in the night (Sun behind the Earth): no albedo.
        let night = CssGeometry { sun_ref: -Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: false };
        assert_eq!(css.ideal(&q, &night)[1], 1.0, "nadir head sees the Sun directly, no albedo");
        // Eclipse: the direct term vanishes on every head; with albedo off all read 0.
        let ecl = CssGeometry { sun_ref: -Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: true };
        assert_eq!(css.ideal(&q, &ecl), [0.0; MAX_CSS_HEADS]);
        let mut dark = CoarseSunSensors::new(css_spec(0.0, 0.0), 1, 5);
        let lit_but_flagged = CssGeometry { sun_ref: Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: true };
        let rd = dark.update(0.0, &q, &lit_but_flagged);
        assert!(rd.valid && rd.output == [0.0; MAX_CSS_HEADS], "{rd:?}");
    }

    #[test]
    fn css_noise_sigma() {
        // Head 0 faces the Sun at 60°: mean 0.5, 1σ 0.01 (50σ above the floor at 0).
        let sigma = 0.01;
        let mut css = CoarseSunSensors::new(css_spec(sigma, 0.0), 8, 5);
        let b = 60f64.to_radians();
        let g =
            CssGeometry { sun_ref: Vec3::new(b.cos(), b.sin(), 0.0), r_m: Vec3::new(7.0e6, 0.0, 0.0), eclipse: false };
        let n = 20_000;
        let (mut s1, mut s2) = (0.0, 0.0);
        for k in 0..n {
            let e = css.update(k as f64 / 10.0, &Quat::identity(), &g).output[0] - 0.5;
            s1 += e;
            s2 += e * e;
        }
        let mean = s1 / n as f64;
        let sd = (s2 / n as f64 - mean * mean).sqrt();
        println!("css noise: mean {mean:.2e}, sd / σ = {:.4}", sd / sigma);
        // 20 000 samples: 1σ of the sd estimate 0.5 %; tolerance 3 %.
        assert!((sd / sigma - 1.0).abs() < 0.03, "{sd}");
        assert!(mean.abs() < 4.0 * sigma / (n as f64).sqrt(), "{mean}");
        // Floored at 0: a head facing away reads max(0, noise) ≥ 0, about half the time > 0.
        let mut pos = 0;
        for k in n..n + 2000 {
            let y = css.update(k as f64 / 10.0, &Quat::identity(), &g).output[1];
            assert!(y >= 0.0);
            pos += usize::from(y > 0.0);
        }
        assert!((pos as f64 / 2000.0 - 0.5).abs() < 0.05, "{pos}");
    }

    #[test]
    fn gnss_fix_noise_statistics_and_outages() {
        let spec = GnssSpec { rate_hz: 1.0, position_noise_m: 5.0, velocity_noise_m_s: 0.05, outages_s: vec![] };
        let mut g = GnssReceiver::new(spec.clone(), 3, 6);
        let (r, v) = ([7.0e6, -1.0e5, 2.0e5], [10.0, 7500.0, -30.0]);
        let n = 20_000;
        let (mut sr, mut sr2, mut sv, mut sv2) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..n {
            let fix = g.update(k as f64, &r, &v).expect("fix every second");
            for i in 0..3 {
                let (er, ev) = (fix.pos_m[i] - r[i], fix.vel_m_s[i] - v[i]);
                sr += er;
                sr2 += er * er;
                sv += ev;
                sv2 += ev * ev;
            }
        }
        let m = 3.0 * n as f64;
        let (sd_r, sd_v) = ((sr2 / m - (sr / m).powi(2)).sqrt(), (sv2 / m - (sv / m).powi(2)).sqrt());
        println!("gnss noise: position sd / σ = {:.4}, velocity sd / σ = {:.4}", sd_r / 5.0, sd_v / 0.05);
        // 60 000 samples: 1σ of the sd estimate 0.3 %; tolerance 2 %.
        assert!((sd_r / 5.0 - 1.0).abs() < 0.02 && (sd_v / 0.05 - 1.0).abs() < 0.02);
        assert!((sr / m).abs() < 4.0 * 5.0 / m.sqrt() && (sv / m).abs() < 4.0 * 0.05 / m.sqrt());
        // Outage: the same noise before and after it (draws continue inside).
        let out = GnssSpec { outages_s: vec![[10.0, 19.5]], ..spec.clone() };
        let (mut a, mut b) = (GnssReceiver::new(spec, 4, 6), GnssReceiver::new(out, 4, 6));
        for k in 0..40 {
            let (fa, fb) = (a.update(k as f64, &r, &v), b.update(k as f64, &r, &v));
            if (10..=19).contains(&k) {
                assert!(fb.is_none(), "{k}");
            } else {
                assert_eq!(fa, fb, "{k}");
            }
        }
    }

    #[test]
    fn determinism_and_independent_streams() {
        let spec = gyro_spec();
        let run = |seed, idx, with_other: bool| {
            let mut g = Gyro::new(spec, seed, idx);
            let mut other = Magnetometer::new(
                MagnetometerSpec {
                    rate_hz: 10.0,
                    noise_t: [1e-7; 3],
                    bias_t: [0.0; 3],
                    coupling_t_per_am2: [[0.0; 3]; 3],
                    misalignment_rad: [0.0; 3],
                },
                seed,
                idx + 1,
            );
            (0..1000)
                .map(|k| {
                    let t = k as f64 / 10.0;
                    if with_other {
                        other.update(t, &[1e-5; 3], &[0.0; 3]);
                    }
                    g.update(t, &[0.01, 0.0, 0.0]).rate_rad_s.map(f64::to_bits)
                })
                .collect::<Vec<_>>()
        };
        let a = run(42, 0, false);
        assert_eq!(a, run(42, 0, false), "same seed, same bits");
        assert_eq!(a, run(42, 0, true), "another sensor does not disturb this one");
        assert_ne!(a, run(42, 1, false), "other index, other stream");
        assert_ne!(a, run(43, 0, false), "other seed, other stream");
        // Stream 0 (the existing SensorSuite's) is not used by index 0.
        let mut legacy = ChaCha8Rng::seed_from_u64(42);
        let mut idx0 = sensor_rng(42, 0);
        let (x, y): (f64, f64) = (StandardNormal.sample(&mut legacy), StandardNormal.sample(&mut idx0));
        assert_ne!(x.to_bits(), y.to_bits());
    }
}
