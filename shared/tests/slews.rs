//! Planned slews through `Guidance`, as the flight software drives it (a ground command
//! `set_params`, then one `guide` per control step): the rest-to-rest profile against the
//! closed form of bang-coast-bang and bang-bang, the keep-out cones checked by a dense
//! sampling written here (f64, not the planner's closed form), refusals counted with their
//! reason, the planner's work per step, and the near-parallel fallback's exit planned.

// Test-side f32 helpers (normalize, clamp) on known-good values.
#![allow(clippy::disallowed_methods)]

use acs_flight::estimation::navigation::NavSolution;
use acs_flight::guidance::Guidance;
use acs_flight::guidance::blend::quat_exp;
use acs_flight::guidance::manoeuvre::{CANDIDATES, CANDIDATES_PER_STEP, Refusal, phase};
use acs_flight::math::{Quat, Vec3, quat_to_xyzw};
use acs_flight::models::sun::sun_direction_eci;
use acs_flight::models::time::J2000Time;
use acs_flight::params::{Direction, GuidanceParams, KeepOutCone, ManoeuvreParams, Pointing, TargetFrame};
use acs_flight::types::{MAX_WHEELS, Measurements};

const RATE: f32 = 0.05;
const ACCEL: f32 = 0.005;

fn measurements() -> Measurements {
    Measurements {
        q: Quat::identity(),
        rate_rad_s: Vec3::zeros(),
        gimbal_angle_rad: [0.0; 4],
        wheel_speed_rad_s: [0.0; MAX_WHEELS],
        mag_field_t: Vec3::zeros(),
        q_ref: Quat::identity(),
        ref_rate_rad_s: Vec3::zeros(),
        sun_body: None,
        eclipse: false,
    }
}

