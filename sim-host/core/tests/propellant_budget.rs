//! The `propellant_exceeded` verdict (issue 42; docs/scenario.md "Propellant exceeded"):
//! with `[performance] propellant_budget_kg`, a run whose thrusters used more than the budget
//! fails, with or without faults; a lost or degraded pointing wins over it. On paper 004's
//! eight thrusters (`scenarios/paper004/dp-nominal.toml`, 60 s) with thruster 0 stuck open
//! from 5 s and a budget of 0.1 kg (between the fault-free twin's use and the faulted one's):
//! (a) the faulted run is `propellant_exceeded`, the twin `ok`;
//! (b) the truth of each use is recomputed from the time series apart from the plant's
//!     bookkeeping: paper 004 has no minimum on-time and no valve delays, so a valve is open
//!     exactly over the control steps its bit of `thrusters_on` (the flight's command) is
//!     set — or, from the onset on, the stuck thruster's — each step spending
//!     `F dt / (Isp g0)` per open valve;
//! (c) flown 150 s, the same fault is `pointing_degraded` (held 9° off, docs/fdir.md), the
//!     budget exceeded beside it in the summary;
//! (d) a budget on a spacecraft without thrusters is refused naming the key.

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

/// The scenario's thrust, specific impulse and control rate (dp-nominal.toml; asserted
/// present below), and standard gravity.
const THRUST_N: f64 = 10.0;
const ISP_S: f64 = 220.0;
const DT_S: f64 = 0.01;
const G0_M_S2: f64 = 9.80665;
const BUDGET_KG: f64 = 0.1;
const ONSET_S: f64 = 5.0;

fn dp_nominal(duration_s: f64) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper004/dp-nominal.toml");
    let text = std::fs::read_to_string(path).unwrap();
    for line in ["thrust_n = 10.0", "isp_s = 220.0", "control_rate_hz = 100.0", "duration_s = 60.0"] {
        assert!(text.contains(line), "dp-nominal.toml no longer has {line}");
    }
    // Every control step recorded, so the series holds every command.
    text.replace("output_every = 10", "output_every = 1")
        .replace("duration_s = 60.0", &format!("duration_s = {duration_s:?}"))
        + &format!("\n[performance]\npropellant_budget_kg = {BUDGET_KG:?}\n")
}

fn stuck_open(base: &str) -> String {
    format!("{base}\n[[faults]]\nonset_s = {ONSET_S:?}\nunit = \"thruster.0\"\nkind = \"stuck_open\"\n")
}

fn fly(text: &str) -> (serde_json::Value, RunResult) {
    let sc = Scenario::from_toml(text).unwrap();
    let r = run(&sc, &mut InProcess::new(), false).unwrap();
    (serde_json::to_value(&r.summary).unwrap(), r)
}

/// Propellant from the commands in the series: every row but the last (its command is
/// never flown) holds its valves open for one control step; `stuck`: thruster 0 is open
/// from [`ONSET_S`] whatever the command.
fn propellant_from_the_series(r: &RunResult, stuck: bool) -> f64 {
    let col = |n: &str| r.series.col(n).unwrap_or_else(|| panic!("column {n}"));
    let (t, mask) = (col("t_s"), col("thrusters_on"));
    let open_steps: u32 = (0..t.len() - 1)
        .map(|i| {
            let m = mask[i] as u32 | u32::from(stuck && t[i] >= ONSET_S - 1e-9);
            m.count_ones()
        })
        .sum();
    f64::from(open_steps) * THRUST_N * DT_S / (ISP_S * G0_M_S2)
}

/// One control step of all eight valves, kg: the recomputation's tolerance (the row's
/// time against the step boundary, the first and last steps).
const ONE_STEP_KG: f64 = 8.0 * THRUST_N * DT_S / (ISP_S * G0_M_S2);

#[test]
fn a_stuck_open_thruster_exceeds_a_budget_its_fault_free_twin_meets() {
    let base = dp_nominal(60.0);
    let (twin, r_twin) = fly(&base);
    let (s, r) = fly(&stuck_open(&base));
    let truth = (propellant_from_the_series(&r_twin, false), propellant_from_the_series(&r, true));
    let used = (twin["propellant_kg"].as_f64().unwrap(), s["propellant_kg"].as_f64().unwrap());
    eprintln!(
        "60 s, budget {BUDGET_KG} kg: twin {} (summary {:.6} kg, series {:.6} kg); stuck open {} (summary {:.6} kg, \
         series {:.6} kg)",
        twin["run_status"], used.0, truth.0, s["run_status"], used.1, truth.1
    );
    // The recomputation agrees with the plant's bookkeeping.
    assert!((truth.0 - used.0).abs() <= ONE_STEP_KG, "twin {truth:?} vs {used:?}");
    assert!((truth.1 - used.1).abs() <= ONE_STEP_KG, "faulted {truth:?} vs {used:?}");
    // The budget lies between them, clear of the tolerance either way.
    assert!(truth.0 + ONE_STEP_KG < BUDGET_KG && BUDGET_KG < truth.1 - ONE_STEP_KG, "{truth:?}");
    assert_eq!(twin["run_status"], "ok", "{}", twin["failure"]);
    assert_eq!(twin["propellant_budget_kg"], BUDGET_KG);
    assert_eq!(s["run_status"], "propellant_exceeded", "{}", s["failure"]);
    let reason = s["failure"]["reason"].as_str().unwrap();
    assert!(reason.contains("budget of 0.1 kg") && reason.contains("propellant_budget_kg"), "{reason}");
}

#[test]
fn a_degraded_pointing_wins_over_the_budget_and_a_budget_needs_thrusters() {
    // 150 s: the window 90-150 s starts 85 s after the onset, so the hold 9 deg off is judged.
    let (s, r) = fly(&stuck_open(&dp_nominal(150.0)));
    let truth = propellant_from_the_series(&r, true);
    eprintln!("150 s: {} with {truth:.4} kg (series) against {BUDGET_KG} kg", s["run_status"]);
    assert!(truth > BUDGET_KG + ONE_STEP_KG);
    assert_eq!(s["run_status"], "pointing_degraded", "{}", s["failure"]);
    assert_eq!(s["propellant_budget_kg"], BUDGET_KG);
    assert!(s["propellant_kg"].as_f64().unwrap() > BUDGET_KG);
    // Paper 000's CMG pyramid has no thrusters: the budget is refused at the load.
    let cmg =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper000/test1.toml"))
            .unwrap();
    assert!(!cmg.contains("[performance]") && !cmg.contains("thrusters"));
    let e = Scenario::from_toml(&format!("{cmg}\n[performance]\npropellant_budget_kg = 1.0\n")).unwrap_err();
    assert!(format!("{e:#}").contains("performance.propellant_budget_kg"), "{e:#}");
}
