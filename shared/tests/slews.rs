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

/// SplitMix64: a seeded generator for the Monte Carlo (no dependency; same seed, same draws).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A uniform random unit quaternion (Shoemake).
    fn quat(&mut self) -> Quat {
        let (u1, u2, u3) = (self.next(), self.next() * std::f64::consts::TAU, self.next() * std::f64::consts::TAU);
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        Quat::new((b * u3.cos()) as f32, (a * u2.sin()) as f32, (a * u2.cos()) as f32, (b * u3.sin()) as f32)
    }
    fn unit(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next() - 1.0;
        let phi = self.next() * std::f64::consts::TAU;
        let s = (1.0 - z * z).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    }
}

/// A circular 500 km orbit about the unit normal `n`, phase `u0` rad at t = 0, on epoch day
/// `day` (the Sun's place), `t_s` later.
fn orbit_nav(n: [f64; 3], u0: f64, day: i32, t_s: f64) -> NavSolution {
    let r = 6_878_137.0;
    let w = (MU / (r * r * r)).sqrt();
    // An in-plane basis: p ⊥ n, q = n × p.
    let a = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let p = cross(n, a);
    let pn = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let p = p.map(|x| x / pn);
    let q = cross(n, p);
    let (s, c) = (u0 + w * t_s).sin_cos();
    let pos: [f64; 3] = std::array::from_fn(|i| r * (c * p[i] + s * q[i]));
    let vel: [f64; 3] = std::array::from_fn(|i| r * w * (-s * p[i] + c * q[i]));
    NavSolution {
        r_m: Vec3::new(pos[0] as f32, pos[1] as f32, pos[2] as f32),
        v_m_s: Vec3::new(vel[0] as f32, vel[1] as f32, vel[2] as f32),
        time: J2000Time::new(day, 0.0).unwrap().add_seconds(t_s as f32).unwrap(),
        q_lvlh: Quat::identity(),
        lvlh_rate_rad_s: Vec3::zeros(),
        fix_age_s: 0.0,
    }
}

/// Truth margins of `q` (f64): the smallest angle to the edge of every cone, rad (Sun:
/// angle to the Sun − half-angle; Earth: angle to nadir − asin(R_E / r) − margin).
fn truth_margin(q: &Quat, cones: &[KeepOutCone], sun: [f64; 3], nav: &NavSolution) -> f64 {
    let r = [nav.r_m.x as f64, nav.r_m.y as f64, nav.r_m.z as f64];
    let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let nadir = r.map(|x| -x / rn);
    let earth = (6_378_137.0 / rn).asin();
    let mut worst = f64::INFINITY;
    for c in cones {
        let b = rotate(q, c.boresight_body.map(f64::from));
        if c.sun_half_angle_rad > 0.0 {
            worst = worst.min(angle(b, sun) - c.sun_half_angle_rad as f64);
        }
        if c.earth_margin_rad >= 0.0 {
            worst = worst.min(angle(b, nadir) - earth - c.earth_margin_rad as f64);
        }
    }
    worst
}

/// Normalised linear interpolation of two nearby attitudes, f64 (sub-samples between
/// steps at most ω·dt = 0.25° apart).
fn nlerp(a: &Quat, b: &Quat, s: f64) -> Quat {
    let sign = if a.coords.dot(&b.coords) < 0.0 { -1.0 } else { 1.0 };
    let c: [f64; 4] = std::array::from_fn(|i| (1.0 - s) * a.coords[i] as f64 + s * sign * b.coords[i] as f64);
    let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]).sqrt();
    Quat::new((c[3] / n) as f32, (c[0] / n) as f32, (c[1] / n) as f32, (c[2] / n) as f32)
}

