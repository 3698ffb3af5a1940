//! The gyro bias-step monitor in closed loop (issue 42; docs/fdir.md "Gyro bias step"), on
//! the shipped scenario `scenarios/fdir/gyro-bias-step-3u.toml` (the 3U mission in hold, a
//! 0.01 rad/s bias step on gyro x at 6000 s, run to 7000 s):
//! (a) declared within 2.5 s of the onset (k = 3 rejected tracker samples at 2 Hz, once
//!     the drift is past the gate), named `gyro.x`, matched; no other event. Truth: the
//!     bias error (truth column `est_bias_error_deg_h`) falls from the step's 2,063°/h to
//!     below 2°/h within 120 s, the spacecraft stays within 1° of its target and ends in
//!     hold within 0.05°; the twin without the test ends `control_lost`;
//! (b) steps of 1e-3 and 1e-4 rad/s: declared and named `gyro.x`, and the largest
//!     pointing error after the onset is smaller than the twin's without the test (which
//!     waits for `max_consecutive_rejections` and restarts with a zero bias);
//! (c) a flipped tracker with the test on: the star-tracker monitor's event only (the
//!     witnesses contradict the tracker, so its rejections are not a gyro step), and the
//!     nominal mission (10,000 s) with every sensor monitor on: no event.

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

const FILE: &str = "scenarios/fdir/gyro-bias-step-3u.toml";
const FLIP_FILE: &str = "scenarios/fdir/tracker-flip-3u.toml";
const ONSET_S: f64 = 6000.0;
const STEP_RAD_S: f64 = 0.01;

fn read(file: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(file)).unwrap()
}

fn fly(text: &str) -> (serde_json::Value, RunResult) {
    let sc = Scenario::from_toml(text).unwrap();
    let r = run(&sc, &mut InProcess::new(), false).unwrap();
    (serde_json::to_value(&r.summary).unwrap(), r)
}

fn without_test(text: &str) -> String {
    let out = text.replace("bias_step = { k = 3, n = 4 }\n", "");
    assert_ne!(out, text);
    out
}

fn with_step(rad_s: f64) -> String {
    let text = read(FILE);
    let out = text.replace(&format!("magnitude = {STEP_RAD_S}\n"), &format!("magnitude = {rad_s:e}\n"));
    assert_ne!(out, text);
    out
}

/// (time, value) of a column from `from_s` on, NaN rows (no estimate) skipped.
fn column_from(r: &RunResult, col: &str, from_s: f64) -> Vec<(f64, f64)> {
    let t = r.series.col("t_s").unwrap();
    let v = r.series.col(col).unwrap();
    t.iter().zip(v).filter(|(t, v)| **t >= from_s && v.is_finite()).map(|(t, v)| (*t, *v)).collect()
}

fn max_from(r: &RunResult, col: &str, from_s: f64) -> f64 {
    column_from(r, col, from_s).iter().map(|x| x.1).fold(0.0, f64::max)
}

fn the_one_event(s: &serde_json::Value) -> serde_json::Value {
    let events = s["fdir"]["events"].as_array().unwrap();
    assert_eq!(events.len(), 1, "{events:?}");
    assert_eq!(s["fdir"]["false_alarms"], 0);
    events[0].clone()
}

#[test]
fn a_bias_step_is_declared_named_and_the_filter_takes_it_into_its_bias() {
    let (s, r) = fly(&read(FILE));
    assert_eq!(s["run_status"], "ok", "{}", s["run_status"]);
    let e = the_one_event(&s);
    assert_eq!((e["unit"].as_str(), e["isolated_as"].as_str()), (Some("gyro.x"), Some("gyro.x")));
    assert_eq!((e["test"].as_str(), e["fault"].as_u64()), (Some("gyro_bias_innovation"), Some(0)));
    let at = e["detected_at_s"].as_f64().unwrap();
    assert!(at > ONSET_S && at <= ONSET_S + 2.5, "declared at {at} s");
    // The bias error right after the onset is the step itself (truth), then the restarted
    // filter's estimate covers it.
    let step_deg_h = STEP_RAD_S.to_degrees() * 3600.0;
    let early = max_from(&r, "est_bias_error_deg_h", ONSET_S);
    assert!((early - step_deg_h).abs() < 0.05 * step_deg_h, "bias error after the onset {early} deg/h");
    let settled = max_from(&r, "est_bias_error_deg_h", ONSET_S + 120.0);
    assert!(settled < 2.0, "bias error 120 s after the onset: {settled} deg/h");
    let worst = max_from(&r, "error_deg", ONSET_S);
    let end = column_from(&r, "error_deg", 0.0).last().unwrap().1;
    assert!(worst < 1.0 && end < 0.05, "pointing error after the onset: max {worst} deg, end {end} deg");
    let (twin, _) = fly(&without_test(&read(FILE)));
    assert_eq!(twin["run_status"], "control_lost");
}

#[test]
fn smaller_steps_are_declared_and_cost_less_pointing_than_the_divergence_restart() {
    for rad_s in [1e-3, 1e-4] {
        let (s, r) = fly(&with_step(rad_s));
        assert_eq!(s["run_status"], "ok", "{rad_s}");
        let e = the_one_event(&s);
        assert_eq!((e["unit"].as_str(), e["fault"].as_u64()), (Some("gyro.x"), Some(0)), "{rad_s}");
        let (_, twin) = fly(&without_test(&with_step(rad_s)));
        let (with, without) = (max_from(&r, "error_deg", ONSET_S), max_from(&twin, "error_deg", ONSET_S));
        assert!(with < without, "{rad_s} rad/s: max error {with} deg with the test, {without} deg without");
    }
}

#[test]
fn a_flipped_tracker_is_not_a_bias_step_and_the_nominal_mission_raises_nothing() {
    let monitor = "[fdir.gyro]\nmax_repeats = 3\nbias_step = { k = 3, n = 4 }\n\n";
    let flip = read(FLIP_FILE);
    let at = flip.find("[[faults]]").unwrap();
    let (s, _) = fly(&format!("{}{monitor}{}", &flip[..at], &flip[at..]));
    let e = the_one_event(&s);
    assert_eq!(e["unit"].as_str(), Some("star_tracker"));
    let (nominal, _) = fly(&format!("{}{monitor}", &flip[..at]));
    assert_eq!(nominal["run_status"], "ok");
    assert_eq!(nominal["fdir"]["events"].as_array().unwrap().len(), 0, "{}", nominal["fdir"]);
}
