//! Controller parameters: one variant per attitude law, with their validation.

use super::{ParamError, ParamField, check_finite, check_range, flat};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

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
    /// Sun-pointing safe mode on the coarse sun sensors and the gyro, no attitude
    /// ([`crate::control::sun_safe`]).
    SunSafe(super::SunSafeParams),
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

impl QuaternionFeedbackParams {
    pub fn validate(&self) -> Result<(), ParamError> {
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
