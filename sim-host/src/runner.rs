//! The closed-loop run: sensors → flight code (over a link) → plant, at the control rate,
//! with the plant integrated by RK4 at `control_rate × dynamics_substeps`.
//!
//! Timing: the frame sampled at `t_k` is answered with gimbal-rate commands that the plant
//! holds over `[t_k, t_k+1)` (zero-order hold, no added latency).

use crate::attitude::{error_angle, euler_from_quat};
use crate::link::{FlightLink, LinkInfo};
use crate::output::TimeSeries;
use crate::plant::Input;
use crate::scenario::Scenario;
use crate::sensors::SensorSuite;
use acs_flight::protocol::status;
use anyhow::{Context, Result};
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
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    pub scenario: String,
    pub link: String,
    /// 0 in-process, 1 QEMU mps2-an386, 2 STM32F405.
    pub board: u8,
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
    pub final_euler_deg: [f64; 3],
    pub target_euler_deg: [f64; 3],
    pub final_rate_rad_s: [f64; 3],
    /// Largest commanded gimbal rate, rad/s.
    pub max_gimbal_rate_rad_s: f64,
    /// Smallest `det(J₁ J₁ᵀ)` of the true gimbal angles (unit rotor momentum).
    pub min_singularity_measure: f64,
    /// Largest `Fsw::step` cost in instructions (QEMU) — `null` when not measured.
    pub max_step_instructions: Option<u64>,
    pub mean_step_instructions: Option<f64>,
    /// Largest `Fsw::step` cost in raw counter ticks (any board that measures).
    pub max_step_ticks: Option<u32>,
    pub status_counts: StatusCounts,
    pub frames_dropped_flight: u32,
    pub frames_dropped_host: u32,
    /// Wall time of the closed loop only (no file output), s.
    pub wall_time_s: f64,
    pub real_time_factor: f64,
}

pub struct RunResult {
    pub summary: Summary,
    pub series: TimeSeries,
}

