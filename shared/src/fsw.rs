//! The flight software step: the one function the firmware's control task and the
//! simulator's in-process link both call.
//!
//! `Fsw::step(&SensorFrame) -> ActuatorCommand`:
//! 1. reject bad input (missing validity bits for what the configuration needs, NaN/inf,
//!    quaternion norm off by > 10 %, rates > 50 rad/s, field components > 1e-2 T, wheel
//!    speeds > 1e4 rad/s): the safe command (all actuators
//!    idle: gimbals stop, wheel torques, dipoles and thrusters zero) with `BAD_INPUT`;
//! 2. the control law → body-torque demand;
//! 3. allocation to the configured actuator family → commands, the torque they realise,
//!    saturation, and status bits the controller uses for anti-windup next step.
//!
//! No heap, no panics, no loops without a fixed bound.

use crate::allocation::thruster::{Allocator, Bounds, Failures, Pwpf, PwpfParams};
use crate::allocation::{AllocResult, AllocStatus, magnetorquers, wheels};
use crate::control::{
    Bdot, BdotGains, DcmPdGains, Dmcs, DmcsGains, EulerPdGains, LqgEstimator, LqrGains, QuaternionFeedback,
    QuaternionFeedbackGains, RateDampingGains, dcm_pd, euler_pd, lqr, lqr_from_state, lqr_state, rate_damping,
};
use crate::math::{
    Mat3, Quat, Vec3, attitude_error, quat_from_xyzw, quat_normalized, rotate_ref_to_body, rotation_angle,
};
use crate::modes::{MODE_COUNT, Mode, ModeInputs, ModeManager, ModeManagerParams, ModeRequest};
use crate::params::{
    ActuatorParams, ControllerParams, FlightParams, MAX_THRUSTERS, MAX_WHEELS, ParamError, ParamField, ParamReason,
    SteeringLaw, SteeringParams, TargetFrame, ThrusterMethod, ThrusterParams,
};
use crate::protocol::{ActuatorCommand, SensorFrame, status, valid};
use crate::steering::cmg::{CmgPyramid, GimbalLimits, GimbalTrig, limit_rates};

/// Largest body rate the flight code accepts as a measurement, rad/s.
pub const MAX_RATE_RAD_S: f32 = 50.0;
/// Largest magnetometer component accepted, T (Earth's field is < 7e-5 T; a lab
/// Helmholtz cage a few 1e-4 T).
pub const MAX_FIELD_T: f32 = 1.0e-2;
/// Largest wheel speed accepted, rad/s (≈ 95,000 rpm).
pub const MAX_WHEEL_SPEED_RAD_S: f32 = 1.0e4;

/// Thruster allocator at the configured capacity (`N + 1` LP columns: thrusters and λ).
pub type ThrusterAllocator = Allocator<MAX_THRUSTERS, { MAX_THRUSTERS + 1 }>;

#[derive(Clone, Debug)]
enum Actuators {
    Cmg {
        pyramid: CmgPyramid,
        limits: GimbalLimits,
        steering: SteeringParams,
    },
    Wheels(crate::params::WheelParams),
    Magnetorquers(crate::params::MagnetorquerParams),
    Thrusters {
        alloc: ThrusterAllocator,
        bounds: Bounds<MAX_THRUSTERS>,
        method: ThrusterMethod,
        pwpf: Pwpf<MAX_THRUSTERS>,
    },
}

#[derive(Clone, Copy, Debug)]
enum Law {
    QuaternionFeedback(QuaternionFeedbackGains),
    DcmPd(DcmPdGains),
    EulerPd(EulerPdGains),
    Bdot(BdotGains),
    RateDamping(RateDampingGains),
    Lqr(LqrGains),
    /// Gimbal rates straight from the state (4×6 gain), no steering.
    LqrGimbalRate([[f32; 6]; 4]),
    Lqg(LqrGains, LqgEstimator),
    Dmcs(DmcsGains),
}

#[derive(Clone, Debug)]
struct Configured {
    params: FlightParams,
    inertia: Mat3,
    law: Law,
    dt_s: f32,
    q_target: Quat,
    actuators: Actuators,
    /// Validity bits a sensor frame must carry for this configuration.
    required: u16,
}

/// Flight software state. `Fsw::new()` is unconfigured; `configure` must accept a
/// parameter set (or `configure_mode` + `arm_modes` a mode table) before `step` commands
/// anything but the safe command.
#[derive(Clone, Debug)]
pub struct Fsw {
    /// Single parameter set: slot 0. Mode table: slot `Mode::index()`.
    slots: [Option<Configured>; MODE_COUNT],
    /// Slot in force.
    active: usize,
    /// Slots hold a mode table (not a single parameter set).
    table: bool,
    /// The armed mode table's transition logic.
    manager: Option<ModeManager>,
    control: QuaternionFeedback,
    bdot: Bdot,
    dmcs: Dmcs,
    /// Torque realised last step (the LQG estimator's input).
    torque_last: Vec3,
    saturated_last: bool,
}

