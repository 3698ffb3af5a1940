//! The flight software step: the one function the firmware's control task and the
//! simulator's in-process link both call.
//!
//! `Fsw::step(&SensorFrame) -> ActuatorCommand` runs the data path top-down:
//! 1. estimate: the frame's typed samples ([`crate::validation::sensor_samples`]) into
//!    navigation, reference models and attitude determination
//!    ([`crate::estimation::determination`]), every step whatever the mode;
//! 2. mode: the mode manager picks the parameter set in force ([`mode`]);
//! 3. validate: the frame and the estimate checked against what the mode needs
//!    ([`check::check_frame`]); if anything is missing, the safe command (all
//!    actuators idle: gimbals stop, wheel torques, dipoles and thrusters zero) with
//!    `BAD_INPUT` (a sensor) or `NO_ESTIMATE` (attitude estimate, navigation); then
//!    actuator momentum and geometry (the LQG law runs its own estimator);
//! 4. guide: commanded attitude and rate ([`crate::guidance`]), the mission pointing
//!    replaced by the ground's timeline when one of its segments takes over ([`timeline`]);
//! 5. control: the law → body-torque (or gimbal-rate) demand ([`crate::control::law`]);
//! 6. allocate: the actuator family → commands, the torque they realise, saturation
//!    ([`crate::allocation::family`]);
//! 7. report: the wire command (with the estimation stage's own
//!    [`crate::estimation::status::EstimateStatus`] packed as `EstimateTelemetry`), and
//!    the saturation the laws use for anti-windup next step ([`report`]).
//!
//! No heap, no panics, no loops without a fixed bound.

pub mod check;
mod config;
mod mode;
pub mod report;
mod timeline;

use crate::allocation::family::{ActuatorFamily, Actuators, Commands, ThrusterSet};
use crate::control::{AttitudeLaw, Law, LawInputs, momentum};
use crate::estimation::determination::{Determination, Estimate};
use crate::estimation::navigation::NavSolution;
use crate::fdir::wheel_chain::WheelFdir;
use crate::guidance::Guidance;
use crate::guidance::timeline::Timeline;
use crate::link::{ActuatorCommand, SensorFrame};
use crate::math::{Mat3, Vec3};
use crate::modes::ModeManager;
use crate::params::{ActuatorParams, FlightParams, MODE_COUNT};
use crate::types::{Demand, Status, Valid};
use crate::validation::sensor_samples;

use check::Missing;
pub use config::{FreezeError, ModeError};

/// A ground command named a unit the flight code does not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoSuchUnit;

/// One validated parameter set, ready to run.
#[derive(Clone, Debug)]
struct Configured {
    params: FlightParams,
    inertia: Mat3,
    /// The law with its own state.
    law: Law,
    dt_s: f32,
    guidance: Guidance,
    actuators: Actuators,
    /// Validity bits a sensor frame must carry for this configuration (`ATTITUDE`: the
    /// estimation stage's attitude).
    required: Valid,
    /// The target needs the on-board navigation solution.
    needs_navigation: bool,
    /// The thrusters of the momentum dump (`momentum.dumps()`), beside the family.
    dump: Option<ThrusterSet>,
}

/// What the thruster dump commanded this step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct DumpCommand {
    level: [f32; crate::params::MAX_THRUSTERS],
    on: u16,
    /// Body torque of the open thrusters, N m (fed forward to the wheels).
    pulse_nm: Vec3,
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
    /// Torque realised last step (the LQG estimator's input).
    torque_last: Vec3,
    saturated_last: bool,
    /// The estimation stage (navigation, attitude determination).
    determination: Determination,
    /// Torquer dipole commanded last step (held until this step's sample): its field at
    /// the magnetometer is subtracted ([`crate::control::momentum::torquer_field_t`]).
    dipole_last_am2: Vec3,
    /// A thruster momentum dump is under way (hysteresis state).
    dumping: bool,
    /// The ground's pointing timeline ([`timeline`]) and the latest navigation solution
    /// (what arming checks the segments against).
    timeline: Timeline,
    nav_last: Option<NavSolution>,
    /// Wheel fault detection, isolation and recovery ([`crate::fdir::wheel_chain`]).
    wheel_fdir: WheelFdir,
}

impl Default for Fsw {
    fn default() -> Self {
        Self::new()
    }
}

