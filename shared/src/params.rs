//! The flight parameter set: one typed, versioned structure that the host uploads at
//! start-up and the flight code validates before it runs a single step. One firmware
//! image therefore runs every scenario.
//!
//! Gains are explicit matrices: the host turns scenario-level choices (e.g. paper 000's
//! `zeta`, `wn`) into them, so the flight code stays generic and cheap.

use crate::math::{Mat3, quat_from_xyzw};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Bumped whenever the meaning or layout of [`FlightParams`] changes.
pub const PARAMS_VERSION: u16 = 9;

/// Largest serialised size of a [`FlightParams`] (checked by a test).
pub const PARAMS_MAX_SIZE: usize = 768;

/// Capacity of the reaction-wheel array.
pub const MAX_WHEELS: usize = 6;
/// Capacity of the thruster set.
pub const MAX_THRUSTERS: usize = 12;

/// The project CRC (defined in [`crate::checksum`]), re-exported for parameter users.
pub use crate::checksum::CRC32;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightParams {
    /// Must equal [`PARAMS_VERSION`].
    pub version: u16,
    /// Control (step) rate; the step uses `dt = 1 / control_rate_hz`.
    pub control_rate_hz: f32,
    /// Spacecraft inertia about the centre of mass, body axes, row-major, kg m².
    pub inertia_kgm2: [[f32; 3]; 3],
    pub controller: ControllerParams,
    pub actuator: ActuatorParams,
    /// Commanded attitude, scalar-last `[x, y, z, w]` (see `math` for the convention),
    /// relative to `target_frame`.
    pub target_q_xyzw: [f32; 4],
    pub target_frame: TargetFrame,
    /// Steps without a valid sensor frame after which the real-time loop holds the safe
    /// command (zero gimbal rates).
    pub hold_after_missed_frames: u16,
}

/// The frame the target attitude is given in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TargetFrame {
    /// `q_c = q_target` (inertial pointing).
    Inertial,
    /// `q_c = q_ref ⊗ q_target` with `q_ref` (e.g. LVLH → inertial) and its rate from the
    /// sensor frame's navigation fields: pointing that follows the orbit.
    Reference,
}

/// The control law and its gains.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControllerParams {
    QuaternionFeedback(QuaternionFeedbackParams),
    /// PD on the DCM error (paper 004 eqs 25-27).
    DcmPd(DcmPdParams),
    /// PD on Euler-angle errors (paper 003 eq 23), usually with magnetorquers.
    EulerPd(DcmPdParams),
    /// Rate damping `T = -Kd ∘ ω` (gyro only): detumbling without magnetorquers.
    RateDamping {
        kd_nms: [f32; 3],
        torque_limit_nm: [f32; 3],
    },
    /// B-dot detumbling `m = -k dB/dt` (magnetorquers only).
    Bdot {
        gain_am2_s_per_t: f32,
        filter_time_constant_s: f32,
    },
    /// LQR `u = -K [e; ω - ω_c]` (K row-major 3×6, N m per rad and per rad/s).
    Lqr {
        k: [[f32; 6]; 3],
        torque_limit_nm: [f32; 3],
    },
    /// LQR with the gimbal rates as its input (paper 002 eqs 8-11: `δ̇ = -K [e; ω - ω_c]`,
    /// K row-major 4×6, rad/s per rad and per rad/s, designed on the body + CMG model
    /// linearised at fixed gimbal angles). No steering law: the rates go to the gimbals
    /// after the failure mask and the rate and angle limits. CMG only.
    LqrGimbalRate {
        k: [[f32; 6]; 4],
    },
    /// LQG: the LQR gain on the estimate of a steady-state Kalman filter on the discrete
    /// model `x⁺ = A x + B u` with `z = x` measured ([e; ω - ω_c]) and gain L
    /// (`x̂ ← x̂⁻ + L (z - x̂⁻)`, paper 002 eq 13).
    Lqg(LqgParams),
    /// Adaptive DMCS (paper 001 eqs 31-51).
    Dmcs(DmcsParams),
}

/// DMCS parameters (paper 001 table 2: α 55, β 220, Q diag(0.1, 1), ωn 0.035, ζ 0.95,
/// I_m diag(398, 391, 176)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DmcsParams {
    pub wn_rad_s: f32,
    pub zeta: f32,
    pub model_inertia_kgm2: [f32; 3],
    pub alpha: f32,
    pub beta: f32,
    /// Q of the Lyapunov equation (49), diagonal.
    pub q_weights: [f32; 2],
    /// Bound on every adaptive gain.
    pub gain_limit: f32,
    pub torque_limit_nm: [f32; 3],
}