impl Default for Fsw {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a mode command or a mode-table operation was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeError {
    /// No mode table is armed.
    NotArmed,
    /// The requested mode has no parameter set in the armed table.
    NoSuchMode,
}

fn thruster_runtime(t: &ThrusterParams, dt_s: f32) -> Result<Actuators, ParamError> {
    let bad = |field| ParamError { field, reason: ParamReason::OutOfRange };
    let n = (t.count as usize).min(MAX_THRUSTERS);
    let mut u_max = [0.0f32; MAX_THRUSTERS];
    for x in u_max.iter_mut().take(n) {
        *x = 1.0;
    }
    let alloc = ThrusterAllocator::new(t.torque_nm, [0.0; MAX_THRUSTERS], u_max);
    let failures = Failures { failed: u32::from(t.failed_mask), stuck_on: 0 };
    let bounds = alloc.bounds(None, failures);
    let pp = PwpfParams { km: t.pwpf_km, tm: t.pwpf_tm_s, u_on: t.pwpf_u_on, u_off: t.pwpf_u_off, u_m: 1.0 };
    let pwpf = Pwpf::new(pp, dt_s).ok_or(bad(ParamField::Pwpf))?;
    Ok(Actuators::Thrusters { alloc, bounds, method: t.method, pwpf })
}

impl Fsw {
    pub const fn new() -> Self {
        Self {
            slots: [const { None }; MODE_COUNT],
            active: 0,
            table: false,
            manager: None,
            control: QuaternionFeedback { integral: nalgebra::Vector3::new(0.0, 0.0, 0.0) },
            bdot: Bdot::new(),
            dmcs: Dmcs::new(),
            torque_last: nalgebra::Vector3::new(0.0, 0.0, 0.0),
            saturated_last: false,
        }
    }

    /// Validate and adopt a single parameter set (no mode manager); returns its checksum.
    /// On rejection the previous configuration (if any) stays in force.
    pub fn configure(&mut self, p: &FlightParams) -> Result<u32, ParamError> {
        let (cfg, checksum) = Self::build(p)?;
        self.slots = [const { None }; MODE_COUNT];
        if let Some(s) = self.slots.get_mut(0) {
            *s = Some(cfg);
        }
        self.active = 0;
        self.table = false;
        self.manager = None;
        self.reset_law_state();
        Ok(checksum)
    }

    /// Validate and store the parameter set of one mode of a mode table; returns its
    /// checksum. A first call after a single `configure` starts a new table (the single
    /// set stops commanding until the table is armed). Replacing the active mode's set
    /// while armed takes effect at the next step with fresh law state.
    pub fn configure_mode(&mut self, mode: Mode, p: &FlightParams) -> Result<u32, ParamError> {
        let (cfg, checksum) = Self::build(p)?;
        // An armed table runs at one control rate.
        if self.manager.is_some() && self.slots.iter().flatten().any(|o| o.dt_s != cfg.dt_s) {
            return Err(ParamError { field: ParamField::ControlRate, reason: ParamReason::OutOfRange });
        }
        if !self.table {
            self.slots = [const { None }; MODE_COUNT];
            self.manager = None;
            self.table = true;
        }
        if let Some(s) = self.slots.get_mut(mode.index()) {
            *s = Some(cfg);
        }
        if self.manager.is_some() && self.active == mode.index() {
            self.reset_law_state();
        }
        Ok(checksum)
    }

    /// Arm the uploaded mode table; returns the checksum of `p`. Slots outside `p.slots`
    /// are dropped; every slot inside must be uploaded and all share one control rate.
    pub fn arm_modes(&mut self, p: &ModeManagerParams) -> Result<u32, ParamError> {
        let bad = |reason| ParamError { field: ParamField::ModeTable, reason };
        p.validate()?;
        let checksum = p.checksum()?;
        if !self.table {
            return Err(bad(ParamReason::OutOfRange));
        }
        let mut configured = [false; MODE_COUNT];
        let mut dt_s = None;
        for (i, (slot, c)) in self.slots.iter().zip(configured.iter_mut()).enumerate() {
            if p.slots & (1 << i) == 0 {
                continue;
            }
            let Some(cfg) = slot else {
                return Err(bad(ParamReason::OutOfRange));
            };
            if dt_s.is_some_and(|d| d != cfg.dt_s) {
                return Err(ParamError { field: ParamField::ControlRate, reason: ParamReason::OutOfRange });
            }
            dt_s = Some(cfg.dt_s);
            *c = true;
        }
        let mgr = ModeManager::new(*p, configured, dt_s.unwrap_or(0.0)).ok_or(bad(ParamReason::OutOfRange))?;
        for (slot, used) in self.slots.iter_mut().zip(configured) {
            if !used {
                *slot = None;
            }
        }
        self.active = p.initial.index();
        self.manager = Some(mgr);
        self.reset_law_state();
        Ok(checksum)
    }

    /// A ground mode command; returns the mode in force afterwards.
    pub fn command_mode(&mut self, r: ModeRequest) -> Result<Mode, ModeError> {
        let mgr = self.manager.as_mut().ok_or(ModeError::NotArmed)?;
        let before = mgr.mode;
        if !mgr.command(r) {
            return Err(ModeError::NoSuchMode);
        }
        let now = mgr.mode;
        if now != before {
            self.active = now.index();
            self.reset_law_state();
        }
        Ok(now)
    }

    /// The armed mode manager, if any (mode, reason, transition count).
    pub fn mode_manager(&self) -> Option<&ModeManager> {
        self.manager.as_ref()
    }

    /// Fresh state for the law that takes over (integrators, filters, estimator).
    fn reset_law_state(&mut self) {
        let law = self.slots.get_mut(self.active).and_then(Option::as_mut).map(|c| &mut c.law);
        reset_laws(&mut self.control, &mut self.bdot, &mut self.dmcs, law);
        self.torque_last = Vec3::zeros();
        self.saturated_last = false;
    }

