//! The closed-loop run: sensors → flight code (over a link) → plant, at the control rate,
//! with the plant integrated by RK4 at `control_rate × dynamics_substeps`. With
//! `controller.type = "none"` the actuators follow the scenario's open-loop table instead.
//!
//! Timing: the frame sampled at `t_k` is answered with commands that the plant holds over
//! `[t_k, t_k+1)` (zero-order hold, no added latency). Thruster valves are updated at
//! every dynamics step (minimum on-time, delays, failures) with exact impulse.

use crate::attitude::{Quat, error_angle, euler_from_quat, rotate_ref_to_body};
use crate::environment::model::EnvSnapshot;
use crate::link::{FlightLink, LinkInfo};
use crate::output::TimeSeries;
use crate::plant::thrusters::ThrusterState;
use crate::plant::{Input, MAX_WHEELS};
use crate::scenario::{Controller, OpenLoopRow, RefFrame, Scenario};
use crate::sensors::SensorSuite;
use acs_flight::modes::{Mode, Reason};
use acs_flight::params::MAX_THRUSTERS;
use acs_flight::protocol::{ActuatorCommand, FswMsg, status};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::time::{Duration, Instant};

/// Attitude-error bound that defines the settle time, deg.
pub const SETTLE_BOUND_DEG: f64 = 1.0;

#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct StatusCounts {
    pub torque_limited: u64,
    pub rate_scaled: u64,
    pub angle_limited: u64,
    pub singular: u64,
    pub bad_input: u64,
    pub torque_shortfall: u64,
    pub alloc_fallback: u64,
    pub unrealised: u64,
    pub law_fault: u64,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    pub scenario: String,
    pub link: String,
    /// 0 in-process, 1 QEMU mps2-an386, 2 STM32F405; null for open-loop runs.
    pub board: Option<u8>,
    pub steps: u64,
    pub sim_time_s: f64,
    pub control_rate_hz: f64,
    pub dynamics_rate_hz: f64,
    /// Principal angle between the true and the target attitude at the end, deg.
    pub final_error_deg: f64,
    /// Time after which the error stays below `SETTLE_BOUND_DEG`; `null` if it never does.
    pub settle_time_s: Option<f64>,
    pub settle_bound_deg: f64,
    pub max_error_after_settle_deg: Option<f64>,
    /// Mean error over the whole run, deg.
    pub mean_error_deg: f64,
    /// RMS error after the settle time (whole run if it never settles), deg.
    pub rms_error_deg: f64,
    /// Euler angles relative to the target's frame (inertial, lab or LVLH), deg.
    pub final_euler_deg: [f64; 3],
    pub target_euler_deg: [f64; 3],
    pub final_rate_rad_s: [f64; 3],
    /// Largest commanded gimbal rate, rad/s (null without CMGs).
    pub max_gimbal_rate_rad_s: Option<f64>,
    /// Smallest `det(J₁ J₁ᵀ)` of the true gimbal angles (unit rotor momentum).
    pub min_singularity_measure: Option<f64>,
    pub max_wheel_speed_rpm: Option<f64>,
    pub max_wheel_power_w: Option<f64>,
    pub max_wheel_current_a: Option<f64>,
    pub propellant_kg: Option<f64>,
    /// Most valve openings of any single thruster.
    pub max_pulses: Option<u32>,
    /// Largest `Fsw::step` cost in instructions (QEMU) — `null` when not measured.
    pub max_step_instructions: Option<u64>,
    pub mean_step_instructions: Option<f64>,
    /// Largest `Fsw::step` cost in raw counter ticks (any board that measures).
    pub max_step_ticks: Option<u32>,
    /// Mean and largest wall (host) or counter (board) time of `Fsw::step`, µs.
    pub mean_step_us: Option<f64>,
    pub max_step_us: Option<f64>,
    /// With thrusters: mean time per control step of the flight code (control law,
    /// LP allocation, PWPF — the LP dominates), µs, on the link's clock.
    pub allocation_us_per_call: Option<f64>,
    pub status_counts: StatusCounts,
    /// Every change of the flight mode (empty without `[modes]`).
    pub mode_transitions: Vec<ModeTransition>,
    pub final_mode: Option<String>,
    pub frames_dropped_flight: u32,
    pub frames_dropped_host: u32,
    /// Wall time of the closed loop only (no file output), s.
    pub wall_time_s: f64,
    pub real_time_factor: f64,
}

