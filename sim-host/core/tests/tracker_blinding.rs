//! Issue 41: a slew that sweeps the star tracker through the Sun blinds it, and the
//! estimator loses it; the same slew planned with a keep-out cone on the tracker does not.
//!
//! The spacecraft of the shipped EO cubesat (MEKF on gyro, tracker, CSS, magnetometer;
//! GNSS navigation) on the sunlit half of its orbit, its tracker along body +y with a 30°
//! Sun exclusion. It holds Sun pointing (+x to the Sun, +z towards nadir) and at 700 s is
//! commanded to put the body direction 150° from +x in the x-y plane on the Sun: the
//! eigen-axis turn is about body z, and the Sun, seen from the body, runs from +x through
//! +y (the tracker) to its new place. Both runs slew under `[manoeuvre]`; the second adds
//! a keep-out cone of 35° about the Sun on +y.
//!
//! Truths, independent of the planner and the sensor model: the Sun's angle to the
//! tracker's boresight from the recorded true attitude and Sun direction, and the
//! estimator's own age of its newest tracker sample (`est_age_tracker_s`; the tracker
//! samples at 4 Hz, so a live tracker keeps it at 0.25 s at most, checked against 1 s; no
//! sample held at all is NaN, counted as lost).

use acs_test_support::vec3::rotate_xyzw;
use sim_core::link::in_process::InProcess;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::Path;
use toml::{Table, Value};

const COMMAND_S: f64 = 700.0;
const TRACKER_EXCLUSION_DEG: f64 = 30.0;

fn table(text: &str) -> Table {
    text.parse::<Table>().unwrap()
}

/// The EO cubesat turned into the blinding case (`keepout`: with the tracker's cone).
fn scenario(keepout: bool) -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-cubesat.toml");
    let mut sc = table(&std::fs::read_to_string(path).unwrap());
    sc.insert("duration_s".into(), Value::Float(1000.0));
    // The descending node at 10:30: the sunlit half of the orbit for the whole run.
    sc["orbit"].as_table_mut().unwrap().insert("arg_lat_deg".into(), Value::Float(180.0));
    let sun_pointing = r#"label = "Sun pointing"
pointing = { primary_body = [1, 0, 0], primary = "sun", secondary_body = [0, 0, 1], secondary = "nadir" }
transition_s = 120.0
ut1_minus_clock_s = 0.05
feedforward = true"#;
    sc.insert("guidance".into(), Value::Table(table(sun_pointing)));
    let turned = r#"at_s = 700.0
guidance = { label = "turned", pointing = { primary_body = [-0.8660254037844386, 0.5, 0], primary = "sun", secondary_body = [0, 0, 1], secondary = "nadir" }, transition_s = 120.0, ut1_minus_clock_s = 0.05, feedforward = true }"#;
    sc.insert("commands".into(), Value::Array(vec![Value::Table(table(turned))]));
    let tracker = sc["sensors"]["star_tracker"].as_table().unwrap().clone();
    let mut tracker = tracker;
    tracker.insert("boresight_body".into(), Value::try_from([0.0, 1.0, 0.0]).unwrap());
    tracker.insert("sun_exclusion_deg".into(), Value::Float(TRACKER_EXCLUSION_DEG));
    sc["sensors"].as_table_mut().unwrap().insert("star_tracker".into(), Value::Table(tracker));
    let mut manoeuvre = table("max_rate_deg_s = 1.0\nmax_accel_deg_s2 = 0.05\nplanning_margin_deg = 2.0\n");
    if keepout {
        let cone = table("name = \"st\"\nboresight_body = [0, 1, 0]\nsun_half_angle_deg = 35.0\n");
        manoeuvre.insert("keepout".into(), Value::Array(vec![Value::Table(cone)]));
    }
    sc.insert("manoeuvre".into(), Value::Table(manoeuvre));
    Scenario::from_toml(&toml::to_string(&sc).unwrap()).unwrap_or_else(|e| panic!("{e:#}"))
}

/// After the command: (rows with the Sun inside the tracker's cone, smallest Sun angle
/// deg, rows without a tracker sample younger than 1 s, largest estimation error deg), and
/// the slews planned.
fn fly(keepout: bool) -> (usize, f64, usize, f64, u32) {
    let run = runner::run(&scenario(keepout), &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"));
    let s = &run.series;
    let col = |n: &str| s.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let (t, age) = (col("t_s"), col("est_age_tracker_s"));
    let error_deg = col("est_error_deg");
    let (mut inside, mut min_deg, mut stale, mut worst_error_deg) = (0, f64::INFINITY, 0, 0.0f64);
    for i in (0..s.len()).filter(|&i| t[i] >= COMMAND_S) {
        let q = [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]];
        let sun = [col("sun_eci_x")[i], col("sun_eci_y")[i], col("sun_eci_z")[i]];
        let b = rotate_xyzw(&q, &[0.0, 1.0, 0.0]);
        let norm = (sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]).sqrt();
        let deg = ((b[0] * sun[0] + b[1] * sun[1] + b[2] * sun[2]) / norm).clamp(-1.0, 1.0).acos().to_degrees();
        min_deg = min_deg.min(deg);
        inside += usize::from(deg < TRACKER_EXCLUSION_DEG);
        // NaN: the estimator holds no tracker sample at all (it dropped the stale one).
        stale += usize::from(age[i].is_nan() || age[i] > 1.0);
        worst_error_deg = worst_error_deg.max(error_deg[i]);
    }
    let planned = run.summary.keepout.as_ref().map_or(0, |k| k.slews_planned);
    (inside, min_deg, stale, worst_error_deg, planned.into())
}

#[test]
fn slewing_through_the_sun_blinds_the_tracker_and_the_keepout_prevents_it() {
    let (inside, min_deg, stale, error_deg, _) = fly(false);
    println!(
        "no keep-out: Sun within {TRACKER_EXCLUSION_DEG} deg of the tracker in {inside} rows (closest \
         {min_deg:.2} deg); no tracker sample younger than 1 s in {stale} rows; est error <= {error_deg:.4} deg"
    );
    assert!(min_deg < 5.0, "the direct slew was meant to cross the Sun: closest {min_deg} deg");
    assert!(inside > 0, "the Sun should have entered the tracker's cone");
    // Every row with the Sun in the cone (2 Hz rows, 4 Hz tracker) has lost the tracker.
    assert!(stale >= inside, "stale {stale} < inside {inside}: the estimator kept the tracker");
    let (inside, min_deg, stale, error_deg, planned) = fly(true);
    println!(
        "keep-out 35 deg: Sun within {TRACKER_EXCLUSION_DEG} deg in {inside} rows (closest {min_deg:.2} deg); \
         no tracker sample younger than 1 s in {stale} rows; est error <= {error_deg:.4} deg; {planned} slews planned"
    );
    assert!(planned >= 1, "the turn should have been planned");
    assert!(min_deg > TRACKER_EXCLUSION_DEG + 5.0, "{min_deg}");
    assert_eq!((inside, stale), (0, 0));
}
