//! Issue 41: a pointing timeline from the ground flown end to end. The EO cubesat of
//! `scenarios/guidance/eo-cubesat.toml` (MEKF, GNSS navigation, planned slews at 1 deg/s
//! and 0.05 deg/s²) without its ground commands, given a 3-segment `[[timeline]]`: Sun
//! pointing (+x to the Sun) from 600 s, nadir (+z to the Earth's centre) from 1500 s, and
//! the Windorah target pass (+z on the site above 20°, nadir otherwise) from 2950 s.
//!
//! Truths, independent of the flight code and of the simulator's guidance truth for the
//! first two: the angle between the true body +x and the recorded Sun direction, and
//! between the true body +z and −r (the recorded true position); for the ground target the
//! truth's own primary error column (`pointing_primary_error_deg`: the true line of sight
//! to the site through the full Earth orientation) while the site is above 20°. Each is
//! taken from its segment's start + 200 s (slew and settling) while the segment is in
//! force (`timeline_segment`), and must stay under 0.1°; the flight code must report
//! 3 segments met, 0 missed.

use acs_test_support::vec3::rotate_xyzw;
use sim_core::link::in_process::InProcess;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::Path;
use toml::{Table, Value};

const SETTLE_S: f64 = 200.0;
const BOUND_DEG: f64 = 0.1;

fn table(text: &str) -> Table {
    text.parse::<Table>().unwrap()
}

fn scenario(timeline: &str) -> Scenario {
    scenario_from(scenario_table(timeline))
}

fn scenario_from(sc: Table) -> Scenario {
    Scenario::from_toml(&toml::to_string(&sc).unwrap()).unwrap_or_else(|e| panic!("{e:#}"))
}

fn scenario_table(timeline: &str) -> Table {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-cubesat.toml");
    let mut sc = table(&std::fs::read_to_string(path).unwrap());
    sc.insert("duration_s".into(), Value::Float(3450.0));
    sc.remove("commands");
    sc.insert(
        "manoeuvre".into(),
        Value::Table(table("max_rate_deg_s = 1.0\nmax_accel_deg_s2 = 0.05\nplanning_margin_deg = 2.0\n")),
    );
    let tl = table(timeline);
    sc.insert("timeline".into(), tl["timeline"].clone());
    sc
}

const THREE: &str = r#"
[[timeline]]
start_s = 600.0
guidance = { label = "Sun", pointing = { primary_body = [1, 0, 0], primary = "sun", secondary_body = [0, 0, 1], secondary = "nadir" }, ut1_minus_clock_s = 0.05, feedforward = true }
[[timeline]]
start_s = 1500.0
guidance = { label = "nadir", pointing = { primary_body = [0, 0, 1], primary = "nadir", secondary_body = [1, 0, 0], secondary = "sun" }, ut1_minus_clock_s = 0.05, feedforward = true }
[[timeline]]
start_s = 2950.0
guidance = { label = "Windorah", pointing = { primary_body = [0, 0, 1], primary = { ground = { lat_deg = -25.42, lon_deg = 142.65, alt_m = 140.0 } }, secondary_body = [1, 0, 0], secondary = "sun" }, min_elevation_deg = 20.0, otherwise = { primary_body = [0, 0, 1], primary = "nadir", secondary_body = [1, 0, 0], secondary = "sun" }, ut1_minus_clock_s = 0.05, feedforward = true }
"#;

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let n = (a.iter().map(|x| x * x).sum::<f64>() * b.iter().map(|x| x * x).sum::<f64>()).sqrt();
    (dot / n).clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn a_three_segment_timeline_is_flown_and_every_segment_met() {
    let run = runner::run(&scenario(THREE), &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"));
    let (s, sum) = (&run.series, &run.summary);
    let tl = sum.timeline.as_ref().expect("timeline summary");
    println!("timeline: {tl:?}; run_status {:?}", sum.run_status);
    let col = |n: &str| s.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let (t, seg) = (col("t_s"), col("timeline_segment"));
    let starts = [600.0, 1500.0, 2950.0];
    let mut worst = [0.0f64; 3];
    let mut rows = [0usize; 3];
    for i in 0..s.len() {
        let k = seg[i] as usize;
        if k == 0 || t[i] < starts[k - 1] + SETTLE_S {
            continue;
        }
        let q = [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]];
        let err = match k {
            1 => angle_deg(
                rotate_xyzw(&q, &[1.0, 0.0, 0.0]),
                [col("sun_eci_x")[i], col("sun_eci_y")[i], col("sun_eci_z")[i]],
            ),
            2 => angle_deg(
                rotate_xyzw(&q, &[0.0, 0.0, 1.0]),
                [-col("r_eci_x_m")[i], -col("r_eci_y_m")[i], -col("r_eci_z_m")[i]],
            ),
            // The target while the site is above 20° and has been for SETTLE_S.
            _ if col("target_elevation_deg")[i] >= 20.0 => {
                let rise =
                    (0..i).rev().take_while(|&j| col("target_elevation_deg")[j] >= 20.0).last().map_or(t[i], |j| t[j]);
                if t[i] < rise + SETTLE_S {
                    continue;
                }
                col("pointing_primary_error_deg")[i]
            }
            _ => continue,
        };
        worst[k - 1] = worst[k - 1].max(err);
        rows[k - 1] += 1;
    }
    println!(
        "worst pointing error after start + {SETTLE_S} s: Sun {:.4}°, nadir {:.4}°, target {:.4}° (rows {rows:?})",
        worst[0], worst[1], worst[2]
    );
    assert!(rows.iter().all(|&n| n > 50), "each segment judged over enough rows: {rows:?}");
    for (k, w) in worst.iter().enumerate() {
        assert!(*w < BOUND_DEG, "segment {k}: {w}° ≥ {BOUND_DEG}°");
    }
    assert_eq!((tl.segments, tl.met, tl.missed, tl.pending), (3, 3, 0, 0));
    assert!(sum.failure.is_none(), "{:?}", sum.failure);
}

