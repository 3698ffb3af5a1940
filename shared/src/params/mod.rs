//! The flight parameter set: one typed, versioned structure that the host uploads at
//! start-up and the flight code validates before it runs a single step. One firmware
//! image therefore runs every scenario.
//!
//! One rule: every algorithm's parameter type lives here, below the algorithms, and this
//! module imports none of them. Split per family: [`controller`] (one variant per law),
//! [`sun_safe`] (the sun-safe law's), [`actuator`] (one per actuator family),
//! [`momentum`] (momentum management), [`estimation`] (attitude determination) and
//! [`modes`] (the mode table: [`Mode`], [`ModeRequest`], [`ModeManagerParams`], shared
//! with the wire); the set itself, its errors and checksum live here (the CRC in
//! [`crate::checksum`]).
//!
//! Gains are explicit matrices: the host turns scenario-level choices (e.g. paper 000's
//! `zeta`, `wn`) into them, so the flight code stays generic and cheap.

use crate::math::Mat3;
pub mod actuator;
pub mod controller;
pub mod estimation;
pub mod fdir;
pub mod guidance;
pub mod modes;
pub mod momentum;
pub mod sun_safe;
pub mod timeline;

pub use actuator::*;
pub use controller::*;
pub use estimation::{AttitudeSource, CUBE_FACES, EstimationParams, MAX_NOISE_FIGURE, MAX_REPLAYED_NODES_LIMIT};
pub use guidance::{Direction, GuidanceParams, KeepOutCone, ManoeuvreParams, Pointing};
pub use modes::{MAX_THRESHOLD, MODE_COUNT, MODE_NONE, Mode, ModeManagerParams, ModeRequest};
pub use momentum::{MomentumParams, NO_THRUSTERS, UnloadMethod};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};
pub use sun_safe::{SunSafeError, SunSafeParams};
pub use timeline::{MAX_TIMELINE_SEGMENTS, TimelineError, TimelineFault, TimelineSegment};

/// Bumped whenever the meaning or layout of [`FlightParams`] changes.
pub const PARAMS_VERSION: u16 = 14;

/// Largest serialised size of a [`FlightParams`] (checked by a test).
pub const PARAMS_MAX_SIZE: usize = 1280;

/// Capacity of the thruster set.
pub const MAX_THRUSTERS: usize = 12;

use crate::checksum::CRC32;

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
    /// What the spacecraft points at (params version 11; a fixed attitude in the inertial
    /// frame or LVLH before): [`GuidanceParams`].
    pub guidance: GuidanceParams,
    /// Planned slews and keep-out cones (params version 12).
    pub manoeuvre: ManoeuvreParams,
    /// Steps without a valid sensor frame after which the real-time loop holds the safe
    /// command (zero gimbal rates).
    pub hold_after_missed_frames: u16,
    /// Momentum management: magnetic unloading and the magnetometer's torquer-field
    /// correction (params version 10).
    pub momentum: MomentumParams,
    /// Fault detection, isolation and recovery (params version 13; docs/fdir.md).
    pub fdir: fdir::FdirParams,
}

/// The frame the target attitude is given in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TargetFrame {
    /// `q_c = q_target` (inertial pointing).
    Inertial,
    /// `q_c = q_lvlh ⊗ q_target` with the LVLH frame and its rate computed on board from
    /// the navigation solution (GNSS fix, propagated between fixes,
    /// [`crate::estimation::navigation`]): pointing that follows the orbit.
    Reference,
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
    /// Attitude-determination parameters ([`EstimationParams`]).
    Estimation,
    /// Momentum management ([`MomentumParams`]), or unloading enabled on an actuator
    /// family that stores no momentum.
    Momentum,
    /// The thruster dump of [`MomentumParams`] (`dump_*` fields, params version 10).
    MomentumDump,
    /// Guidance ([`GuidanceParams`], params version 11): a direction, the gate, the
    /// transition, the thresholds.
    Pointing,
    /// Guidance's body axes: not unit, or primary and secondary (nearly) parallel.
    PointingAxes,
    /// Planned slews and keep-out cones ([`ManoeuvreParams`]).
    Manoeuvre,
    /// Fault detection ([`fdir::FdirParams`], params version 13), or a wheel monitor on
    /// a family without wheels.
    Fdir,
    /// The magnetorquer rods the ground masked (`failed_mask` of [`MagnetorquerParams`]
    /// or [`MomentumParams`], params version 14): a bit beyond the three rods.
    RodMask,
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

