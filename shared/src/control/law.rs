//! One interface for every attitude law: [`AttitudeLaw`], implemented by [`Law`], an enum
//! of the configured law with its gains and its own state (no `dyn`, no heap). A mode
//! switch or a law fault calls [`AttitudeLaw::reset`] on the law that takes over.

use super::sun_safe::{SunSafe, SunSafePhase};
use super::{
    Bdot, BdotGains, DcmPdGains, Dmcs, DmcsGains, EulerPdGains, LqrGains, QuaternionFeedback, QuaternionFeedbackGains,
    RateDampingGains, dcm_pd, euler_pd, lqr, lqr_from_state, lqr_state, rate_damping, state_feedback,
};
use crate::estimation::LqgEstimator;
use crate::math::{Mat3, Vec3};
use crate::params::{ControllerParams, ParamError, ParamField, ParamReason, rows_to_mat};
use crate::types::{Demand, Measurements, Setpoint, TorqueDemand};

/// Everything a law may read in one step.
#[derive(Clone, Copy, Debug)]
pub struct LawInputs<'a> {
    pub m: &'a Measurements,
    pub sp: &'a Setpoint,
    pub inertia: &'a Mat3,
    /// Actuator momentum, body axes (gyroscopic compensation), N m s.
    pub h_act_nms: &'a Vec3,
    /// Torque realised last step (the LQG estimator's input), N m.
    pub torque_last_nm: &'a Vec3,
    pub dt_s: f32,
    /// The previous step saturated (conditional integration / anti-windup).
    pub saturated_last: bool,
}

/// What a law produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawOutput {
    pub demand: Demand,
    /// The demand hit the law's torque limit and was scaled.
    pub limited: bool,
    /// Rotation angle of the attitude error, rad.
    pub error_angle_rad: f32,
}

impl From<TorqueDemand> for LawOutput {
    fn from(d: TorqueDemand) -> Self {
        Self { demand: Demand::Torque(d.torque_nm), limited: d.limited, error_angle_rad: d.error_angle_rad }
    }
}

/// An attitude control law with its state.
pub trait AttitudeLaw {
    /// One control update.
    fn update(&mut self, x: &LawInputs<'_>) -> LawOutput;
    /// Fresh state (integrators, filters, adaptive gains, estimate).
    fn reset(&mut self);
    /// Internal state worth reporting ([`LawStatus`]; `fsw::report` packs it into the
    /// wire's generic slot).
    fn status(&self) -> LawStatus {
        LawStatus::Stateless
    }
}

/// What a law reports of its internal state. Each law speaks its own variant; the wire
/// carries it in one generic slot (`ActuatorCommand::law_telemetry`, layout in
/// [`crate::link::law_slots`]), so a new law adds a variant here and its slots there,
/// with no change to the message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LawStatus {
    /// Nothing beyond the demand (PD laws, LQR, LQG, B-dot, rate damping).
    Stateless,
    /// DMCS adaptive gains (paper 001 eq 44, `u_p = Δk_p x_p + Δk_u u_m`): Δk_u per axis,
    /// and Δk_p per axis `[on q_e, on ω]`.
    Dmcs { feedforward_gain: [f32; 3], proportional_gain: [[f32; 2]; 3] },
    /// Sun-safe: its phase and the age of the remembered Sun direction, s.
    SunSafe { phase: SunSafePhase, memory_age_s: f32 },
}

/// The configured law: gains and, for laws with memory, their state.
#[derive(Clone, Copy, Debug)]
pub enum Law {
    QuaternionFeedback(QuaternionFeedbackGains, QuaternionFeedback),
    DcmPd(DcmPdGains),
    EulerPd(EulerPdGains),
    Bdot(BdotGains, Bdot),
    RateDamping(RateDampingGains),
    Lqr(LqrGains),
    /// Gimbal rates straight from the state (4×6 gain), no steering.
    LqrGimbalRate([[f32; 6]; 4]),
    Lqg(LqrGains, LqgEstimator),
    Dmcs(DmcsGains, Dmcs),
    SunSafe(SunSafe),
}

