//! The flight parameter set: one typed, versioned structure that the host uploads at
//! start-up and the flight code validates before it runs a single step. One firmware
//! image therefore runs every scenario.
//!
//! Gains are explicit matrices: the host turns scenario-level choices (e.g. paper 000's
//! `zeta`, `wn`) into them, so the flight code stays generic and cheap.

use crate::math::{quat_from_xyzw, Mat3};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Bumped whenever the meaning or layout of [`FlightParams`] changes.
pub const PARAMS_VERSION: u16 = 1;

/// Largest serialised size of a [`FlightParams`] (checked by a test).
pub const PARAMS_MAX_SIZE: usize = 384;

/// CRC used for frames and the parameter checksum: CRC-32/ISO-HDLC (the zlib CRC).
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

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
    pub cmg: CmgParams,
    pub steering: SteeringParams,
    /// Commanded attitude `q_ib`, scalar-last `[x, y, z, w]` (see `math` for the convention).
    pub target_q_xyzw: [f32; 4],
    /// Steps without a valid sensor frame after which the real-time loop holds the safe
    /// command (zero gimbal rates).
    pub hold_after_missed_frames: u16,
}

/// Quaternion feedback `u = -K q_e - D ω - Ki ∫q_e dt (+ ω × H)` (paper 000 eqs 15-18).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerParams {
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
}

/// How the steering law turns a momentum-rate demand into gimbal rates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SteeringLaw {
    /// `δ̇ = Jᵀ (J Jᵀ)⁻¹ ḣ`; at a singularity it returns zero rates and a `Singular` status.
    MoorePenrose,
    /// `δ̇ = Jᵀ (J Jᵀ + α I)⁻¹ ḣ` (paper 000 eq 11) with the given α schedule.
    SingularityRobust(AlphaSchedule),
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
    if xs.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(err(field, ParamReason::NotFinite))
    }
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

impl FlightParams {
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
        let c = &self.controller;
        check_finite(F::AttitudeGain, &flat(&c.k_att_nm))?;
        check_finite(F::RateGain, &flat(&c.d_rate_nms))?;
        check_finite(F::IntegralGain, &flat(&c.ki_att_nm_s))?;
        check_range(F::IntegralLimit, c.integral_limit_s, 0.0, 1.0e6)?;
        for t in c.torque_limit_nm {
            check_range(F::TorqueLimit, t, 1e-9, 1.0e6)?;
        }
        let g = &self.cmg;
        check_range(
            F::CmgSkew,
            g.skew_rad,
            1e-3,
            core::f32::consts::FRAC_PI_2 - 1e-3,
        )?;
        check_range(F::CmgMomentum, g.h0_nms, 1e-6, 1.0e5)?;
        check_range(F::GimbalRateLimit, g.max_gimbal_rate_rad_s, 1e-6, 100.0)?;
        check_range(F::GimbalAngleRange, g.gimbal_min_rad, -1.0e3, 1.0e3)?;
        check_range(F::GimbalAngleRange, g.gimbal_max_rad, -1.0e3, 1.0e3)?;
        if g.gimbal_min_rad >= g.gimbal_max_rad {
            return Err(err(F::GimbalAngleRange, R::OutOfRange));
        }
        match self.steering.law {
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
        }
        check_range(
            F::SingularThreshold,
            self.steering.singular_threshold,
            1e-12,
            1.0,
        )?;
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
        let used = postcard::to_slice(self, &mut buf)
            .map_err(|_| err(ParamField::Version, ParamReason::TooLarge))?;
        Ok(CRC32.checksum(used))
    }

    /// Inertia as a matrix.
    pub fn inertia(&self) -> Mat3 {
        mat(&self.inertia_kgm2)
    }
}

/// Row-major array form of a matrix (for building parameter sets).
pub fn mat_to_rows(m: &Mat3) -> [[f32; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
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
            controller: ControllerParams {
                k_att_nm: scale(k),
                d_rate_nms: scale(d),
                ki_att_nm_s: [[0.0; 3]; 3],
                integral_limit_s: 0.0,
                torque_limit_nm: [10.0; 3],
                gyro_compensation: false,
            },
            cmg: CmgParams {
                skew_rad: 54.73f32.to_radians(),
                h0_nms: 0.623,
                max_gimbal_rate_rad_s: 60f32.to_radians(),
                gimbal_min_rad: -1000.0,
                gimbal_max_rad: 1000.0,
            },
            steering: SteeringParams {
                law: SteeringLaw::SingularityRobust(AlphaSchedule::Exponential {
                    a0: 0.01,
                    mu: 10.0,
                }),
                singular_threshold: 1e-6,
            },
            target_q_xyzw: [0.0, 0.0, 0.0, 1.0],
            hold_after_missed_frames: 10,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        q.controller.k_att_nm[2][2] += 1e-3;
        assert_ne!(p.checksum().unwrap(), q.checksum().unwrap());
        assert_eq!(p.checksum().unwrap(), p.clone().checksum().unwrap());
    }

    #[test]
    fn rejections_name_the_field() {
        let base = FlightParams::default();
        let mut p = base;
        p.inertia_kgm2[0][0] = -1.0;
        assert_eq!(
            p.validate().unwrap_err(),
            err(ParamField::Inertia, ParamReason::NotPositiveDefinite)
        );
        let mut p = base;
        p.inertia_kgm2[0][1] = 0.5;
        assert_eq!(p.validate().unwrap_err().reason, ParamReason::NotSymmetric);
        let mut p = base;
        p.controller.d_rate_nms[1][1] = f32::NAN;
        assert_eq!(
            p.validate().unwrap_err(),
            err(ParamField::RateGain, ParamReason::NotFinite)
        );
        let mut p = base;
        p.cmg.h0_nms = 0.0;
        assert_eq!(p.validate().unwrap_err().field, ParamField::CmgMomentum);
        let mut p = base;
        p.target_q_xyzw = [0.0, 0.0, 0.0, 2.0];
        assert_eq!(
            p.validate().unwrap_err().reason,
            ParamReason::NotUnitQuaternion
        );
        let mut p = base;
        p.version = 99;
        assert_eq!(p.validate().unwrap_err().field, ParamField::Version);
        let mut p = base;
        p.cmg.gimbal_min_rad = 1.0;
        p.cmg.gimbal_max_rad = 0.5;
        assert_eq!(
            p.validate().unwrap_err().field,
            ParamField::GimbalAngleRange
        );
    }
}