pub(crate) fn err(field: ParamField, reason: ParamReason) -> ParamError {
    ParamError { field, reason }
}

fn mat(m: &[[f32; 3]; 3]) -> Mat3 {
    Mat3::from_fn(|r, c| m.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0))
}

pub(crate) fn check_finite(field: ParamField, xs: &[f32]) -> Result<(), ParamError> {
    if xs.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(err(field, ParamReason::NotFinite)) }
}

pub(crate) fn check_range(field: ParamField, x: f32, lo: f32, hi: f32) -> Result<(), ParamError> {
    if !x.is_finite() {
        Err(err(field, ParamReason::NotFinite))
    } else if x < lo || x > hi {
        Err(err(field, ParamReason::OutOfRange))
    } else {
        Ok(())
    }
}

pub(crate) fn flat(m: &[[f32; 3]; 3]) -> [f32; 9] {
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
            ControllerParams::SunSafe(p) => p
                .validate()
                .map_err(|_| ParamError { field: ParamField::Controller, reason: ParamReason::OutOfRange })?,
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
        self.guidance.validate()?;
        self.manoeuvre.validate()?;
        if self.hold_after_missed_frames == 0 {
            return Err(err(F::HoldAfterMissed, R::OutOfRange));
        }
        self.momentum.validate()?;
        let stores_momentum = matches!(self.actuator, ActuatorParams::Wheels(_) | ActuatorParams::Cmg { .. });
        if self.momentum.enabled && !stores_momentum {
            return Err(err(F::Momentum, R::OutOfRange));
        }
        if let Some(w) = &self.fdir.wheel {
            let ActuatorParams::Wheels(wheels) = &self.actuator else {
                return Err(err(F::Fdir, R::OutOfRange));
            };
            w.validate(wheels.inertia_kgm2).map_err(|_| err(F::Fdir, R::OutOfRange))?;
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
            guidance: GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial),
            manoeuvre: ManoeuvreParams::OFF,
            hold_after_missed_frames: 10,
            momentum: MomentumParams::OFF,
            fdir: fdir::FdirParams::OFF,
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
        let wheels = WheelParams::body_axes_triad(0.1);
        let mtq = MagnetorquerParams {
            max_dipole_am2: [12.26; 3],
            min_dipole_am2: [11.76; 3],
            deadband_lo_am2: [-1.26; 3],
            deadband_hi_am2: [1.86; 3],
            min_field_t: 1e-7,
            failed_mask: 0,
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
        let msg = crate::link::HostMsg::UploadModeParams { mode: crate::params::Mode::Hold, params: p };
        let n = postcard::to_slice(&msg, &mut buf).unwrap().len();
        assert!(n <= crate::link::MAX_PAYLOAD, "LQG + thrusters: {n} bytes");
        for a in [ActuatorParams::Wheels(wheels), ActuatorParams::Magnetorquers(mtq), ActuatorParams::Thrusters(thr)] {
            let p = FlightParams { actuator: a, ..base };
            assert_eq!(p.validate(), Ok(()), "{a:?}");
            let mut buf = [0u8; 2048];
            let n = postcard::to_slice(&crate::link::HostMsg::UploadParams(p), &mut buf).unwrap().len();
            assert!(n <= crate::link::MAX_PAYLOAD, "{n} bytes");
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
        p.guidance = GuidanceParams::fixed([0.0, 0.0, 0.0, 2.0], TargetFrame::Inertial);
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
