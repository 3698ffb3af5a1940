//! The pointing timeline (`guidance::timeline`) against truths written here: the arming
//! refuses each fault that can be built with the right segment index and reason; the
//! lead of a segment is the closed-form rest-to-rest time (written separately below) plus
//! the planner's steps; `step` hands over at start − lead and counts met / missed;
//! `seconds_between` across day boundaries.

// Test-side f32 helpers on known-good values.
#![allow(clippy::disallowed_methods)]

use acs_flight::estimation::navigation::NavSolution;
use acs_flight::guidance::Guided;
use acs_flight::guidance::blend::quat_exp;
use acs_flight::guidance::manoeuvre::{CANDIDATES, CANDIDATES_PER_STEP};
use acs_flight::guidance::timeline::{SEGMENT_BUF, Timeline, checksum, seconds_between};
use acs_flight::math::{Quat, Vec3, quat_to_xyzw};
use acs_flight::models::time::J2000Time;
use acs_flight::params::timeline::TIMELINE_HORIZON_S;
use acs_flight::params::{
    Direction, GuidanceParams, KeepOutCone, MAX_TIMELINE_SEGMENTS, ManoeuvreParams, Pointing, TargetFrame,
    TimelineError, TimelineFault, TimelineSegment,
};

const RATE: f64 = 0.05;
const ACCEL: f64 = 0.005;
const DT: f64 = 0.1;
/// Navigation epoch: 400 s before a midnight, so segments cross the day boundary.
const EPOCH_DAYS: i32 = 9_600;
const EPOCH_S: f64 = 86_000.0;
const R_ORBIT_M: f64 = 6_878_137.0;
const MU: f64 = 3.986_004_418e14;

fn manoeuvre(cones: &[KeepOutCone]) -> ManoeuvreParams {
    let mut p = ManoeuvreParams {
        enabled: true,
        max_rate_rad_s: RATE as f32,
        max_accel_rad_s2: ACCEL as f32,
        planning_margin_rad: 0.02,
        ..ManoeuvreParams::OFF
    };
    for (slot, c) in p.cones.iter_mut().zip(cones) {
        *slot = *c;
    }
    p.cone_count = cones.len() as u8;
    p.validate().unwrap();
    p
}

/// Time `t_s` after the epoch, normalised in f64 then rounded once to f32.
fn time_at(t_s: f64) -> J2000Time {
    let total = EPOCH_S + t_s;
    let days = (total / 86_400.0).floor();
    J2000Time { days: EPOCH_DAYS + days as i32, seconds: (total - days * 86_400.0) as f32 }
}

/// A circular equatorial orbit `t_s` after the epoch.
fn nav(t_s: f64) -> NavSolution {
    let n = (MU / R_ORBIT_M.powi(3)).sqrt();
    let (s, c) = (n * t_s).sin_cos();
    let v = n * R_ORBIT_M;
    NavSolution {
        r_m: Vec3::new((R_ORBIT_M * c) as f32, (R_ORBIT_M * s) as f32, 0.0),
        v_m_s: Vec3::new((-v * s) as f32, (v * c) as f32, 0.0),
        time: time_at(t_s),
        q_lvlh: Quat::identity(),
        lvlh_rate_rad_s: Vec3::zeros(),
        fix_age_s: 0.0,
    }
}

fn inertial_at(t_s: f64, q: &Quat) -> TimelineSegment {
    let t = time_at(t_s);
    TimelineSegment {
        start_j2000_days: t.days,
        start_j2000_s: t.seconds,
        guidance: GuidanceParams::fixed(quat_to_xyzw(q), TargetFrame::Inertial),
    }
}

/// Rest-to-rest eigen-axis time over `theta` within RATE and ACCEL (closed form: bang-
/// coast-bang `θ/ω + ω/α` when `θ ≥ ω²/α`, else bang-bang `2√(θ/α)`).
fn rest_to_rest_s(theta: f64) -> f64 {
    if theta >= RATE * RATE / ACCEL { theta / RATE + RATE / ACCEL } else { 2.0 * (theta / ACCEL).sqrt() }
}

/// The lead the module documents: 10 % margin on the slew, the planner's steps, one step.
fn expected_lead_s(theta: f64) -> f64 {
    1.1 * rest_to_rest_s(theta) + (CANDIDATES.div_ceil(CANDIDATES_PER_STEP)) as f64 * DT + DT
}

