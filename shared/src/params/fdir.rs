//! Parameters of the fault detection monitors ([`crate::fdir`]), with their validation.
//! Wire types (postcard), ready for the uploaded parameter set; each threshold's
//! false-alarm probability is stated where it is chosen (docs/fdir.md).

/// Largest persistence window, samples (the outcomes are the bits of a `u32`).
pub const MAX_WINDOW: u8 = 32;

/// k-of-n persistence: a test fires when at least `k` of the last `n` samples exceeded
/// their threshold ([`crate::fdir::window`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KOfN {
    pub k: u8,
    pub n: u8,
}

impl KOfN {
    /// `1 ≤ k ≤ n ≤ 32`.
    pub fn valid(&self) -> bool {
        self.k >= 1 && self.k <= self.n && self.n <= MAX_WINDOW
    }
}

/// Noise of what a wheel's torque residual is computed from ([`crate::fdir::wheel`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WheelResidualNoise {
    /// White noise of one tachometer reading, rad/s (1σ, ≥ 0).
    pub tach_sigma_rad_s: f32,
    /// Quantisation step of the tachometer, rad/s (≥ 0; 0: not quantised).
    pub tach_lsb_rad_s: f32,
    /// White noise of the gyro's rate about one wheel axis, rad/s (1σ, ≥ 0; 0 when the
    /// body's rate change is not used).
    pub gyro_sigma_rad_s: f32,
}

/// The wheel monitor: a residual beyond `threshold_sigma` of its σ is an exceedance; a
/// wheel is declared failed when `window` fires.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WheelMonitorParams {
    pub noise: WheelResidualNoise,
    /// Rotor inertia about the spin axis, kg m² (> 0).
    pub inertia_kgm2: f32,
    /// Threshold on |residual| / σ (> 0). Two-sided Gaussian tail per sample:
    /// 3 → 2.7e-3, 4 → 6.3e-5, 5 → 5.7e-7.
    pub threshold_sigma: f32,
    /// A floor on the threshold, N m (≥ 0): torque errors the model does not carry
    /// (friction transients, command quantisation) below it never count.
    pub floor_nm: f32,
    pub window: KOfN,
}

/// Which monitor parameter is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FdirParamError {
    WheelNoise,
    WheelInertia,
    WheelThreshold,
    WheelWindow,
    /// The isolation's ratio or body-torque noise.
    Isolation,
    /// The star-tracker monitor's witness angle, window or repeat count.
    Tracker,
    /// The magnetometer monitor's noise, threshold, window or repeat count.
    Magnetometer,
    /// The GNSS monitor's noise, model acceleration, threshold or window.
    Gnss,
}

impl WheelMonitorParams {
    pub fn validate(&self) -> Result<(), FdirParamError> {
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        let n = &self.noise;
        if !(nonneg(n.tach_sigma_rad_s) && nonneg(n.tach_lsb_rad_s) && nonneg(n.gyro_sigma_rad_s)) {
            return Err(FdirParamError::WheelNoise);
        }
        if !(self.inertia_kgm2.is_finite() && self.inertia_kgm2 > 0.0) {
            return Err(FdirParamError::WheelInertia);
        }
        if !(self.threshold_sigma.is_finite() && self.threshold_sigma > 0.0 && nonneg(self.floor_nm)) {
            return Err(FdirParamError::WheelThreshold);
        }
        if !self.window.valid() {
            return Err(FdirParamError::WheelWindow);
        }
        Ok(())
    }
}

/// The wheel FDIR of a parameter set (params version 13): detection by the torque
/// residual ([`crate::fdir::wheel`]; the rotor inertia comes from the wheel parameters),
/// isolation rotor/tachometer ([`crate::fdir::isolate`]), recovery by dropping the wheel
/// from the allocation (docs/fdir.md "Wiring").
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WheelFdirParams {
    pub noise: WheelResidualNoise,
    /// Threshold on |residual| / σ (> 0; see [`WheelMonitorParams::threshold_sigma`]).
    pub threshold_sigma: f32,
    /// Floor on the threshold, N m (≥ 0).
    pub floor_nm: f32,
    pub window: KOfN,
    /// Isolation decides only when |residual| ≥ this many σ of the body mismatch (> 0).
    pub isolation_min_ratio: f32,
    /// Unmodelled body torque (disturbances) added in quadrature to the body mismatch's
    /// noise, N m (≥ 0).
    pub body_torque_sigma_nm: f32,
}

impl WheelFdirParams {
    /// The monitor's parameters for rotors of `inertia_kgm2`.
    pub fn monitor(&self, inertia_kgm2: f32) -> WheelMonitorParams {
        WheelMonitorParams {
            noise: self.noise,
            inertia_kgm2,
            threshold_sigma: self.threshold_sigma,
            floor_nm: self.floor_nm,
            window: self.window,
        }
    }

    pub fn validate(&self, inertia_kgm2: f32) -> Result<(), FdirParamError> {
        self.monitor(inertia_kgm2).validate()?;
        let ok = self.isolation_min_ratio.is_finite()
            && self.isolation_min_ratio > 0.0
            && self.body_torque_sigma_nm.is_finite()
            && self.body_torque_sigma_nm >= 0.0;
        if ok { Ok(()) } else { Err(FdirParamError::Isolation) }
    }
}

