//! One run as a value: [`Simulation`] owns the plant, its environment, the sensors, the
//! link to the flight code and the run's statistics; [`Simulation::step`] advances one
//! control period and hands the recorded row to a [`Recorder`].
//!
//! Timing: the sensors are offered the true state at t = 0 and after every RK4 substep
//! (in `Simulation::advance`), each sampling on its own clock; the frame of `t_k` carries the
//! newest samples that have arrived by then and is answered with commands that the plant
//! holds over `[t_k, t_k+1)` (zero-order hold, no added latency). Thruster valves are updated at
//! every dynamics step (minimum on-time, delays, failures) with exact impulse.
//!
//! Files: this one, the run loop; [`actuation`]: command → plant input; [`metrics`]: the
//! run's extremes and counters; [`row`]: the recorded row; [`probe`]: everything an
//! analysis needs to drive a run from outside (`sim-host margins`).

use crate::attitude::{Quat, Vec3, error_angle_and_vector, euler_from_quat};
use crate::environment::guidance::{PointingErrors, Sky, TruthGuidance, TruthSet, TruthStep};
use crate::environment::model::EnvSnapshot;
use crate::estimation::stats::EstimationStats;
use crate::faults::{CmgFault, Fault, FaultLog, WheelFault};
use crate::link::{FlightLink, LinkInfo};
use crate::plant::delay::DelayLine;
use crate::plant::wheel::{WheelDeriv, WheelOutput};
use crate::plant::{Input, MAX_GIMBALS, MAX_WHEELS, Spacecraft, State};
use crate::recorder::columns::Layout;
use crate::recorder::control_lost::{ControlWatch, LostVerdict};
use crate::recorder::momentum::MomentumStats;
use crate::recorder::pointing::PointingStats;
use crate::recorder::propellant;
use crate::recorder::segments::{SegmentKey, Segments};
use crate::recorder::series::Recorder;
use crate::recorder::summary::{
    CONTROL_STARTUP_FRACTION, CONTROL_STARTUP_MAX_S, ErrorStats, Failure, MAX_UNCONTROLLED_FRACTION, RunStatus,
    Summary, nan_max, nan_min,
};
use crate::scenario::{
    Clock, GroundCommand, InertiaChange, OpenLoopRow, Performance, Resolved, Scenario, TargetConfig, Upload, layout,
};
use crate::sensors::SensorSuite;
use acs_flight::link::{ActuatorCommand, FswMsg, status};
use acs_flight::math::EulerSeq;
use acs_flight::params::Mode;
use anyhow::{Context, Result, bail};

mod actuation;
mod metrics;
pub mod probe;
mod row;
mod timeline;
use crate::recorder::fdir::FdirLog;

use actuation::Actuation;
use metrics::{Metrics, mode_name};
use probe::LoopInjection;
use row::StepView;

/// Rows a run of `steps` control steps records with `output_every = every` (every
/// `every`-th step and the last).
pub fn recorded_rows(steps: u64, every: u64) -> u64 {
    steps / every + 1 + u64::from(!steps.is_multiple_of(every))
}

/// The column names a scenario records.
pub fn column_names(sc: &Scenario, n_wheels: usize, n_thrusters: usize) -> Vec<String> {
    layout(sc, n_wheels, n_thrusters).names()
}

/// The mission pointings in the order they take effect, as [`Simulation::retarget_truth`]
/// numbers them: the scenario's, then each ground command with a pointing or a target
/// (label and start, s).
fn mission_pointings(tg: &TruthGuidance, commands: &[GroundCommand]) -> Vec<(String, f64)> {
    let mut out = vec![(tg.mission.label.clone(), 0.0)];
    for c in commands.iter().filter(|c| c.pointing.is_some() || c.target.is_some()) {
        let label = c.pointing.as_ref().map_or_else(|| format!("target {}", out.len()), |p| p.label.clone());
        out.push((label, c.at_s));
    }
    out
}

/// The open-loop row in force at `t`.
fn open_loop_at(rows: &[OpenLoopRow], t: f64) -> Option<&OpenLoopRow> {
    rows.iter().take_while(|r| r.t_s <= t + 1e-12).last()
}

fn open_loop_command(row: Option<&OpenLoopRow>, seq: u32) -> ActuatorCommand {
    let mut c = ActuatorCommand { seq, ..Default::default() };
    if let Some(r) = row {
        if let Some(g) = r.gimbal_rate_rad_s {
            c.gimbal_rate_cmd_rad_s = g.map(|x| x as f32);
        }
        if let Some(w) = &r.wheel_torque_nm {
            for (d, s) in c.wheel_torque_cmd_nm.iter_mut().zip(w) {
                *d = *s as f32;
            }
        }
        if let Some(d) = r.dipole_am2 {
            c.dipole_cmd_am2 = d.map(|x| x as f32);
        }
        if let Some(t) = &r.thrusters_on {
            c.thruster_on = t.iter().fold(0u16, |m, i| m | (1 << (i - 1)));
        }
    }
    c
}