impl Fsw {
    pub const fn new() -> Self {
        Self {
            slots: [const { None }; MODE_COUNT],
            active: 0,
            table: false,
            manager: None,
            torque_last: nalgebra::Vector3::new(0.0, 0.0, 0.0),
            saturated_last: false,
            determination: Determination::sensor_only(),
            dipole_last_am2: nalgebra::Vector3::new(0.0, 0.0, 0.0),
            dumping: false,
            timeline: Timeline::new(),
            nav_last: None,
            wheel_fdir: WheelFdir::new(),
        }
    }

    /// The command to hold when there is no trustworthy input: every actuator idle.
    /// `status_bits`: wire [`crate::link::status`] bits.
    pub fn safe_command(seq: u32, status_bits: u16) -> ActuatorCommand {
        ActuatorCommand { seq, status: status_bits, ..Default::default() }
    }

    fn safe(seq: u32, status: Status) -> ActuatorCommand {
        Self::safe_command(seq, status.bits())
    }

    /// One control step.
    pub fn step(&mut self, f: &SensorFrame) -> ActuatorCommand {
        let corrected = self.without_torquer_field(f);
        let f = corrected.as_ref().unwrap_or(f);
        // Estimate: runs whatever the mode (and unconfigured: the filter converges while
        // the ground uploads the laws).
        let est = self.determination.step(&sensor_samples(f));
        let substituted = self.without_failed_magnetometer(f, &est);
        let f = substituted.as_ref().unwrap_or(f);
        self.step_fdir(f);
        let mut cmd = self.step_active(f, &est);
        self.wheel_fdir.command_sent(&cmd.wheel_torque_cmd_nm);
        cmd.fdir = self.wheel_fdir.telemetry();
        let d = &self.determination;
        report::sensor_fdir(&mut cmd.fdir, d);
        // A dropped wheel's drive is switched off: a runaway drive stops pushing.
        cmd.wheel_power_off = self.wheel_fdir.failed_mask();
        report::pack_estimate(&mut cmd.estimate, &est.status);
        if let Some(mgr) = &self.manager {
            report::mode_telemetry(&mut cmd, mgr);
        }
        let dipole = Vec3::from(cmd.dipole_cmd_am2);
        self.dipole_last_am2 = if dipole.iter().all(|x| x.is_finite()) { dipole } else { Vec3::zeros() };
        cmd
    }

    /// The ground re-enables wheel `wheel` (0-based; [`crate::link::ALL_UNITS`]: every
    /// wheel) that FDIR dropped, forgetting its exceedances. `Err` for an index beyond
    /// `MAX_WHEELS` (nothing changed). The failure stays counted in the events.
    pub fn clear_wheel_fault(&mut self, wheel: u8) -> Result<(), NoSuchUnit> {
        match usize::from(wheel) {
            _ if wheel == crate::link::ALL_UNITS => self.wheel_fdir.clear(None),
            i if i < crate::types::MAX_WHEELS => self.wheel_fdir.clear(Some(i)),
            _ => return Err(NoSuchUnit),
        }
        Ok(())
    }

    /// The ground re-enables the star tracker and the gyro axes the estimation stage's
    /// monitors declared failed (used again from their next sample; the failures stay
    /// counted).
    pub fn clear_sensor_faults(&mut self) {
        self.determination.clear_sensor_faults();
    }

    /// FDIR: the wheel monitor of the set in force (when it has one and flies wheels)
    /// judges the commands of the last step against the frame (docs/fdir.md "Wiring").
    fn step_fdir(&mut self, f: &SensorFrame) {
        // The residual uses the gyro: not judged once an axis is declared stuck.
        if self.determination.gyro_monitor().failed_axes() != 0 {
            self.wheel_fdir.skip();
            return;
        }
        match self.slots.get(self.active).and_then(Option::as_ref) {
            Some(Configured { params: p, inertia, .. }) => match (&p.fdir.wheel, &p.actuator) {
                (Some(fp), ActuatorParams::Wheels(w)) => self.wheel_fdir.step(fp, w, inertia, f),
                _ => self.wheel_fdir.skip(),
            },
            None => self.wheel_fdir.skip(),
        }
    }