/// Column names of the time series, in order.
pub fn column_names() -> Vec<String> {
    let mut v: Vec<String> = [
        "t_s",
        "q_x",
        "q_y",
        "q_z",
        "q_w",
        "roll_deg",
        "pitch_deg",
        "yaw_deg",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    v.extend(["roll_target_deg", "pitch_target_deg", "yaw_target_deg"].map(String::from));
    v.extend(["rate_x_rad_s", "rate_y_rad_s", "rate_z_rad_s"].map(String::from));
    v.extend(
        [
            "torque_demand_x_nm",
            "torque_demand_y_nm",
            "torque_demand_z_nm",
        ]
        .map(String::from),
    );
    v.extend(
        [
            "torque_realised_x_nm",
            "torque_realised_y_nm",
            "torque_realised_z_nm",
        ]
        .map(String::from),
    );
    v.extend(
        [
            "torque_applied_x_nm",
            "torque_applied_y_nm",
            "torque_applied_z_nm",
        ]
        .map(String::from),
    );
    v.extend((1..=4).map(|i| format!("gimbal{i}_deg")));
    v.extend((1..=4).map(|i| format!("gimbal_rate{i}_rad_s")));
    v.extend(
        [
            "singularity_m",
            "steering_alpha",
            "error_deg",
            "status",
            "step_cost_insns",
        ]
        .map(String::from),
    );
    v
}

/// Run the scenario against an already-opened link.
pub fn run(sc: &Scenario, link: &mut dyn FlightLink, progress: bool) -> Result<RunResult> {
    let info: LinkInfo = link.hello().context("hello")?;
    let params = sc.flight_params()?;
    link.upload(&params).context("parameter upload")?;

    let craft = sc.spacecraft()?;
    let n_gimbals = craft.cmg.as_ref().map_or(0, |c| c.len());
    let mut state = sc.initial_state();
    let mut sensors = SensorSuite::new(&sc.sensors);
    let q_target = sc.target.quaternion();
    let seq = sc.target.euler_sequence.into();
    let target_euler_deg = euler_from_quat(&q_target, seq).map(f64::to_degrees);
    let dt = sc.control_dt();
    let sub = sc.timing.dynamics_substeps;
    let h = dt / sub as f64;
    let steps = sc.steps();
    let every = sc.timing.output_every as u64;

    let mut ts = TimeSeries::with_columns(column_names(), (steps / every + 2) as usize);
    let mut row = vec![0.0; ts.names.len()];
    let mut counts = StatusCounts::default();
    let (mut max_rate, mut min_m) = (0.0f64, f64::INFINITY);
    let (mut max_ticks, mut sum_ticks, mut n_ticks) = (0u32, 0f64, 0u64);
    let mut last_above: Option<f64> = Some(0.0);
    let mut errors = Vec::with_capacity(steps as usize + 1);
    let mut frames_dropped_flight = 0;
    let mut bar: Option<indicatif::ProgressBar> = None;

    let start = Instant::now();
    for k in 0..=steps {
        let t = k as f64 * dt;
        let frame = sensors.sample(k as u32, t, &state, n_gimbals);
        let report = link
            .step(&frame)
            .with_context(|| format!("control step {k} at t = {t:.3} s"))?;
        let cmd = &report.cmd;
        frames_dropped_flight = report.frames_dropped;
        let mut input = Input::default();
        for (dst, src) in input
            .gimbal_rate_cmd_rad_s
            .iter_mut()
            .zip(cmd.gimbal_rate_cmd_rad_s)
        {
            *dst = src as f64;
        }

        let err_deg = error_angle(&state.q, &q_target).to_degrees();
        errors.push((t, err_deg));
        if err_deg >= SETTLE_BOUND_DEG {
            last_above = Some(t);
        }
        let m = craft
            .cmg
            .as_ref()
            .map_or(f64::NAN, |c| c.singularity_measure(&state.gimbal_rad));
        min_m = min_m.min(m);
        max_rate = cmd
            .gimbal_rate_cmd_rad_s
            .iter()
            .fold(max_rate, |a, r| a.max(r.abs() as f64));
        let s = cmd.status;
        for (bit, c) in [
            (status::TORQUE_LIMITED, &mut counts.torque_limited),
            (status::RATE_SCALED, &mut counts.rate_scaled),
            (status::ANGLE_LIMITED, &mut counts.angle_limited),
            (status::SINGULAR, &mut counts.singular),
            (status::BAD_INPUT, &mut counts.bad_input),
            (status::TORQUE_SHORTFALL, &mut counts.torque_shortfall),
        ] {
            *c += u64::from(s & bit != 0);
        }
        if report.step_cost_ticks > 0 {
            max_ticks = max_ticks.max(report.step_cost_ticks);
            sum_ticks += report.step_cost_ticks as f64;
            n_ticks += 1;
        }
        let insns = info
            .instructions_per_tick
            .map_or(f64::NAN, |f| report.step_cost_ticks as f64 * f);

        if k % every == 0 || k == steps {
            let e = euler_from_quat(&state.q, seq).map(f64::to_degrees);
            let applied = craft.actuator_torque(&state, &input);
            let mut i = 0;
            let mut put = |x: f64| {
                row[i] = x;
                i += 1;
            };
            put(t);
            [state.q.i, state.q.j, state.q.k, state.q.w]
                .into_iter()
                .for_each(&mut put);
            e.into_iter().for_each(&mut put);
            target_euler_deg.into_iter().for_each(&mut put);
            state.w.iter().for_each(|x| put(*x));
            cmd.torque_demand_nm.iter().for_each(|x| put(*x as f64));
            cmd.torque_realised_nm.iter().for_each(|x| put(*x as f64));
            applied.iter().for_each(|x| put(*x));
            state.gimbal_rad[..4]
                .iter()
                .for_each(|x| put(x.to_degrees()));
            cmd.gimbal_rate_cmd_rad_s
                .iter()
                .for_each(|x| put(*x as f64));
            put(cmd.singularity_measure as f64);
            put(cmd.steering_alpha as f64);
            put(err_deg);
            put(s as f64);
            put(insns);
            ts.push_row(&row);
        }
        if k == steps {
            break;
        }
        for _ in 0..sub {
            state = craft.rk4(t, &state, &input, h, None);
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
    let max_error_after_settle_deg = settle_time_s.map(|ts0| {
        errors
            .iter()
            .filter(|(t, _)| *t >= ts0)
            .fold(0.0f64, |a, (_, e)| a.max(*e))
    });
    let summary = Summary {
        scenario: sc.name.clone(),
        link: link.name(),
        board: info.board,
        steps,
        sim_time_s: sim_time,
        control_rate_hz: sc.timing.control_rate_hz,
        dynamics_rate_hz: sc.timing.control_rate_hz * sub as f64,
        final_error_deg,
        settle_time_s,
        settle_bound_deg: SETTLE_BOUND_DEG,
        max_error_after_settle_deg,
        final_euler_deg: euler_from_quat(&state.q, seq).map(f64::to_degrees),
        target_euler_deg,
        final_rate_rad_s: state.w.into(),
        max_gimbal_rate_rad_s: max_rate,
        min_singularity_measure: min_m,
        max_step_instructions: info
            .instructions_per_tick
            .filter(|_| n_ticks > 0)
            .map(|f| (max_ticks as f64 * f).round() as u64),
        mean_step_instructions: info
            .instructions_per_tick
            .filter(|_| n_ticks > 0)
            .map(|f| sum_ticks / n_ticks as f64 * f),
        max_step_ticks: (n_ticks > 0).then_some(max_ticks),
        status_counts: counts,
        frames_dropped_flight,
        frames_dropped_host: link.frames_dropped_host(),
        wall_time_s: wall,
        real_time_factor: sim_time / wall.max(1e-9),
    };
    Ok(RunResult {
        summary,
        series: ts,
    })
}