/// Issue 41's Monte Carlo: 1,000 random slews with the EO cubesat's slew limits and cones
/// (tests/keepout_columns.rs: 1 deg/s, 0.05 deg/s², planning margin 1°; a tracker on −y
/// with a 30° Sun cone, a radiator on +y 5° off the Earth's disc), flown through
/// `Guidance` at the scenario's 4 Hz. Random per run: the start attitude (redrawn until
/// it is outside every cone: the spacecraft rests at a legal attitude), the target
/// attitude, the orbit plane and position (500 km circular) and the day of the year (the
/// Sun's place; uniform attitudes and orbit make its direction relative to them uniform).
/// Truth, independent of the planner's closed form: every commanded attitude and 8
/// interpolated ones between steps, at the step's own Sun and orbit, checked in f64; each
/// run not refused must have a positive smallest margin and arrive (1e-3 rad). Refusals
/// are counted by reason; the time penalty against the unconstrained slew (closed form of
/// the direct eigen-axis angle, planned at the first step) is reported as a distribution.
#[test]
fn monte_carlo_of_random_slews_keeps_every_cone_or_refuses() {
    let cones = [
        KeepOutCone {
            boresight_body: [0.0, -1.0, 0.0],
            sun_half_angle_rad: 30f32.to_radians(),
            earth_margin_rad: -1.0,
        },
        KeepOutCone { boresight_body: [0.0, 1.0, 0.0], sun_half_angle_rad: 0.0, earth_margin_rad: 5f32.to_radians() },
    ];
    let mut params = manoeuvre(&cones);
    params.max_rate_rad_s = 1f32.to_radians();
    params.max_accel_rad_s2 = 0.05f32.to_radians();
    params.planning_margin_rad = 1f32.to_radians();
    params.validate().unwrap();
    let (w, a) = (params.max_rate_rad_s as f64, params.max_accel_rad_s2 as f64);
    let direct_time = |theta: f64| if theta >= w * w / a { theta / w + w / a } else { 2.0 * (theta / a).sqrt() };
    let (hz, runs) = (4.0f64, 1000usize);
    let dt = 1.0 / hz;
    let m = measurements();
    let mut rng = Rng(41);
    let (mut refused, mut penalties, mut worst_margin, mut via_waypoint) = ([0usize; 3], Vec::new(), f64::INFINITY, 0);
    for run in 0..runs {
        let (n, u0, day) = (rng.unit(), rng.next() * std::f64::consts::TAU, EPOCH_DAYS + (rng.next() * 365.0) as i32);
        let nav_at = |t: f64| orbit_nav(n, u0, day, t);
        let sun_at = |t: f64| {
            let s = sun_direction_eci(&nav_at(t).time).0;
            [s.x as f64, s.y as f64, s.z as f64]
        };
        let from = loop {
            let q = rng.quat();
            if truth_margin(&q, &cones, sun_at(0.0), &nav_at(0.0)) > 0.05 {
                break q;
            }
        };
        let to = rng.quat();
        let mut g = Guidance::new(&inertial(&from), &params);
        let us = |t: f64| (t * 1e6).round() as u64;
        for k in 0..4 {
            g.guide(&m, Some(&nav_at(k as f64 * dt)), us(k as f64 * dt));
        }
        g.set_params(&inertial(&to));
        let (mut prev, mut end, mut min_margin, mut moved) = (from, None, f64::INFINITY, false);
        let mut k = 4u64;
        while end.is_none() && (k as f64) * dt < 1500.0 {
            let t = k as f64 * dt;
            let nav = nav_at(t);
            let q = g.guide(&m, Some(&nav), us(t)).q;
            let sun = sun_at(t);
            for j in 1..=8 {
                let qs = nlerp(&prev, &q, j as f64 / 8.0);
                min_margin = min_margin.min(truth_margin(&qs, &cones, sun, &nav));
            }
            prev = q;
            let man = g.manoeuvre();
            // The step that plans reports IDLE before the profile starts: the slew has
            // ended at the first IDLE after a profile phase.
            moved |= (phase::ACCELERATING..=phase::DECELERATING).contains(&man.last_phase);
            if moved && man.last_phase == phase::IDLE {
                end = Some(t - 4.0 * dt);
            }
            if man.last_phase == phase::REFUSED {
                break;
            }
            k += 1;
        }
        let man = g.manoeuvre();
        if let Some(r) = man.last_refusal {
            refused[usize::from(r.code()) - 1] += 1;
            assert!(min_margin > 0.0, "run {run}: refused {r:?}, but the held command is inside a cone ({min_margin})");
            continue;
        }
        let end = end.unwrap_or_else(|| panic!("run {run}: neither arrived nor refused in 1500 s"));
        assert!(min_margin > 0.0, "run {run}: a cone was entered: margin {:.4}°", min_margin.to_degrees());
        assert!(between(&prev, &to) < 1e-3, "run {run}: arrived {} rad off", between(&prev, &to));
        worst_margin = worst_margin.min(min_margin);
        via_waypoint += usize::from(man.counters.with_waypoint);
        penalties.push(end - direct_time(between(&from, &to)));
    }
    penalties.sort_by(f64::total_cmp);
    let pct = |p: f64| penalties[((penalties.len() - 1) as f64 * p).round() as usize];
    println!(
        "{runs} slews: {} flown ({via_waypoint} via a waypoint), refused {refused:?} (target in a cone, no path, \
         no geometry); smallest truth margin {:.3}°; time penalty vs the unconstrained slew: median {:.2} s, p95 \
         {:.2} s, max {:.2} s",
        penalties.len(),
        worst_margin.to_degrees(),
        pct(0.5),
        pct(0.95),
        pct(1.0)
    );
    assert_eq!(penalties.len() + refused.iter().sum::<usize>(), runs);
    assert_eq!(refused[2], 0, "navigation is always given");
    // About 4 in 10 targets are inside a cone (the radiator's Earth cone is 75° wide at
    // 500 km with the planning margin): at least a third must fly, some via a waypoint.
    assert!(penalties.len() >= runs / 3 && via_waypoint > 0, "too few flown or none round a cone");
}