fn stage_all(tl: &mut Timeline, segs: &[TimelineSegment]) {
    for (i, s) in segs.iter().enumerate() {
        tl.stage(i as u8, s).unwrap();
    }
}

fn arm(
    tl: &mut Timeline,
    segs: &[TimelineSegment],
    from: Option<&Quat>,
    m: &ManoeuvreParams,
) -> Result<u32, TimelineError> {
    let from = from.map(|q| Guided { q: *q, rate_rad_s: Vec3::zeros(), accel_rad_s2: Vec3::zeros() });
    tl.arm(segs.len() as u8, checksum(segs).unwrap(), Some(&nav(0.0)), from, m, DT as f32)
}

fn err(index: u8, fault: TimelineFault) -> Result<u32, TimelineError> {
    Err(TimelineError { index, fault })
}

/// Three inertial segments 0.5 rad apart, 100 s apart (each slew ~ 22 s plus planning).
fn three() -> (Vec<TimelineSegment>, [Quat; 3]) {
    let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
    let q: [Quat; 3] = core::array::from_fn(|k| quat_exp(&(axis * (0.5 * k as f32))));
    (q.iter().enumerate().map(|(k, q)| inertial_at(100.0 * (k + 1) as f64, q)).collect(), q)
}

#[test]
fn arming_refuses_each_fault_naming_the_segment() {
    let m = manoeuvre(&[]);
    let (segs, q) = three();
    let mut tl = Timeline::new();
    let d = |tl: &mut Timeline, count: u8| tl.arm(count, 0, Some(&nav(0.0)), None, &m, DT as f32);
    assert_eq!(d(&mut tl, 0), err(0, TimelineFault::BadCount));
    assert_eq!(d(&mut tl, MAX_TIMELINE_SEGMENTS as u8 + 1), err(0, TimelineFault::BadCount));
    // Segment 1 never staged.
    tl.stage(0, &segs[0]).unwrap();
    tl.stage(2, &segs[2]).unwrap();
    assert_eq!(d(&mut tl, 3), err(1, TimelineFault::NotUploaded));
    // Staging beyond the table is refused.
    assert!(tl.stage(MAX_TIMELINE_SEGMENTS as u8, &segs[0]).is_err());
    stage_all(&mut tl, &segs);
    // Checksum: the ground's differs by one bit; and a segment altered after the ground's sum.
    let good = checksum(&segs).unwrap();
    assert_eq!(tl.arm(3, good ^ 1, Some(&nav(0.0)), None, &m, DT as f32), err(0, TimelineFault::Checksum));
    let mut altered = segs.clone();
    altered[2].start_j2000_s += 1.0;
    assert_eq!(
        tl.arm(3, checksum(&altered).unwrap(), Some(&nav(0.0)), None, &m, DT as f32),
        err(0, TimelineFault::Checksum)
    );
    assert_eq!(tl.arm(3, good, None, None, &m, DT as f32), err(0, TimelineFault::NoNavigation));
    assert!(!tl.is_armed());

    // Times: not increasing (equal and earlier), in the past, beyond the horizon, NaN.
    let mut t = Timeline::new();
    let same = vec![segs[0], segs[1], inertial_at(200.0, &q[2])];
    stage_all(&mut t, &same);
    assert_eq!(arm(&mut t, &same, None, &m), err(2, TimelineFault::NotIncreasing));
    let earlier = vec![segs[0], segs[1], inertial_at(150.0, &q[2])];
    stage_all(&mut t, &earlier);
    assert_eq!(arm(&mut t, &earlier, None, &m), err(2, TimelineFault::NotIncreasing));
    let past = vec![inertial_at(-1.0, &q[0])];
    stage_all(&mut t, &past);
    assert_eq!(arm(&mut t, &past, None, &m), err(0, TimelineFault::InThePast));
    let far = vec![segs[0], inertial_at(TIMELINE_HORIZON_S as f64 + 10.0, &q[1])];
    stage_all(&mut t, &far);
    assert_eq!(arm(&mut t, &far, None, &m), err(1, TimelineFault::BeyondHorizon));
    let mut nan = vec![segs[0], segs[1]];
    nan[1].start_j2000_s = f32::NAN;
    stage_all(&mut t, &nan);
    assert_eq!(arm(&mut t, &nan, None, &m), err(1, TimelineFault::BadStart));
    // An invalid pointing never reaches the arming: staging refuses it.
    let mut bad = segs[0];
    bad.guidance.pointing = Pointing::Fixed { q_xyzw: [0.0, 0.0, 0.0, 2.0], frame: TargetFrame::Inertial };
    assert!(t.stage(0, &bad).is_err());

    // The good timeline arms and returns the ground's checksum.
    stage_all(&mut t, &segs);
    assert_eq!(arm(&mut t, &segs, None, &m), Ok(good));
    assert!(t.is_armed());
}