/// The first non-finite quantity of the plant state and of the environment snapshot
/// (orbit, field, LVLH frame), by name.
fn plant_non_finite(s: &State, snap: Option<&EnvSnapshot>) -> Option<&'static str> {
    let all = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
    let wheels = |f: fn(&crate::plant::wheel::WheelState) -> f64| s.wheels.iter().all(|w| f(w).is_finite());
    // Rates and momenta before the attitude: the renormalised quaternion turns NaN in
    // the same substep as the rate that drove it, and the rate names the cause.
    let checks: [(&'static str, bool); 8] = [
        ("rate_rad_s", all(s.w.as_slice())),
        ("wheel_momentum_nms", wheels(|w| w.h_abs_nms)),
        ("wheel_speed_ref_rad_s", wheels(|w| w.speed_ref_rad_s)),
        ("wheel_friction_nm", wheels(|w| w.dahl_friction_nm)),
        ("wheel_rotor_angle_rad", wheels(|w| w.rotor_angle_rad)),
        ("gimbal_rate_rad_s", all(&s.gimbal_rate_rad_s)),
        ("gimbal_rad", all(&s.gimbal_rad)),
        ("attitude_q", all(&[s.q.i, s.q.j, s.q.k, s.q.w])),
    ];
    if let Some((name, _)) = checks.iter().find(|c| !c.1) {
        return Some(name);
    }
    let snap = snap?;
    let v = |x: Option<Vec3>| x.is_none_or(|x| all(x.as_slice()));
    let env: [(&'static str, bool); 5] = [
        ("orbit_position", v(snap.orbit.map(|o| o.0))),
        ("orbit_velocity", v(snap.orbit.map(|o| o.1))),
        ("magnetic_field_t", v(snap.b_ref_t)),
        ("lvlh_frame", snap.q_lvlh.is_none_or(|q| all(&[q.i, q.j, q.k, q.w]))),
        ("lvlh_rate", all(snap.lvlh_rate_ref.as_slice())),
    ];
    env.iter().find(|c| !c.1).map(|c| c.0)
}

/// The first non-finite quantity of a flight command (what drives the actuators and the
/// telemetry the statistics use), by name.
fn command_non_finite(c: &ActuatorCommand) -> Option<&'static str> {
    let all = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
    let e = &c.estimate;
    let checks: [(&'static str, bool); 9] = [
        ("command.gimbal_rate_cmd_rad_s", all(&c.gimbal_rate_cmd_rad_s)),
        ("command.wheel_torque_cmd_nm", all(&c.wheel_torque_cmd_nm)),
        ("command.dipole_cmd_am2", all(&c.dipole_cmd_am2)),
        ("command.thruster_level", all(&c.thruster_level)),
        ("command.torque_demand_nm", all(&c.torque_demand_nm)),
        ("command.torque_realised_nm", all(&c.torque_realised_nm)),
        ("command.attitude_error_rad", c.attitude_error_rad.is_finite()),
        ("command.estimate.q_est_xyzw", all(&e.q_est_xyzw)),
        ("command.estimate.bias_est_rad_s", all(&e.bias_est_rad_s)),
    ];
    checks.iter().find(|c| !c.1).map(|c| c.0)
}

/// The attitude target: relative to its frame (inertial, or LVLH when the scenario says so).
#[derive(Clone)]
struct Target {
    q_rel: Quat,
    euler_deg: [f64; 3],
    seq: EulerSeq,
    lvlh: bool,
}

impl Target {
    fn set(&mut self, q_rel: Quat) {
        self.q_rel = q_rel;
        self.euler_deg = euler_from_quat(&q_rel, self.seq).map(f64::to_degrees);
    }

    /// The target's frame at this snapshot.
    fn frame(&self, snap: Option<&EnvSnapshot>) -> Quat {
        match (self.lvlh, snap.and_then(|s| s.q_lvlh)) {
            (true, Some(q)) => q,
            _ => Quat::identity(),
        }
    }
}

/// The truth of the pointing at one control step (with `[guidance]` or `[modes]`).
#[derive(Clone, Copy, Debug)]
struct TruthRow {
    step: TruthStep,
    errors: Option<PointingErrors>,
    sky: Option<Sky>,
    /// The ideal attitude (held from the last step when this one's cannot be defined).
    q_cmd: Quat,
    earth_angle_rad: f64,
}

/// A run in progress.
pub struct Simulation<'a> {
    /// The scenario's name and rates, for the summary.
    name: String,
    control_rate_hz: f64,
    dynamics_rate_hz: f64,
    /// The timed ground commands, in order.
    commands: Vec<GroundCommand>,
    link: &'a mut dyn FlightLink,
    info: Option<LinkInfo>,
    craft: Spacecraft,
    state: State,
    snap: Option<EnvSnapshot>,
    /// `snap` already holds the environment of the next control step (built at the last
    /// substep boundary for the sensors).
    snap_ready: bool,
    sensors: SensorSuite,
    /// The step change of the inertia, if any.
    inertia_change: Option<InertiaChange>,
    /// The open-loop command table (empty: none).
    open_loop: Vec<OpenLoopRow>,
    act: Actuation,
    target: Target,
    /// Index of the next ground command in `commands`.
    next_command: usize,
    metrics: Metrics,
    errors: ErrorStats,
    /// Pointing-performance indices over `[performance] from_s ..` (body-axis error).
    pointing: PointingStats,
    performance: Performance,
    /// The flight estimate against the truth.
    estimation: EstimationStats,
    layout: Layout,
    /// Stored-momentum figures (with the momentum group).
    momentum: Option<MomentumStats>,
    /// The keep-up and gimbal monitors are on (their counts go in the summary).
    slow_fdir: bool,
    /// Keep-out margins of the truth (with `[manoeuvre]` cones and an orbit).
    keepout: Option<crate::recorder::keepout::KeepOutStats>,
    columns: Vec<String>,
    row: Vec<f64>,
    /// The next control step.
    k: u64,
    clock: Clock,
    /// Set when a quantity became non-finite: the run stops there.
    failure: Option<Failure>,
    /// Time of the last control step that ran (the divergence time after a failure), s.
    t_end: f64,
    /// Added to the loop while set (`None` in every ordinary run).
    injection: Option<LoopInjection>,
    /// The last control step's command and true attitude error (deg), for tools that
    /// observe a run step by step.
    last_step: Option<(ActuatorCommand, f64)>,
    /// The truth of the pointing (with `[guidance]` or `[modes]`).
    truth: Option<TruthGuidance>,
    /// The truth of the step being recorded.
    truth_row: Option<TruthRow>,
    /// Pointing performance per segment (with `[guidance]` or `[modes]`).
    segments: Option<Segments>,
    /// Changes whenever a ground command replaces the mission's pointing.
    pointing_id: u32,
    /// The injected faults (`[[faults]]`) and when each first acted.
    pub(super) faults: FaultLog,
    /// With `[fdir]`: the flight's FDIR events, matched to the faults.
    pub(super) fdir: Option<FdirLog>,
    /// With `[[faults]]`: whether the truth lost control (the `control_lost` verdict).
    pub(super) control: Option<ControlWatch>,
    /// The scenario's `[[timeline]]` and the flight code's counters of it.
    timeline: timeline::TimelineRun,
}