    /// The frame with the torquers' field at the magnetometer removed (the calibrated
    /// coupling of the parameter set in force times last step's dipole); `None` (use the
    /// frame as it is, no copy on the hot path) when no set is in force or its coupling is 0.
    fn without_torquer_field(&self, f: &SensorFrame) -> Option<SensorFrame> {
        let p = &self.active_cfg()?.params.momentum;
        if p.mag_coupling_t_per_am2.iter().flatten().all(|c| *c == 0.0) {
            return None;
        }
        let field = momentum::torquer_field_t(p, &self.dipole_last_am2);
        let mut g = *f;
        g.mag_field_t = (Vec3::from(f.mag_field_t) - field).into();
        Some(g)
    }

    /// Recovery of a magnetometer the estimation stage declared failed (docs/fdir.md
    /// "Magnetometer"): the laws (B-dot, magnetic unloading) get the on-board model's field
    /// turned into body axes by the attitude estimate instead of the failed reading; with
    /// no model field or no estimate the magnetometer is invalid for them (its valid bit
    /// cleared: a law that needs it lacks its input, unloading commands nothing). `None`: a
    /// healthy magnetometer (no copy on the hot path).
    fn without_failed_magnetometer(&self, f: &SensorFrame, est: &Estimate) -> Option<SensorFrame> {
        if !self.determination.magnetometer_monitor().failed() {
            return None;
        }
        let mut g = *f;
        match (self.determination.model_field_eci_t(), est.attitude) {
            (Some(b_eci), Some(q_ib)) => g.mag_field_t = crate::math::rotate_ref_to_body(&q_ib, &b_eci).into(),
            _ => g.valid &= !crate::link::valid::MAG,
        }
        Some(g)
    }

    fn step_active(&mut self, f: &SensorFrame, est: &Estimate) -> ActuatorCommand {
        if self.table && self.manager.is_none() {
            return Self::safe(f.seq, Status::NOT_CONFIGURED);
        }
        // Mode: may switch the slot in force (and reset the law taking over).
        self.update_mode(f, est);
        // Timeline: a segment taking over replaces the mission pointing before guidance.
        self.step_timeline(est);
        let Some(Some(cfg)) = self.slots.get_mut(self.active) else {
            return Self::safe(f.seq, Status::NOT_CONFIGURED);
        };
        // Recovery: the wheels FDIR dropped are out of the allocation, whatever the set.
        if let (Actuators::Wheels(w), ActuatorParams::Wheels(base)) = (&mut cfg.actuators, &cfg.params.actuator) {
            w.failed_mask = base.failed_mask | self.wheel_fdir.failed_mask();
        }
        // Validate.
        let m = match check::check_frame(f, cfg.required, cfg.needs_navigation, est) {
            Ok(m) => m,
            Err(Missing::Sensor) => return Self::safe(f.seq, Status::BAD_INPUT),
            Err(Missing::Estimate) => return Self::safe(f.seq, Status::NO_ESTIMATE),
        };
        // Estimate: actuator momentum (gyroscopic terms) and geometry.
        let act = cfg.actuators.observe(&m);
        // Guide.
        let sp = cfg.guidance.setpoint(&m, est.nav.as_ref(), cfg.actuators.steering(), f.time_us);
        // Control.
        let inputs = LawInputs {
            m: &m,
            sp: &sp,
            inertia: &cfg.inertia,
            h_act_nms: &act.momentum_nms,
            torque_last_nm: &self.torque_last,
            dt_s: cfg.dt_s,
            saturated_last: self.saturated_last,
        };
        let mut out = cfg.law.update(&inputs);
        let mut flags = Status::empty();
        if !out.demand.is_finite() {
            // Documented fallback: allocate nothing; the law's state starts afresh.
            out.demand = out.demand.zeroed();
            flags |= Status::LAW_FAULT;
            cfg.law.reset();
        }
        // Momentum management: the wheels (CMGs) absorb the expected magnetic torque.
        // Only on a valid magnetometer (otherwise a zero field: nothing commanded).
        let mag_ok = Valid::from_bits_retain(f.valid).contains(Valid::MAG);
        let b_t = if mag_ok { m.mag_field_t } else { Vec3::zeros() };
        let unload = momentum::unload(&cfg.params.momentum, &act.momentum_nms, &b_t);
        let dump = Self::thruster_dump(cfg, &act.momentum_nms, &mut self.dumping);
        if let Demand::Torque(t) = &mut out.demand {
            *t -= unload.torque_nm;
            if let Some(d) = &dump {
                *t -= d.pulse_nm;
            }
        }
        // Allocate.
        let alloc = cfg.actuators.allocate(&out.demand, &m, &act, &sp, cfg.dt_s);
        // Report.
        let r = report::Report::new(&out, &alloc, flags, cfg.law.status());
        self.torque_last = match &dump {
            Some(d) => r.torque_for_estimator() + d.pulse_nm,
            // Not `+ 0`: a -0.0 component stays -0.0 (same bits as before the dump existed).
            None => r.torque_for_estimator(),
        };
        self.saturated_last = r.status.intersects(Status::SATURATING);
        let mut cmd = r.command(f.seq);
        cmd.guidance = cfg.guidance.telemetry();
        if let Some(d) = dump {
            cmd.thruster_on = d.on;
            cmd.thruster_level = d.level;
        }
        if cfg.params.momentum.enabled {
            cmd.dipole_cmd_am2 = unload.dipole_am2.into();
            cmd.stored_momentum_nms = act.momentum_nms.into();
        }
        cmd
    }
}