/// The scenario checks name the key: an overlap, an empty list, too many segments and a
/// bad pointing are refused before any flight.
#[test]
fn invalid_timelines_are_refused_naming_the_key() {
    let refused = |timeline: &str| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-cubesat.toml");
        let mut sc = table(&std::fs::read_to_string(path).unwrap());
        sc.remove("commands");
        let tl = table(timeline);
        sc.insert("timeline".into(), tl.get("timeline").cloned().unwrap_or(Value::Array(vec![])));
        format!("{:#}", Scenario::from_toml(&toml::to_string(&sc).unwrap()).expect_err("must be refused"))
    };
    let seg = |t: f64| {
        format!(
            "[[timeline]]\nstart_s = {t}\nguidance = {{ pointing = {{ primary_body = [0, 0, 1], primary = \"nadir\", secondary_body = [1, 0, 0], secondary = \"sun\" }} }}\n"
        )
    };
    let overlap = refused(&(seg(900.0) + &seg(800.0)));
    assert!(overlap.contains("timeline[1].start_s") && overlap.contains("overlap"), "{overlap}");
    let empty = refused("timeline = []");
    assert!(empty.contains("`timeline`") && empty.contains("empty"), "{empty}");
    let many: String = (1..=17).map(|k| seg(100.0 * k as f64)).collect();
    let many = refused(&many);
    assert!(many.contains("`timeline`") && many.contains("at most 16"), "{many}");
    let bad = refused(
        "[[timeline]]\nstart_s = 100\nguidance = { pointing = { primary_body = [0, 0, 1], primary = \"nadir\", secondary_body = [0, 0, 1], secondary = \"sun\" } }\n",
    );
    assert!(bad.contains("timeline[0].guidance"), "{bad}");
}

/// A timeline the flight code refuses (its second segment 10 s after the first, far less
/// than the ~190 s slew from Sun pointing to nadir) fails the run with the segment and the
/// reason; nothing is flown as if it had been accepted.
#[test]
fn a_timeline_the_flight_code_refuses_fails_the_run_with_the_reason() {
    let tl = THREE.replace("start_s = 1500.0", "start_s = 610.0");
    let e = runner::run(&scenario(&tl), &mut InProcess::new(), false).map(|_| ()).expect_err("must fail");
    let msg = format!("{e:#}");
    println!("{msg}");
    assert!(msg.contains("timeline[1]") && msg.contains("Unreachable"), "{msg}");
}

/// Segments due while the flight code is out of its mission modes are missed, counted, and
/// fail the run (`timeline_missed`) unless the scenario allows it. A ground command locks
/// detumble at 1300 s: the Sun segment (600 s) is met, nadir (1500 s) and the target
/// (2950 s) fall in the locked detumble and are missed.
#[test]
fn segments_due_out_of_the_mission_modes_are_missed_and_fail_the_run() {
    use sim_core::recorder::summary::{Failure, RunStatus};
    let fly = |allow: bool| {
        let mut t = scenario_table(THREE);
        let lock = table("at_s = 1300.0\nmode = \"detumble\"\nlock = true\n");
        t.insert("commands".into(), Value::Array(vec![Value::Table(lock)]));
        let mut sc = scenario_from(t);
        sc.performance.allow_missed_segments = allow;
        runner::run(&sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"))
    };
    let strict = fly(false);
    let tl = strict.summary.timeline.clone().expect("timeline summary");
    println!("{tl:?}; {:?}", strict.summary.failure);
    assert_eq!((tl.met, tl.missed, tl.pending), (1, 2, 0), "{tl:?}");
    assert_eq!(strict.summary.run_status, RunStatus::TimelineMissed);
    assert!(matches!(&strict.summary.failure, Some(Failure::Timeline { .. })));
    // The column never shows a segment after the first while detumble is locked.
    let (t, seg) = (strict.series.col("t_s").unwrap(), strict.series.col("timeline_segment").unwrap());
    assert!(t.iter().zip(seg).filter(|(t, _)| **t > 1300.0).all(|(_, s)| *s <= 1.0));
    let lenient = fly(true);
    let tl = lenient.summary.timeline.clone().expect("timeline summary");
    assert_eq!((tl.met, tl.missed), (1, 2));
    assert_eq!(lenient.summary.run_status, RunStatus::Ok, "{:?}", lenient.summary.failure);
}