impl<'a> Simulation<'a> {
    /// Opens the flight side (closed loop: hello and parameter or mode-table upload) and
    /// starts from the resolved scenario: plant in its initial state, sensors, actuators.
    pub fn new(cfg: Resolved, link: &'a mut dyn FlightLink) -> Result<Self> {
        let Resolved {
            name,
            clock,
            control_rate_hz,
            dynamics_rate_hz,
            upload,
            estimation,
            craft,
            snap0: snap,
            initial: state,
            thrusters,
            n_thrusters: n_thr,
            magnetorquers,
            sensors,
            target: TargetConfig { q_rel, seq, lvlh },
            truth,
            inertia_change,
            open_loop,
            commands,
            layout,
            keepout,
            keepout_enforced_from_s,
            momentum_trip,
            slow_fdir,
            performance,
            faults,
            timeline,
            allow_missed_segments,
            fdir,
            tumble_rate_deg_s,
            degraded_hold_error_deg,
        } = cfg;
        let timeline =
            timeline::TimelineRun { entries: timeline, allow_missed: allow_missed_segments, ..Default::default() };
        let info = match &upload {
            Some(up) => {
                let info = link.hello().context("hello")?;
                match up {
                    Upload::Modes(table) => link.upload_modes(table).context("mode table upload")?,
                    Upload::Params(p) => link.upload(p).context("parameter upload")?,
                };
                if let Some(e) = &estimation {
                    link.configure_estimation(e).context("estimation parameters")?;
                }
                timeline.stage(link).context("timeline upload")?;
                Some(info)
            }
            None => None,
        };
        let wheel_delay = DelayLine::from_seconds(craft.wheels.first().map_or(0.0, |w| w.torque_delay_s), clock.h());
        let gimbal_delay = DelayLine::from_seconds(craft.cmg.as_ref().map_or(0.0, |c| c.rate_delay_s), clock.dt);
        let mut act = Actuation::new(magnetorquers, thrusters, n_thr, wheel_delay, gimbal_delay);
        act.set_faults(&faults, craft.wheels.iter().map(|w| w.max_torque_nm));
        let mut sensors = sensors;
        sensors.set_faults(&faults);
        let mut target = Target { q_rel: Quat::identity(), euler_deg: [0.0; 3], seq, lvlh };
        target.set(q_rel);
        let columns = layout.names();
        let mission = truth.as_ref().map(|tg| mission_pointings(tg, &commands));
        Ok(Self {
            name,
            control_rate_hz,
            dynamics_rate_hz,
            commands,
            link,
            info,
            sensors,
            inertia_change,
            open_loop,
            craft,
            state,
            snap,
            snap_ready: false,
            act,
            target,
            next_command: 0,
            metrics: Metrics { min_singularity: f64::INFINITY, ..Metrics::default() },
            errors: ErrorStats::new(
                clock.dt,
                performance.settle_bound_deg,
                performance.settle_dwell_s,
                performance.confidence,
            ),
            pointing: PointingStats::new(performance.windows),
            segments: mission.map(|m| {
                let p = &performance;
                Segments::new(p.windows, p.confidence, p.segment_settle_s, p.from_s, m)
            }),
            truth,
            truth_row: None,
            pointing_id: 0,
            performance,
            estimation: EstimationStats::default(),
            row: Vec::with_capacity(columns.len()),
            momentum: layout.momentum.then(|| MomentumStats::new(momentum_trip, clock.dt)),
            slow_fdir,
            keepout: (!keepout.is_empty())
                .then(|| crate::recorder::keepout::KeepOutStats::new(keepout, keepout_enforced_from_s)),
            layout,
            columns,
            k: 0,
            clock,
            failure: None,
            t_end: 0.0,
            injection: None,
            last_step: None,
            control: (!faults.is_empty())
                .then(|| ControlWatch::new(tumble_rate_deg_s, degraded_hold_error_deg, performance.confidence)),
            faults: FaultLog::new(faults),
            fdir: fdir.then(FdirLog::default),
            timeline,
        })
    }

    /// The plant's state now (at the next control step's time).
    pub fn state(&self) -> &State {
        &self.state
    }

    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Rows the whole run records.
    pub fn recorded_rows(&self) -> u64 {
        recorded_rows(self.clock.steps, self.clock.output_every)
    }

