//! The report's stability-margin table: `sim-host margins` (`crate::margins::measure`,
//! default options, in-process) on every paper scenario, one row each — the worst axis's
//! crossover, phase, gain and delay margins and the multiloop disk margin, or why the
//! scenario's loop was not measured (docs/margins.md).

use super::experiment::Block;
use super::experiment::par_map;
use crate::format::sig;
use crate::margins::summary::summarize;
use crate::margins::{MarginError, MarginOptions, measure};
use sim_core::scenario::{MarginRequest, Scenario};
use std::path::PathBuf;

/// The report's cost budget per scenario, plant (RK4) steps: paper 000 and 002 cost about
/// 1e6 each; paper 001's slow DMCS loop with the accurate wheels (20 substeps, a crossover
/// near 0.07 rad/s) would cost minutes and is left to `sim-host margins`.
pub const MAX_PLANT_STEPS: u64 = 10_000_000;

/// A paper scenario to measure: its path relative to `scenarios/`, and the file.
pub struct Target {
    pub rel: String,
    pub path: PathBuf,
}

/// The scenario's loop in words: its law and actuator family.
fn loop_kind(sc: &Scenario) -> String {
    let law = sc
        .controller
        .as_ref()
        .and_then(|c| serde_json::to_value(c).ok())
        .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(str::to_owned))
        .unwrap_or_else(|| "—".into());
    let a = &sc.actuators;
    let family = if a.cmg.is_some() {
        "CMGs"
    } else if a.wheels.is_some() {
        "wheels"
    } else if a.thrusters.is_some() {
        "thrusters"
    } else if a.magnetorquers.is_some() {
        "magnetorquers"
    } else {
        "none"
    };
    format!("{law}, {family}")
}

/// Why a loop was not measured, in a few words (the first clause of the refusal).
fn refusal(e: &MarginError, sc: &Scenario) -> String {
    let first = |r: &str| r.split(':').next().unwrap_or(r).trim().to_owned();
    match e {
        _ if !sc.closed_loop() => "open loop: no control loop to measure".into(),
        MarginError::Unsupported(_) if sc.actuators.thrusters.is_some() => {
            "not covered: a thruster (PWPF, on/off valves) loop (docs/margins.md)".into()
        }
        MarginError::Unsupported(m) => format!("not covered: {}", first(m)),
        MarginError::NotSteady { reason, .. } => format!("not a steady hold: {}", first(reason)),
        MarginError::OverBudget(o) => format!(
            "over the report's cost budget of {MAX_PLANT_STEPS:.0e} plant steps (`sim-host margins` has none): {}",
            o.cost()
        ),
        MarginError::Unstable { reason } => format!("Unstable: {}", first(reason)),
        MarginError::Flight(m) => format!("Error: {}", first(m)),
        MarginError::Refused(r) => format!("Error: {r}"),
    }
}

fn opt(x: Option<f64>, digits: usize, inf: &str) -> String {
    x.map_or(inf.into(), |v| sig(v, digits))
}

/// One row: measured at the end of the scenario (the settled hold), one worker thread.
fn row(t: &Target) -> Vec<String> {
    let sc = match Scenario::load(&t.path) {
        Ok(sc) => sc,
        Err(e) => return vec![format!("`scenarios/{}.toml`", t.rel), format!("scenario error: {e:#}")],
    };
    let opts = MarginOptions { threads: 1, max_plant_steps: Some(MAX_PLANT_STEPS), ..Default::default() };
    let req = MarginRequest { at_s: sc.duration_s, point: opts.point, grid_points: opts.grid_points };
    let measured = measure(&sc, &opts);
    let name = format!("`scenarios/{}.toml`", t.rel);
    if let Err(e) = &measured {
        let dash = || "—".to_string();
        return vec![name, loop_kind(&sc), dash(), dash(), dash(), dash(), dash(), refusal(e, &sc)];
    }
    let m = summarize(&req, &measured);
    let gm = format!("{} / {}", opt(m.gain_margin_low_db, 3, "−∞"), opt(m.gain_margin_high_db, 3, "∞"));
    vec![
        name,
        loop_kind(&sc),
        opt(m.crossover_rad_s, 4, "—"),
        opt(m.phase_margin_deg, 3, "—"),
        gm,
        opt(m.delay_margin_s, 3, "∞"),
        opt(m.multiloop_disk_alpha, 3, "—"),
        if m.stable == Some(true) { "stable".into() } else { "NOT STABLE".into() },
    ]
}

/// The table, rows in the order given, measured on `jobs` threads.
pub fn table(targets: &[Target], jobs: usize) -> Block {
    Block::Table {
        header: [
            "scenario",
            "law, actuators",
            "crossover (rad/s)",
            "phase margin (°)",
            "gain margins low / high (dB)",
            "delay margin (s)",
            "multiloop disk α",
            "verdict",
        ]
        .map(String::from)
        .to_vec(),
        rows: par_map(jobs, targets, row),
    }
}