/// LQG parameters (all row-major), designed on the host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LqgParams {
    pub k: [[f32; 6]; 3],
    pub a: [[f32; 6]; 6],
    pub b: [[f32; 3]; 6],
    /// Steady-state Kalman gain (used when `time_varying` is false).
    pub l: [[f32; 6]; 6],
    pub torque_limit_nm: [f32; 3],
    /// Time-varying filter: propagate the covariance from `p0_diag` with the diagonal
    /// process (per step) and measurement noise variances below (Joseph-form update,
    /// `estimation::kalman`); `l` is then unused. False: the steady-state gain `l`.
    pub time_varying: bool,
    pub process_noise: [f32; 6],
    pub measurement_noise: [f32; 6],
    pub p0_diag: [f32; 6],
}

/// Per-axis PD gains. DCM PD: `M = Kp ∘ [a32 - a23, a13 - a31, a21 - a12] + Kd ∘ ω`
/// (paper 004: Kp = [21, 53, 53], Kd = [-42, -91, -91]). Euler PD:
/// `T = -Kp ∘ e - Kd ∘ ω` (paper 003: Kp = [0.001584, 0.001608, 0.002628],
/// Kd = [0.1799, 0.1826, 0.2985]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DcmPdParams {
    pub kp_nm: [f32; 3],
    pub kd_nms: [f32; 3],
    pub torque_limit_nm: [f32; 3],
}

/// The actuator family the torque demand is allocated to, with its geometry and limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ActuatorParams {
    Cmg { cmg: CmgParams, steering: SteeringParams },
    Wheels(WheelParams),
    Magnetorquers(MagnetorquerParams),
    Thrusters(ThrusterParams),
}

/// Reaction-wheel array (allocation in `allocation::wheels`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WheelParams {
    pub count: u8,
    /// Spin axes in body axes (unit), the columns of paper 001's C (eq 9).
    pub axes: [[f32; 3]; MAX_WHEELS],
    pub max_torque_nm: f32,
    pub max_speed_rad_s: f32,
    /// Axial rotor inertia.
    pub inertia_kgm2: f32,
    /// Null-space momentum-management gain, 1/s (0 = off).
    pub null_gain_per_s: f32,
    /// Wheel speeds the null-space term drives towards.
    pub bias_speed_rad_s: [f32; MAX_WHEELS],
    /// Bit i: wheel i failed (removed from the allocation).
    pub failed_mask: u8,
}

/// Magnetorquer rods along the body axes (allocation in `allocation::magnetorquers`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagnetorquerParams {
    /// Largest positive dipole per axis, A m².
    pub max_dipole_am2: [f32; 3],
    /// Largest negative dipole per axis, as a positive magnitude, A m².
    pub min_dipole_am2: [f32; 3],
    /// Hysteresis dead band `(lo, hi)` per axis (paper 003: -1.26 … +1.86 A m²); 0, 0 = none.
    pub deadband_lo_am2: [f32; 3],
    pub deadband_hi_am2: [f32; 3],
    /// Below this field magnitude the dipole law is not used, T.
    pub min_field_t: f32,
}

/// Thruster allocation method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ThrusterMethod {
    /// Paper 004 eqs 12-18, then minimum propellant when attainable.
    DirectionPreserving,
    /// Bodson's scaled direction-preserving LP.
    Bodson,
}

/// On/off thrusters (allocation in `allocation::thruster`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ThrusterParams {
    pub count: u8,
    /// Torque of each thruster firing at full thrust, N m (columns of paper 004's B
    /// times the thrust); row = axis.
    pub torque_nm: [[f32; MAX_THRUSTERS]; 3],
    pub method: ThrusterMethod,
    /// PWPF modulator (paper 004 fig 5, table 3), run at the control rate.
    pub pwpf_km: f32,
    pub pwpf_tm_s: f32,
    pub pwpf_u_on: f32,
    pub pwpf_u_off: f32,
    /// Bit i: thruster i failed off.
    pub failed_mask: u16,
}