    pub fn steps(&self) -> u64 {
        self.clock.steps
    }

    /// Control steps done so far.
    pub fn steps_done(&self) -> u64 {
        self.k
    }

    /// Whether every control step (0..=steps) has run, or the run diverged.
    pub fn finished(&self) -> bool {
        self.k > self.clock.steps || self.failure.is_some()
    }

    /// The divergence that stopped the run, if any.
    pub fn failure(&self) -> Option<&Failure> {
        self.failure.as_ref()
    }

    /// Ends the run at `t` if `quantity` names a non-finite one: records the failure and
    /// counts the step's (undefined) attitude error as NaN, so the error statistics say
    /// "not settled" rather than keep the last finite figures.
    fn diverged_at(&mut self, t: f64, quantity: Option<&str>) -> bool {
        let Some(q) = quantity else { return false };
        self.failure = Some(Failure::Diverged { t_s: t, quantity: q.to_owned() });
        self.errors.push(t, f64::NAN);
        self.push_pointing(t, [f64::NAN; 3]);
        self.t_end = t;
        true
    }

    /// The body-axis attitude error at `t`, deg, into the pointing indices (from
    /// `[performance] from_s` on).
    fn push_pointing(&mut self, t: f64, err_deg: [f64; 3]) {
        if t >= self.performance.from_s {
            self.pointing.push(err_deg);
        }
    }

    /// The sensor models, for tests that inject a fault into them mid-run.
    pub fn sensors_mut(&mut self) -> &mut SensorSuite {
        &mut self.sensors
    }

    /// The flight estimate against the truth so far (last step's error included).
    pub fn estimation(&self) -> &EstimationStats {
        &self.estimation
    }

    pub fn sim_time_s(&self) -> f64 {
        self.clock.steps as f64 * self.clock.dt
    }

    /// One control step at `t_k`: ground commands, sensors, flight code (or the open-loop
    /// table), statistics, the recorded row, then the plant over `[t_k, t_k+1)`.
    pub fn step(&mut self, rec: &mut dyn Recorder) -> Result<()> {
        let k = self.k;
        let t = k as f64 * self.clock.dt;
        if k > 0 && !self.snap_ready {
            self.snap = self.craft.env_at(t)?;
        }
        self.snap_ready = false;
        // No point flying (or asking the flight code about) a non-finite plant.
        if self.diverged_at(t, plant_non_finite(&self.state, self.snap.as_ref())) {
            return Ok(());
        }
        self.ground_commands(t)?;
        self.faults.observe(t);
        self.plant_faults(t);
        let (cmd, ticks) = self.flight_command(k, t)?;
        if self.diverged_at(t, command_non_finite(&cmd)) {
            return Ok(());
        }
        self.t_end = t;
        let (mut input, dipole_cmd) = self.act.input(t, &cmd, self.injection.as_ref());
        let q_frame = self.target.frame(self.snap.as_ref());
        self.truth_row = self.truth_step(t, &cmd);
        // With [guidance] the truth's ideal attitude is the target; else the scenario's.
        let guided = self.truth_row.filter(|_| self.layout.guidance);
        let q_cmd = guided.map_or(q_frame * self.target.q_rel, |r| r.q_cmd);
        let target_euler_deg = match guided {
            Some(r) => euler_from_quat(&(q_frame.conjugate() * r.q_cmd), self.target.seq).map(f64::to_degrees),
            None => self.target.euler_deg,
        };
        let (err_rad, err_vec_rad) = error_angle_and_vector(&self.state.q, &q_cmd);
        let err_deg = err_rad.to_degrees();
        self.last_step = Some((cmd, err_deg));
        self.push_pointing(t, err_vec_rad.map(f64::to_degrees));
        self.push_segment(t, &cmd);
        let wheels = self.observe(t, &cmd, ticks, &input, err_deg);
        self.observe_momentum(t, &cmd, err_deg);
        if let Some(c) = &mut self.control {
            let mode = self.layout.mode.then_some(cmd.mode).and_then(Mode::from_code);
            c.push(t, self.faults.any_injected(), err_deg, self.state.w.into(), mode);
        }

        // Thruster valves over the first dynamics step decide what is recorded as applied.
        let thr_mask = u32::from(cmd.thruster_on);
        let h = self.clock.h();
        if k < self.clock.steps {
            input.thruster_torque_nm = self.act.thruster_torque(thr_mask, t, h);
        }
        if k.is_multiple_of(self.clock.output_every) || k == self.clock.steps {
            let v = StepView {
                t,
                cmd: &cmd,
                ticks,
                err_deg,
                q_frame,
                target_euler_deg,
                input: &input,
                dipole_cmd,
                wheels: &wheels,
                n_wheels: self.craft.wheels.len(),
            };
            self.fill_row(&v);
            rec.record(&self.row)?;
        }
        if k < self.clock.steps {
            self.advance(t, &mut input, thr_mask)?;
        }
        self.k += 1;
        Ok(())
    }

    /// Sends the ground commands due at `t` and follows their new targets.
    fn ground_commands(&mut self, t: f64) -> Result<()> {
        while let Some(c) = self.commands.get(self.next_command).filter(|c| c.at_s <= t + 1e-9) {
            self.next_command += 1;
            for msg in &c.messages {
                match self.link.request(msg).with_context(|| format!("command at t = {t:.3} s"))? {
                    FswMsg::Ack | FswMsg::ModeAccepted { .. } => {}
                    other => bail!("command {msg:?} at t = {t:.3} s refused: {other:?}"),
                }
            }
            let (target, pointing) = (c.target, c.pointing.clone());
            if let Some(q) = target {
                self.target.set(q);
            }
            self.retarget_truth(target, pointing);
        }
        Ok(())
    }