/// A +z boresight with a 30° Sun cone: a segment pointing +z at the Sun is refused at its
/// start; pointing −z at the Sun (the boresight 180° from it) is accepted.
#[test]
fn arming_refuses_a_segment_in_a_keep_out_cone_at_its_start() {
    let cone =
        KeepOutCone { boresight_body: [0.0, 0.0, 1.0], sun_half_angle_rad: 30f32.to_radians(), earth_margin_rad: -1.0 };
    let m = manoeuvre(&[cone]);
    let sun = |body: [f32; 3], t_s: f64| {
        let t = time_at(t_s);
        let g = GuidanceParams {
            pointing: Pointing::Align {
                primary_body: body,
                primary: Direction::Sun,
                secondary_body: [1.0, 0.0, 0.0],
                secondary: Direction::OrbitNormal,
            },
            ..GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial)
        };
        TimelineSegment { start_j2000_days: t.days, start_j2000_s: t.seconds, guidance: g }
    };
    let (segs, _) = three();
    let bad = vec![segs[0], sun([0.0, 0.0, 1.0], 400.0)];
    let mut t = Timeline::new();
    stage_all(&mut t, &bad);
    assert_eq!(arm(&mut t, &bad, None, &m), err(1, TimelineFault::KeepOutAtStart));
    let ok = vec![segs[0], sun([0.0, 0.0, -1.0], 400.0)];
    stage_all(&mut t, &ok);
    assert!(arm(&mut t, &ok, None, &m).is_ok());
}

/// Two inertial attitudes `theta` apart: the second segment is reachable when its start
/// leaves the closed-form lead after the first's start (+0.05 s), refused as unreachable
/// when it leaves 0.05 s less; the armed lead equals the closed form within 1e-3 s (f32
/// quaternion angle). Both the bang-coast-bang (2 rad) and bang-bang (0.2 rad) cases; and
/// the first segment measured from the command in force.
#[test]
fn unreachable_segments_are_refused_by_the_closed_form_lead() {
    let m = manoeuvre(&[]);
    let axis = Vec3::new(-0.2, 0.9, 0.4).normalize();
    for theta in [2.0f64, 0.2] {
        let q0 = Quat::identity();
        let q1 = quat_exp(&(axis * theta as f32));
        let lead = expected_lead_s(theta);
        let t0 = 50.0;
        for (gap, ok) in [(lead + 0.05, true), (lead - 0.05, false)] {
            let segs = vec![inertial_at(t0, &q0), inertial_at(t0 + gap, &q1)];
            let mut t = Timeline::new();
            stage_all(&mut t, &segs);
            let r = arm(&mut t, &segs, Some(&q0), &m);
            if ok {
                assert!(r.is_ok(), "θ {theta}: gap {gap} s: {r:?}");
                let got = t.lead_s(1).unwrap() as f64;
                println!("θ {theta} rad: lead {got:.4} s, closed form {lead:.4} s");
                assert!((got - lead).abs() < 1e-3, "θ {theta}: lead {got} vs {lead}");
            } else {
                assert_eq!(r, err(1, TimelineFault::Unreachable), "θ {theta}: gap {gap}");
            }
        }
        // The first segment: from the command in force, before the arming.
        let first = vec![inertial_at(lead - 0.05, &q1)];
        let mut t = Timeline::new();
        stage_all(&mut t, &first);
        assert_eq!(arm(&mut t, &first, Some(&q0), &m), err(0, TimelineFault::Unreachable));
        let first = vec![inertial_at(lead + 0.05, &q1)];
        stage_all(&mut t, &first);
        assert!(arm(&mut t, &first, Some(&q0), &m).is_ok());
    }
    // Without planned slews the lead is the blend's transition.
    let mut g = inertial_at(30.0, &Quat::identity());
    g.guidance.transition_s = 20.0;
    let mut t = Timeline::new();
    t.stage(0, &g).unwrap();
    t.arm(1, checksum(&[g]).unwrap(), Some(&nav(0.0)), None, &ManoeuvreParams::OFF, DT as f32).unwrap();
    assert_eq!(t.lead_s(0), Some(20.0));
}