/// Quaternion feedback `u = -K q_e - D ω - Ki ∫q_e dt (+ ω × H)` (paper 000 eqs 15-18).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QuaternionFeedbackParams {
    /// Attitude gain K, N m per unit quaternion vector part, row-major.
    pub k_att_nm: [[f32; 3]; 3],
    /// Rate gain D, N m per rad/s, row-major.
    pub d_rate_nms: [[f32; 3]; 3],
    /// Integral gain Ki, N m per (unit quaternion × s), row-major. All zero: no integral.
    pub ki_att_nm_s: [[f32; 3]; 3],
    /// Anti-windup clamp on each component of the integral state, s.
    pub integral_limit_s: f32,
    /// Per-axis torque demand limit, N m; the demand vector is scaled (direction kept).
    pub torque_limit_nm: [f32; 3],
    /// Add the gyroscopic term `ω × (I ω + h_cmg)` to the demand.
    pub gyro_compensation: bool,
    /// Eigen-axis slew-rate limit (Wie & Lu 1995), rad/s; 0 = none. The attitude term is
    /// saturated so that the steady slew under saturation runs at this rate.
    pub max_slew_rate_rad_s: f32,
}

/// Four single-gimbal CMGs in a pyramid (paper 000 eq 6).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CmgParams {
    /// Pyramid skew angle β, rad (54.73° gives a nearly spherical momentum envelope).
    pub skew_rad: f32,
    /// Rotor angular momentum of one unit, N m s.
    pub h0_nms: f32,
    /// Gimbal-rate limit, rad/s; the whole rate vector is scaled to respect it.
    pub max_gimbal_rate_rad_s: f32,
    /// Gimbal-angle range, rad; `min <= δ <= max`. Use ±π or wider for unlimited gimbals.
    pub gimbal_min_rad: f32,
    pub gimbal_max_rad: f32,
    /// Bit i: CMG i failed — its Jacobian column is removed and its rate command locked at 0.
    pub failed_mask: u8,
}

/// How the steering law turns a momentum-rate demand into gimbal rates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SteeringLaw {
    /// `δ̇ = Jᵀ (J Jᵀ)⁻¹ ḣ`; at a singularity it returns zero rates and a `Singular` status.
    MoorePenrose,
    /// `δ̇ = Jᵀ (J Jᵀ + α I)⁻¹ ḣ` (paper 000 eq 11) with the given α schedule.
    SingularityRobust(AlphaSchedule),
    /// Generalized SR (Wie 2005; paper 002): `δ̇ = Jᵀ (J Jᵀ + λ E)⁻¹ ḣ`,
    /// `E = [[1, ε3, ε2], [ε3, 1, ε1], [ε2, ε1, 1]]`, `εi = ε0 sin(ω t + φi)` with
    /// `φ = (0, π/2, π)`, `λ = λ0 exp(-μ m)`. The time-varying off-diagonal dither moves
    /// the gimbals off internal elliptic singularities where SR is stuck.
    GeneralizedSr { lambda0: f32, mu: f32, eps0: f32, omega_rad_s: f32 },
}

/// Singularity-robust weight α as a function of `m = det(J Jᵀ)` (paper 000 eqs 12-14).
/// `m` is computed with `h0 = 1` (unit-free, in `[0, 16/27·…]`), so schedules do not
/// depend on the rotor momentum.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlphaSchedule {
    /// eq 12: `α = 0` if `m >= m_cr`, else `a0 (1 - m/m0)²`.
    Quadratic { a0: f32, m0: f32, m_cr: f32 },
    /// eq 13: `α = 0` if `m >= m_cr`, else `min(a0/m, a_max)`.
    Inverse { a0: f32, m_cr: f32, a_max: f32 },
    /// eq 14: `α = a0 exp(-μ m)`.
    Exponential { a0: f32, mu: f32 },
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SteeringParams {
    pub law: SteeringLaw,
    /// Below this `m` the Moore-Penrose inverse is declared singular.
    pub singular_threshold: f32,
    /// Null motion `k (I - J⁺J)(δ_pref - δ)` towards preferred gimbal angles, 1/s (0 = off).
    pub null_gain_per_s: f32,
    pub preferred_gimbal_rad: [f32; 4],
    /// Below this `m` the steering checks for the momentum-envelope (saturation)
    /// singularity and reports it.
    pub saturation_check_m: f32,
}

/// Which parameter was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamField {
    Version,
    ControlRate,
    Inertia,
    AttitudeGain,
    RateGain,
    IntegralGain,
    IntegralLimit,
    TorqueLimit,
    CmgSkew,
    CmgMomentum,
    GimbalRateLimit,
    GimbalAngleRange,
    SteeringAlpha,
    SingularThreshold,
    Target,
    HoldAfterMissed,
    WheelCount,
    WheelAxis,
    WheelLimit,
    WheelNullSpace,
    DipoleLimit,
    DeadBand,
    MinField,
    ThrusterCount,
    ThrusterTorque,
    Pwpf,
    NullMotion,
    /// The control law does not fit the actuator family (B-dot needs magnetorquers).
    Controller,
    /// Mode-manager thresholds or the mode table (missing slot, mismatched rates).
    ModeTable,
}