    /// A ground command's new mission pointing, in the truth: a `target` (a fixed attitude
    /// in the target's frame) or a `guidance`.
    fn retarget_truth(&mut self, target: Option<Quat>, pointing: Option<TruthSet>) {
        let Some(tg) = self.truth.as_mut() else { return };
        let lvlh = self.target.lvlh;
        let new = pointing.or_else(|| {
            let main = crate::environment::guidance::TruthPointing::fixed(target?, lvlh);
            Some(TruthSet { label: format!("target {}", self.pointing_id + 1), main, gate: None })
        });
        if let Some(set) = new {
            tg.mission = set;
            self.pointing_id += 1;
        }
    }

    /// The truth of the pointing in force at `t` (the flight's reported mode's own, or the
    /// mission's), with the true attitude's errors from it.
    fn truth_step(&mut self, t: f64, cmd: &ActuatorCommand) -> Option<TruthRow> {
        let mode = self.layout.mode.then_some(cmd.mode).and_then(Mode::from_code);
        let tg = self.truth.as_mut()?;
        let snap = self.snap.as_ref();
        let env = self.craft.env.as_ref();
        let sun = env.map(|e| crate::environment::torques::sun_position_eci(e.julian_date(t)));
        let sky = snap.and_then(|s| s.orbit).zip(sun).map(|((r, v), sun)| Sky::new(t, r, v, sun, &tg.earth));
        let own = mode.and_then(|m| tg.modes.get_mut(m.index())).and_then(Option::as_mut);
        let set = match own {
            Some(s) => s,
            None => &mut tg.mission,
        };
        let step = set.step(sky.as_ref(), snap.and_then(|s| s.q_lvlh));
        let q_cmd = step.ideal.map(|i| i.q).or(self.truth_row.map(|r| r.q_cmd)).unwrap_or_else(Quat::identity);
        let errors = step.ideal.and_then(|i| i.errors(&self.state.q));
        Some(TruthRow { step, errors, sky, q_cmd, earth_angle_rad: tg.earth.angle(t) })
    }

    /// The step's errors from the truth's pointing into the segment it belongs to.
    fn push_segment(&mut self, t: f64, cmd: &ActuatorCommand) {
        let (Some(seg), Some(row), Some(tg)) = (self.segments.as_mut(), self.truth_row, self.truth.as_ref()) else {
            return;
        };
        let mode = self.layout.mode.then_some(cmd.mode);
        let own = mode
            .and_then(Mode::from_code)
            .and_then(|m| tg.modes.get(m.index()).and_then(Option::as_ref).map(|s| (m, s)));
        let (pointing, label) = match own {
            Some((m, s)) => (u32::MAX - m.index() as u32, s.label.as_str()),
            None => (self.pointing_id, tg.mission.label.as_str()),
        };
        let key = SegmentKey { mode, pointing, branch: row.step.branch };
        let (_, err) = error_angle_and_vector(&self.state.q, &row.q_cmd);
        let deg = |v: [f64; 3]| v.map(f64::to_degrees);
        let primary = row.errors.map(|e| deg(e.primary_vec_rad.into()));
        seg.push(t, key, (mode.map(mode_name), label), deg(err), primary);
    }

    /// The actuator command of step `k`: the flight code's answer to the sampled sensor
    /// frame (closed loop) or the open-loop table's; with the flight step's cost in ticks.
    fn flight_command(&mut self, k: u64, t: f64) -> Result<(ActuatorCommand, u32)> {
        if k == 0 {
            // The sensors' first offer of the truth (the later ones: after each substep).
            self.sensors.sample_due(t, &self.state, &self.craft, self.snap.as_ref(), &self.act.rod_dipole);
        }
        let mut frame = self.sensors.frame(k as u32, t, &self.state, &self.craft, self.snap.as_ref());
        if let Some(inj) = &self.injection {
            inj.add_to_frame(&mut frame);
        }
        if self.info.is_none() {
            return Ok((open_loop_command(open_loop_at(&self.open_loop, t), k as u32), 0));
        }
        let report = self.link.step(&frame).with_context(|| format!("control step {k} at t = {t:.3} s"))?;
        self.metrics.frames_dropped_flight = report.frames_dropped;
        self.estimation.push(&self.state.q, &self.sensors.gyro_bias_rad_s(), &report.cmd.estimate);
        if self.layout.mode {
            self.metrics.mode(t, &report.cmd);
        }
        self.timeline_after_step(t, report.timeline)?;
        if let Some(log) = &mut self.fdir {
            log.observe(t, &report.cmd.fdir, &self.faults.list);
        }
        Ok((report.cmd, report.step_cost_ticks))
    }