fn manoeuvre(cones: &[KeepOutCone]) -> ManoeuvreParams {
    let mut p = ManoeuvreParams {
        enabled: true,
        max_rate_rad_s: RATE,
        max_accel_rad_s2: ACCEL,
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

fn inertial(q: &Quat) -> GuidanceParams {
    GuidanceParams::fixed(quat_to_xyzw(q), TargetFrame::Inertial)
}

const EPOCH_DAYS: i32 = 9_600; // 2026-04-14
const R_ORBIT_M: f64 = 6_878_137.0;
const MU: f64 = 3.986_004_418e14;

/// A circular equatorial orbit, `t_s` after the epoch (exact, f64 → f32).
fn nav(t_s: f64) -> NavSolution {
    let n = (MU / R_ORBIT_M.powi(3)).sqrt();
    let (s, c) = (n * t_s).sin_cos();
    let v = n * R_ORBIT_M;
    NavSolution {
        r_m: Vec3::new((R_ORBIT_M * c) as f32, (R_ORBIT_M * s) as f32, 0.0),
        v_m_s: Vec3::new((-v * s) as f32, (v * c) as f32, 0.0),
        time: J2000Time::new(EPOCH_DAYS, 0.0).unwrap().add_seconds(t_s as f32).unwrap(),
        q_lvlh: Quat::identity(),
        lvlh_rate_rad_s: Vec3::zeros(),
        fix_age_s: 0.0,
    }
}

/// `v` rotated by the unit quaternion `q` (body → inertial), in f64.
fn rotate(q: &Quat, v: [f64; 3]) -> [f64; 3] {
    let n = (q.w as f64).hypot((q.i as f64).hypot((q.j as f64).hypot(q.k as f64)));
    let (w, u) = (q.w as f64 / n, [q.i as f64 / n, q.j as f64 / n, q.k as f64 / n]);
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = cross(u, v).map(|x| 2.0 * x);
    let ut = cross(u, t);
    [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]]
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos()
}

/// Rotation angle between two attitudes, f64 (`2 atan2(|vec(a* b)|, |scalar|)`: exact
/// near 0, where `acos` of the dot product is not).
fn between(a: &Quat, b: &Quat) -> f64 {
    let (aw, ai, aj, ak) = (a.w as f64, -(a.i as f64), -(a.j as f64), -(a.k as f64));
    let (bw, bi, bj, bk) = (b.w as f64, b.i as f64, b.j as f64, b.k as f64);
    let w = aw * bw - ai * bi - aj * bj - ak * bk;
    let x = aw * bi + ai * bw + aj * bk - ak * bj;
    let y = aw * bj - ai * bk + aj * bw + ak * bi;
    let z = aw * bk + ai * bj - aj * bi + ak * bw;
    2.0 * (x * x + y * y + z * z).sqrt().atan2(w.abs())
}

struct Flown {
    /// (time after the command, commanded attitude, |commanded rate|, phase) per step.
    steps: Vec<(f64, Quat, f64, u8)>,
}

/// Hold `from` for 1 s at `hz`, command `to` (a ground command between two steps), then
/// fly `seconds`.
fn fly(g: &mut Guidance, to: &GuidanceParams, hz: f64, seconds: f64, with_nav: bool) -> Flown {
    let m = measurements();
    let dt = 1.0 / hz;
    let us = |t: f64| (t * 1e6).round() as u64;
    let mut k = 0u64;
    while (k as f64) * dt < 1.0 {
        let t = k as f64 * dt;
        g.guide(&m, with_nav.then(|| nav(t)).as_ref(), us(t));
        k += 1;
    }
    let t_cmd = k as f64 * dt - 0.5 * dt;
    g.set_params(to);
    let mut steps = Vec::new();
    while (k as f64) * dt < t_cmd + seconds {
        let t = k as f64 * dt;
        let out = g.guide(&m, with_nav.then(|| nav(t)).as_ref(), us(t));
        let phase = g.manoeuvre().last_phase;
        steps.push((t - t_cmd, out.q, out.rate_rad_s.norm() as f64, phase));
        k += 1;
    }
    Flown { steps }
}

/// Closed form of a rest-to-rest profile over `theta` (rad): (duration, peak rate, angle
/// at `t`), bang-coast-bang when `theta ≥ ω²/α`, else bang-bang.
fn closed_form(theta: f64, t: f64) -> (f64, f64, f64) {
    let (w, a) = (RATE as f64, ACCEL as f64);
    if theta >= w * w / a {
        let ta = w / a;
        let total = theta / w + ta;
        let angle = if t < ta {
            0.5 * a * t * t
        } else if t < total - ta {
            0.5 * a * ta * ta + w * (t - ta)
        } else if t < total {
            theta - 0.5 * a * (total - t).powi(2)
        } else {
            theta
        };
        (total, w, angle)
    } else {
        let ta = (theta / a).sqrt();
        let angle = if t < ta {
            0.5 * a * t * t
        } else if t < 2.0 * ta {
            theta - 0.5 * a * (2.0 * ta - t).powi(2)
        } else {
            theta
        };
        (2.0 * ta, a * ta, angle)
    }
}

/// Rest-to-rest slews (no cones) through `Guidance`: the commanded angle follows the
/// closed form at every step (1e-4 rad: f32 quaternion composition over ≤ 3 rad), the
/// slew ends within one step of the closed-form duration after the step that starts it,
/// and the largest commanded rate is the closed-form peak (no more than it + 1e-5 rad/s,
/// no less than it − α·dt: a triangular peak is sampled at the step rate).
#[test]
fn slew_time_and_peak_rate_are_the_closed_form_of_bang_coast_bang_and_bang_bang() {
    let hz = 10.0;
    let dt = 1.0 / hz;
    // 2.5 rad ≥ ω²/α = 0.5 rad: bang-coast-bang; 0.3 rad: bang-bang.
    for theta in [2.5f32, 0.3] {
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        let from = quat_exp(&Vec3::new(0.2, 0.1, -0.4));
        let to = quat_exp(&(axis * theta)) * from;
        let mut g = Guidance::new(&inertial(&from), &manoeuvre(&[]));
        let f = fly(&mut g, &inertial(&to), hz, 120.0, false);
        // The slew starts at the first step after the command (no cones: planned there).
        let start = f.steps[0].0;
        let (total, peak, _) = closed_form(theta as f64, 0.0);
        let mut peak_seen = 0.0f64;
        let mut end = None;
        for &(t, q, rate, ph) in &f.steps {
            let (_, _, expect) = closed_form(theta as f64, t - start);
            let got = between(&q, &from);
            assert!((got - expect).abs() < 1e-4, "θ {theta}: t {t}: angle {got} vs {expect}");
            peak_seen = peak_seen.max(rate);
            if end.is_none() && ph == phase::IDLE && t > start {
                end = Some(t - start);
            }
        }
        let end = end.expect("the slew ended");
        println!(
            "θ {theta} rad: closed form T {total:.4} s, peak {peak:.6} rad/s; measured end {end:.4} s, peak {peak_seen:.6}"
        );
        assert!(end >= total - 1e-3 && end < total + dt + 1e-3, "θ {theta}: ended {end} s, closed form {total} s");
        assert!(peak_seen <= peak + 1e-5, "θ {theta}: peak {peak_seen} > {peak}");
        assert!(peak_seen >= peak - ACCEL as f64 * dt, "θ {theta}: peak {peak_seen} ≪ {peak}");
        assert_eq!(g.manoeuvre().counters.planned, 1);
    }
}

/// A star tracker along body +y with a 30° Sun cone; the command is a 170° eigen-axis
/// turn whose direct path sweeps the tracker straight through the Sun (shown by sampling
/// the direct path here). Flown at 50 Hz, every commanded attitude keeps the tracker
/// outside the cone: the smallest angle from the tracker to the Sun, computed here in f64
/// from the commands, is above 30°; between two samples the tracker moves at most
/// ω·dt = 0.001 rad, which the check leaves as slack. The slew arrives (1e-4 rad).
#[test]
fn a_direct_path_through_the_sun_cone_is_replaced_by_one_that_stays_out() {
    let half = 30f64.to_radians();
    let tracker =
        KeepOutCone { boresight_body: [0.0, 1.0, 0.0], sun_half_angle_rad: half as f32, earth_margin_rad: -1.0 };
    let sun = sun_direction_eci(&nav(0.0).time).0;
    let e = sun.cross(&Vec3::z()).normalize();
    // q_a: body +y onto the Sun; start 85° before it along the turn about e.
    let y = Vec3::y();
    let q_a = quat_exp(&(y.cross(&sun).normalize() * y.dot(&sun).clamp(-1.0, 1.0).acos()));
    let from = quat_exp(&(e * (-85f32).to_radians())) * q_a;
    let to = quat_exp(&(e * 170f32.to_radians())) * from;
    let sun64 = [sun.x as f64, sun.y as f64, sun.z as f64];
    // The direct eigen-axis path, sampled: it crosses the cone.
    let direct_min = (0..=2000)
        .map(|k| {
            let q = quat_exp(&(e * (170f32.to_radians() * k as f32 / 2000.0))) * from;
            angle(rotate(&q, [0.0, 1.0, 0.0]), sun64)
        })
        .fold(f64::INFINITY, f64::min);
    assert!(direct_min < 0.01, "the direct path must cross the Sun: closest {direct_min} rad");
    let mut g = Guidance::new(&inertial(&from), &manoeuvre(&[tracker]));
    let f = fly(&mut g, &inertial(&to), 50.0, 400.0, true);
    let closest =
        f.steps.iter().map(|(_, q, _, _)| angle(rotate(q, [0.0, 1.0, 0.0]), sun64)).fold(f64::INFINITY, f64::min);
    let margin = closest - half;
    let c = g.manoeuvre().counters;
    println!(
        "closest tracker–Sun angle {:.3}°, margin {:.3}°, counters {c:?}",
        closest.to_degrees(),
        margin.to_degrees()
    );
    assert!(margin > 0.001, "the tracker entered the Sun cone: margin {margin} rad");
    assert_eq!((c.planned, c.with_waypoint, c.refused_total()), (1, 1, 0));
    let last = f.steps.last().unwrap().1;
    assert!(between(&last, &to) < 1e-4, "did not arrive: {} rad off", between(&last, &to));
}

/// Refusals with their reason: a target that puts the tracker on the Sun (`TargetInCone`,
/// the start held exactly), and cones without navigation (`NoGeometry`, held, then planned
/// and flown once navigation returns).
#[test]
fn refused_targets_are_counted_with_their_reason_and_the_attitude_held() {
    let tracker = KeepOutCone { boresight_body: [0.0, 1.0, 0.0], sun_half_angle_rad: 0.5, earth_margin_rad: -1.0 };
    let sun = sun_direction_eci(&nav(0.0).time).0;
    let y = Vec3::y();
    let onto_sun = quat_exp(&(y.cross(&sun).normalize() * y.dot(&sun).clamp(-1.0, 1.0).acos()));
    let e = sun.cross(&Vec3::z()).normalize();
    let from = quat_exp(&(e * 1.2)) * onto_sun;
    let mut g = Guidance::new(&inertial(&from), &manoeuvre(&[tracker]));
    let f = fly(&mut g, &inertial(&onto_sun), 10.0, 20.0, true);
    assert!(f.steps.iter().all(|(_, q, _, _)| between(q, &from) < 1e-6), "not held at the start");
    assert!(f.steps.iter().skip(1).all(|s| s.3 == phase::REFUSED));
    let m = g.manoeuvre();
    assert_eq!((m.counters.refused, m.last_refusal, m.counters.planned), ([1, 0, 0], Some(Refusal::TargetInCone), 0));
    assert_eq!(g.telemetry().slew_refusal, 1);

    // No navigation: the cones cannot be evaluated.
    let to = quat_exp(&(e * 0.3)) * from;
    let mut g = Guidance::new(&inertial(&from), &manoeuvre(&[tracker]));
    let f = fly(&mut g, &inertial(&to), 10.0, 5.0, false);
    assert!(f.steps.iter().all(|(_, q, _, _)| between(q, &from) < 1e-6));
    assert_eq!(g.manoeuvre().counters.refused, [0, 0, 1]);
    assert_eq!(g.manoeuvre().last_refusal, Some(Refusal::NoGeometry));
    // Navigation back: planned, flown, arrived.
    let m0 = measurements();
    for k in 0..400u64 {
        let t = 10.0 + k as f64 * 0.1;
        g.guide(&m0, Some(&nav(t)), (t * 1e6) as u64);
    }
    let last = g.last().unwrap().q;
    assert!(between(&last, &to) < 1e-4, "{}", between(&last, &to));
    assert_eq!(g.manoeuvre().counters.planned, 1);
}

/// Bounded work: while a waypoint is searched, no step evaluates more than
/// `CANDIDATES_PER_STEP` candidates, and the search ends within ⌈CANDIDATES /
/// CANDIDATES_PER_STEP⌉ + 1 steps of the command.
#[test]
fn the_waypoint_search_is_spread_over_steps_with_bounded_work() {
    let tracker = KeepOutCone { boresight_body: [0.0, 1.0, 0.0], sun_half_angle_rad: 0.5, earth_margin_rad: -1.0 };
    let sun = sun_direction_eci(&nav(0.0).time).0;
    let e = sun.cross(&Vec3::z()).normalize();
    let y = Vec3::y();
    let q_a = quat_exp(&(y.cross(&sun).normalize() * y.dot(&sun).clamp(-1.0, 1.0).acos()));
    let from = quat_exp(&(e * -1.4)) * q_a;
    let to = quat_exp(&(e * 2.8)) * from;
    let mut g = Guidance::new(&inertial(&from), &manoeuvre(&[tracker]));
    let m = measurements();
    for k in 0..10u64 {
        g.guide(&m, Some(&nav(k as f64 * 0.1)), k * 100_000);
    }
    g.set_params(&inertial(&to));
    let mut planning_steps = 0;
    for k in 10..200u64 {
        g.guide(&m, Some(&nav(k as f64 * 0.1)), k * 100_000);
        let man = g.manoeuvre();
        assert!(usize::from(man.last_candidates) <= CANDIDATES_PER_STEP, "{} candidates", man.last_candidates);
        if man.last_phase == phase::PLANNING {
            planning_steps += 1;
        }
    }
    let bound = CANDIDATES.div_ceil(CANDIDATES_PER_STEP) + 1;
    println!("planning took {planning_steps} steps (bound {bound})");
    assert!(planning_steps >= 1 && planning_steps <= bound, "{planning_steps} > {bound}");
    assert_eq!(g.manoeuvre().counters.with_waypoint, 1);
}

/// Leaving the near-parallel fallback: nadir primary (body +z), a celestial secondary in
/// the orbit plane (body +x toward RA 90°, Dec 0); nadir sweeps through it, the fallback
/// holds the roll, and on exit the ideal frame has turned ≈ 180° about nadir. Without
/// planned slews the command steps by more than 2 rad in one step; with them no step
/// turns the command by more than ω·dt + orbit-rate·dt (+1e-4 rad), and a slew is planned.
#[test]
fn leaving_the_parallel_fallback_is_a_planned_turn_not_a_step() {
    let pointing = GuidanceParams {
        pointing: Pointing::Align {
            primary_body: [0.0, 0.0, 1.0],
            primary: Direction::Nadir,
            secondary_body: [1.0, 0.0, 0.0],
            secondary: Direction::Celestial { ra_rad: std::f32::consts::FRAC_PI_2, dec_rad: 0.0 },
        },
        parallel_threshold_rad: 0.1,
        ..GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial)
    };
    let m = measurements();
    let n = (MU / R_ORBIT_M.powi(3)).sqrt();
    // Nadir is at RA 180° + n t: anti-parallel to the secondary at n t = π/2, parallel at
    // 3π/2. Fly from 0.5 rad after the first to 0.5 rad after the second (threshold 0.1).
    let (t_start, t_end) = ((std::f64::consts::FRAC_PI_2 + 0.5) / n, (1.5 * std::f64::consts::PI + 0.5) / n);
    let largest_step = |manoeuvres: &ManoeuvreParams| {
        let mut g = Guidance::new(&pointing, manoeuvres);
        let (mut prev, mut worst, mut k) = (None::<Quat>, 0.0f64, 0u64);
        while t_start + k as f64 * 0.5 < t_end {
            let t = t_start + k as f64 * 0.5;
            let q = g.guide(&m, Some(&nav(t)), (t * 1e6) as u64).q;
            if let Some(p) = prev {
                worst = worst.max(between(&q, &p));
            }
            prev = Some(q);
            k += 1;
        }
        (worst, g.report().parallel_events, g.manoeuvre().counters)
    };
    let (step_off, events_off, _) = largest_step(&ManoeuvreParams::OFF);
    let (step_on, events_on, c) = largest_step(&manoeuvre(&[]));
    println!("largest step: {step_off:.3} rad without slews, {step_on:.5} rad with ({c:?})");
    assert_eq!((events_off, events_on), (1, 1));
    assert!(step_off > 2.0, "the fallback's exit should step the command: {step_off}");
    assert!(step_on < RATE as f64 * 0.5 + n * 0.5 + 1e-4, "{step_on}");
    assert!(c.planned >= 1);
}