/// A change of the flight mode as reported in telemetry.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ModeTransition {
    /// Time of the first step the new mode commanded, s.
    pub t_s: f64,
    pub from: String,
    pub to: String,
    /// Why the flight code switched (`acs_flight::modes::Reason`).
    pub reason: String,
}

fn mode_name(code: u8) -> String {
    Mode::from_code(code).map_or("none", Mode::name).into()
}

pub struct RunResult {
    pub summary: Summary,
    pub series: TimeSeries,
}

/// The columns a scenario records: always attitude, rates, torques and error; then one
/// group per actuator family and environment model present.
pub fn column_names(sc: &Scenario, n_wheels: usize, n_thrusters: usize) -> Vec<String> {
    let s = |x: &[&str]| x.iter().map(|c| c.to_string()).collect::<Vec<_>>();
    let mut v = s(&["t_s", "q_x", "q_y", "q_z", "q_w", "roll_deg", "pitch_deg", "yaw_deg"]);
    v.extend(s(&[
        "roll_target_deg",
        "pitch_target_deg",
        "yaw_target_deg",
        "rate_x_rad_s",
        "rate_y_rad_s",
        "rate_z_rad_s",
    ]));
    for g in ["demand", "realised", "applied"] {
        v.extend(["x", "y", "z"].map(|a| format!("torque_{g}_{a}_nm")));
    }
    v.extend(s(&["error_deg", "status", "step_cost_insns"]));
    if matches!(sc.controller, Some(Controller::Dmcs { .. })) {
        v.extend(["x", "y", "z"].map(|a| format!("adaptive_gain_{a}")));
    }
    if sc.modes.is_some() {
        v.push("mode".into());
    }
    if sc.closed_loop() {
        // The flight code's own error to the target of the law in force (per mode).
        v.push("flight_error_deg".into());
    }
    if sc.actuators.cmg.is_some() {
        v.extend((1..=4).map(|i| format!("gimbal{i}_deg")));
        v.extend((1..=4).map(|i| format!("gimbal_rate{i}_rad_s")));
        v.extend(s(&["singularity_m", "steering_alpha"]));
    }
    for i in 1..=n_wheels {
        v.extend(
            ["speed_rpm", "current_a", "voltage_v", "power_w", "friction_nm", "torque_nm"]
                .map(|q| format!("wheel{i}_{q}")),
        );
    }
    if sc.actuators.magnetorquers.is_some() {
        v.extend(["x", "y", "z"].map(|a| format!("dipole_cmd_{a}_am2")));
        v.extend(["x", "y", "z"].map(|a| format!("dipole_{a}_am2")));
    }
    if n_thrusters > 0 {
        v.extend(s(&["thrusters_on", "propellant_kg", "pulses_total"]));
        v.extend((1..=n_thrusters).map(|i| format!("thruster{i}_level")));
    }
    if sc.orbit.is_some() || sc.environment.lab_field_t.is_some() {
        v.extend(["x", "y", "z"].map(|a| format!("b_body_{a}_t")));
    }
    if has_environment(sc) {
        for g in ["gravity_gradient", "drag", "srp", "magnetic", "rig", "external"] {
            v.extend(["x", "y", "z"].map(|a| format!("torque_{g}_{a}_nm")));
        }
    }
    v
}