/// Stepping at 10 Hz across midnight: each segment's pointing takes over at the first
/// step at or after start − lead (closed form), once; each start counts met when on
/// target, missed when not; nothing after the last.
#[test]
fn step_hands_over_at_start_minus_lead_and_counts_met_and_missed() {
    let m = manoeuvre(&[]);
    let (segs, q) = three();
    let mut t = Timeline::new();
    stage_all(&mut t, &segs);
    arm(&mut t, &segs, Some(&q[0]), &m).unwrap();
    let starts = [100.0, 200.0, 300.0];
    let leads = [expected_lead_s(0.0), expected_lead_s(0.5), expected_lead_s(0.5)];
    let mut switches = Vec::new();
    let mut counted = Vec::new();
    let (mut met, mut missed) = (0, 0);
    for k in 1..4_000 {
        let ts = k as f64 * DT;
        // Segment 1 (index 1) is still slewing at its start: missed.
        let on_target = !(ts > 150.0 && ts < 250.0);
        if let Some(g) = t.step(&time_at(ts), on_target) {
            switches.push((ts, g));
        }
        let c = t.counters;
        if (c.met, c.missed) != (met, missed) {
            counted.push((ts, c.met - met, c.missed - missed));
            (met, missed) = (c.met, c.missed);
        }
    }
    assert_eq!(switches.len(), 3, "{switches:?}");
    for (i, (ts, g)) in switches.iter().enumerate() {
        let due = starts[i] - leads[i];
        println!("segment {i}: took over at {ts:.1} s, due {due:.3} s");
        // First 10 Hz step at or after the due time (0.02 s: f32 seconds near 86 400).
        assert!(*ts >= due - 0.02 && *ts < due + DT + 0.02, "segment {i}: at {ts}, due {due}");
        assert_eq!(*g, segs[i].guidance);
    }
    assert_eq!(counted.len(), 3, "{counted:?}");
    for (i, (ts, dmet, dmissed)) in counted.iter().enumerate() {
        assert!(*ts >= starts[i] - 0.02 && *ts < starts[i] + DT + 0.02, "segment {i}: counted at {ts}");
        assert_eq!((*dmet, *dmissed), if i == 1 { (0, 1) } else { (1, 0) }, "segment {i}");
    }
    assert_eq!((t.counters.met, t.counters.missed, t.counters.in_force), (2, 1, 3));
}

/// A timeline not stepped for a while (the flight software out of the mission modes):
/// segments whose successor is already due are skipped as missed, the latest due one
/// takes over.
#[test]
fn a_gap_in_stepping_skips_overdue_segments_as_missed() {
    let m = manoeuvre(&[]);
    let (segs, q) = three();
    let mut t = Timeline::new();
    stage_all(&mut t, &segs);
    arm(&mut t, &segs, Some(&q[0]), &m).unwrap();
    assert_eq!(t.step(&time_at(1.0), true), None);
    // Jump to 290 s: segment 2's slew is due (300 − lead ≈ 275 s); 0 and 1 were never flown.
    let g = t.step(&time_at(290.0), true);
    assert_eq!(g, Some(segs[2].guidance));
    assert_eq!((t.counters.met, t.counters.missed, t.counters.in_force), (0, 2, 3));
    assert_eq!(t.step(&time_at(300.05), true), None);
    assert_eq!((t.counters.met, t.counters.missed), (1, 2));
}