/// Why it was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamReason {
    NotFinite,
    OutOfRange,
    NotSymmetric,
    NotPositiveDefinite,
    UnsupportedVersion,
    NotUnitQuaternion,
    TooLarge,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    pub field: ParamField,
    pub reason: ParamReason,
}

impl core::fmt::Display for ParamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "parameter {:?} rejected: {:?}", self.field, self.reason)
    }
}
#[cfg(feature = "std")]
impl std::error::Error for ParamError {}

fn err(field: ParamField, reason: ParamReason) -> ParamError {
    ParamError { field, reason }
}

fn mat(m: &[[f32; 3]; 3]) -> Mat3 {
    Mat3::from_fn(|r, c| m.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0))
}

fn check_finite(field: ParamField, xs: &[f32]) -> Result<(), ParamError> {
    if xs.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(err(field, ParamReason::NotFinite)) }
}

fn check_range(field: ParamField, x: f32, lo: f32, hi: f32) -> Result<(), ParamError> {
    if !x.is_finite() {
        Err(err(field, ParamReason::NotFinite))
    } else if x < lo || x > hi {
        Err(err(field, ParamReason::OutOfRange))
    } else {
        Ok(())
    }
}

fn flat(m: &[[f32; 3]; 3]) -> [f32; 9] {
    let [a, b, c] = *m;
    [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
}

/// Symmetric positive definite by Sylvester's criterion (leading minors > 0).
fn is_spd(m: &Mat3) -> bool {
    let m1 = m[(0, 0)];
    let m2 = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    let m3 = m.determinant();
    m1 > 0.0 && m2 > 0.0 && m3 > 0.0
}

fn is_symmetric(m: &Mat3) -> bool {
    let scale = m.abs().max().max(1e-30);
    (m - m.transpose()).abs().max() <= 1e-5 * scale
}

impl QuaternionFeedbackParams {
    fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        check_finite(F::AttitudeGain, &flat(&self.k_att_nm))?;
        check_finite(F::RateGain, &flat(&self.d_rate_nms))?;
        check_finite(F::IntegralGain, &flat(&self.ki_att_nm_s))?;
        check_range(F::IntegralLimit, self.integral_limit_s, 0.0, 1.0e6)?;
        check_range(F::RateGain, self.max_slew_rate_rad_s, 0.0, 100.0)?;
        for t in self.torque_limit_nm {
            check_range(F::TorqueLimit, t, 1e-9, 1.0e6)?;
        }
        Ok(())
    }
}

fn validate_cmg(g: &CmgParams, steering: &SteeringParams) -> Result<(), ParamError> {
    use ParamField as F;
    use ParamReason as R;
    check_range(F::CmgSkew, g.skew_rad, 1e-3, core::f32::consts::FRAC_PI_2 - 1e-3)?;
    check_range(F::CmgMomentum, g.h0_nms, 1e-6, 1.0e5)?;
    check_range(F::GimbalRateLimit, g.max_gimbal_rate_rad_s, 1e-6, 100.0)?;
    check_range(F::GimbalAngleRange, g.gimbal_min_rad, -1.0e3, 1.0e3)?;
    check_range(F::GimbalAngleRange, g.gimbal_max_rad, -1.0e3, 1.0e3)?;
    if g.gimbal_min_rad >= g.gimbal_max_rad {
        return Err(err(F::GimbalAngleRange, R::OutOfRange));
    }
    match steering.law {
        SteeringLaw::MoorePenrose => {}
        SteeringLaw::SingularityRobust(AlphaSchedule::Quadratic { a0, m0, m_cr }) => {
            check_range(F::SteeringAlpha, a0, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, m0, 1e-9, 1.0e6)?;
            check_range(F::SteeringAlpha, m_cr, 0.0, 1.0e6)?;
        }
        SteeringLaw::SingularityRobust(AlphaSchedule::Inverse { a0, m_cr, a_max }) => {
            check_range(F::SteeringAlpha, a0, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, m_cr, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, a_max, 1e-9, 1.0e6)?;
        }
        SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0, mu }) => {
            check_range(F::SteeringAlpha, a0, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, mu, 0.0, 1.0e6)?;
        }
        SteeringLaw::GeneralizedSr { lambda0, mu, eps0, omega_rad_s } => {
            check_range(F::SteeringAlpha, lambda0, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, mu, 0.0, 1.0e6)?;
            check_range(F::SteeringAlpha, eps0, 0.0, 1.0)?;
            check_range(F::SteeringAlpha, omega_rad_s, 1e-6, 1.0e4)?;
        }
    }
    check_range(F::NullMotion, steering.null_gain_per_s, 0.0, 1.0e3)?;
    check_finite(F::NullMotion, &steering.preferred_gimbal_rad)?;
    check_range(F::SingularThreshold, steering.saturation_check_m, 0.0, 10.0)?;
    check_range(F::SingularThreshold, steering.singular_threshold, 1e-12, 1.0)
}

