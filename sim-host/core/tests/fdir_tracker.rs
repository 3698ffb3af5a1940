//! The estimation stage's star-tracker monitor in closed loop (issue 42; docs/fdir.md
//! "Star tracker"), on the shipped scenario `scenarios/fdir/tracker-flip-3u.toml` (the 3U
//! mission, MEKF; the tracker's attitude turned 180° about its boresight from 6000 s, in
//! hold):
//! (a) the flip is declared within k = 3 tracker samples (1.5 s at 2 Hz), named, matched to
//!     its `[[faults]]` entry; no other event. Truth: the estimate never follows the flip —
//!     its error (truth column `est_error_deg`) stays below 5° from the onset on, where
//!     the same scenario without the monitor (the twin below) ends with the estimate
//!     more than 90° off (the filter restarted from the flipped tracker); the mission then
//!     leaves hold for sun-safe (input lost) and ends there at rest;
//! (b) a frozen tracker (fresh time tags) is declared by the repeat test after
//!     max_repeats + 1 = 4 repeated samples (2.0 s);
//! (c) the nominal twin (no fault) raises nothing over the whole 10,000 s mission (a
//!     tumble, detumble, sun-safe, slews, eclipses);
//! (d) a witness threshold its own noise crosses (0.5°, below the coarse sun sensors' 3°)
//!     raises an event on the healthy tracker: the run fails (`fdir_false_alarm`).

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

const FILE: &str = "scenarios/fdir/tracker-flip-3u.toml";
const ONSET_S: f64 = 6000.0;
const TRACKER_HZ: f64 = 2.0;

fn shipped() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(FILE)).unwrap()
}

fn fly(text: &str) -> (serde_json::Value, RunResult) {
    let sc = Scenario::from_toml(text).unwrap();
    let r = run(&sc, &mut InProcess::new(), false).unwrap();
    (serde_json::to_value(&r.summary).unwrap(), r)
}

fn without_fault() -> String {
    let text = shipped();
    text[..text.find("\n[[faults]]").unwrap()].to_string()
}

/// Largest of a column from `from_s` on (NaN rows — no estimate — skipped).
fn max_from(r: &RunResult, col: &str, from_s: f64) -> f64 {
    let t = r.series.col("t_s").unwrap();
    let v = r.series.col(col).unwrap();
    t.iter().zip(v).filter(|(t, v)| **t >= from_s && v.is_finite()).map(|(_, v)| *v).fold(0.0, f64::max)
}

fn the_one_event(s: &serde_json::Value) -> serde_json::Value {
    let events = s["fdir"]["events"].as_array().unwrap();
    assert_eq!(events.len(), 1, "{events:?}");
    assert_eq!(s["fdir"]["false_alarms"], 0);
    events[0].clone()
}

#[test]
fn a_flipped_tracker_is_declared_dropped_and_the_estimate_never_follows_it() {
    let (s, r) = fly(&shipped());
    assert_eq!(s["run_status"], "ok");
    let e = the_one_event(&s);
    assert_eq!((e["unit"].as_str(), e["fault"].as_u64()), (Some("star_tracker"), Some(0)));
    assert_eq!(
        (e["test"].as_str(), e["recovery"].as_str()),
        (Some("tracker_witness"), Some("dropped_from_estimation"))
    );
    let detected = e["detected_at_s"].as_f64().unwrap();
    eprintln!("flip declared at {detected} s");
    assert!(detected > ONSET_S && detected <= ONSET_S + 3.0 / TRACKER_HZ, "declared at {detected} s");
    assert_eq!(s["faults"][0]["detected_at_s"].as_f64(), Some(detected));
    let est_after = max_from(&r, "est_error_deg", ONSET_S);
    eprintln!("largest estimate error after the flip: {est_after:.4} deg");
    assert!(est_after < 5.0, "{est_after}");
    assert_eq!(s["final_mode"], "sun_safe");
    let w = s["final_rate_rad_s"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap().powi(2)).sum::<f64>().sqrt();
    assert!(w < 1e-3, "at rest in sun-safe: {w} rad/s");

    // The twin without the monitor: the filter restarts from the flipped tracker.
    let text = shipped();
    let (a, b) = (text.find("\n[fdir.star_tracker]").unwrap(), text.find("\n[[faults]]").unwrap());
    let (u, ur) = fly(&format!("{}{}", &text[..a], &text[b..]));
    let est_unmonitored = max_from(&ur, "est_error_deg", ONSET_S);
    eprintln!(
        "without the monitor: estimate error up to {est_unmonitored:.1} deg, final error {}",
        u["final_error_deg"]
    );
    assert!(est_unmonitored > 90.0, "{est_unmonitored}");
}

#[test]
fn a_frozen_tracker_is_declared_by_its_repeats() {
    let text = shipped().replace("kind = \"flip\"", "kind = \"frozen\"");
    let (s, _) = fly(&text);
    let e = the_one_event(&s);
    assert_eq!((e["unit"].as_str(), e["test"].as_str()), (Some("star_tracker"), Some("tracker_frozen")));
    let detected = e["detected_at_s"].as_f64().unwrap();
    eprintln!("frozen tracker declared at {detected} s");
    // The first frozen sample sets the value; repeats 1..=4 follow at 2 Hz.
    assert!(detected > ONSET_S && detected <= ONSET_S + 4.0 / TRACKER_HZ + 0.5, "declared at {detected} s");
}

#[test]
fn the_nominal_mission_raises_nothing_and_a_too_tight_witness_threshold_fails_the_run() {
    let (s, _) = fly(&without_fault());
    assert_eq!(s["run_status"], "ok");
    assert_eq!(s["fdir"]["events"].as_array().map(Vec::len), Some(0), "{}", s["fdir"]);
    let tight = without_fault().replace("witness_max_deg = 20.0", "witness_max_deg = 0.5");
    let (t, _) = fly(&tight);
    assert_eq!(t["run_status"], "fdir_false_alarm", "{}", t["fdir"]);
}
