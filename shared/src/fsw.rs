//! The flight software step: the one function the firmware's control task and the
//! simulator's in-process link both call.
//!
//! `Fsw::step(&SensorFrame) -> ActuatorCommand`:
//! 1. reject bad input (flags, NaN/inf, quaternion norm off by > 10 %, rates > 50 rad/s):
//!    the safe command (zero gimbal rates: the CMGs hold their momentum) with `BAD_INPUT`;
//! 2. quaternion feedback → torque demand;
//! 3. CMG steering → gimbal rates, then the torque they realise and a shortfall flag.
//!
//! No heap, no panics, no loops without a fixed bound.

use crate::control::{QuaternionFeedback, QuaternionFeedbackGains};
use crate::math::{quat_from_xyzw, quat_normalized, Mat3, Quat, Vec3};
use crate::params::{FlightParams, ParamError, ParamField, ParamReason};
use crate::protocol::{status, valid, ActuatorCommand, SensorFrame};
use crate::steering::cmg::{CmgPyramid, GimbalLimits, GimbalTrig};

/// Largest body rate the flight code accepts as a measurement, rad/s.
pub const MAX_RATE_RAD_S: f32 = 50.0;

#[derive(Clone, Copy, Debug)]
struct Configured {
    params: FlightParams,
    inertia: Mat3,
    gains: QuaternionFeedbackGains,
    dt_s: f32,
    q_target: Quat,
    pyramid: CmgPyramid,
    limits: GimbalLimits,
}

/// Flight software state. `Fsw::new()` is unconfigured; `configure` must accept a
/// parameter set before `step` commands anything but the safe command.
#[derive(Clone, Debug, Default)]
pub struct Fsw {
    cfg: Option<Configured>,
    control: QuaternionFeedback,
    saturated_last: bool,
}

impl Fsw {
    pub const fn new() -> Self {
        Self {
            cfg: None,
            control: QuaternionFeedback {
                integral: nalgebra::Vector3::new(0.0, 0.0, 0.0),
            },
            saturated_last: false,
        }
    }

    /// Validate and adopt a parameter set; returns its checksum. On rejection the
    /// previous configuration (if any) stays in force.
    pub fn configure(&mut self, p: &FlightParams) -> Result<u32, ParamError> {
        p.validate()?;
        let checksum = p.checksum()?;
        let q_target = quat_normalized(&quat_from_xyzw(p.target_q_xyzw)).ok_or(ParamError {
            field: ParamField::Target,
            reason: ParamReason::NotUnitQuaternion,
        })?;
        let c = &p.controller;
        let m = crate::params::rows_to_mat;
        self.cfg = Some(Configured {
            params: *p,
            inertia: p.inertia(),
            gains: QuaternionFeedbackGains {
                k: m(&c.k_att_nm),
                d: m(&c.d_rate_nms),
                ki: m(&c.ki_att_nm_s),
                integral_limit_s: c.integral_limit_s,
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
                gyro_compensation: c.gyro_compensation,
            },
            dt_s: 1.0 / p.control_rate_hz,
            q_target,
            pyramid: CmgPyramid::new(p.cmg.skew_rad, p.cmg.h0_nms),
            limits: GimbalLimits::from(&p.cmg),
        });
        self.control.reset();
        self.saturated_last = false;
        Ok(checksum)
    }

    pub fn params(&self) -> Option<&FlightParams> {
        self.cfg.as_ref().map(|c| &c.params)
    }

    pub fn is_configured(&self) -> bool {
        self.cfg.is_some()
    }

    /// Change the commanded attitude (the integral state is kept: the set point moved,
    /// the disturbance did not).
    pub fn set_target(&mut self, q_xyzw: [f32; 4]) -> Result<(), ParamError> {
        let bad = ParamError {
            field: ParamField::Target,
            reason: ParamReason::NotUnitQuaternion,
        };
        let q = quat_from_xyzw(q_xyzw);
        if !q.coords.iter().all(|x| x.is_finite()) || (q.norm() - 1.0).abs() > 1e-3 {
            return Err(bad);
        }
        let cfg = self.cfg.as_mut().ok_or(bad)?;
        cfg.q_target = quat_normalized(&q).ok_or(bad)?;
        Ok(())
    }

    /// The command to hold when there is no trustworthy input: gimbals stop.
    pub fn safe_command(seq: u32, status_bits: u16) -> ActuatorCommand {
        ActuatorCommand {
            seq,
            status: status_bits,
            ..Default::default()
        }
    }