/// Fault detection, isolation and recovery of a parameter set (params version 13). Every
/// monitor is optional: `None` is off.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FdirParams {
    /// The wheel monitor (only on a wheel family).
    pub wheel: Option<WheelFdirParams>,
}

impl FdirParams {
    pub const OFF: Self = Self { wheel: None };
}

/// The star-tracker monitor of the estimation stage (estimation parameters, protocol
/// 21; [`crate::fdir::tracker`]): a frozen output, or an attitude the other vector
/// sensors contradict.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackerFdirParams {
    /// A measured Sun or field direction more than this from where the tracker's attitude
    /// puts it is an exceedance, rad (in (0, π)); well above the witnesses' own errors
    /// (coarse sun sensors, field model), well below what a wrong attitude does (a 180°
    /// flip about the boresight moves a direction θ off the boresight by 2θ).
    pub witness_max_rad: f32,
    /// k-of-n persistence over the fresh tracker samples judged.
    pub window: KOfN,
    /// Frozen: every quaternion component repeats more than this many times in a row
    /// (≥ 1; a live tracker's noise makes even one exact repeat of all four rare).
    pub max_repeats: u16,
}

impl TrackerFdirParams {
    pub fn validate(&self) -> Result<(), FdirParamError> {
        let angle_ok = self.witness_max_rad.is_finite()
            && self.witness_max_rad > 0.0
            && self.witness_max_rad < core::f32::consts::PI;
        if !angle_ok || !self.window.valid() || self.max_repeats == 0 {
            return Err(FdirParamError::Tracker);
        }
        Ok(())
    }
}

/// The gyro monitor of the estimation stage (protocol 21; [`crate::fdir::gyro`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroFdirParams {
    /// An axis whose rate repeats more than this many times in a row is stuck (≥ 1).
    pub max_repeats: u16,
    /// The bias-step test ([`crate::fdir::bias`], protocol 22): `k` of the last `n`
    /// corroborated tracker samples rejected by the filter's gate (χ²₃ at 0.999) declare a
    /// step (`k ≥ 2`: the step is a slope). `None`: off. Needs the star-tracker monitor
    /// (its witnesses isolate the gyro from the tracker).
    pub bias_step: Option<KOfN>,
}

impl GyroFdirParams {
    /// Whether the parameters can fly (`tracker_monitor`: the star-tracker monitor is on).
    pub fn valid(&self, tracker_monitor: bool) -> bool {
        let bias_ok = self.bias_step.is_none_or(|w| w.valid() && w.k >= 2 && tracker_monitor);
        self.max_repeats >= 1 && bias_ok
    }
}

/// The magnetometer monitor of the estimation stage (estimation parameters, protocol 23;
/// [`crate::fdir::magnetometer`]): the measured field's magnitude against the on-board
/// model, and a stuck axis. Needs the MEKF source (the field model runs only there).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagnetometerFdirParams {
    /// White noise of one magnetometer axis, T (1σ, ≥ 0).
    pub noise_t: f32,
    /// 1σ error of the on-board model's field magnitude, T (≥ 0; its degree, the
    /// navigation's position error, secular variation).
    pub model_sigma_t: f32,
    /// Threshold on |residual| / σ (> 0): two-sided Gaussian tail per sample 4 → 6.3e-5,
    /// 5 → 5.7e-7.
    pub threshold_sigma: f32,
    /// k-of-n persistence over the fresh samples judged.
    pub window: KOfN,
    /// Stuck: an axis repeating more than this many times in a row (≥ 1).
    pub max_repeats: u16,
}

impl MagnetometerFdirParams {
    pub fn validate(&self) -> Result<(), FdirParamError> {
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        // σ > 0 overall: a zero threshold would declare on any noise.
        let sigma_ok = nonneg(self.noise_t) && nonneg(self.model_sigma_t) && self.noise_t + self.model_sigma_t > 0.0;
        let threshold_ok = self.threshold_sigma.is_finite() && self.threshold_sigma > 0.0;
        if sigma_ok && threshold_ok && self.window.valid() && self.max_repeats >= 1 {
            Ok(())
        } else {
            Err(FdirParamError::Magnetometer)
        }
    }
}

/// The GNSS monitor of the estimation stage (estimation parameters, protocol 24;
/// [`crate::fdir::gnss`]): each fix against the last accepted one propagated to its time.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GnssFdirParams {
    /// White noise of one position axis of a fix, m (1σ, ≥ 0).
    pub position_sigma_m: f32,
    /// White noise of one velocity axis of a fix, m/s (1σ, ≥ 0).
    pub velocity_sigma_m_s: f32,
    /// The acceleration the two-body propagation leaves out (J2, drag; a thrust), m/s²
    /// (≥ 0): its `½ a Δt²` widens the threshold.
    pub model_accel_m_s2: f32,
    /// Threshold on the residual / σ (> 0): per fix `P(χ²₃ > γ²)`, 5 → 1.5e-5.
    pub threshold_sigma: f32,
    /// k-of-n persistence over the fixes judged.
    pub window: KOfN,
}

impl GnssFdirParams {
    pub fn validate(&self) -> Result<(), FdirParamError> {
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        let ok = nonneg(self.position_sigma_m)
            && nonneg(self.velocity_sigma_m_s)
            && nonneg(self.model_accel_m_s2)
            && self.threshold_sigma.is_finite()
            && self.threshold_sigma > 0.0
            && self.window.valid();
        if ok { Ok(()) } else { Err(FdirParamError::Gnss) }
    }
}