impl WheelParams {
    fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        let n = self.count as usize;
        if n == 0 || n > MAX_WHEELS {
            return Err(err(F::WheelCount, R::OutOfRange));
        }
        for a in self.axes.iter().take(n) {
            check_finite(F::WheelAxis, a)?;
            let norm = libm::sqrtf(a.iter().map(|x| x * x).sum());
            if (norm - 1.0).abs() > 1e-3 {
                return Err(err(F::WheelAxis, R::OutOfRange));
            }
        }
        check_range(F::WheelLimit, self.max_torque_nm, 1e-9, 1.0e4)?;
        check_range(F::WheelLimit, self.max_speed_rad_s, 1e-3, 1.0e5)?;
        check_range(F::WheelLimit, self.inertia_kgm2, 1e-9, 1.0e3)?;
        check_range(F::WheelNullSpace, self.null_gain_per_s, 0.0, 1.0e3)?;
        check_finite(F::WheelNullSpace, &self.bias_speed_rad_s)?;
        Ok(())
    }
}

impl MagnetorquerParams {
    fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        for i in 0..3 {
            let g = |a: &[f32; 3]| a.get(i).copied().unwrap_or(f32::NAN);
            check_range(F::DipoleLimit, g(&self.max_dipole_am2), 0.0, 1.0e6)?;
            check_range(F::DipoleLimit, g(&self.min_dipole_am2), 0.0, 1.0e6)?;
            let (lo, hi) = (g(&self.deadband_lo_am2), g(&self.deadband_hi_am2));
            check_range(F::DeadBand, lo, -1.0e6, 1.0e6)?;
            check_range(F::DeadBand, hi, -1.0e6, 1.0e6)?;
            if lo > hi || lo > 0.0 || hi < 0.0 {
                return Err(err(F::DeadBand, R::OutOfRange));
            }
        }
        check_range(F::MinField, self.min_field_t, 0.0, 1.0)
    }
}

impl ThrusterParams {
    fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        let n = self.count as usize;
        if n == 0 || n > MAX_THRUSTERS {
            return Err(err(F::ThrusterCount, R::OutOfRange));
        }
        for row in &self.torque_nm {
            check_finite(F::ThrusterTorque, row)?;
            if row.iter().any(|x| libm::fabsf(*x) > 1.0e6) {
                return Err(err(F::ThrusterTorque, R::OutOfRange));
            }
        }
        check_range(F::Pwpf, self.pwpf_km, 1e-6, 1.0e6)?;
        check_range(F::Pwpf, self.pwpf_tm_s, 1e-6, 1.0e4)?;
        check_range(F::Pwpf, self.pwpf_u_on, 1e-6, 1.0e6)?;
        check_range(F::Pwpf, self.pwpf_u_off, 0.0, 1.0e6)?;
        if self.pwpf_u_off >= self.pwpf_u_on {
            return Err(err(F::Pwpf, R::OutOfRange));
        }
        Ok(())
    }
}

impl DmcsParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        let d = self;
        check_range(F::AttitudeGain, d.wn_rad_s, 1e-6, 1.0e3)?;
        check_range(F::AttitudeGain, d.zeta, 1e-6, 1.0e3)?;
        for i in d.model_inertia_kgm2 {
            check_range(F::Inertia, i, 1e-9, 1.0e9)?;
        }
        check_range(F::RateGain, d.alpha, 0.0, 1.0e9)?;
        check_range(F::RateGain, d.beta, 0.0, 1.0e9)?;
        for q in d.q_weights {
            check_range(F::RateGain, q, 1e-12, 1.0e9)?;
        }
        check_range(F::IntegralLimit, d.gain_limit, 1e-6, 1.0e12)?;
        for t in d.torque_limit_nm {
            check_range(F::TorqueLimit, t, 1e-9, 1.0e6)?;
        }
        Ok(())
    }
}

