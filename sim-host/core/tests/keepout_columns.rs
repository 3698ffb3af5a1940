//! `[manoeuvre]` in a flown scenario: the shipped EO cubesat (MEKF, GNSS navigation, its
//! ground commands) with planned slews and two keep-out boresights. Truths: each recorded
//! margin column equals the margin recomputed here from the recorded true attitude
//! (`q_*`) and true Sun direction (`sun_eci_*`) — angle to the Sun minus the half-angle
//! (1e-9 deg); the summary's smallest margin equals the column's minimum (exact); the
//! flight planned or refused a slew for every pointing change it was commanded.

use acs_test_support::vec3::rotate_xyzw;
use sim_core::link::in_process::InProcess;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::Path;

const MANOEUVRE: &str = r#"
[manoeuvre]
max_rate_deg_s = 1.0
max_accel_deg_s2 = 0.05
planning_margin_deg = 1.0
[[manoeuvre.keepout]]
name = "st"
boresight_body = [0, -1, 0]
sun_half_angle_deg = 30.0
[[manoeuvre.keepout]]
name = "radiator"
boresight_body = [0, 1, 0]
earth_margin_deg = 5.0
"#;

#[test]
fn keepout_columns_and_summary_are_the_truth_margins() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-cubesat.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let anchor = "[actuators.wheels]";
    assert!(text.contains(anchor));
    let sc = Scenario::from_toml(&text.replacen(anchor, &format!("{MANOEUVRE}\n{anchor}"), 1)).unwrap();
    let run = runner::run(&sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"));
    let (s, k) = (&run.series, run.summary.keepout.clone().expect("summary keepout"));
    let col = |n: &str| s.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let q: Vec<[f64; 4]> = (0..s.len()).map(|i| [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]]).collect();
    let sun = (0..s.len()).map(|i| [col("sun_eci_x")[i], col("sun_eci_y")[i], col("sun_eci_z")[i]]);
    let margins = col("keepout_st_sun_margin_deg");
    let mut worst = 0.0f64;
    for ((q, sun), m) in q.iter().zip(sun).zip(margins) {
        let b = rotate_xyzw(q, &[0.0, -1.0, 0.0]);
        let dot = (b[0] * sun[0] + b[1] * sun[1] + b[2] * sun[2]).clamp(-1.0, 1.0);
        let expect = dot.acos().to_degrees() - 30.0;
        worst = worst.max((expect - m).abs());
    }
    println!("summary {k:?}; largest column error {worst:.3e} deg");
    assert!(worst < 1e-9, "{worst}");
    for (key, name) in
        [("st.sun", "keepout_st_sun_margin_deg"), ("radiator.earth", "keepout_radiator_earth_margin_deg")]
    {
        let min = col(name).iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(k.min_margin_deg[key], Some(min), "{key}");
    }
    let refused: u16 = k.slews_refused.iter().sum();
    // Four SetPointing commands, each a planned or refused slew.
    assert!(k.slews_planned + refused >= 4, "{k:?}");
    assert!(col("slew_phase").iter().all(|p| (0.0..=5.0).contains(p)));
}

/// The EO cubesat pointing at the Sun from an arbitrary initial attitude: its first
/// capture (not a planned slew) takes the +y boresight into its 35° Sun cone.
fn captured_through_the_cone(enforced_from_s: f64) -> runner::RunResult {
    use toml::{Table, Value};
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-cubesat.toml");
    let t = |s: &str| s.parse::<Table>().unwrap();
    let mut sc = t(&std::fs::read_to_string(path).unwrap());
    sc.insert("duration_s".into(), Value::Float(300.0));
    sc["orbit"].as_table_mut().unwrap().insert("arg_lat_deg".into(), Value::Float(180.0));
    let sun = "label = \"Sun pointing\"\npointing = { primary_body = [1, 0, 0], primary = \"sun\", \
               secondary_body = [0, 0, 1], secondary = \"nadir\" }\ntransition_s = 120.0\n";
    sc.insert("guidance".into(), Value::Table(t(sun)));
    sc.remove("commands");
    let manoeuvre = format!(
        "max_rate_deg_s = 1.0\nmax_accel_deg_s2 = 0.05\nplanning_margin_deg = 2.0\n\
         keepout_enforced_from_s = {enforced_from_s:?}\n\
         [[keepout]]\nname = \"st\"\nboresight_body = [0, 1, 0]\nsun_half_angle_deg = 35.0\n"
    );
    sc.insert("manoeuvre".into(), Value::Table(t(&manoeuvre)));
    let sc = Scenario::from_toml(&toml::to_string(&sc).unwrap()).unwrap();
    runner::run(&sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"))
}

/// A boresight inside its cone fails the run (`keepout_violated`) from
/// `keepout_enforced_from_s` on; the violation the summary names is the first recorded row
/// with a negative margin column (time and depth exact), and the count is the column's.
#[test]
fn a_keepout_violation_fails_the_run_from_its_enforcement_time() {
    use sim_core::recorder::summary::{Failure, RunStatus};
    let strict = captured_through_the_cone(0.0);
    let (t, m) = (strict.series.col("t_s").unwrap(), strict.series.col("keepout_st_sun_margin_deg").unwrap());
    let inside: Vec<(f64, f64)> = t.iter().zip(m).filter(|(_, m)| **m < 0.0).map(|(t, m)| (*t, *m)).collect();
    let k = strict.summary.keepout.clone().expect("keepout summary");
    println!("inside rows {}, first {:?}; summary {k:?}", inside.len(), inside.first());
    assert!(!inside.is_empty(), "the capture should enter the cone");
    assert_eq!(strict.summary.run_status, RunStatus::KeepOutViolated);
    assert!(matches!(&strict.summary.failure, Some(Failure::KeepOut { reason }) if reason.contains("`st.sun`")));
    let f = k.first_violation.clone().expect("first violation");
    assert_eq!((f.t_s, f.margin_deg.to_bits(), f.cone.as_str()), (inside[0].0, inside[0].1.to_bits(), "st.sun"));
    assert_eq!((k.violations, k.steps_inside), (inside.len() as u64, inside.len() as u64));
    // Enforced after the capture: the same rows inside, none of them a violation.
    let last_inside = inside.last().unwrap().0;
    let lenient = captured_through_the_cone(last_inside + 1.0);
    let k = lenient.summary.keepout.clone().expect("keepout summary");
    assert_eq!((k.steps_inside, k.violations, k.first_violation), (inside.len() as u64, 0, None));
    assert_eq!(lenient.summary.run_status, RunStatus::Ok, "{:?}", lenient.summary.failure);
}