impl Law {
    /// The law of a validated parameter set, with fresh state.
    // Not inlined into `Configured::build`: its temporaries would sum into the build's
    // frame on the firmware's deepest stack chain (docs/firmware.md "Stack").
    #[inline(never)]
    pub fn from_params(c: &ControllerParams) -> Result<Self, ParamError> {
        Ok(match c {
            ControllerParams::QuaternionFeedback(c) => Self::QuaternionFeedback(
                QuaternionFeedbackGains {
                    k: rows_to_mat(&c.k_att_nm),
                    d: rows_to_mat(&c.d_rate_nms),
                    ki: rows_to_mat(&c.ki_att_nm_s),
                    integral_limit_s: c.integral_limit_s,
                    torque_limit_nm: Vec3::from(c.torque_limit_nm),
                    gyro_compensation: c.gyro_compensation,
                    max_slew_rate_rad_s: c.max_slew_rate_rad_s,
                },
                QuaternionFeedback::default(),
            ),
            ControllerParams::DcmPd(c) => Self::DcmPd(DcmPdGains {
                kp_nm: Vec3::from(c.kp_nm),
                kd_nms: Vec3::from(c.kd_nms),
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
            }),
            ControllerParams::EulerPd(c) => Self::EulerPd(EulerPdGains {
                kp_nm: Vec3::from(c.kp_nm),
                kd_nms: Vec3::from(c.kd_nms),
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
            }),
            ControllerParams::Bdot { gain_am2_s_per_t, filter_time_constant_s } => Self::Bdot(
                BdotGains { gain: *gain_am2_s_per_t, filter_time_constant_s: *filter_time_constant_s },
                Bdot::new(),
            ),
            ControllerParams::Lqr { k, torque_limit_nm } => {
                Self::Lqr(LqrGains { k: *k, torque_limit_nm: Vec3::from(*torque_limit_nm) })
            }
            ControllerParams::LqrGimbalRate { k } => Self::LqrGimbalRate(*k),
            ControllerParams::RateDamping { kd_nms, torque_limit_nm } => Self::RateDamping(RateDampingGains {
                kd_nms: Vec3::from(*kd_nms),
                torque_limit_nm: Vec3::from(*torque_limit_nm),
            }),
            ControllerParams::SunSafe(p) => Self::SunSafe(
                SunSafe::new(*p)
                    .map_err(|_| ParamError { field: ParamField::Controller, reason: ParamReason::OutOfRange })?,
            ),
            ControllerParams::Dmcs(d) => {
                let bad = ParamError { field: ParamField::AttitudeGain, reason: ParamReason::OutOfRange };
                let (p21, p22) =
                    DmcsGains::lyapunov_p(d.wn_rad_s, d.zeta, d.q_weights[0], d.q_weights[1]).ok_or(bad)?;
                let g = DmcsGains {
                    wn: d.wn_rad_s,
                    zeta: d.zeta,
                    model_inertia: Vec3::from(d.model_inertia_kgm2),
                    alpha: d.alpha,
                    beta: d.beta,
                    p21,
                    p22,
                    gain_limit: d.gain_limit,
                    torque_limit_nm: Vec3::from(d.torque_limit_nm),
                };
                Self::Dmcs(g, Dmcs::new())
            }
            ControllerParams::Lqg(g) => {
                let est = if g.time_varying {
                    LqgEstimator::time_varying(&g.a, &g.b, &g.process_noise, &g.measurement_noise, &g.p0_diag)
                        .ok_or(ParamError { field: ParamField::RateGain, reason: ParamReason::NotFinite })?
                } else {
                    LqgEstimator::new(&g.a, &g.b, &g.l)
                };
                Self::Lqg(LqrGains { k: g.k, torque_limit_nm: Vec3::from(g.torque_limit_nm) }, est)
            }
        })
    }