    /// One control step.
    pub fn step(&mut self, f: &SensorFrame) -> ActuatorCommand {
        let Some(cfg) = self.cfg.as_ref() else {
            return Self::safe_command(f.seq, status::NOT_CONFIGURED);
        };
        let Some((q, w, delta)) = check_frame(f) else {
            return Self::safe_command(f.seq, status::BAD_INPUT);
        };
        let trig = GimbalTrig::new(&delta);
        let h_cmg = cfg.pyramid.momentum(&trig);
        let demand = self.control.update(
            &cfg.gains,
            &cfg.inertia,
            &q,
            &cfg.q_target,
            &w,
            &h_cmg,
            cfg.dt_s,
            self.saturated_last,
        );
        let s = &cfg.params.steering;
        let out = cfg.pyramid.steer(
            &s.law,
            s.singular_threshold,
            &cfg.limits,
            &trig,
            &delta,
            &w,
            &demand.torque_nm,
            cfg.dt_s,
        );
        let realised = cfg
            .pyramid
            .torque_on_body(&trig, &w, &out.gimbal_rate_rad_s);
        let mut st = out.status;
        if demand.limited {
            st |= status::TORQUE_LIMITED;
        }
        if (realised - demand.torque_nm).norm() > 0.01 * demand.torque_nm.norm() + 1e-6 {
            st |= status::TORQUE_SHORTFALL;
        }
        self.saturated_last = st
            & (status::TORQUE_LIMITED
                | status::RATE_SCALED
                | status::ANGLE_LIMITED
                | status::TORQUE_SHORTFALL
                | status::SINGULAR)
            != 0;
        ActuatorCommand {
            seq: f.seq,
            gimbal_rate_cmd_rad_s: out.gimbal_rate_rad_s,
            torque_demand_nm: demand.torque_nm.into(),
            torque_realised_nm: realised.into(),
            singularity_measure: out.singularity_measure,
            steering_alpha: out.alpha,
            attitude_error_rad: demand.error_angle_rad,
            status: st,
        }
    }
}

/// Validated, normalised measurements, or `None` when anything is untrustworthy.
fn check_frame(f: &SensorFrame) -> Option<(Quat, Vec3, [f32; 4])> {
    if f.valid & valid::ALL != valid::ALL {
        return None;
    }
    let q = quat_from_xyzw(f.q_ib_xyzw);
    let n = q.norm();
    if !n.is_finite() || !(0.9..=1.1).contains(&n) {
        return None;
    }
    let q = quat_normalized(&q)?;
    let w = Vec3::from(f.rate_rad_s);
    if !w.iter().all(|x| x.is_finite()) || w.amax() > MAX_RATE_RAD_S {
        return None;
    }
    if !f
        .gimbal_angle_rad
        .iter()
        .all(|x| x.is_finite() && libm::fabsf(*x) < 1.0e3)
    {
        return None;
    }
    Some((q, w, f.gimbal_angle_rad))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{quat_from_euler, quat_to_xyzw, EulerSeq};

    fn frame(q: Quat) -> SensorFrame {
        SensorFrame {
            seq: 5,
            time_us: 0,
            q_ib_xyzw: quat_to_xyzw(&q),
            rate_rad_s: [0.0; 3],
            gimbal_angle_rad: [0.1, 0.2, -0.1, 0.3],
            valid: valid::ALL,
        }
    }

    #[test]
    fn unconfigured_and_bad_frames_get_the_safe_command() {
        let mut f = Fsw::new();
        let c = f.step(&frame(Quat::identity()));
        assert_eq!(c.status, status::NOT_CONFIGURED);
        assert_eq!(c.gimbal_rate_cmd_rad_s, [0.0; 4]);
        f.configure(&FlightParams::default()).unwrap();
        let nan = |g: fn(&mut SensorFrame)| {
            let mut fr = frame(Quat::identity());
            g(&mut fr);
            fr
        };
        let bad = [
            nan(|f| f.q_ib_xyzw[0] = f32::NAN),
            nan(|f| f.q_ib_xyzw = [0.0; 4]),
            nan(|f| f.q_ib_xyzw = [0.0, 0.0, 0.0, 3.0]),
            nan(|f| f.rate_rad_s[2] = f32::INFINITY),
            nan(|f| f.rate_rad_s[1] = 1e6),
            nan(|f| f.gimbal_angle_rad[3] = f32::NAN),
            nan(|f| f.valid = valid::RATE),
        ];
        for b in bad {
            let c = f.step(&b);
            assert_eq!(c.status, status::BAD_INPUT, "{b:?}");
            assert_eq!(c.gimbal_rate_cmd_rad_s, [0.0; 4]);
            assert_eq!(c.seq, 5);
        }
    }

    #[test]
    fn realised_torque_matches_demand_away_from_singularity() {
        let mut f = Fsw::new();
        f.configure(&FlightParams::default()).unwrap();
        let q = quat_from_euler([0.01, -0.02, 0.05], EulerSeq::Zyx321);
        let c = f.step(&frame(q));
        let d = Vec3::from(c.torque_demand_nm);
        let r = Vec3::from(c.torque_realised_nm);
        assert!(d.norm() > 1e-3);
        assert!((d - r).norm() < 0.01 * d.norm(), "{d:?} vs {r:?}");
        assert!(c.singularity_measure > 0.1);
    }

    #[test]
    fn rejected_parameters_keep_the_previous_configuration() {
        let mut f = Fsw::new();
        let good = FlightParams::default();
        f.configure(&good).unwrap();
        let mut bad = good;
        bad.control_rate_hz = -1.0;
        assert_eq!(
            f.configure(&bad).unwrap_err().field,
            ParamField::ControlRate
        );
        assert_eq!(f.params(), Some(&good));
    }
}