    fn build(p: &FlightParams) -> Result<(Configured, u32), ParamError> {
        p.validate()?;
        let checksum = p.checksum()?;
        let q_target = quat_normalized(&quat_from_xyzw(p.target_q_xyzw))
            .ok_or(ParamError { field: ParamField::Target, reason: ParamReason::NotUnitQuaternion })?;
        let dt_s = 1.0 / p.control_rate_hz;
        let m = crate::params::rows_to_mat;
        let law = match &p.controller {
            ControllerParams::QuaternionFeedback(c) => Law::QuaternionFeedback(QuaternionFeedbackGains {
                k: m(&c.k_att_nm),
                d: m(&c.d_rate_nms),
                ki: m(&c.ki_att_nm_s),
                integral_limit_s: c.integral_limit_s,
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
                gyro_compensation: c.gyro_compensation,
                max_slew_rate_rad_s: c.max_slew_rate_rad_s,
            }),
            ControllerParams::DcmPd(c) => Law::DcmPd(DcmPdGains {
                kp_nm: Vec3::from(c.kp_nm),
                kd_nms: Vec3::from(c.kd_nms),
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
            }),
            ControllerParams::EulerPd(c) => Law::EulerPd(EulerPdGains {
                kp_nm: Vec3::from(c.kp_nm),
                kd_nms: Vec3::from(c.kd_nms),
                torque_limit_nm: Vec3::from(c.torque_limit_nm),
            }),
            ControllerParams::Bdot { gain_am2_s_per_t, filter_time_constant_s } => {
                Law::Bdot(BdotGains { gain: *gain_am2_s_per_t, filter_time_constant_s: *filter_time_constant_s })
            }
            ControllerParams::Lqr { k, torque_limit_nm } => {
                Law::Lqr(LqrGains { k: *k, torque_limit_nm: Vec3::from(*torque_limit_nm) })
            }
            ControllerParams::LqrGimbalRate { k } => Law::LqrGimbalRate(*k),
            ControllerParams::RateDamping { kd_nms, torque_limit_nm } => Law::RateDamping(RateDampingGains {
                kd_nms: Vec3::from(*kd_nms),
                torque_limit_nm: Vec3::from(*torque_limit_nm),
            }),
            ControllerParams::Dmcs(d) => {
                let bad = ParamError { field: ParamField::AttitudeGain, reason: ParamReason::OutOfRange };
                let (p21, p22) =
                    DmcsGains::lyapunov_p(d.wn_rad_s, d.zeta, d.q_weights[0], d.q_weights[1]).ok_or(bad)?;
                Law::Dmcs(DmcsGains {
                    wn: d.wn_rad_s,
                    zeta: d.zeta,
                    model_inertia: Vec3::from(d.model_inertia_kgm2),
                    alpha: d.alpha,
                    beta: d.beta,
                    p21,
                    p22,
                    gain_limit: d.gain_limit,
                    torque_limit_nm: Vec3::from(d.torque_limit_nm),
                })
            }
            ControllerParams::Lqg(g) => Law::Lqg(
                LqrGains { k: g.k, torque_limit_nm: Vec3::from(g.torque_limit_nm) },
                if g.time_varying {
                    LqgEstimator::time_varying(&g.a, &g.b, &g.process_noise, &g.measurement_noise, &g.p0_diag)
                        .ok_or(ParamError { field: ParamField::RateGain, reason: ParamReason::NotFinite })?
                } else {
                    LqgEstimator::new(&g.a, &g.b, &g.l)
                },
            ),
        };
        // Detumbling laws need no attitude (star trackers lose lock while tumbling).
        let mut required =
            if matches!(law, Law::Bdot(_) | Law::RateDamping(_)) { valid::RATE } else { valid::ATTITUDE | valid::RATE };
        let actuators = match &p.actuator {
            ActuatorParams::Cmg { cmg, steering } => {
                required |= valid::GIMBALS;
                Actuators::Cmg {
                    pyramid: CmgPyramid::new(cmg.skew_rad, cmg.h0_nms),
                    limits: GimbalLimits::from(cmg),
                    steering: *steering,
                }
            }
            ActuatorParams::Wheels(w) => {
                required |= valid::WHEELS;
                Actuators::Wheels(*w)
            }
            ActuatorParams::Magnetorquers(mt) => {
                required |= valid::MAG;
                Actuators::Magnetorquers(*mt)
            }
            ActuatorParams::Thrusters(t) => thruster_runtime(t, dt_s)?,
        };
        if p.target_frame == TargetFrame::Reference {
            required |= valid::REFERENCE;
        }
        let cfg = Configured { params: *p, inertia: p.inertia(), law, dt_s, q_target, actuators, required };
        Ok((cfg, checksum))
    }

    /// The parameter set in force.
    pub fn params(&self) -> Option<&FlightParams> {
        self.active_cfg().map(|c| &c.params)
    }

    fn active_cfg(&self) -> Option<&Configured> {
        if self.table && self.manager.is_none() {
            return None;
        }
        self.slots.get(self.active).and_then(Option::as_ref)
    }

    pub fn is_configured(&self) -> bool {
        self.active_cfg().is_some()
    }