    /// Freeze (`true`) or resume (`false`) the adaptation of an adaptive law (DMCS, eqs
    /// 50-51); `false` when the law does not adapt (nothing changed).
    pub fn freeze_adaptation(&mut self, frozen: bool) -> bool {
        match self {
            Self::Dmcs(_, s) => {
                s.set_frozen(frozen);
                true
            }
            _ => false,
        }
    }

    /// Detumbling and sun-safe need no attitude (star trackers lose lock while tumbling;
    /// sun-safe is what runs when the attitude is lost).
    pub fn needs_attitude(&self) -> bool {
        !matches!(self, Self::Bdot(..) | Self::RateDamping(_) | Self::SunSafe(_))
    }
}

impl AttitudeLaw for Law {
    fn update(&mut self, x: &LawInputs<'_>) -> LawOutput {
        let (m, sp) = (x.m, x.sp);
        let (q, w, q_cmd, w_cmd) = (&m.q, &m.rate_rad_s, &sp.q_cmd, &sp.rate_cmd_rad_s);
        match self {
            Self::QuaternionFeedback(g, s) => {
                let ff = sp.feedforward.then_some(&sp.accel_cmd_rad_s2);
                s.update(g, x.inertia, q, q_cmd, w, w_cmd, ff, x.h_act_nms, x.dt_s, x.saturated_last).into()
            }
            Self::DcmPd(g) => dcm_pd(g, q, q_cmd, w, w_cmd).into(),
            Self::EulerPd(g) => euler_pd(g, q, q_cmd, w, w_cmd).into(),
            Self::Bdot(g, s) => s.torque_demand(g, &m.mag_field_t, x.dt_s).into(),
            Self::RateDamping(g) => rate_damping(g, w).into(),
            Self::Lqr(g) => lqr(g, q, q_cmd, w, w_cmd).into(),
            Self::LqrGimbalRate(k) => {
                let (state, angle) = lqr_state(q, q_cmd, w, w_cmd);
                let rates = state_feedback(k, &state);
                LawOutput { demand: Demand::GimbalRates(rates), limited: false, error_angle_rad: angle }
            }
            Self::Dmcs(g, s) => s.update(g, q, q_cmd, w, x.dt_s).into(),
            Self::SunSafe(s) => {
                let o = s.update(m.sun_body, m.eclipse, w, x.dt_s);
                // The "error" of sun-safe is the panel–Sun angle (0 when the Sun is unknown).
                let angle = if o.sun_angle_rad.is_finite() { o.sun_angle_rad } else { 0.0 };
                LawOutput { demand: Demand::Torque(o.torque_nm), limited: o.saturated, error_angle_rad: angle }
            }
            Self::Lqg(g, est) => {
                let (z, angle) = lqr_state(q, q_cmd, w, w_cmd);
                let state = est.update(&z, x.torque_last_nm);
                lqr_from_state(g, &state, angle).into()
            }
        }
    }

    fn reset(&mut self) {
        match self {
            Self::QuaternionFeedback(_, s) => s.reset(),
            Self::Bdot(_, s) => s.reset(),
            Self::Dmcs(_, s) => s.reset(),
            Self::Lqg(_, est) => est.reset(),
            Self::SunSafe(s) => s.reset(),
            Self::DcmPd(_) | Self::EulerPd(_) | Self::RateDamping(_) | Self::Lqr(_) | Self::LqrGimbalRate(_) => {}
        }
    }

    fn status(&self) -> LawStatus {
        match self {
            Self::Dmcs(_, s) => LawStatus::Dmcs { feedforward_gain: s.dku, proportional_gain: s.dkp },
            Self::SunSafe(s) => LawStatus::SunSafe { phase: s.phase(), memory_age_s: s.memory_age_s() },
            _ => LawStatus::Stateless,
        }
    }
}
