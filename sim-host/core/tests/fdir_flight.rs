//! The flight code's wheel FDIR in closed loop (issue 42; docs/fdir.md "Wiring"), on the
//! shipped scenario `scenarios/fdir/wheel-seized-6u.toml` (the 6U example, four pyramid
//! wheels, MEKF, nadir hold; wheel 3 seizes at 3000 s):
//! (a) the healthy wheels' residual σ against the closed form `(I_w/Δt) √(2 σ_g²)` with
//!     the gyro's per-sample noise `σ_g = ARW/√Δt` (the tachometer is not noisy; the f32
//!     rounding of its speeds adds at most `ulp(|ω|max)/√12` per reading): within 5 %
//!     below and the rounding bound + 5 % above;
//! (b) the seized wheel is declared within k control steps of the onset (1.0 s at 4 Hz),
//!     named, matched to its `[[faults]]` entry (`detected_at_s`), dropped; no other event;
//!     the hold after the fault keeps the nominal twin's pointing (95 % error within 10 %);
//! (c) the nominal twin (no fault) raises nothing: zero events;
//! (d) every wheel fault kind is declared within k steps and the hold recovered by the end
//!     (final error < 0.01°); a runaway (2 mN m, far above the body's noise) is isolated to
//!     its rotor, and its drive switched off;
//! (e) a threshold that noise crosses (0.5 σ, no floor) raises events on healthy wheels:
//!     the run fails (`fdir_false_alarm`), never ok.

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

const FILE: &str = "scenarios/fdir/wheel-seized-6u.toml";
const ONSET_S: f64 = 3000.0;

fn shipped() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(FILE)).unwrap()
}

fn fly(text: &str) -> (serde_json::Value, RunResult) {
    let sc = Scenario::from_toml(text).unwrap();
    let r = run(&sc, &mut InProcess::new(), false).unwrap();
    (serde_json::to_value(&r.summary).unwrap(), r)
}

/// The scenario with its `[[faults]]` entry replaced by `kind` (TOML lines).
fn with_fault(kind: &str) -> String {
    let text = shipped();
    let at = text.find("[[faults]]").expect("the shipped scenario has a fault");
    format!("{}[[faults]]\nonset_s = {ONSET_S}\nunit = \"wheel.2\"\n{kind}\n", &text[..at])
}

fn nominal() -> String {
    let text = shipped();
    text[..text.find("[[faults]]").unwrap()].to_string()
}

/// The 95th percentile of the attitude error from `from_s` on, deg (truth column).
fn p95_error_deg(r: &RunResult, from_s: f64) -> f64 {
    let t = r.series.col("t_s").unwrap();
    let e = r.series.col("error_deg").unwrap();
    let mut v: Vec<f64> = t.iter().zip(e).filter(|(t, _)| **t >= from_s).map(|(_, e)| *e).collect();
    v.sort_by(f64::total_cmp);
    v[(0.95 * (v.len() - 1) as f64).round() as usize]
}

#[test]
fn a_seized_wheel_is_declared_dropped_and_the_hold_goes_on() {
    let (s, r) = fly(&shipped());
    assert_eq!(s["run_status"], "ok");
    let events = s["fdir"]["events"].as_array().unwrap();
    assert_eq!(events.len(), 1, "{events:?}");
    let e = &events[0];
    assert_eq!((e["unit"].as_str(), e["fault"].as_u64()), (Some("wheel.2"), Some(0)));
    assert_eq!(e["recovery"], "dropped_from_allocation");
    let detected = e["detected_at_s"].as_f64().unwrap();
    let k_steps_s = 4.0 / 4.0; // k = 4 at 4 Hz
    assert!(detected > ONSET_S && detected <= ONSET_S + k_steps_s, "detected at {detected} s");
    assert_eq!(s["faults"][0]["detected_at_s"].as_f64(), Some(detected));
    assert_eq!(s["fdir"]["false_alarms"], 0);
    // Dropped for good: the mask column holds bit 2 from the detection on.
    let t = r.series.col("t_s").unwrap();
    let mask = r.series.col("fdir_failed_wheels").unwrap();
    assert!(t.iter().zip(mask).all(|(t, m)| if *t >= detected { *m == 4.0 } else { *m == 0.0 }));
    // The hold after the fault against the nominal twin's over the same span.
    let (n, nr) = fly(&nominal());
    assert_eq!(n["fdir"]["events"].as_array().map(Vec::len), Some(0), "the nominal twin raises nothing");
    let (faulty, healthy) = (p95_error_deg(&r, ONSET_S + 60.0), p95_error_deg(&nr, ONSET_S + 60.0));
    eprintln!("95 % error after the fault: {faulty:.6} deg (nominal {healthy:.6} deg)");
    assert!(faulty < 1.1 * healthy, "{faulty} vs {healthy}");
}