    /// Statistics of step at `t`; returns the wheels evaluated (zero without wheels).
    fn observe(
        &mut self,
        t: f64,
        cmd: &ActuatorCommand,
        ticks: u32,
        input: &Input,
        err_deg: f64,
    ) -> [(WheelDeriv, WheelOutput); MAX_WHEELS] {
        self.errors.push(t, err_deg);
        let after_startup = self.k >= self.startup_steps();
        let m = &mut self.metrics;
        if let Some(c) = &self.craft.cmg {
            m.min_singularity = nan_min(m.min_singularity, c.singularity_measure(&self.state.gimbal_rad));
            m.max_gimbal_rate =
                cmd.gimbal_rate_cmd_rad_s.iter().fold(m.max_gimbal_rate, |a, r| nan_max(a, r.abs() as f64));
        }
        let n_wheels = self.craft.wheels.len();
        let wheels = if n_wheels > 0 { self.craft.wheel_evaluations(&self.state, input) } else { Default::default() };
        m.wheels(wheels[..n_wheels].iter().map(|(_, o)| o));
        m.status(cmd.status);
        m.ticks(ticks);
        if after_startup {
            m.steps_after_startup += 1;
            m.uncontrolled_after_startup += u64::from(cmd.status & (status::BAD_INPUT | status::NO_ESTIMATE) != 0);
        }
        wheels
    }

    /// Flight steps of the start-up allowance of the no-control check: the first
    /// `CONTROL_STARTUP_FRACTION` of the run's steps, at most `CONTROL_STARTUP_MAX_S`.
    fn startup_steps(&self) -> u64 {
        let total = (self.clock.steps + 1) as f64;
        let by_time = (CONTROL_STARTUP_MAX_S / self.clock.dt).ceil();
        (CONTROL_STARTUP_FRACTION * total).ceil().min(by_time) as u64
    }

    /// Why the run counts as uncontrolled (`no_control`), if it does.
    fn no_control_reason(&self) -> Option<String> {
        let m = &self.metrics;
        let (n, bad) = (m.steps_after_startup, m.uncontrolled_after_startup);
        if self.info.is_none() || n == 0 || (bad as f64) <= MAX_UNCONTROLLED_FRACTION * n as f64 {
            return None;
        }
        let allowance_s = self.startup_steps() as f64 * self.clock.dt;
        Some(format!(
            "the flight code held the safe command on {bad} of the {n} control steps after the first {allowance_s} s \
             ({:.1} %, more than {:.0} %): the active mode lacked an input it needs (status_counts: bad_input {}, \
             no_estimate {} over the run)",
            100.0 * bad as f64 / n as f64,
            100.0 * MAX_UNCONTROLLED_FRACTION,
            m.counts.bad_input,
            m.counts.no_estimate
        ))
    }

    /// Stored-momentum figures of step at `t` (every step, with the momentum group).
    fn observe_momentum(&mut self, t: f64, cmd: &ActuatorCommand, err_deg: f64) {
        let Some(stats) = self.momentum.as_mut() else {
            return;
        };
        let h = self.craft.actuator_momentum(&self.state);
        let frac = self
            .craft
            .wheels
            .iter()
            .zip(self.state.wheels.iter())
            // Relative speed (eq 4 solved for ω_w) over its limit.
            .map(|(p, s)| {
                let w = s.h_abs_nms / p.inertia_kgm2 - Vec3::from(p.spin_axis).dot(&self.state.w);
                w.abs() / p.max_speed_rad_s
            })
            .fold(0.0, f64::max);
        stats.push(t, h.into(), frac, err_deg, cmd.momentum_events);
        if self.slow_fdir {
            stats.slow_events(cmd.momentum_keepup_events, cmd.gimbal_events);
        }
    }

    /// The plant over `[t, t + dt)`: the inertia step change, then the RK4 substeps.
    fn advance(&mut self, t: f64, input: &mut Input, thr_mask: u32) -> Result<()> {
        // Once, in the first step that reaches `at_s` (at the first step for `at_s <= 0`).
        if self.inertia_change.as_ref().is_some_and(|c| t + self.clock.dt >= c.at_s)
            && let Some(c) = self.inertia_change.take()
        {
            let j = self.craft.inertia * c.factor;
            self.craft.set_inertia(j);
        }
        let h = self.clock.h();
        for j in 0..self.clock.substeps {
            let tj = t + j as f64 * h;
            if j > 0 {
                input.thruster_torque_nm = self.act.thruster_torque(thr_mask, tj, h);
                input.wheel_torque_cmd_nm = self.act.wheel_torques();
            }
            self.plant_faults(tj);
            // The plant integrator (the only call): RK4 over [tj, tj + h) with the
            // environment evaluated at every stage's own time (issue 9).
            self.state = self.craft.rk4_env(tj, &self.state, input, h)?;
            if plant_non_finite(&self.state, None).is_some() {
                break; // the next control step reports it
            }
            // The last boundary is the next control step, at the time the step computes.
            let last = j + 1 == self.clock.substeps;
            self.offer_truth(if last { (self.k + 1) as f64 * self.clock.dt } else { tj + h }, last)?;
        }
        Ok(())
    }

    /// The plant's faults in force at `t` (checked at every dynamics step): the wheels
    /// seized and their friction factors, the CMG gimbals seized and the rotors' spin-down
    /// rates.
    fn plant_faults(&mut self, t: f64) {
        let mut seized = [false; MAX_WHEELS];
        let mut friction = [1.0; MAX_WHEELS];
        let mut gimbal_stuck = [false; MAX_GIMBALS];
        let mut decay = [0.0; MAX_GIMBALS];
        for f in self.faults.list.iter().filter(|f| f.window.active(t)) {
            match f.fault {
                Fault::Wheel { index, kind: WheelFault::Stuck } => {
                    if let Some(s) = seized.get_mut(index) {
                        *s = true;
                    }
                }
                Fault::Wheel { index, kind: WheelFault::Friction { factor } } => {
                    if let Some(k) = friction.get_mut(index) {
                        *k *= factor;
                    }
                }
                Fault::Cmg { index, kind: CmgFault::GimbalStuck } => {
                    if let Some(s) = gimbal_stuck.get_mut(index) {
                        *s = true;
                    }
                }
                Fault::Cmg { index, kind: CmgFault::RotorSpinDown { tau_s } } => {
                    if let Some(k) = decay.get_mut(index) {
                        *k += 1.0 / tau_s; // tau_s >= 1 s (validated)
                    }
                }
                _ => {}
            }
        }
        self.craft.seized = seized;
        self.craft.friction_factor = friction;
        self.craft.gimbal_stuck = gimbal_stuck;
        self.craft.rotor_decay_per_s = decay;
    }