/// Out of the mission modes (`skip_overdue`) nothing takes over and each segment is
/// counted missed once its start has passed, not before; back in a mission mode the next
/// segment is flown as usual.
#[test]
fn out_of_the_mission_modes_passed_segments_are_missed() {
    let m = manoeuvre(&[]);
    let (segs, q) = three();
    let mut t = Timeline::new();
    stage_all(&mut t, &segs);
    arm(&mut t, &segs, Some(&q[0]), &m).unwrap();
    let (s0, s1, s2) = (100.0, 200.0, 300.0); // three()'s starts
    t.skip_overdue(&time_at(s0 - 0.05));
    assert_eq!((t.counters.met, t.counters.missed, t.counters.in_force), (0, 0, 0));
    t.skip_overdue(&time_at(s0 + 0.05));
    assert_eq!(t.counters.missed, 1);
    t.skip_overdue(&time_at(s1 + 0.05));
    assert_eq!((t.counters.missed, t.counters.in_force), (2, 0));
    // Back in a mission mode before segment 2's start: it takes over and is met.
    let mut took_over = None;
    let mut k = 0;
    while took_over.is_none() && k < 10_000 {
        took_over = t.step(&time_at(s1 + 0.1 * f64::from(k)), true);
        k += 1;
    }
    assert_eq!(took_over, Some(segs[2].guidance));
    assert_eq!(t.step(&time_at(s2 + 0.05), true), None);
    assert_eq!((t.counters.met, t.counters.missed, t.counters.in_force), (1, 2, 3));
}

/// Staging a new timeline does not change the one executing; clearing drops both.
#[test]
fn staging_does_not_alter_the_armed_timeline_and_clear_drops_it() {
    let m = manoeuvre(&[]);
    let (segs, q) = three();
    let mut t = Timeline::new();
    stage_all(&mut t, &segs);
    arm(&mut t, &segs, Some(&q[0]), &m).unwrap();
    let other = inertial_at(120.0, &q[2]);
    t.stage(1, &other).unwrap();
    assert_eq!(t.segment(1), Some(&segs[1]));
    let mut got = Vec::new();
    for k in 1..2_500 {
        if let Some(g) = t.step(&time_at(k as f64 * DT), true) {
            got.push(g);
        }
    }
    assert_eq!(got, vec![segs[0].guidance, segs[1].guidance]);
    t.clear();
    assert!(!t.is_armed());
    assert_eq!(t.step(&time_at(400.0), true), None);
    assert_eq!(t.counters, Default::default());
}

#[test]
fn seconds_between_crosses_day_boundaries() {
    let t = |d, s| J2000Time::new(d, s).unwrap();
    assert_eq!(seconds_between(&t(100, 86_399.5), &t(101, 0.5)), 1.0);
    assert_eq!(seconds_between(&t(101, 0.5), &t(100, 86_399.5)), -1.0);
    assert_eq!(seconds_between(&t(100, 3_600.0), &t(103, 0.0)), 3.0 * 86_400.0 - 3_600.0);
    // Normalised input: 90 000 s into day 100 is day 101 at 3 600 s.
    assert_eq!(seconds_between(&t(100, 90_000.0), &t(101, 3_600.0)), 0.0);
    // Against f64 over a day of 7-s steps from a late start: within f32 rounding (0.01 s).
    for k in 0..12_345 {
        let dt = k as f64 * 7.0;
        let got = seconds_between(&time_at(0.0), &time_at(dt)) as f64;
        assert!((got - dt).abs() < 0.01, "{dt}: {got}");
    }
}

/// The largest segment (two-vector ground pointing with a gated alternative) encodes
/// within the checksum's buffer, so the checksum never fails for a valid segment.
#[test]
fn the_largest_segment_fits_the_checksum_buffer() {
    let ground = Direction::Ground { lat_rad: 0.7, lon_rad: -2.1, alt_m: 1_234.0 };
    let celestial = Direction::Celestial { ra_rad: 1.0, dec_rad: -0.5 };
    let align = |p, s| Pointing::Align {
        primary_body: [0.0, 0.0, 1.0],
        primary: p,
        secondary_body: [1.0, 0.0, 0.0],
        secondary: s,
    };
    let seg = TimelineSegment {
        start_j2000_days: i32::MIN,
        start_j2000_s: f32::MAX,
        guidance: GuidanceParams {
            pointing: align(ground, celestial),
            min_elevation_rad: Some(0.1),
            otherwise: align(celestial, ground),
            ..GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial)
        },
    };
    let mut buf = [0u8; 4 * SEGMENT_BUF];
    let n = postcard::to_slice(&seg, &mut buf).unwrap().len();
    println!("largest segment: {n} bytes of {SEGMENT_BUF}");
    assert!(n <= SEGMENT_BUF);
    assert!(checksum(&[seg; MAX_TIMELINE_SEGMENTS]).is_some());
}