/// Whether any environment or rig torque can act (the torque breakdown is recorded then).
fn has_environment(sc: &Scenario) -> bool {
    sc.orbit.is_some()
        || sc.rig.is_some()
        || sc.environment.lab_field_t.is_some()
        || sc.spacecraft.harmonic_torque.is_some()
        || sc.spacecraft.external_torque_nm != [0.0; 3]
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

/// Run the scenario. Closed loop: against an already-opened link; open loop
/// (`controller.type = "none"`): the link is not used.
pub fn run(sc: &Scenario, link: &mut dyn FlightLink, progress: bool) -> Result<RunResult> {
    let closed_loop = sc.closed_loop();
    let info: Option<LinkInfo> = if closed_loop {
        let info = link.hello().context("hello")?;
        match sc.mode_table()? {
            Some(table) => link.upload_modes(&table).context("mode table upload")?,
            None => link.upload(&sc.flight_params()?).context("parameter upload")?,
        };
        Some(info)
    } else {
        None
    };
    let mut craft = sc.spacecraft()?;
    let snapshot = |craft: &mut crate::plant::Spacecraft, t: f64| -> Result<Option<EnvSnapshot>> { craft.env_at(t) };
    let snap0 = snapshot(&mut craft, 0.0)?;
    let mut state = sc.initial_state(&craft, snap0.as_ref());
    let n_wheels = craft.wheels.len();
    let mtq = sc.magnetorquer_set();
    let thrusters = sc.thruster_set();
    let n_thr = thrusters.as_ref().map_or(0, |t| t.thrusters.len()).min(MAX_THRUSTERS);
    let mut thr_state = ThrusterState::new(n_thr);
    let mut sensors = SensorSuite::new(&sc.sensors, sc.timing.control_rate_hz);
    let mut rod_dipole = [0.0f64; 3];
    let mut q_target_rel = sc.target.quaternion();
    let mut pending_commands = sc.commands.iter().peekable();
    let mut mode_transitions: Vec<ModeTransition> = Vec::new();
    let mut mode_now: Option<u8> = None;
    let seq = sc.target.euler_sequence.into();
    let mut target_euler_deg = euler_from_quat(&q_target_rel, seq).map(f64::to_degrees);
    let target_frame = |snap: Option<&EnvSnapshot>| -> Quat {
        match (sc.target.frame, snap.and_then(|s| s.q_lvlh)) {
            (RefFrame::Lvlh, Some(q)) => q,
            _ => Quat::identity(),
        }
    };
    let dt = sc.control_dt();
    let sub = sc.timing.dynamics_substeps;
    let h = dt / sub as f64;
    let steps = sc.steps();
    let every = sc.timing.output_every as u64;
    let open_rows: &[OpenLoopRow] = sc.open_loop.as_ref().map_or(&[], |o| o.commands.as_slice());

    let mut ts = TimeSeries::with_columns(column_names(sc, n_wheels, n_thr), (steps / every + 2) as usize);
    let mut row = Vec::with_capacity(ts.names.len());
    let mut counts = StatusCounts::default();
    let (mut max_rate, mut min_m) = (0.0f64, f64::INFINITY);
    let (mut max_wheel_rpm, mut max_wheel_w, mut max_wheel_a) = (0.0f64, 0.0f64, 0.0f64);
    let (mut max_ticks, mut sum_ticks, mut n_ticks) = (0u32, 0f64, 0u64);
    let mut last_above: Option<f64> = Some(0.0);
    let mut errors = Vec::with_capacity(steps as usize + 1);
    let mut frames_dropped_flight = 0;
    let mut bar: Option<indicatif::ProgressBar> = None;
    let mut snap = snap0;
    let with_env = has_environment(sc);

    let start = Instant::now();
    for k in 0..=steps {
        let t = k as f64 * dt;
        if k > 0 {
            snap = snapshot(&mut craft, t)?;
        }
        while let Some(c) = pending_commands.next_if(|c| c.at_s <= t + 1e-9) {
            for msg in sc.command_messages(c) {
                match link.request(&msg).with_context(|| format!("command at t = {t:.3} s"))? {
                    FswMsg::Ack | FswMsg::ModeAccepted { .. } => {}
                    other => bail!("command {msg:?} at t = {t:.3} s refused: {other:?}"),
                }
            }
            if let Some(tg) = &c.target {
                q_target_rel = tg.quaternion();
                target_euler_deg = euler_from_quat(&q_target_rel, seq).map(f64::to_degrees);
            }
        }
        let frame = sensors.sample(k as u32, t, &state, &craft, snap.as_ref(), &rod_dipole);
        let (cmd, ticks) = if closed_loop {
            let report = link.step(&frame).with_context(|| format!("control step {k} at t = {t:.3} s"))?;
            frames_dropped_flight = report.frames_dropped;
            if sc.modes.is_some() && mode_now != Some(report.cmd.mode) {
                if let Some(from) = mode_now {
                    mode_transitions.push(ModeTransition {
                        t_s: t,
                        from: mode_name(from),
                        to: mode_name(report.cmd.mode),
                        reason: Reason::from_code(report.cmd.mode_reason).map_or("unknown", Reason::name).into(),
                    });
                }
                mode_now = Some(report.cmd.mode);
            }
            (report.cmd, report.step_cost_ticks)
        } else {
            (open_loop_command(open_loop_at(open_rows, t), k as u32), 0)
        };
        let mut input = Input::default();
        for (d, s) in input.gimbal_rate_cmd_rad_s.iter_mut().zip(cmd.gimbal_rate_cmd_rad_s) {
            *d = s as f64;
        }
        for (d, s) in input.wheel_torque_cmd_nm.iter_mut().zip(cmd.wheel_torque_cmd_nm).take(MAX_WHEELS) {
            *d = s as f64;
        }
        let dipole_cmd = cmd.dipole_cmd_am2.map(|x| x as f64);
        if !mtq.rods.is_empty() {
            rod_dipole = mtq.rod_dipole_am2(&mtq.realised(&dipole_cmd));
        }
        input.dipole_am2 = rod_dipole.into();
        input.dipole_am2 += crate::attitude::Vec3::from(mtq.residual_dipole_am2);

        let q_frame = target_frame(snap.as_ref());
        let q_target = q_frame * q_target_rel;
        let err_deg = error_angle(&state.q, &q_target).to_degrees();
        errors.push((t, err_deg));
        if err_deg >= SETTLE_BOUND_DEG {
            last_above = Some(t);
        }
        if let Some(c) = &craft.cmg {
            min_m = min_m.min(c.singularity_measure(&state.gimbal_rad));
            max_rate = cmd.gimbal_rate_cmd_rad_s.iter().fold(max_rate, |a, r| a.max(r.abs() as f64));
        }
        let wheel_out = if n_wheels > 0 { craft.wheel_outputs(&state, &input) } else { Default::default() };
        for o in wheel_out.iter().take(n_wheels) {
            max_wheel_rpm = max_wheel_rpm.max(o.speed_rad_s.abs() * 30.0 / std::f64::consts::PI);
            max_wheel_w = max_wheel_w.max(o.power_w.abs());
            max_wheel_a = max_wheel_a.max(o.current_a.abs());
        }
        let s = cmd.status;
        for (bit, c) in [
            (status::TORQUE_LIMITED, &mut counts.torque_limited),
            (status::RATE_SCALED, &mut counts.rate_scaled),
            (status::ANGLE_LIMITED, &mut counts.angle_limited),
            (status::SINGULAR, &mut counts.singular),
            (status::BAD_INPUT, &mut counts.bad_input),
            (status::TORQUE_SHORTFALL, &mut counts.torque_shortfall),
            (status::ALLOC_FALLBACK, &mut counts.alloc_fallback),
            (status::UNREALISED, &mut counts.unrealised),
            (status::LAW_FAULT, &mut counts.law_fault),
        ] {
            *c += u64::from(s & bit != 0);
        }
        if ticks > 0 {
            max_ticks = max_ticks.max(ticks);
            sum_ticks += ticks as f64;
            n_ticks += 1;
        }

        // Thruster valves over the first dynamics step decide what is recorded as applied.
        let thr_mask = u32::from(cmd.thruster_on);
        let thr_torque = |t0: f64, ts_: &mut ThrusterState| -> crate::attitude::Vec3 {
            match &thrusters {
                Some(set) => set.wrench(&set.step(ts_, thr_mask, t0, h)).1.into(),
                None => crate::attitude::Vec3::zeros(),
            }
        };
        input.thruster_torque_nm = if k < steps { thr_torque(t, &mut thr_state) } else { Default::default() };

        if k % every == 0 || k == steps {
            let rel = q_frame.conjugate() * state.q;
            let e = euler_from_quat(&rel, seq).map(f64::to_degrees);
            let tq = craft.torques(t, &state, &input, snap.as_ref());
            let applied = tq.actuators_nm + tq.magnetic_nm + tq.thrusters_nm;
            row.clear();
            row.push(t);
            row.extend([state.q.i, state.q.j, state.q.k, state.q.w]);
            row.extend(e);
            row.extend(target_euler_deg);
            row.extend(state.w.iter());
            row.extend(cmd.torque_demand_nm.iter().map(|x| *x as f64));
            row.extend(cmd.torque_realised_nm.iter().map(|x| *x as f64));
            row.extend(applied.iter());
            row.push(err_deg);
            row.push(s as f64);
            row.push(info.as_ref().and_then(|i| i.instructions_per_tick).map_or(f64::NAN, |f| ticks as f64 * f));
            if matches!(sc.controller, Some(Controller::Dmcs { .. })) {
                row.extend(cmd.law_telemetry.iter().map(|x| *x as f64));
            }
            if sc.modes.is_some() {
                row.push(cmd.mode as f64);
            }
            if closed_loop {
                row.push((cmd.attitude_error_rad as f64).to_degrees());
            }
            if sc.actuators.cmg.is_some() {
                row.extend(state.gimbal_rad[..4].iter().map(|x| x.to_degrees()));
                row.extend(cmd.gimbal_rate_cmd_rad_s.iter().map(|x| *x as f64));
                row.push(craft.cmg.as_ref().map_or(f64::NAN, |c| c.singularity_measure(&state.gimbal_rad)));
                row.push(cmd.steering_alpha as f64);
            }
            for o in wheel_out.iter().take(n_wheels) {
                row.extend([
                    o.speed_rad_s * 30.0 / std::f64::consts::PI,
                    o.current_a,
                    o.voltage_v,
                    o.power_w,
                    o.friction_nm,
                    o.delivered_torque_nm,
                ]);
            }
            if sc.actuators.magnetorquers.is_some() {
                row.extend(dipole_cmd);
                row.extend(rod_dipole);
            }
            if n_thr > 0 {
                row.push(thr_mask as f64);
                row.push(thr_state.total_propellant_kg());
                row.push(thr_state.pulses.iter().sum::<u32>() as f64);
                row.extend(cmd.thruster_level.iter().take(n_thr).map(|x| *x as f64));
            }
            if sc.orbit.is_some() || sc.environment.lab_field_t.is_some() {
                let b = snap
                    .and_then(|s| s.b_ref_t)
                    .map_or(crate::attitude::Vec3::repeat(f64::NAN), |b| rotate_ref_to_body(&state.q, &b));
                row.extend(b.iter());
            }
            if with_env {
                for v in [
                    tq.env.gravity_gradient,
                    tq.env.drag,
                    tq.env.srp,
                    tq.magnetic_nm,
                    tq.rig_nm,
                    tq.env.external + craft.external_torque_nm,
                ] {
                    row.extend(v.iter());
                }
            }
            ts.push_row(&row);
        }
        if k == steps {
            break;
        }
        if let Some(c) = &sc.spacecraft.inertia_change
            && t < c.at_s
            && t + dt >= c.at_s
        {
            let j = craft.inertia * c.factor;
            craft.set_inertia(j);
        }
        for j in 0..sub {
            let tj = t + j as f64 * h;
            if j > 0 {
                input.thruster_torque_nm = thr_torque(tj, &mut thr_state);
            }
            state = craft.rk4_env(tj, &state, &input, h)?;
        }
        if progress && k % 1024 == 0 {
            if bar.is_none() && start.elapsed() > Duration::from_secs(1) {
                let b = indicatif::ProgressBar::new(steps);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{elapsed_precise} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta})",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                bar = Some(b);
            }
            if let Some(b) = &bar {
                b.set_position(k);
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }

    let sim_time = steps as f64 * dt;
    let final_error_deg = errors.last().map_or(f64::NAN, |e| e.1);
    let settle_time_s = match last_above {
        None => Some(0.0),
        Some(t) if t < sim_time => Some(t + dt),
        Some(_) => None,
    };
    let after: Vec<f64> = errors.iter().filter(|(t, _)| settle_time_s.is_none_or(|s| *t >= s)).map(|e| e.1).collect();
    let rms_error_deg = (after.iter().map(|e| e * e).sum::<f64>() / after.len().max(1) as f64).sqrt();
    let final_q_rel = target_frame(snap.as_ref()).conjugate() * state.q;
    let ipt = info.as_ref().and_then(|i| i.instructions_per_tick).filter(|_| n_ticks > 0);
    let hz = info.as_ref().map(|i| i.cost_counter_hz as f64).filter(|h| *h > 0.0 && n_ticks > 0);
    let summary = Summary {
        scenario: sc.name.clone(),
        link: if closed_loop { link.name() } else { "open-loop".into() },
        board: info.as_ref().map(|i| i.board),
        steps,
        sim_time_s: sim_time,
        control_rate_hz: sc.timing.control_rate_hz,
        dynamics_rate_hz: sc.timing.control_rate_hz * sub as f64,
        final_error_deg,
        settle_time_s,
        settle_bound_deg: SETTLE_BOUND_DEG,
        max_error_after_settle_deg: settle_time_s.map(|_| after.iter().fold(0.0f64, |a, e| a.max(*e))),
        mean_error_deg: errors.iter().map(|e| e.1).sum::<f64>() / errors.len().max(1) as f64,
        rms_error_deg,
        final_euler_deg: euler_from_quat(&final_q_rel, seq).map(f64::to_degrees),
        target_euler_deg,
        final_rate_rad_s: state.w.into(),
        max_gimbal_rate_rad_s: craft.cmg.as_ref().map(|_| max_rate),
        min_singularity_measure: craft.cmg.as_ref().map(|_| min_m),
        max_wheel_speed_rpm: (n_wheels > 0).then_some(max_wheel_rpm),
        max_wheel_power_w: (n_wheels > 0).then_some(max_wheel_w),
        max_wheel_current_a: (n_wheels > 0).then_some(max_wheel_a),
        propellant_kg: (n_thr > 0).then(|| thr_state.total_propellant_kg()),
        max_pulses: (n_thr > 0).then(|| thr_state.pulses.iter().copied().max().unwrap_or(0)),
        max_step_instructions: ipt.map(|f| (max_ticks as f64 * f).round() as u64),
        mean_step_instructions: ipt.map(|f| sum_ticks / n_ticks as f64 * f),
        max_step_ticks: (n_ticks > 0).then_some(max_ticks),
        mean_step_us: hz.map(|h| sum_ticks / n_ticks as f64 / h * 1e6),
        max_step_us: hz.map(|h| max_ticks as f64 / h * 1e6),
        allocation_us_per_call: hz.filter(|_| n_thr > 0).map(|h| sum_ticks / n_ticks as f64 / h * 1e6),
        status_counts: counts,
        mode_transitions,
        final_mode: mode_now.map(mode_name),
        frames_dropped_flight,
        frames_dropped_host: if closed_loop { link.frames_dropped_host() } else { 0 },
        wall_time_s: wall,
        real_time_factor: sim_time / wall.max(1e-9),
    };
    Ok(RunResult { summary, series: ts })
}