    /// The true state at the substep boundary `t` to the sensors due there, with the
    /// environment at `t` when one of them reads it. At the control step (`control_step`)
    /// the step's own snapshot is built here and kept for it.
    fn offer_truth(&mut self, t: f64, control_step: bool) -> Result<()> {
        let env = if control_step {
            self.snap = self.craft.env_at(t)?;
            self.snap_ready = true;
            self.snap
        } else if self.sensors.needs_env_at(t) {
            self.craft.env_at(t)?
        } else {
            None
        };
        self.sensors.sample_due(t, &self.state, &self.craft, env.as_ref(), &self.act.rod_dipole);
        Ok(())
    }

    /// How the run ended: diverged, every flight step refused (`bad_input` on each of the
    /// control steps the flight code answered), a link anomaly, sensor samples dropped,
    /// not controlled for a material part of the run, a keep-out cone entered, a timeline
    /// missed, an FDIR false alarm, control lost unnoticed, a recovery failed, a pointing
    /// degraded, the propellant budget exceeded, or ok.
    fn outcome(&self) -> (RunStatus, Option<Failure>) {
        if let Some(f) = &self.failure {
            return (RunStatus::Diverged, Some(f.clone()));
        }
        let n = self.k;
        if self.info.is_some() && n > 0 && self.metrics.counts.bad_input == n {
            let reason = format!(
                "the flight code refused the input of every one of the {n} control steps (status bad_input): \
                 the sensor frames or the state it was given lie outside what it accepts \
                 (initial state, sensor noise and ranges in the scenario)"
            );
            return (RunStatus::AllRefused, Some(Failure::Refused { reason }));
        }
        if let Some(reason) = self.link.anomalies().failure_reason() {
            return (RunStatus::LinkAnomaly, Some(Failure::Link { reason }));
        }
        let dropped = self.sensors.samples_dropped();
        if dropped.iter().any(|(_, n)| *n > 0) {
            let lost: Vec<String> = dropped.iter().filter(|(_, n)| *n > 0).map(|(s, n)| format!("{s} {n}")).collect();
            let reason = format!("sensor samples dropped by the latency queues: {}", lost.join(", "));
            return (RunStatus::SamplesDropped, Some(Failure::Sensors { reason }));
        }
        if let Some(reason) = self.no_control_reason() {
            return (RunStatus::NoControl, Some(Failure::Control { reason }));
        }
        if let Some(reason) = self.keepout.as_ref().and_then(|k| k.violation_reason()) {
            return (RunStatus::KeepOutViolated, Some(Failure::KeepOut { reason }));
        }
        if let Some(reason) = self.timeline.failure_reason() {
            return (RunStatus::TimelineMissed, Some(Failure::Timeline { reason }));
        }
        if let Some(reason) = self.fdir.as_ref().and_then(FdirLog::failure_reason) {
            return (RunStatus::FdirFalseAlarm, Some(Failure::Fdir { reason }));
        }
        let fdir_events = self.fdir.as_ref().map_or(0, |f| f.summary().events.len());
        match self.control.as_ref().and_then(|c| c.verdict(fdir_events)) {
            Some(LostVerdict::ControlLost(reason)) => (RunStatus::ControlLost, Some(Failure::ControlLost { reason })),
            Some(LostVerdict::RecoveryFailed(reason)) => {
                (RunStatus::RecoveryFailed, Some(Failure::RecoveryFailed { reason }))
            }
            Some(LostVerdict::PointingDegraded(reason)) => {
                (RunStatus::PointingDegraded, Some(Failure::PointingDegraded { reason }))
            }
            // Last: a lost or degraded pointing is the worse failure (recorder::propellant).
            None => match propellant::exceeded(self.propellant_kg(), self.performance.propellant_budget_kg) {
                Some(reason) => (RunStatus::PropellantExceeded, Some(Failure::Propellant { reason })),
                None => (RunStatus::Ok, None),
            },
        }
    }

    /// Propellant the thrusters used so far, kg (`None` without thrusters).
    fn propellant_kg(&self) -> Option<f64> {
        (self.act.n_thr > 0).then(|| self.act.thr_state.total_propellant_kg())
    }

