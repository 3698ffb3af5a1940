//! Actuator parameters: one variant per family (CMG pyramid and steering, wheels,
//! magnetorquers, thrusters), with their validation.

use super::{MAX_THRUSTERS, ParamError, ParamField, ParamReason, check_finite, check_range, err};
use crate::types::MAX_WHEELS;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

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
    /// Bit i: rod i (body axis i) failed — it is commanded nothing and the torque is
    /// realised by the others (`allocation::magnetorquers::dipole_for_torque`; params
    /// version 14).
    pub failed_mask: u8,
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

pub fn validate_cmg(g: &CmgParams, steering: &SteeringParams) -> Result<(), ParamError> {
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
    /// Test fixture: three wheels along the body axes, 600 rad/s, 0.01 kg m².
    #[cfg(test)]
    pub(crate) fn body_axes_triad(max_torque_nm: f32) -> Self {
        let mut axes = [[0.0; 3]; MAX_WHEELS];
        axes[0] = [1.0, 0.0, 0.0];
        axes[1] = [0.0, 1.0, 0.0];
        axes[2] = [0.0, 0.0, 1.0];
        Self {
            count: 3,
            axes,
            max_torque_nm,
            max_speed_rad_s: 600.0,
            inertia_kgm2: 0.01,
            null_gain_per_s: 0.0,
            bias_speed_rad_s: [0.0; MAX_WHEELS],
            failed_mask: 0,
        }
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        use ParamReason as R;
        let n = self.count as usize;
        if n == 0 || n > MAX_WHEELS {
            return Err(err(F::WheelCount, R::OutOfRange));
        }
        for a in self.axes.iter().take(n) {
            check_finite(F::WheelAxis, a)?;
            let norm = crate::math::f32m::sqrt(a.iter().map(|x| x * x).sum());
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
    pub fn validate(&self) -> Result<(), ParamError> {
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
        check_range(F::MinField, self.min_field_t, 0.0, 1.0)?;
        check_rod_mask(self.failed_mask)
    }
}

/// A rod mask names only the three rods.
pub fn check_rod_mask(mask: u8) -> Result<(), ParamError> {
    if mask & !ALL_RODS == 0 { Ok(()) } else { Err(err(ParamField::RodMask, ParamReason::OutOfRange)) }
}

/// Every rod of the three (a mask with all of them failed commands no dipole).
pub const ALL_RODS: u8 = 0b111;

impl ThrusterParams {
    pub fn validate(&self) -> Result<(), ParamError> {
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