impl Fsw {
    /// The thruster momentum dump of a wheel or CMG mode ([`momentum::dump_torque_nm`]):
    /// the LP allocation of `τ_dump`, modulated (PWPF). `None` when the set has no dump
    /// or no dump runs (the modulator then starts afresh at the next dump). The wheels
    /// are fed the open thrusters' torque, so the pointing is held.
    fn thruster_dump(cfg: &mut Configured, h_nms: &Vec3, active: &mut bool) -> Option<DumpCommand> {
        let set = cfg.dump.as_mut()?;
        let tau = momentum::dump_torque_nm(&cfg.params.momentum, h_nms, active);
        if !*active || !tau.iter().all(|x| x.is_finite()) {
            set.pwpf.reset();
            return None;
        }
        match set.allocate(&tau).commands {
            Commands::Thrusters { level, on } => Some(DumpCommand { level, on, pulse_nm: set.pulse_torque_nm(on) }),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{status, valid};
    use crate::math::{EulerSeq, Quat, quat_from_euler, quat_to_xyzw};
    use crate::params::{ActuatorParams, ControllerParams, MagnetorquerParams, ParamField, WheelParams};
    use crate::params::{Mode, ModeManagerParams, ModeRequest};

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
            // Everything idle; only the estimation telemetry (not a command) differs.
            let commanded = ActuatorCommand { estimate: Default::default(), ..c };
            assert_eq!(commanded, Fsw::safe_command(5, status::BAD_INPUT));
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
        let w = WheelParams::body_axes_triad(10.0);
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
            failed_mask: 0,
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
            momentum_trip_fraction: 0.0,
            momentum_recover_fraction: 0.0,
            momentum_keepup_fraction: 0.0,
            gimbal_singularity_min: 0.0,
            slow_fdir_persistence_s: 0.0,
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
        assert_eq!(f.step(&fr).mode, crate::params::MODE_NONE);
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

    #[test]
    fn unloading_is_fed_forward_to_the_wheels_and_the_torquer_field_subtracted() {
        use crate::params::MomentumParams;
        let mut w = WheelParams::body_axes_triad(1.0);
        w.inertia_kgm2 = 1e-3;
        let mp = MomentumParams {
            enabled: true,
            gain_per_s: 1e-4,
            max_dipole_am2: [10.0; 3],
            residual_dipole_am2: [0.0, 0.0, 0.01],
            mag_coupling_t_per_am2: [[1e-6, 0.0, 0.0], [0.0, 2e-6, 0.0], [3e-7, 0.0, -1e-6]],
            ..MomentumParams::OFF
        };
        let base = FlightParams { actuator: ActuatorParams::Wheels(w), ..FlightParams::default() };
        let on = FlightParams { momentum: mp, ..base };
        let (mut f_off, mut f_on) = (Fsw::new(), Fsw::new());
        f_off.configure(&base).unwrap();
        f_on.configure(&on).unwrap();
        let b_true = Vec3::new(2e-5, -1e-5, 3e-5);
        let mut fr = frame(quat_from_euler([0.01, -0.02, 0.03], EulerSeq::Zyx321));
        fr.wheel_speed_rad_s = [100.0, -50.0, 20.0, 0.0, 0.0, 0.0];
        let c_off = f_off.step(&fr);
        let c_on = f_on.step(&fr);
        let h = Vec3::from(c_on.stored_momentum_nms);
        assert!((h - Vec3::new(0.1, -0.05, 0.02)).norm() < 1e-7);
        // The law is the same; the wheels are asked for law torque minus the magnetic torque.
        let u = momentum::unload(&mp, &h, &b_true);
        assert!(u.dipole_am2.norm() > 0.1 && !u.scaled);
        assert_eq!(Vec3::from(c_on.dipole_cmd_am2), u.dipole_am2);
        let d_off = Vec3::from(c_off.torque_demand_nm);
        let d_on = Vec3::from(c_on.torque_demand_nm);
        assert!((d_on - (d_off - u.torque_nm)).norm() < 1e-6 * d_off.norm(), "{d_on:?} {d_off:?}");
        // What the body receives: wheels + magnetic = what the law asked for.
        let total = Vec3::from(c_on.torque_realised_nm) + u.torque_nm;
        assert!((total - d_off).norm() < 1e-5 * d_off.norm());
        // Next step the magnetometer carries the torquers' field C m: it is removed.
        let polluted = b_true + momentum::torquer_field_t(&mp, &u.dipole_am2);
        fr.mag_field_t = polluted.into();
        let c2 = f_on.step(&fr);
        let clean = momentum::unload(&mp, &h, &b_true);
        let dirty = momentum::unload(&mp, &h, &polluted);
        assert!((Vec3::from(c2.dipole_cmd_am2) - clean.dipole_am2).norm() < 1e-6 * clean.dipole_am2.norm());
        assert!((dirty.dipole_am2 - clean.dipole_am2).norm() > 1e-3 * clean.dipole_am2.norm(), "the test can fail");
        // Unloading on magnetorquers (no stored momentum) is refused.
        let bad = FlightParams { actuator: ActuatorParams::Magnetorquers(mtq(1.0)), ..on };
        assert_eq!(Fsw::new().configure(&bad).unwrap_err().field, ParamField::Momentum);
    }

    #[test]
    fn thruster_dump_feeds_the_pulse_forward_and_stops_below_the_release() {
        use crate::allocation::thruster::paper::{PAPER_PWPF, paper_b};
        use crate::params::{MAX_THRUSTERS, MomentumParams, ThrusterMethod, ThrusterParams, UnloadMethod};
        let mut torque_nm = [[0.0f32; MAX_THRUSTERS]; 3];
        for (row, r8) in torque_nm.iter_mut().zip(paper_b(1.0).iter()) {
            row[..8].copy_from_slice(r8);
        }
        let thr = ThrusterParams {
            count: 8,
            torque_nm,
            method: ThrusterMethod::DirectionPreserving,
            pwpf_km: PAPER_PWPF.km,
            pwpf_tm_s: PAPER_PWPF.tm,
            pwpf_u_on: PAPER_PWPF.u_on,
            pwpf_u_off: PAPER_PWPF.u_off,
            failed_mask: 0,
        };
        let mp = MomentumParams {
            enabled: true,
            method: UnloadMethod::Thrusters,
            dump_gain_per_s: 0.05,
            dump_torque_max_nm: 0.3,
            dump_start_nms: 1.0,
            dump_stop_nms: 0.1,
            dump_thrusters: thr,
            ..MomentumParams::OFF
        };
        let mut w = WheelParams::body_axes_triad(5.0);
        w.inertia_kgm2 = 0.01;
        let base = FlightParams { actuator: ActuatorParams::Wheels(w), ..FlightParams::default() };
        let (mut f_off, mut f_on) = (Fsw::new(), Fsw::new());
        f_off.configure(&base).unwrap();
        f_on.configure(&FlightParams { momentum: mp, ..base }).unwrap();
        let mut fr = frame(quat_from_euler([0.01, -0.02, 0.03], EulerSeq::Zyx321));
        fr.wheel_speed_rad_s = [200.0, 0.0, 0.0, 0.0, 0.0, 0.0]; // h = [2, 0, 0] N m s
        let mut fired = 0;
        for _ in 0..100 {
            let c_off = f_off.step(&fr);
            let c_on = f_on.step(&fr);
            let d_off = Vec3::from(c_off.torque_demand_nm);
            let pulse = f_on.slots[0].as_ref().unwrap().dump.as_ref().unwrap().pulse_torque_nm(c_on.thruster_on);
            // The wheels are asked for the law's torque minus the thrusters' pulse.
            let d_on = Vec3::from(c_on.torque_demand_nm);
            assert!((d_on - (d_off - pulse)).norm() < 1e-5 * (1.0 + d_off.norm()), "{d_on:?} {d_off:?} {pulse:?}");
            // The level the LP gave makes a torque along -h_err (direction preserving).
            let mut lvl = Vec3::zeros();
            for (k, row) in torque_nm.iter().enumerate() {
                lvl[k] = row.iter().zip(c_on.thruster_level.iter()).map(|(b, u)| b * u).sum();
            }
            assert!(lvl.y.abs() < 1e-5 && lvl.z.abs() < 1e-5 && (lvl.x + 0.1).abs() < 1e-4, "{lvl:?}");
            fired += usize::from(c_on.thruster_on != 0);
        }
        assert!(fired > 0, "the PWPF fired");
        // Below the release threshold: no thruster, demand unchanged.
        fr.wheel_speed_rad_s = [5.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let c_on = f_on.step(&fr);
        let c_off = f_off.step(&fr);
        assert_eq!((c_on.thruster_on, c_on.thruster_level), (0, [0.0; MAX_THRUSTERS]));
        assert_eq!(c_on.torque_demand_nm, c_off.torque_demand_nm);
        // Between release and start (0.5 N m s): not restarted.
        fr.wheel_speed_rad_s = [50.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(f_on.step(&fr).thruster_on, 0);
        // A dump on a thruster family is refused (no stored momentum).
        let bad = FlightParams { actuator: ActuatorParams::Thrusters(thr), momentum: mp, ..base };
        assert_eq!(Fsw::new().configure(&bad).unwrap_err().field, ParamField::Momentum);
    }

    #[test]
    fn gimbal_monitor_counts_a_persistent_singularity_or_angle_limit_flag_only() {
        let mut base = FlightParams::default(); // the CMG pyramid, gimbals limited to ±1.5 rad
        if let ActuatorParams::Cmg { cmg, .. } = &mut base.actuator {
            (cmg.gimbal_min_rad, cmg.gimbal_max_rad) = (-1.5, 1.5);
        }
        let arm = |sing_min: f32| {
            let mut f = Fsw::new();
            f.configure_mode(Mode::Hold, &base).unwrap();
            let p = ModeManagerParams {
                slots: 0b1000,
                initial: Mode::Hold,
                gimbal_singularity_min: sing_min,
                slow_fdir_persistence_s: 0.05, // 5 steps at 100 Hz
                ..table_params()
            };
            f.arm_modes(&p).unwrap();
            f
        };
        let fr = frame(Quat::identity());
        // Away from singularity and limits (the measure here is > 0.1): nothing.
        let mut f = arm(1e-3);
        let cmds: Vec<_> = (0..50).map(|_| f.step(&fr)).collect();
        assert!(cmds.iter().all(|c| c.gimbal_events == 0 && c.status & status::MOMENTUM_SATURATION == 0));
        assert!(cmds[0].singularity_measure > 1e-3);
        // A threshold above the measure: one event after 5 steps, flagged, mode kept.
        let mut f = arm(2.0);
        let cmds: Vec<_> = (0..50).map(|_| f.step(&fr)).collect();
        assert_eq!(cmds[3].gimbal_events, 0);
        assert_eq!(cmds[4].gimbal_events, 1);
        assert_eq!(cmds[49].gimbal_events, 1);
        assert!(cmds[10].status & status::MOMENTUM_SATURATION != 0);
        assert!(cmds.iter().all(|c| c.mode == Mode::Hold.code() && c.momentum_events == 0));
        // A gimbal at its angle limit (singularity test off): counted too; 2 mrad inside: not.
        let mut f = arm(0.0);
        let mut at = fr;
        at.gimbal_angle_rad[2] = 1.498;
        assert_eq!((0..10).map(|_| f.step(&at)).last().unwrap().gimbal_events, 0);
        at.gimbal_angle_rad[2] = 1.5;
        assert_eq!((0..10).map(|_| f.step(&at)).last().unwrap().gimbal_events, 1);
    }
}