    /// The summary of the finished run; `wall_s` is the wall time of the loop.
    pub fn summary(self, wall_s: f64) -> Summary {
        let (m, info) = (&self.metrics, self.info.as_ref());
        let (run_status, failure) = self.outcome();
        // A diverged run reaches only the time of its failure.
        let sim_time = if self.failure.is_some() { self.t_end } else { self.sim_time_s() };
        let ef = self.errors.figures(sim_time);
        let q_frame = self.target.frame(self.snap.as_ref());
        let final_q_rel = q_frame.conjugate() * self.state.q;
        let guided = self.truth_row.filter(|_| self.layout.guidance);
        let target_euler_deg = guided.map_or(self.target.euler_deg, |r| {
            euler_from_quat(&(q_frame.conjugate() * r.q_cmd), self.target.seq).map(f64::to_degrees)
        });
        let (segments, unlisted, mission) = match self.segments.clone() {
            Some(s) => {
                let (list, n, mission) = s.finish();
                (Some(list), Some(n), Some(mission))
            }
            None => (None, None, None),
        };
        let n_ticks = m.n_ticks;
        let ipt = info.and_then(|i| i.instructions_per_tick).filter(|_| n_ticks > 0);
        let hz = info.map(|i| i.cost_counter_hz as f64).filter(|h| *h > 0.0 && n_ticks > 0);
        // QEMU's virtual clock is not the MCU's time (instructions are what it measures;
        // `sim-host cycles` bounds the cycles), so no µs are reported on board 1 (`HelloAck::board`: QEMU mps2-an386).
        let hz = hz.filter(|_| info.map(|i| i.board) != Some(1));
        let mean_us = hz.map(|h| m.sum_ticks / n_ticks as f64 / h * 1e6);
        let (n_wheels, n_thr, cmg) = (self.craft.wheels.len(), self.act.n_thr, self.craft.cmg.is_some());
        let accurate_wheels = self.craft.wheels.iter().any(|w| w.fidelity == crate::plant::wheel::Fidelity::Accurate);
        let thr = &self.act.thr_state;
        let est = self.estimation.figures();
        Summary {
            scenario: self.name.clone(),
            run_status,
            failure,
            link: if info.is_some() { self.link.name() } else { "open-loop".into() },
            board: info.map(|i| i.board),
            steps: self.clock.steps,
            sim_time_s: sim_time,
            control_rate_hz: self.control_rate_hz,
            dynamics_rate_hz: self.dynamics_rate_hz,
            final_error_deg: ef.final_error_deg,
            settle_time_s: ef.settle_time_s,
            settle_bound_deg: self.performance.settle_bound_deg,
            after_settle_from_s: ef.after_settle_from_s,
            max_error_after_settle_deg: ef.max_error_after_settle_deg,
            mean_error_whole_run_deg: ef.mean_error_whole_run_deg,
            rms_error_after_settle_deg: ef.rms_error_after_settle_deg,
            ape_after_settle_deg: ef.ape_after_settle_deg,
            final_euler_deg: euler_from_quat(&final_q_rel, self.target.seq).map(f64::to_degrees),
            target_euler_deg,
            final_rate_rad_s: self.state.w.into(),
            max_gimbal_rate_rad_s: cmg.then_some(m.max_gimbal_rate),
            min_singularity_measure: cmg.then_some(m.min_singularity),
            max_wheel_speed_rpm: (n_wheels > 0).then_some(m.max_wheel_rpm),
            max_wheel_power_w: (n_wheels > 0).then_some(m.max_wheel_w),
            // Ideal wheels have no motor model: no current to report (not 0 A).
            max_wheel_current_a: accurate_wheels.then_some(m.max_wheel_a),
            propellant_kg: self.propellant_kg(),
            propellant_budget_kg: self.performance.propellant_budget_kg,
            max_pulses: (n_thr > 0).then(|| thr.pulses.iter().copied().max().unwrap_or(0)),
            max_step_instructions: ipt.map(|f| (m.max_ticks as f64 * f).round() as u64),
            mean_step_instructions: ipt.map(|f| m.sum_ticks / n_ticks as f64 * f),
            max_step_ticks: (n_ticks > 0).then_some(m.max_ticks),
            mean_step_us: mean_us,
            max_step_us: hz.map(|h| m.max_ticks as f64 / h * 1e6),
            allocation_us_per_call: mean_us.filter(|_| n_thr > 0),
            status_counts: m.counts.clone(),
            mode_transitions: m.mode_transitions.clone(),
            final_mode: m.mode_now.map(mode_name),
            sensor_samples_dropped: self.sensors.samples_dropped().iter().map(|(_, n)| n).sum(),
            frames_dropped_flight: m.frames_dropped_flight,
            frames_dropped_host: if info.is_some() { self.link.frames_dropped_host() } else { 0 },
            link_anomalies: self.link.anomalies(),
            estimation_error_rms_deg: est.map(|e| e.error_rms_deg),
            estimation_error_max_deg: est.map(|e| e.error_max_deg),
            bias_error_final_deg_h: est.and_then(|e| e.bias_error_final_deg_h),
            nees_mean: est.and_then(|e| e.nees_mean),
            estimation_steps: est.map(|e| e.steps),
            innovations_rejected: est.map(|e| e.innovations_rejected),
            estimator_resets: est.map(|e| e.resets),
            sample_fusion: est.map(|e| e.sample_fusion),
            wall_time_s: wall_s,
            real_time_factor: sim_time / wall_s.max(1e-9),
            momentum: self.momentum.as_ref().map(MomentumStats::summary),
            keepout: self.keepout.as_ref().map(crate::recorder::keepout::KeepOutStats::summary),
            pointing: self.pointing.summary(self.performance.from_s, self.performance.confidence, self.clock.dt),
            pointing_segments: segments,
            pointing_segments_unlisted: unlisted,
            mission_pointings: mission,
            timeline: self.timeline.summary(),
            margins: None,
            faults: self.faults.records().map(|mut r| {
                if let Some(log) = &self.fdir {
                    log.mark_detections(&mut r);
                }
                r
            }),
            fdir: self.fdir.as_ref().map(FdirLog::summary),
        }
    }
}