impl LqgParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        let g = self;
        for row in &g.k {
            check_finite(F::AttitudeGain, row)?;
        }
        for row in g.a.iter().chain(g.l.iter()) {
            check_finite(F::RateGain, row)?;
        }
        for row in &g.b {
            check_finite(F::RateGain, row)?;
        }
        if g.time_varying {
            for v in g.process_noise.iter().chain(g.p0_diag.iter()) {
                check_range(F::RateGain, *v, 0.0, 1.0e6)?;
            }
            // The innovation covariance P⁻ + R must stay positive definite.
            for v in g.measurement_noise {
                check_range(F::RateGain, v, 1e-30, 1.0e6)?;
            }
        }
        for t in g.torque_limit_nm {
            check_range(F::TorqueLimit, t, 1e-9, 1.0e6)?;
        }
        Ok(())
    }
}

impl FlightParams {
    /// The controller's gains and limits, and that it fits the actuator family.
    fn validate_controller(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        match &self.controller {
            ControllerParams::QuaternionFeedback(c) => c.validate()?,
            ControllerParams::DcmPd(c) | ControllerParams::EulerPd(c) => {
                check_finite(F::AttitudeGain, &c.kp_nm)?;
                check_finite(F::RateGain, &c.kd_nms)?;
                for t in c.torque_limit_nm {
                    check_range(F::TorqueLimit, t, 1e-9, 1.0e6)?;
                }
            }
            ControllerParams::Dmcs(d) => d.validate()?,
            ControllerParams::Lqg(g) => g.validate()?,
            ControllerParams::Lqr { k, torque_limit_nm } => {
                for row in k {
                    check_finite(F::AttitudeGain, row)?;
                }
                for t in torque_limit_nm {
                    check_range(F::TorqueLimit, *t, 1e-9, 1.0e6)?;
                }
            }
            ControllerParams::RateDamping { kd_nms, torque_limit_nm } => {
                for kd in kd_nms {
                    check_range(F::RateGain, *kd, 0.0, 1.0e6)?;
                }
                for t in torque_limit_nm {
                    check_range(F::TorqueLimit, *t, 1e-9, 1.0e6)?;
                }
            }
            ControllerParams::LqrGimbalRate { k } => {
                for row in k {
                    check_finite(F::AttitudeGain, row)?;
                }
                if !matches!(self.actuator, ActuatorParams::Cmg { .. }) {
                    return Err(err(F::Controller, R::OutOfRange));
                }
            }
            ControllerParams::Bdot { gain_am2_s_per_t, filter_time_constant_s } => {
                check_range(F::AttitudeGain, *gain_am2_s_per_t, 0.0, 1.0e12)?;
                check_range(F::RateGain, *filter_time_constant_s, 0.0, 1.0e4)?;
                if !matches!(self.actuator, ActuatorParams::Magnetorquers(_)) {
                    return Err(err(F::Controller, R::OutOfRange));
                }
            }
        }
        Ok(())
    }

    /// Check every field; the first offending field is reported.
    pub fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        if self.version != PARAMS_VERSION {
            return Err(err(F::Version, R::UnsupportedVersion));
        }
        check_range(F::ControlRate, self.control_rate_hz, 0.01, 10_000.0)?;
        check_finite(F::Inertia, &flat(&self.inertia_kgm2))?;
        let inertia = mat(&self.inertia_kgm2);
        if !is_symmetric(&inertia) {
            return Err(err(F::Inertia, R::NotSymmetric));
        }
        if !is_spd(&inertia) {
            return Err(err(F::Inertia, R::NotPositiveDefinite));
        }
        self.validate_controller()?;
        match &self.actuator {
            ActuatorParams::Cmg { cmg, steering } => validate_cmg(cmg, steering)?,
            ActuatorParams::Wheels(w) => w.validate()?,
            ActuatorParams::Magnetorquers(m) => m.validate()?,
            ActuatorParams::Thrusters(t) => t.validate()?,
        }
        check_finite(F::Target, &self.target_q_xyzw)?;
        let n = quat_from_xyzw(self.target_q_xyzw).norm();
        if (n - 1.0).abs() > 1e-3 {
            return Err(err(F::Target, R::NotUnitQuaternion));
        }
        if self.hold_after_missed_frames == 0 {
            return Err(err(F::HoldAfterMissed, R::OutOfRange));
        }
        Ok(())
    }

    /// CRC-32 of the postcard encoding: what the host computed must match what the
    /// flight code received.
    pub fn checksum(&self) -> Result<u32, ParamError> {
        let mut buf = [0u8; PARAMS_MAX_SIZE];
        let used = postcard::to_slice(self, &mut buf).map_err(|_| err(ParamField::Version, ParamReason::TooLarge))?;
        Ok(CRC32.checksum(used))
    }

    /// Inertia as a matrix.
    pub fn inertia(&self) -> Mat3 {
        mat(&self.inertia_kgm2)
    }
}