    /// Change the commanded attitude (the integral state is kept: the set point moved,
    /// the disturbance did not). With a mode table the manoeuvre and hold targets change
    /// (the mission target); detumble and stabilise keep theirs.
    pub fn set_target(&mut self, q_xyzw: [f32; 4]) -> Result<(), ParamError> {
        let bad = ParamError { field: ParamField::Target, reason: ParamReason::NotUnitQuaternion };
        let q = quat_from_xyzw(q_xyzw);
        if !q.coords.iter().all(|x| x.is_finite()) || (q.norm() - 1.0).abs() > 1e-3 {
            return Err(bad);
        }
        let q = quat_normalized(&q).ok_or(bad)?;
        let mut any = false;
        for (i, slot) in self.slots.iter_mut().enumerate() {
            let mission = !self.table || i == Mode::Manoeuvre.index() || i == Mode::Hold.index();
            if let Some(cfg) = slot.as_mut().filter(|_| mission) {
                cfg.q_target = q;
                any = true;
            }
        }
        if any { Ok(()) } else { Err(bad) }
    }

    /// The command to hold when there is no trustworthy input: every actuator idle.
    pub fn safe_command(seq: u32, status_bits: u16) -> ActuatorCommand {
        ActuatorCommand { seq, status: status_bits, ..Default::default() }
    }

    /// One control step.
    pub fn step(&mut self, f: &SensorFrame) -> ActuatorCommand {
        let mut cmd = self.step_active(f);
        if let Some(mgr) = &self.manager {
            cmd.mode = mgr.mode.code();
            cmd.mode_reason = mgr.reason as u8;
            cmd.mode_transitions = mgr.transitions;
        }
        cmd
    }

    /// Mode logic on the active mode's view of the measurements; switches `active`. The
    /// rate trigger needs only the gyro: a tumble that blinds the star tracker must still
    /// reach detumble. Without the active mode's inputs, error and relative rate are NaN
    /// (never converged, never off target).
    fn update_mode(&mut self, f: &SensorFrame) {
        let (Some(mgr), Some(Some(cfg))) = (self.manager.as_mut(), self.slots.get(self.active)) else {
            return;
        };
        let w = Vec3::from(f.rate_rad_s);
        if f.valid & valid::RATE == 0 || !finite(&f.rate_rad_s) || w.amax() > MAX_RATE_RAD_S {
            return;
        }
        let (error_rad, rel_rate_rad_s) = match check_frame(f, cfg.required | valid::ATTITUDE) {
            Some(m) => {
                let (q_cmd, w_cmd) = command_frame(cfg, &m);
                (rotation_angle(&attitude_error(&m.q, &q_cmd)), (m.w - w_cmd).norm())
            }
            None => (f32::NAN, f32::NAN),
        };
        let mut inputs_ok = [false; MODE_COUNT];
        for (ok, slot) in inputs_ok.iter_mut().zip(self.slots.iter()) {
            *ok = slot.as_ref().is_some_and(|c| check_frame(f, c.required).is_some());
        }
        let inputs = ModeInputs { rate_rad_s: w.norm(), rel_rate_rad_s, error_rad, inputs_ok };
        if let Some((mode, _)) = mgr.update(&inputs) {
            self.active = mode.index();
            self.reset_law_state();
        }
    }

