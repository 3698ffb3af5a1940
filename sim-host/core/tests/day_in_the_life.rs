//! Issue 41: the shipped day in the life (`scenarios/guidance/eo-day-in-the-life.toml`)
//! flown in-process: 11 timeline segments (Sun charging, three imaging targets, a station
//! pass, nadir between) with planned slews and a star-tracker Sun keep-out, across the
//! eclipses. The flight must report every segment met and the simulator no keep-out
//! violation.
//!
//! Truths, independent of the flight code: the tracker's Sun margin recomputed here from
//! the recorded true attitude (`q_*`) and true Sun direction (`sun_eci_*`): angle from
//! the boresight minus the 35° half-angle, smallest over the run > 0 and equal to the
//! summary's (1e-9°); each segment's pointing error while it is in force
//! (`timeline_segment`) from its start + 200 s (slew and settling): Sun pointing, the
//! angle between body +x and the Sun; nadir (and a pass's nadir branch, once its site has
//! been below the gate for 150 s), between body +z and −r; a site above its gate for
//! 150 s (the gate's slew), the truth's primary error (`pointing_primary_error_deg`, the
//! true line of sight through the full Earth orientation). Each below 0.1°.

use acs_test_support::vec3::rotate_xyzw;
use sim_core::link::in_process::InProcess;
use sim_core::recorder::summary::RunStatus;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::Path;

const SETTLE_S: f64 = 200.0;
const GATE_SETTLE_S: f64 = 150.0;
const BOUND_DEG: f64 = 0.1;
const TRACKER_BODY: [f64; 3] = [0.0, -0.866_025_403_784_438_6, -0.5];
const TRACKER_HALF_ANGLE_DEG: f64 = 35.0;

/// What each segment points: Sun, nadir, or a site above a gate (deg).
#[derive(Clone, Copy, Debug)]
enum Kind {
    Sun,
    Nadir,
    Site(f64),
}

/// The scenario's segments (start s, kind), in order; checked against the file below.
const SEGMENTS: [(f64, Kind); 11] = [
    (900.0, Kind::Sun),
    (1250.0, Kind::Nadir),
    (1520.0, Kind::Site(30.0)),
    (1900.0, Kind::Nadir),
    (2300.0, Kind::Site(10.0)),
    (3010.0, Kind::Site(20.0)),
    (3600.0, Kind::Sun),
    (4500.0, Kind::Nadir),
    (6600.0, Kind::Sun),
    (7250.0, Kind::Site(30.0)),
    (7860.0, Kind::Nadir),
];

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let n = (a.iter().map(|x| x * x).sum::<f64>() * b.iter().map(|x| x * x).sum::<f64>()).sqrt();
    (dot / n).clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn the_day_in_the_life_meets_every_segment_outside_the_tracker_cone() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/guidance/eo-day-in-the-life.toml");
    let sc = Scenario::from_toml(&std::fs::read_to_string(path).unwrap()).unwrap_or_else(|e| panic!("{e:#}"));
    let starts: Vec<f64> = sc.timeline_entries().unwrap().iter().map(|s| s.start_s).collect();
    assert_eq!(starts, SEGMENTS.map(|s| s.0).to_vec(), "the test's segments are the scenario's");
    let run = runner::run(&sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}"));
    let (s, sum) = (&run.series, &run.summary);
    let col = |n: &str| s.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let tl = sum.timeline.clone().expect("timeline summary");
    let k = sum.keepout.clone().expect("keepout summary");
    println!("timeline {tl:?}\nkeepout {k:?}");
    assert_eq!((tl.segments, tl.met, tl.missed, tl.pending), (11, 11, 0, 0));
    assert_eq!((k.violations, k.steps_inside, k.slews_refused.iter().sum::<u16>()), (0, 0, 0));
    assert_eq!(sum.run_status, RunStatus::Ok, "{:?}", sum.failure);

    let q = |i: usize| [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]];
    let sun = |i: usize| [col("sun_eci_x")[i], col("sun_eci_y")[i], col("sun_eci_z")[i]];
    let min_margin_deg = (0..s.len())
        .map(|i| angle_deg(rotate_xyzw(&q(i), &TRACKER_BODY), sun(i)) - TRACKER_HALF_ANGLE_DEG)
        .fold(f64::INFINITY, f64::min);
    let summary_min = k.min_margin_deg["tracker.sun"].expect("a tracker margin");
    println!("tracker Sun margin: smallest {min_margin_deg:.4} deg (summary {summary_min:.4})");
    assert!(min_margin_deg > 0.0, "{min_margin_deg}");
    assert!((min_margin_deg - summary_min).abs() < 1e-9, "{min_margin_deg} vs {summary_min}");

    let (worst, rows) = pointing_errors(s);
    for (j, ((w, n), seg)) in worst.iter().zip(&rows).zip(SEGMENTS).enumerate() {
        println!("segment {j} {:?} from {} s: worst {w:.4} deg over {n} rows", seg.1, seg.0);
        assert!(*n > 50, "segment {j} judged over {n} rows");
        assert!(*w < BOUND_DEG, "segment {j}: {w} deg ≥ {BOUND_DEG} deg");
    }
}

/// Per segment: (worst truth pointing error after its start + SETTLE_S while in force,
/// rows judged), as the module comment says.
fn pointing_errors(s: &sim_core::recorder::series::TimeSeries) -> ([f64; 11], [usize; 11]) {
    let col = |n: &str| s.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let (t, seg, el) = (col("t_s"), col("timeline_segment"), col("target_elevation_deg"));
    let (mut worst, mut rows) = ([0.0f64; 11], [0usize; 11]);
    // How long the gate has been on the same side as at row i (s).
    let held_s = |i: usize, gate: f64| {
        let up = el[i] >= gate;
        (0..i).rev().take_while(|&j| (el[j] >= gate) == up).last().map_or(0.0, |j| t[i] - t[j])
    };
    for i in 0..s.len() {
        let Some(j) = (seg[i] as usize).checked_sub(1) else { continue };
        let (start, kind) = SEGMENTS[j];
        if t[i] < start + SETTLE_S {
            continue;
        }
        let q = [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]];
        let nadir = || {
            angle_deg(
                rotate_xyzw(&q, &[0.0, 0.0, 1.0]),
                [-col("r_eci_x_m")[i], -col("r_eci_y_m")[i], -col("r_eci_z_m")[i]],
            )
        };
        let err = match kind {
            Kind::Sun => angle_deg(
                rotate_xyzw(&q, &[1.0, 0.0, 0.0]),
                [col("sun_eci_x")[i], col("sun_eci_y")[i], col("sun_eci_z")[i]],
            ),
            Kind::Nadir => nadir(),
            Kind::Site(gate) if held_s(i, gate) < GATE_SETTLE_S => continue,
            Kind::Site(gate) if el[i] >= gate => col("pointing_primary_error_deg")[i],
            Kind::Site(_) => nadir(),
        };
        worst[j] = worst[j].max(err);
        rows[j] += 1;
    }
    (worst, rows)
}