/// Row-major array form of a matrix (for building parameter sets).
pub fn mat_to_rows(m: &Mat3) -> [[f32; 3]; 3] {
    [[m[(0, 0)], m[(0, 1)], m[(0, 2)]], [m[(1, 0)], m[(1, 1)], m[(1, 2)]], [m[(2, 0)], m[(2, 1)], m[(2, 2)]]]
}

/// Matrix from row-major arrays.
pub fn rows_to_mat(m: &[[f32; 3]; 3]) -> Mat3 {
    mat(m)
}

impl Default for FlightParams {
    /// Paper 000 test 1 (inertia diag(3.1, 3.1, 5.8), ζ 0.47, ωn 0.7, four 0.623 N m s
    /// CMGs, SR steering): a valid set, used by tests and as a firmware boot default.
    fn default() -> Self {
        let inertia = [[3.1, 0.0, 0.0], [0.0, 3.1, 0.0], [0.0, 0.0, 5.8]];
        let (zeta, wn) = (0.47f32, 0.7f32);
        let k = 2.0 * wn * wn;
        let d = 2.0 * zeta * wn;
        let scale = |s: f32| {
            let mut m = inertia;
            for row in m.iter_mut() {
                for x in row.iter_mut() {
                    *x *= s;
                }
            }
            m
        };
        FlightParams {
            version: PARAMS_VERSION,
            control_rate_hz: 100.0,
            inertia_kgm2: inertia,
            controller: ControllerParams::QuaternionFeedback(QuaternionFeedbackParams {
                k_att_nm: scale(k),
                d_rate_nms: scale(d),
                ki_att_nm_s: [[0.0; 3]; 3],
                integral_limit_s: 0.0,
                torque_limit_nm: [10.0; 3],
                gyro_compensation: false,
                max_slew_rate_rad_s: 0.0,
            }),
            actuator: ActuatorParams::Cmg {
                cmg: CmgParams {
                    skew_rad: 54.73f32.to_radians(),
                    h0_nms: 0.623,
                    max_gimbal_rate_rad_s: 60f32.to_radians(),
                    gimbal_min_rad: -1000.0,
                    gimbal_max_rad: 1000.0,
                    failed_mask: 0,
                },
                steering: SteeringParams {
                    law: SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0: 0.01, mu: 10.0 }),
                    singular_threshold: 1e-6,
                    null_gain_per_s: 0.0,
                    preferred_gimbal_rad: [0.0; 4],
                    saturation_check_m: 0.05,
                },
            },
            target_frame: TargetFrame::Inertial,
            target_q_xyzw: [0.0, 0.0, 0.0, 1.0],
            hold_after_missed_frames: 10,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn qf(p: &mut FlightParams) -> &mut QuaternionFeedbackParams {
        match &mut p.controller {
            ControllerParams::QuaternionFeedback(q) => q,
            _ => panic!("default is quaternion feedback"),
        }
    }

    fn cmg(p: &mut FlightParams) -> &mut CmgParams {
        match &mut p.actuator {
            ActuatorParams::Cmg { cmg, .. } => cmg,
            _ => panic!("default is a CMG set"),
        }
    }