    fn step_active(&mut self, f: &SensorFrame) -> ActuatorCommand {
        if self.table && self.manager.is_none() {
            return Self::safe_command(f.seq, status::NOT_CONFIGURED);
        }
        self.update_mode(f);
        let Some(Some(cfg)) = self.slots.get_mut(self.active) else {
            return Self::safe_command(f.seq, status::NOT_CONFIGURED);
        };
        let Some(m) = check_frame(f, cfg.required) else {
            return Self::safe_command(f.seq, status::BAD_INPUT);
        };
        let (q_cmd, w_cmd) = command_frame(cfg, &m);
        let mut cmd = ActuatorCommand { seq: f.seq, ..Default::default() };
        // Actuator momentum for the gyroscopic term, and CMG trig reused by the steering.
        let (h_act, trig) = match &cfg.actuators {
            Actuators::Cmg { pyramid, .. } => {
                let t = GimbalTrig::new(&m.gimbals);
                (pyramid.momentum(&t), Some(t))
            }
            Actuators::Wheels(w) => {
                let mut h = Vec3::zeros();
                for (a, s) in w.axes.iter().zip(m.wheels.iter()).take(w.count as usize) {
                    h += Vec3::from(*a) * (w.inertia_kgm2 * s);
                }
                (h, None)
            }
            _ => (Vec3::zeros(), None),
        };
        // Laws that command the gimbal rates themselves (no torque demand to steer).
        let mut direct_rates: Option<[f32; 4]> = None;
        let demand = match &mut cfg.law {
            Law::QuaternionFeedback(g) => {
                self.control.update(g, &cfg.inertia, &m.q, &q_cmd, &m.w, &w_cmd, &h_act, cfg.dt_s, self.saturated_last)
            }
            Law::DcmPd(g) => dcm_pd(g, &m.q, &q_cmd, &m.w, &w_cmd),
            Law::EulerPd(g) => euler_pd(g, &m.q, &q_cmd, &m.w, &w_cmd),
            Law::Bdot(g) => self.bdot.torque_demand(g, &m.mag, cfg.dt_s),
            Law::RateDamping(g) => rate_damping(g, &m.w),
            Law::Lqr(g) => lqr(g, &m.q, &q_cmd, &m.w, &w_cmd),
            Law::LqrGimbalRate(k) => {
                let (x, angle) = lqr_state(&m.q, &q_cmd, &m.w, &w_cmd);
                direct_rates = Some(k.map(|row| -row.iter().zip(x.iter()).map(|(k, x)| k * x).sum::<f32>()));
                crate::control::TorqueDemand { torque_nm: Vec3::zeros(), limited: false, error_angle_rad: angle }
            }
            Law::Dmcs(g) => self.dmcs.update(g, &m.q, &q_cmd, &m.w, cfg.dt_s),
            Law::Lqg(g, est) => {
                let (z, angle) = lqr_state(&m.q, &q_cmd, &m.w, &w_cmd);
                let x = est.update(&z, &self.torque_last);
                lqr_from_state(g, &x, angle)
            }
        };
        let mut u = demand.torque_nm;
        let law_fault =
            !u.iter().all(|x| x.is_finite()) || direct_rates.is_some_and(|r| !r.iter().all(|x| x.is_finite()));
        if law_fault {
            // Documented fallback: allocate nothing; integrators and filters start afresh.
            u = Vec3::zeros();
            direct_rates = direct_rates.map(|_| [0.0; 4]);
            cmd.status |= status::LAW_FAULT;
            reset_laws(&mut self.control, &mut self.bdot, &mut self.dmcs, Some(&mut cfg.law));
        }
        let dt = cfg.dt_s;
        let alloc: AllocResult<4> = match &mut cfg.actuators {
            Actuators::Cmg { pyramid, limits, steering } => {
                let Some(t) = trig.as_ref() else {
                    return Self::safe_command(f.seq, status::BAD_INPUT);
                };
                if let Some(mut r) = direct_rates {
                    for (i, x) in r.iter_mut().enumerate() {
                        if limits.failed_mask & (1 << i) != 0 {
                            *x = 0.0;
                        }
                    }
                    cmd.status |= limit_rates(&mut r, &m.gimbals, limits, dt);
                    let realised = pyramid.torque_on_body(t, &m.w, &r);
                    cmd.gimbal_rate_cmd_rad_s = r;
                    let j1 = pyramid.unit_jacobian(t);
                    cmd.singularity_measure = (j1 * j1.transpose()).determinant();
                    // The law's demand is what its rates do.
                    u = realised;
                    cmg_result(r, &realised, &realised)
                } else {
                    let out = pyramid.steer(
                        steering,
                        limits,
                        t,
                        &m.gimbals,
                        &m.w,
                        &u,
                        dt,
                        dither_time_s(steering, f.time_us),
                    );
                    let realised = pyramid.torque_on_body(t, &m.w, &out.gimbal_rate_rad_s);
                    cmd.gimbal_rate_cmd_rad_s = out.gimbal_rate_rad_s;
                    cmd.singularity_measure = out.singularity_measure;
                    cmd.steering_alpha = out.alpha;
                    cmd.status |= out.status;
                    cmg_result(out.gimbal_rate_rad_s, &realised, &u)
                }
            }
            Actuators::Wheels(w) => {
                let r = wheels::allocate(w, &m.wheels, &u);
                cmd.wheel_torque_cmd_nm = r.u;
                narrow(&r)
            }
            Actuators::Magnetorquers(mt) => {
                let r = magnetorquers::allocate(mt, &m.mag, &u);
                cmd.dipole_cmd_am2 = r.u;
                narrow(&r)
            }
            Actuators::Thrusters { alloc, bounds, method, pwpf } => {
                let d: [f32; 3] = u.into();
                let r = match method {
                    ThrusterMethod::DirectionPreserving => alloc.direction_preserving(&d, bounds),
                    ThrusterMethod::Bodson => alloc.bodson(&d, bounds),
                };
                cmd.thruster_level = r.u;
                cmd.thruster_on = pwpf.step(&r.u) as u16;
                narrow(&r)
            }
        };
        cmd.torque_demand_nm = u.into();
        cmd.torque_realised_nm = alloc.realised;
        cmd.attitude_error_rad = demand.error_angle_rad;
        cmd.alloc_iterations = alloc.iterations;
        if let Law::Dmcs(_) = cfg.law {
            cmd.law_telemetry = self.dmcs.dku;
        }
        cmd.saturated = alloc.sat_low | alloc.sat_high;
        if demand.limited {
            cmd.status |= status::TORQUE_LIMITED;
        }
        match alloc.status {
            AllocStatus::Ok => {}
            AllocStatus::Scaled => cmd.status |= status::RATE_SCALED,
            AllocStatus::Singular => cmd.status |= status::SINGULAR,
            AllocStatus::Infeasible | AllocStatus::NonFinite | AllocStatus::IterationCap => {
                cmd.status |= status::ALLOC_FALLBACK
            }
        }
        if alloc.unrealised != 0 {
            cmd.status |= status::UNREALISED;
        }
        let realised = Vec3::from(alloc.realised);
        self.torque_last = if realised.iter().all(|x| x.is_finite()) { realised } else { Vec3::zeros() };
        // Relative test: cubesat torques are ~1e-7 N m, so no absolute floor above round-off.
        if (realised - u).norm() > 0.01 * u.norm() + 1e-12 {
            cmd.status |= status::TORQUE_SHORTFALL;
        }
        self.saturated_last = cmd.status
            & (status::TORQUE_LIMITED
                | status::RATE_SCALED
                | status::ANGLE_LIMITED
                | status::TORQUE_SHORTFALL
                | status::SINGULAR
                | status::ALLOC_FALLBACK
                | status::UNREALISED)
            != 0;
        cmd
    }
}

/// Reset every law's internal state (integrator, B-dot filter, DMCS gains, LQG estimate).
fn reset_laws(control: &mut QuaternionFeedback, bdot: &mut Bdot, dmcs: &mut Dmcs, law: Option<&mut Law>) {
    control.reset();
    bdot.reset();
    dmcs.reset();
    if let Some(Law::Lqg(_, est)) = law {
        est.reset();
    }
}

/// Commanded attitude and rate (body axes) of a configuration for these measurements.
fn command_frame(cfg: &Configured, m: &Measured) -> (Quat, Vec3) {
    match cfg.params.target_frame {
        TargetFrame::Inertial => (cfg.q_target, Vec3::zeros()),
        TargetFrame::Reference => (m.q_ref * cfg.q_target, rotate_ref_to_body(&m.q, &m.ref_rate)),
    }
}

/// The GSR dither phase only matters modulo its period: reduce the clock there so f32
/// keeps full resolution for ever.
fn dither_time_s(p: &SteeringParams, time_us: u64) -> f32 {
    match p.law {
        SteeringLaw::GeneralizedSr { omega_rad_s, .. } if omega_rad_s > 0.0 => {
            let period_us = ((core::f32::consts::TAU / omega_rad_s) * 1.0e6) as u64;
            (time_us % period_us.max(1)) as f32 * 1.0e-6
        }
        _ => 0.0,
    }
}

/// The allocation fields `step` reads, independent of the family's command width.
fn narrow<const N: usize>(r: &AllocResult<N>) -> AllocResult<4> {
    AllocResult {
        u: [0.0; 4],
        realised: r.realised,
        shortfall: r.shortfall,
        lambda: r.lambda,
        sat_low: r.sat_low,
        sat_high: r.sat_high,
        unrealised: r.unrealised,
        iterations: r.iterations,
        status: r.status,
    }
}

fn cmg_result(rates: [f32; 4], realised: &Vec3, demand: &Vec3) -> AllocResult<4> {
    let short = demand - realised;
    let dn = demand.norm_squared();
    AllocResult {
        u: rates,
        realised: (*realised).into(),
        shortfall: short.into(),
        lambda: if dn > 0.0 { (realised.dot(demand) / dn).clamp(0.0, 1.0) } else { 1.0 },
        sat_low: 0,
        sat_high: 0,
        unrealised: 0,
        iterations: 1,
        // The CMG steering reports its own status bits (RATE_SCALED, SINGULAR, …).
        status: AllocStatus::Ok,
    }
}

/// Validated, normalised measurements.
struct Measured {
    q: Quat,
    w: Vec3,
    gimbals: [f32; 4],
    wheels: [f32; MAX_WHEELS],
    mag: Vec3,
    q_ref: Quat,
    ref_rate: Vec3,
}

fn finite(xs: &[f32]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

fn unit_quat(q: [f32; 4]) -> Option<Quat> {
    let q = quat_from_xyzw(q);
    let n = q.norm();
    if !n.is_finite() || !(0.9..=1.1).contains(&n) {
        return None;
    }
    quat_normalized(&q)
}

/// `None` when anything the configuration needs is missing or untrustworthy.
fn check_frame(f: &SensorFrame, required: u16) -> Option<Measured> {
    if f.valid & required != required {
        return None;
    }
    // An attitude flagged valid must be a unit quaternion; one the law does not need may
    // be absent (identity then, unused).
    let q = if f.valid & valid::ATTITUDE != 0 || required & valid::ATTITUDE != 0 {
        unit_quat(f.q_ib_xyzw)?
    } else {
        Quat::identity()
    };
    let w = Vec3::from(f.rate_rad_s);
    if !finite(&f.rate_rad_s) || w.amax() > MAX_RATE_RAD_S {
        return None;
    }
    if required & valid::GIMBALS != 0 && !f.gimbal_angle_rad.iter().all(|x| x.is_finite() && libm::fabsf(*x) < 1.0e3) {
        return None;
    }
    let within = |xs: &[f32], limit: f32| xs.iter().all(|x| libm::fabsf(*x) <= limit);
    if required & valid::WHEELS != 0 && !within(&f.wheel_speed_rad_s, MAX_WHEEL_SPEED_RAD_S) {
        return None;
    }
    if required & valid::MAG != 0 && !within(&f.mag_field_t, MAX_FIELD_T) {
        return None;
    }
    let (q_ref, ref_rate) = if required & valid::REFERENCE != 0 {
        if !finite(&f.ref_rate_rad_s) {
            return None;
        }
        (unit_quat(f.q_ref_xyzw)?, Vec3::from(f.ref_rate_rad_s))
    } else {
        (Quat::identity(), Vec3::zeros())
    };
    Some(Measured {
        q,
        w,
        gimbals: f.gimbal_angle_rad,
        wheels: f.wheel_speed_rad_s,
        mag: Vec3::from(f.mag_field_t),
        q_ref,
        ref_rate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler, quat_to_xyzw};
    use crate::params::{MagnetorquerParams, WheelParams};

    fn frame(q: Quat) -> SensorFrame {
        SensorFrame {
            q_ib_xyzw: quat_to_xyzw(&q),
            gimbal_angle_rad: [0.1, 0.2, -0.1, 0.3],
            mag_field_t: [2e-5, -1e-5, 3e-5],
            valid: valid::ALL,
            ..SensorFrame::empty(5, 0)
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
            nan(|f| f.gimbal_angle_rad[0] = 1e30),
            nan(|f| f.valid = valid::ATTITUDE | valid::RATE), // CMG configuration needs gimbals
        ];
        for b in bad {
            let c = f.step(&b);
            assert_eq!(c.status, status::BAD_INPUT, "{b:?}");
            assert_eq!(c, Fsw::safe_command(5, status::BAD_INPUT));
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
        assert_eq!(f.configure(&bad).unwrap_err().field, ParamField::ControlRate);
        assert_eq!(f.params(), Some(&good));
    }

    fn other_family(a: ActuatorParams) -> Fsw {
        let mut f = Fsw::new();
        f.configure(&FlightParams { actuator: a, ..FlightParams::default() }).unwrap();
        f
    }

    #[test]
    fn every_family_produces_torque_against_the_error() {
        let q = quat_from_euler([0.02, -0.03, 0.05], EulerSeq::Zyx321);
        let mut axes = [[0.0; 3]; MAX_WHEELS];
        axes[0] = [1.0, 0.0, 0.0];
        axes[1] = [0.0, 1.0, 0.0];
        axes[2] = [0.0, 0.0, 1.0];
        let w = WheelParams {
            count: 3,
            axes,
            max_torque_nm: 10.0,
            max_speed_rad_s: 600.0,
            inertia_kgm2: 0.01,
            null_gain_per_s: 0.0,
            bias_speed_rad_s: [0.0; MAX_WHEELS],
            failed_mask: 0,
        };
        let mut fw = other_family(ActuatorParams::Wheels(w));
        let c = fw.step(&frame(q));
        let d = Vec3::from(c.torque_demand_nm);
        assert!((Vec3::from(c.torque_realised_nm) - d).norm() < 1e-5 * d.norm());
        // Body torque = -Σ a_i u_i: with the identity layout u = -T.
        assert!((c.wheel_torque_cmd_nm[0] + d.x).abs() < 1e-6);
        let mut fm = other_family(ActuatorParams::Magnetorquers(mtq(1e6)));
        let c = fm.step(&frame(q));
        let b = Vec3::new(2e-5, -1e-5, 3e-5);
        let d = Vec3::from(c.torque_demand_nm);
        let perp = d - b * (d.dot(&b) / b.norm_squared());
        assert!((Vec3::from(c.torque_realised_nm) - perp).norm() < 1e-4 * perp.norm());
        assert!(Vec3::from(c.dipole_cmd_am2).norm() > 0.0);
    }

    fn mtq(max_am2: f32) -> MagnetorquerParams {
        MagnetorquerParams {
            max_dipole_am2: [max_am2; 3],
            min_dipole_am2: [max_am2; 3],
            deadband_lo_am2: [0.0; 3],
            deadband_hi_am2: [0.0; 3],
            min_field_t: 1e-7,
        }
    }

    fn table_params() -> ModeManagerParams {
        ModeManagerParams {
            slots: 0b0101,
            initial: Mode::Detumble,
            detumble_enter_rate_rad_s: 0.05,
            detumble_exit_rate_rad_s: 0.01,
            stabilise_exit_error_rad: 0.1,
            stabilise_exit_rate_rad_s: 0.01,
            hold_enter_error_rad: 0.01,
            hold_enter_rate_rad_s: 0.01,
            hold_exit_error_rad: 0.05,
            dwell_s: 0.1,
            trigger_persistence_s: 0.02,
        }
    }

    #[test]
    fn mode_table_upload_arm_and_switch() {
        let mut f = Fsw::new();
        let base = FlightParams::default();
        // Arming needs an uploaded table.
        assert_eq!(f.arm_modes(&table_params()).unwrap_err().field, ParamField::ModeTable);
        assert_eq!(f.command_mode(ModeRequest::Auto), Err(ModeError::NotArmed));
        f.configure_mode(Mode::Detumble, &base).unwrap();
        // Uploaded but not armed: nothing commands.
        assert_eq!(f.step(&frame(Quat::identity())).status, status::NOT_CONFIGURED);
        // The mask names manoeuvre, which was not uploaded.
        assert_eq!(f.arm_modes(&table_params()).unwrap_err().field, ParamField::ModeTable);
        f.configure_mode(Mode::Manoeuvre, &base).unwrap();
        // A stale hold slot outside the mask is dropped at arming.
        f.configure_mode(Mode::Hold, &base).unwrap();
        f.arm_modes(&table_params()).unwrap();
        assert_eq!(f.command_mode(ModeRequest::Enter(Mode::Hold)), Err(ModeError::NoSuchMode));
        // At rest on target: detumble converges (rate 0 < exit) after dwell = 10 steps at 100 Hz
        // (the 10th step already runs the next mode: the switch comes before the law).
        let mut modes = Vec::new();
        for _ in 0..12 {
            let c = f.step(&frame(Quat::identity()));
            modes.push(c.mode);
        }
        assert_eq!(modes.first(), Some(&Mode::Detumble.code()));
        assert_eq!(modes.last(), Some(&Mode::Manoeuvre.code()));
        assert_eq!(modes.iter().filter(|m| **m == Mode::Detumble.code()).count(), 9);
        let mut fr = frame(Quat::identity());
        // A high rate sends it back to detumble after the 2-step persistence.
        fr.rate_rad_s = [0.1, 0.0, 0.0];
        let c: Vec<u8> = (0..3).map(|_| f.step(&fr).mode).collect();
        assert_eq!(c, [Mode::Manoeuvre.code(), Mode::Detumble.code(), Mode::Detumble.code()]);
        assert_eq!(f.mode_manager().map(|m| m.transitions), Some(2));
        // Lock manoeuvre: the high rate no longer switches.
        assert_eq!(f.command_mode(ModeRequest::Lock(Mode::Manoeuvre)), Ok(Mode::Manoeuvre));
        assert!((0..10).all(|_| f.step(&fr).mode == Mode::Manoeuvre.code()));
        // A single parameter set replaces the table.
        f.configure(&base).unwrap();
        assert_eq!(f.step(&fr).mode, crate::modes::MODE_NONE);
        assert_eq!(f.command_mode(ModeRequest::Auto), Err(ModeError::NotArmed));
    }

    #[test]
    fn set_target_moves_only_the_mission_modes() {
        let mut f = Fsw::new();
        let base = FlightParams::default();
        f.configure_mode(Mode::Stabilise, &base).unwrap();
        f.configure_mode(Mode::Hold, &base).unwrap();
        f.arm_modes(&ModeManagerParams { slots: 0b1010, initial: Mode::Stabilise, ..table_params() }).unwrap();
        let q = quat_from_euler([0.0, 0.0, 0.5], EulerSeq::Zyx321);
        f.set_target(quat_to_xyzw(&q)).unwrap();
        // Stabilise still points at identity: zero error at identity.
        let c = f.step(&frame(Quat::identity()));
        assert!(c.attitude_error_rad < 1e-6, "{}", c.attitude_error_rad);
        f.command_mode(ModeRequest::Lock(Mode::Hold)).unwrap();
        let c = f.step(&frame(Quat::identity()));
        assert!((c.attitude_error_rad - 0.5).abs() < 1e-4, "{}", c.attitude_error_rad);
        assert!(f.set_target([0.0, 0.0, 0.0, 2.0]).is_err());
    }

    #[test]
    fn gimbal_rate_lqr_commands_minus_k_x_without_steering() {
        let mut k = [[0.0f32; 6]; 4];
        for (i, row) in k.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = 0.1 * (i as f32 + 1.0) - 0.05 * j as f32;
            }
        }
        let p = FlightParams { controller: ControllerParams::LqrGimbalRate { k }, ..FlightParams::default() };
        let mut f = Fsw::new();
        f.configure(&p).unwrap();
        let (r, pi, y) = (0.01f32, -0.02, 0.015);
        let mut fr = frame(quat_from_euler([r, pi, y], EulerSeq::Zyx321));
        fr.rate_rad_s = [0.001, -0.002, 0.003];
        let c = f.step(&fr);
        let x = [r, pi, y, 0.001, -0.002, 0.003];
        for (i, row) in k.iter().enumerate() {
            let expect: f32 = -row.iter().zip(&x).map(|(k, x)| k * x).sum::<f32>();
            assert!((c.gimbal_rate_cmd_rad_s[i] - expect).abs() < 1e-6, "{i}: {:?}", c.gimbal_rate_cmd_rad_s);
        }
        // The reported demand is what those rates do: no shortfall is claimed.
        assert_eq!(c.status & status::TORQUE_SHORTFALL, 0);
        assert!(Vec3::from(c.torque_demand_nm).norm() > 0.0);
        // A gimbal-rate law on wheels is refused.
        let mut bad = p;
        bad.actuator = ActuatorParams::Magnetorquers(mtq(1.0));
        assert_eq!(f.configure(&bad).unwrap_err().field, ParamField::Controller);
    }

    #[test]
    fn a_tumble_that_blinds_the_star_tracker_still_reaches_detumble() {
        let bdot = FlightParams {
            controller: ControllerParams::Bdot { gain_am2_s_per_t: 1e4, filter_time_constant_s: 0.0 },
            actuator: ActuatorParams::Magnetorquers(mtq(0.1)),
            ..FlightParams::default()
        };
        let mut f = Fsw::new();
        f.configure_mode(Mode::Detumble, &bdot).unwrap();
        f.configure_mode(Mode::Hold, &FlightParams::default()).unwrap();
        f.arm_modes(&ModeManagerParams { slots: 0b1001, initial: Mode::Hold, ..table_params() }).unwrap();
        // Gyro and magnetometer valid, attitude lost, tumbling at 0.1 rad/s.
        let mut fr = frame(Quat::identity());
        fr.valid = valid::RATE | valid::MAG | valid::GIMBALS;
        fr.q_ib_xyzw = [0.0; 4];
        fr.rate_rad_s = [0.1, 0.0, 0.0];
        let c1 = f.step(&fr);
        // Hold cannot run blind…
        assert_eq!((c1.status, c1.mode), (status::BAD_INPUT, Mode::Hold.code()));
        // … but the rate trigger fires (2-step persistence) and B-dot needs no attitude.
        let c2 = f.step(&fr);
        assert_eq!(c2.mode, Mode::Detumble.code());
        assert_eq!(c2.status & status::BAD_INPUT, 0);
        fr.mag_field_t = [2.1e-5, -1.0e-5, 3.0e-5];
        let c3 = f.step(&fr);
        assert!(Vec3::from(c3.dipole_cmd_am2).norm() > 0.0, "B-dot acts on the field change");
    }
}