#[test]
fn the_healthy_residual_has_the_sigma_of_the_gyro_noise() {
    let text = nominal();
    let sc = Scenario::from_toml(&text).unwrap();
    let (_, r) = fly(&text);
    let dt = 1.0 / sc.timing.control_rate_hz;
    let i_w: f64 = 1.6e-5; // [actuators.wheels] inertia_kgm2
    let arw = 5.0e-6; // [sensors.gyro] arw_rad_sqrt_s
    assert!(text.contains("inertia_kgm2 = 1.6e-5") && text.contains("arw_rad_sqrt_s = 5.0e-6"));
    let sigma_g = arw / dt.sqrt();
    let closed = i_w / dt * (2.0 * sigma_g * sigma_g).sqrt();
    // f32 rounding of the speeds: at most ulp(max |ω|)/√12 per reading.
    let max_speed = (1..=4)
        .flat_map(|i| r.series.col(&format!("wheel{i}_speed_rpm")).unwrap().iter().map(|x| x.abs()))
        .fold(0.0f64, f64::max)
        * std::f64::consts::PI
        / 30.0;
    let ulp = f64::from(f32::EPSILON) * 2f64.powi(max_speed.log2().floor() as i32);
    let rounding = i_w / dt * (2.0 * ulp * ulp / 12.0).sqrt();
    for i in 1..=4 {
        let v: Vec<f64> =
            r.series.col(&format!("wheel{i}_residual_nm")).unwrap().iter().copied().filter(|x| x.is_finite()).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64).sqrt();
        eprintln!("wheel {i}: σ {sd:.4e} N m (closed form {closed:.4e}, rounding ≤ {rounding:.2e}), mean {mean:.2e}");
        assert!(v.len() > 5_000, "judged recorded steps {}", v.len()); // one row per second
        assert!(sd > 0.95 * closed && sd < 1.05 * (closed * closed + rounding * rounding).sqrt(), "σ {sd:e}");
        assert!(mean.abs() < 0.05 * closed, "bias {mean:e}");
    }
}

#[test]
fn every_wheel_fault_kind_is_declared_within_k_steps() {
    let kinds = [
        ("kind = \"torque_gain\"\nmagnitude = 0.5", None),
        ("kind = \"torque_gain\"\nmagnitude = 0.0", None),
        ("kind = \"tach_stuck\"", None),
        ("kind = \"runaway\"\nmagnitude = 1.0", Some("rotor")),
    ];
    for (kind, isolation) in kinds {
        let (s, _) = fly(&with_fault(kind));
        let events = s["fdir"]["events"].as_array().unwrap();
        assert_eq!(s["run_status"], "ok", "{kind}: {}", s["failure"]);
        assert_eq!(events.len(), 1, "{kind}: {events:?}");
        let t = events[0]["detected_at_s"].as_f64().unwrap();
        eprintln!("{kind:?}: detected at {t} s as {}", events[0]["isolated_as"]);
        assert!(t > ONSET_S && t <= ONSET_S + 1.25, "{kind}: {t}");
        if let Some(iso) = isolation {
            assert_eq!(events[0]["isolated_as"], iso, "{kind}");
        }
        // Recovered by the end (a runaway drive is switched off with the wheel dropped).
        let fin = s["final_error_deg"].as_f64().unwrap();
        assert!(fin < 0.01, "{kind}: final error {fin} deg");
    }
}

#[test]
fn a_threshold_inside_the_noise_fails_the_run_as_a_false_alarm() {
    let text = nominal().replace("floor_nm = 5.0e-8\nthreshold_sigma = 6.0", "floor_nm = 0.0\nthreshold_sigma = 0.5");
    let (s, _) = fly(&text);
    assert_eq!(s["run_status"], "fdir_false_alarm", "{}", s["failure"]);
    assert!(s["fdir"]["false_alarms"].as_u64().unwrap() >= 1);
    assert!(s["failure"]["reason"].as_str().unwrap().contains("false alarm"));
}

/// The 3U mission (`scenarios/modes/cubesat-mission.toml`: three wheels on the body axes, a
/// mode table from detumble to hold) with `[fdir.wheels]`: flown whole (detumble, sun-safe,
/// stabilise, slews, hold, ground commands) it raises nothing; with wheel 1 seized in hold
/// at 6000 s the two left cannot span three axes, so the wheel modes lack an input and the
/// mode manager falls back to detumble on the magnetorquers (safe mode) within the
/// detection (k = 4 steps at 2 Hz after the first step in force) and its 5 s persistence.
#[test]
fn a_three_wheel_mission_losing_a_wheel_falls_back_to_detumble() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/modes/cubesat-mission.toml");
    let base = std::fs::read_to_string(path).unwrap()
        + "\n[fdir.wheels]\nfloor_nm = 5.0e-8\nthreshold_sigma = 6.0\ngyro_sigma_rad_s = 1.4e-5\n";
    let (n, _) = fly(&base);
    assert_eq!((n["run_status"].as_str(), n["fdir"]["events"].as_array().map(Vec::len)), (Some("ok"), Some(0)));
    let faulty = base + "\n[[faults]]\nonset_s = 6000.0\nunit = \"wheel.0\"\nkind = \"stuck\"\n";
    let (s, _) = fly(&faulty);
    let events = s["fdir"]["events"].as_array().unwrap();
    assert_eq!(events.len(), 1, "{events:?}");
    let detected = events[0]["detected_at_s"].as_f64().unwrap();
    assert!(events[0]["unit"] == "wheel.0" && detected > 6000.0 && detected <= 6000.5 + 4.0 * 0.5, "{detected}");
    let fallback = s["mode_transitions"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["t_s"].as_f64().unwrap() > 6000.0)
        .expect("a transition after the fault")
        .clone();
    eprintln!("detected at {detected} s; then {fallback}");
    assert_eq!((fallback["from"].as_str(), fallback["to"].as_str()), (Some("hold"), Some("detumble")));
    assert_eq!(fallback["reason"], "input_lost");
    let t = fallback["t_s"].as_f64().unwrap();
    assert!(t > detected && t <= detected + 5.0 + 0.5, "{t}");
}