    #[test]
    fn every_actuator_family_validates_and_fits_the_frame() {
        let base = FlightParams::default();
        let mut axes = [[0.0; 3]; MAX_WHEELS];
        axes[0] = [1.0, 0.0, 0.0];
        axes[1] = [0.0, 1.0, 0.0];
        axes[2] = [0.0, 0.0, 1.0];
        let wheels = WheelParams {
            count: 3,
            axes,
            max_torque_nm: 0.1,
            max_speed_rad_s: 600.0,
            inertia_kgm2: 0.01,
            null_gain_per_s: 0.0,
            bias_speed_rad_s: [0.0; MAX_WHEELS],
            failed_mask: 0,
        };
        let mtq = MagnetorquerParams {
            max_dipole_am2: [12.26; 3],
            min_dipole_am2: [11.76; 3],
            deadband_lo_am2: [-1.26; 3],
            deadband_hi_am2: [1.86; 3],
            min_field_t: 1e-7,
        };
        let thr = ThrusterParams {
            count: 12,
            torque_nm: [[1.0e5; MAX_THRUSTERS]; 3],
            method: ThrusterMethod::Bodson,
            pwpf_km: 4.5,
            pwpf_tm_s: 0.15,
            pwpf_u_on: 0.45,
            pwpf_u_off: 0.15,
            failed_mask: 0xfff,
        };
        // The largest controller on the largest actuator set must fit a frame too.
        let lqg = ControllerParams::Lqg(LqgParams {
            k: [[1.0; 6]; 3],
            a: [[1.0; 6]; 6],
            b: [[1.0; 3]; 6],
            l: [[1.0; 6]; 6],
            torque_limit_nm: [1.0; 3],
            time_varying: true,
            process_noise: [1.0; 6],
            measurement_noise: [1.0; 6],
            p0_diag: [1.0; 6],
        });
        let p = FlightParams { controller: lqg, actuator: ActuatorParams::Thrusters(thr), ..base };
        assert_eq!(p.validate(), Ok(()));
        let mut buf = [0u8; 2048];
        // The mode-table upload carries one more byte (the mode) than `UploadParams`.
        let msg = crate::protocol::HostMsg::UploadModeParams { mode: crate::modes::Mode::Hold, params: p };
        let n = postcard::to_slice(&msg, &mut buf).unwrap().len();
        assert!(n <= crate::protocol::MAX_PAYLOAD, "LQG + thrusters: {n} bytes");
        for a in [ActuatorParams::Wheels(wheels), ActuatorParams::Magnetorquers(mtq), ActuatorParams::Thrusters(thr)] {
            let p = FlightParams { actuator: a, ..base };
            assert_eq!(p.validate(), Ok(()), "{a:?}");
            let mut buf = [0u8; 2048];
            let n = postcard::to_slice(&crate::protocol::HostMsg::UploadParams(p), &mut buf).unwrap().len();
            assert!(n <= crate::protocol::MAX_PAYLOAD, "{n} bytes");
        }
        let mut w2 = wheels;
        w2.axes[1] = [0.0, 2.0, 0.0];
        assert_eq!(
            FlightParams { actuator: ActuatorParams::Wheels(w2), ..base }.validate().unwrap_err().field,
            ParamField::WheelAxis
        );
        let mut m2 = mtq;
        m2.deadband_lo_am2[1] = 0.5;
        assert_eq!(
            FlightParams { actuator: ActuatorParams::Magnetorquers(m2), ..base }.validate().unwrap_err().field,
            ParamField::DeadBand
        );
        let mut t2 = thr;
        t2.pwpf_u_off = 0.5;
        assert_eq!(
            FlightParams { actuator: ActuatorParams::Thrusters(t2), ..base }.validate().unwrap_err().field,
            ParamField::Pwpf
        );
    }

    #[test]
    fn default_is_valid_and_fits_the_buffer() {
        let p = FlightParams::default();
        assert_eq!(p.validate(), Ok(()));
        let mut buf = [0u8; 1024];
        let n = postcard::to_slice(&p, &mut buf).unwrap().len();
        assert!(n <= PARAMS_MAX_SIZE, "serialised params take {n} bytes");
    }

    #[test]
    fn checksum_changes_with_any_field() {
        let p = FlightParams::default();
        let mut q = p;
        qf(&mut q).k_att_nm[2][2] += 1e-3;
        assert_ne!(p.checksum().unwrap(), q.checksum().unwrap());
        assert_eq!(p.checksum().unwrap(), p.clone().checksum().unwrap());
    }

    #[test]
    fn rejections_name_the_field() {
        let base = FlightParams::default();
        let mut p = base;
        p.inertia_kgm2[0][0] = -1.0;
        assert_eq!(p.validate().unwrap_err(), err(ParamField::Inertia, ParamReason::NotPositiveDefinite));
        let mut p = base;
        p.inertia_kgm2[0][1] = 0.5;
        assert_eq!(p.validate().unwrap_err().reason, ParamReason::NotSymmetric);
        let mut p = base;
        qf(&mut p).d_rate_nms[1][1] = f32::NAN;
        assert_eq!(p.validate().unwrap_err(), err(ParamField::RateGain, ParamReason::NotFinite));
        let mut p = base;
        cmg(&mut p).h0_nms = 0.0;
        assert_eq!(p.validate().unwrap_err().field, ParamField::CmgMomentum);
        let mut p = base;
        p.target_q_xyzw = [0.0, 0.0, 0.0, 2.0];
        assert_eq!(p.validate().unwrap_err().reason, ParamReason::NotUnitQuaternion);
        let mut p = base;
        p.version = 99;
        assert_eq!(p.validate().unwrap_err().field, ParamField::Version);
        let mut p = base;
        cmg(&mut p).gimbal_min_rad = 1.0;
        cmg(&mut p).gimbal_max_rad = 0.5;
        assert_eq!(p.validate().unwrap_err().field, ParamField::GimbalAngleRange);
    }
}
