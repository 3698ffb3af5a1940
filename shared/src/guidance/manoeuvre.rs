//! Planned slews that keep every boresight out of its keep-out cones (docs/guidance.md,
//! "Planned slews and keep-out cones").
//!
//! A change of pointing with [`ManoeuvreParams::enabled`] is flown as rate- and
//! acceleration-limited eigen-axis legs ([`super::profile`], [`super::blend::Shape`]):
//! 1. the direct leg from the command in force `q₀` to the new pointing's command `q₁` is
//!    checked against every cone in closed form ([`super::keepout::arc_min_margin_rad`]),
//!    each cone widened by `planning_margin_rad` and, for the Earth, by the angle the
//!    nadir turns during the leg (orbit rate × duration);
//! 2. if it crosses a cone, [`CANDIDATES`] one-waypoint paths are tried, a fixed set: the
//!    direct path's midpoint turned by 45°, 90° or 135° about each of 26 directions
//!    (the faces, edges and corners of a cube), [`CANDIDATES_PER_STEP`] per control step so
//!    that no step carries the whole search; the fastest safe one (sum of the two legs'
//!    profile durations) is flown, rest to rest at the waypoint;
//! 3. none safe, or `q₁` itself inside a cone: the slew is refused (counted, flagged) and
//!    the command in force is held, at rest, until the target leaves the cones.
//!
//! While planning, the command in force is held at rest. The last leg blends into the live
//! target, so a moving target is met at the end of the slew. Bounded work: a direct check
//! costs `2 × cones` arc evaluations; each candidate twice that.

use super::Guided;
use super::blend::{Blend, Shape, quat_exp, quat_log};
use super::keepout::{arc_min_margin_rad, margin_rad};
use super::profile::{Limits, Profile};
use crate::math::{Quat, Vec3, norm};
use crate::params::{KeepOutCone, ManoeuvreParams};

/// Waypoint candidates tried when the direct leg crosses a cone.
pub const CANDIDATES: usize = 78;
/// Candidates evaluated per control step (bounds the step's cost).
pub const CANDIDATES_PER_STEP: usize = 6;
const TURNS_RAD: [f32; 3] =
    [core::f32::consts::FRAC_PI_4, core::f32::consts::FRAC_PI_2, 3.0 * core::f32::consts::FRAC_PI_4];

/// What the cones are measured against at one step (inertial unit vectors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeEnv {
    /// Towards the Sun, and towards the Earth's centre.
    pub sun: Vec3,
    pub nadir: Vec3,
    /// Angular radius of the Earth's disc, rad, and the orbit rate, rad/s.
    pub earth_radius_rad: f32,
    pub orbit_rate_rad_s: f32,
}

impl ConeEnv {
    /// Half-angle of `cone`'s Earth cone (disc + margin + `extra`), if it has one.
    fn earth_half(&self, cone: &KeepOutCone, extra: f32) -> Option<f32> {
        (cone.earth_margin_rad >= 0.0).then_some(self.earth_radius_rad + cone.earth_margin_rad + extra)
    }

    /// The smallest margin over every cone along the leg from `q0` about the inertial
    /// `axis` by `angle` (0: at `q0` only), each cone widened by `widen` (the Earth's also
    /// by `earth_extra`).
    fn leg_margin(&self, cones: &[KeepOutCone], q0: &Quat, rotation: &Vec3, widen: f32, earth_extra: f32) -> f32 {
        let angle = norm(rotation);
        let mut worst = f32::INFINITY;
        for c in cones {
            let b = Vec3::from(c.boresight_body);
            if c.sun_half_angle_rad > 0.0 {
                worst = worst.min(arc_min_margin_rad(q0, rotation, angle, &b, &self.sun, c.sun_half_angle_rad + widen));
            }
            if let Some(h) = self.earth_half(c, earth_extra) {
                worst = worst.min(arc_min_margin_rad(q0, rotation, angle, &b, &self.nadir, h + widen));
            }
        }
        worst
    }

    /// The smallest margin over every cone along the eigen-axis `rotation` from `q0`,
    /// each cone widened by `widen`.
    pub fn margin_along(&self, cones: &[KeepOutCone], q0: &Quat, rotation: &Vec3, widen: f32) -> f32 {
        self.leg_margin(cones, q0, rotation, widen, 0.0)
    }

    /// The smallest margin of every cone at attitude `q` (no widening).
    pub fn margin_at(&self, cones: &[KeepOutCone], q: &Quat) -> f32 {
        let mut worst = f32::INFINITY;
        for c in cones {
            let b = Vec3::from(c.boresight_body);
            if c.sun_half_angle_rad > 0.0 {
                worst = worst.min(margin_rad(q, &b, &self.sun, c.sun_half_angle_rad));
            }
            if let Some(h) = self.earth_half(c, 0.0) {
                worst = worst.min(margin_rad(q, &b, &self.nadir, h));
            }
        }
        worst
    }
}

/// Why a slew was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// The target attitude itself is inside a cone.
    TargetInCone,
    /// No candidate path stays out of the cones.
    NoPath,
    /// The cones could not be evaluated (no navigation, no Sun) or the plan is degenerate.
    NoGeometry,
}

impl Refusal {
    /// Wire code (telemetry `slew_refusal`; 0: none) and index into
    /// [`ManoeuvreCounters::refused`].
    pub fn code(self) -> u8 {
        match self {
            Self::TargetInCone => 1,
            Self::NoPath => 2,
            Self::NoGeometry => 3,
        }
    }
}

/// Phase of the slew in force (telemetry `slew_phase`).
pub mod phase {
    pub const IDLE: u8 = 0;
    pub const PLANNING: u8 = 1;
    pub const ACCELERATING: u8 = 2;
    pub const COASTING: u8 = 3;
    pub const DECELERATING: u8 = 4;
    /// Refused: the last safe command is held.
    pub const REFUSED: u8 = 5;
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Leg {
    blend: Blend,
    /// A waypoint at rest (`Some`), or the live target.
    waypoint: Option<Quat>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Idle,
    Planning {
        from: Quat,
        target: Quat,
        next: usize,
        best: Option<(f32, Quat)>,
    },
    Executing {
        legs: [Option<Leg>; 2],
        current: usize,
    },
    /// Holding `at` because the slew was refused.
    Refused {
        at: Quat,
        why: Refusal,
    },
}

/// Counters of the planner (saturating).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ManoeuvreCounters {
    pub planned: u16,
    pub with_waypoint: u16,
    /// Refusals by reason: [`Refusal::code`] − 1 (target in a cone, no path, no geometry).
    pub refused: [u16; 3],
}

impl ManoeuvreCounters {
    pub fn refused_total(&self) -> u16 {
        self.refused.iter().fold(0u16, |a, b| a.saturating_add(*b))
    }
}

/// The slew planner and executor of one parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Manoeuvre {
    params: ManoeuvreParams,
    state: State,
    pub counters: ManoeuvreCounters,
    /// The smallest cone margin of the last command, rad (∞ without cones or geometry).
    pub last_margin_rad: f32,
    /// The phase of the last step ([`phase`]), the latest refusal's reason (kept after the
    /// refusal ends), and the waypoint candidates evaluated in the last step (≤
    /// [`CANDIDATES_PER_STEP`]).
    pub last_phase: u8,
    pub last_refusal: Option<Refusal>,
    pub last_candidates: u8,
}

fn at_rest(q: Quat) -> Guided {
    Guided { q, rate_rad_s: Vec3::zeros(), accel_rad_s2: Vec3::zeros() }
}

/// The candidate waypoint `k`: the midpoint `q_mid` turned about direction `k / 3` of the
/// cube's 26 by `TURNS_RAD[k % 3]`.
fn candidate(q_mid: &Quat, k: usize) -> Option<Quat> {
    let d = k / 3;
    // Skip the cube's centre (index 13 of the 27 points).
    let cell = if d >= 13 { d.saturating_add(1) } else { d };
    let coord = |i: usize| (i % 3) as f32 - 1.0;
    let u = Vec3::new(coord(cell), coord(cell / 3), coord(cell / 9));
    let turn = *TURNS_RAD.get(k % 3)?;
    let n = norm(&u);
    (n > 0.0).then(|| quat_exp(&(u * (turn / n))) * q_mid)
}

impl Manoeuvre {
    pub fn new(params: &ManoeuvreParams) -> Self {
        Self {
            params: *params,
            state: State::Idle,
            counters: ManoeuvreCounters::default(),
            last_margin_rad: f32::INFINITY,
            last_phase: phase::IDLE,
            last_refusal: None,
            last_candidates: 0,
        }
    }

    pub fn enabled(&self) -> bool {
        self.params.enabled
    }

    pub fn params(&self) -> ManoeuvreParams {
        self.params
    }

    fn limits(&self) -> Limits {
        Limits { rate_rad_s: self.params.max_rate_rad_s, accel_rad_s2: self.params.max_accel_rad_s2 }
    }

    /// Duration of a rest-to-rest leg through `rotation` (∞ if it cannot be planned).
    fn leg_time_s(&self, rotation: &Vec3) -> f32 {
        Profile::plan(norm(rotation), &self.limits()).map_or(f32::INFINITY, |p| p.duration_s())
    }

    /// A leg that starts `before_s` after planning: its worst margin, the Earth cone
    /// widened by the nadir's turn from planning to the leg's end (the second leg of a
    /// waypoint slew flies after the first: its Earth has moved for both).
    fn leg_margin(&self, env: &ConeEnv, q0: &Quat, rotation: &Vec3, before_s: f32) -> f32 {
        let drift = env.orbit_rate_rad_s * (before_s + self.leg_time_s(rotation));
        env.leg_margin(self.params.active_cones(), q0, rotation, self.params.planning_margin_rad, drift)
    }

    /// A new pointing: plan a slew from `from` (the command in force).
    pub fn begin(&mut self, from: &Guided, target: &Guided) {
        self.state = State::Planning { from: from.q, target: target.q, next: 0, best: None };
    }

    /// True while a slew is planned or flown.
    pub fn busy(&self) -> bool {
        matches!(self.state, State::Planning { .. } | State::Executing { .. })
    }

    pub fn refusal(&self) -> Option<Refusal> {
        match self.state {
            State::Refused { why, .. } => Some(why),
            _ => None,
        }
    }

    /// The command of this step toward the live `target`, or `None` when no slew is in
    /// progress (the caller commands the target itself). `last`: the command in force (what
    /// a refused hold keeps).
    pub fn step(
        &mut self,
        target: &Guided,
        last: Option<&Guided>,
        env: Option<&ConeEnv>,
        now_us: u64,
    ) -> Option<Guided> {
        self.last_candidates = 0;
        self.last_phase = phase::IDLE;
        let out = match self.state {
            State::Idle => self.check_hold(target, last, env),
            State::Planning { from, target: q1, next, best } => Some(self.plan_step(from, q1, next, best, env, now_us)),
            State::Executing { legs, current } => self.execute(legs, current, target, now_us),
            State::Refused { at, .. } => self.retry(at, target, env),
        };
        let cones = self.params.active_cones();
        self.last_margin_rad = match (env, &out) {
            (Some(e), Some(g)) => e.margin_at(cones, &g.q),
            (Some(e), None) => e.margin_at(cones, &target.q),
            (None, _) => f32::INFINITY,
        };
        self.last_phase = match self.state {
            State::Idle => phase::IDLE,
            State::Planning { .. } => phase::PLANNING,
            State::Executing { .. } => self.last_phase,
            State::Refused { .. } => phase::REFUSED,
        };
        out
    }

    /// Holding the target: refuse it when it enters a cone and hold the command in force
    /// (the last one outside), at rest.
    fn check_hold(&mut self, target: &Guided, last: Option<&Guided>, env: Option<&ConeEnv>) -> Option<Guided> {
        let e = env?;
        if self.params.active_cones().is_empty() || e.margin_at(self.params.active_cones(), &target.q) >= 0.0 {
            return None;
        }
        let at = last.map_or(target.q, |g| g.q);
        self.refuse(at, Refusal::TargetInCone);
        Some(at_rest(at))
    }

    fn refuse(&mut self, at: Quat, why: Refusal) {
        let i = usize::from(why.code().saturating_sub(1));
        if let Some(c) = self.counters.refused.get_mut(i) {
            *c = c.saturating_add(1);
        }
        self.last_refusal = Some(why);
        self.state = State::Refused { at, why };
    }

    /// Refused: hold until the target is clear of the cones by the planning margin, then
    /// plan a slew to it.
    fn retry(&mut self, at: Quat, target: &Guided, env: Option<&ConeEnv>) -> Option<Guided> {
        let clear = env.is_some_and(|e| {
            let m = e.leg_margin(
                self.params.active_cones(),
                &target.q,
                &Vec3::zeros(),
                self.params.planning_margin_rad,
                0.0,
            );
            m >= 0.0
        });
        if clear {
            self.begin(&at_rest(at), target);
        }
        Some(at_rest(at))
    }

    /// One planning step: the direct leg first, then [`CANDIDATES_PER_STEP`] waypoints.
    fn plan_step(
        &mut self,
        from: Quat,
        q1: Quat,
        next: usize,
        best: Option<(f32, Quat)>,
        env: Option<&ConeEnv>,
        now_us: u64,
    ) -> Guided {
        let hold = at_rest(from);
        let Some(e) = env.filter(|_| !self.params.active_cones().is_empty()).copied() else {
            if env.is_none() && !self.params.active_cones().is_empty() {
                // Cones but no geometry: refused (counted); held until it returns.
                self.refuse(from, Refusal::NoGeometry);
                return hold;
            }
            self.fly(from, None, now_us);
            return hold;
        };
        let direct = quat_log(&(q1 * from.conjugate()));
        if next == 0 {
            if e.margin_at(self.params.active_cones(), &q1) < 0.0 {
                self.refuse(from, Refusal::TargetInCone);
                return hold;
            }
            if self.leg_margin(&e, &from, &direct, 0.0) >= 0.0 {
                self.fly(from, None, now_us);
                return hold;
            }
        }
        let q_mid = quat_exp(&(direct * 0.5)) * from;
        let mut best = best;
        let end = next.saturating_add(CANDIDATES_PER_STEP).min(CANDIDATES);
        for k in next..end {
            self.last_candidates = self.last_candidates.saturating_add(1);
            let Some(qm) = candidate(&q_mid, k) else { continue };
            let (leg1, leg2) = (quat_log(&(qm * from.conjugate())), quat_log(&(q1 * qm.conjugate())));
            let time1 = self.leg_time_s(&leg1);
            let time = time1 + self.leg_time_s(&leg2);
            if best.is_some_and(|(t, _)| t <= time) {
                continue;
            }
            if self.leg_margin(&e, &from, &leg1, 0.0) >= 0.0 && self.leg_margin(&e, &qm, &leg2, time1) >= 0.0 {
                best = Some((time, qm));
            }
        }
        match (end >= CANDIDATES, best) {
            (false, _) => self.state = State::Planning { from, target: q1, next: end, best },
            (true, Some((_, qm))) => self.fly(from, Some(qm), now_us),
            (true, None) => self.refuse(from, Refusal::NoPath),
        }
        hold
    }

    /// Start flying from `from` (at rest), through `waypoint` if any.
    fn fly(&mut self, from: Quat, waypoint: Option<Quat>, now_us: u64) {
        self.counters.planned = self.counters.planned.saturating_add(1);
        if waypoint.is_some() {
            self.counters.with_waypoint = self.counters.with_waypoint.saturating_add(1);
        }
        // The first leg's profile is planned when it starts (its angle is known then).
        let first = Leg { blend: Blend::shaped(at_rest(from), now_us, Shape::Quintic { duration_s: 0.0 }), waypoint };
        self.state = State::Executing { legs: [Some(first), None], current: 0 };
    }

    /// Fly the current leg; at its end start the next (from its end, at rest).
    fn execute(&mut self, legs: [Option<Leg>; 2], current: usize, target: &Guided, now_us: u64) -> Option<Guided> {
        let mut legs = legs;
        let mut current = current;
        // At most three passes: (re)plan a leg's profile, fly it, move to the next.
        for _ in 0..3 {
            let Some(Some(leg)) = legs.get(current).copied() else {
                self.state = State::Idle;
                return None;
            };
            let to = leg.waypoint.map_or(*target, at_rest);
            let from = leg.blend.from();
            let rotation = quat_log(&(to.q * from.q.conjugate()));
            let blend = match leg.blend.shape() {
                Shape::Quintic { duration_s: 0.0 } => {
                    let Some(p) = Profile::plan(norm(&rotation), &self.limits()) else {
                        self.refuse(from.q, Refusal::NoGeometry);
                        return Some(from);
                    };
                    Blend::shaped(from, leg.blend.start_us(), Shape::Profile(p)).keeping_sense(rotation)
                }
                _ => leg.blend,
            };
            if let Some(slot) = legs.get_mut(current) {
                *slot = Some(Leg { blend, waypoint: leg.waypoint });
            }
            if let Some(g) = blend.apply(&to, now_us) {
                self.state = State::Executing { legs, current };
                self.last_phase = profile_phase(&blend, now_us);
                return Some(g);
            }
            // This leg is over: the next starts from where it ended, at rest.
            current = current.saturating_add(1);
            if let (Some(wp), Some(slot)) = (leg.waypoint, legs.get_mut(current)) {
                *slot = Some(Leg {
                    blend: Blend::shaped(at_rest(wp), now_us, Shape::Quintic { duration_s: 0.0 }),
                    waypoint: None,
                });
            }
        }
        self.state = State::Idle;
        None
    }
}

/// The phase of a profile blend at `now_us`.
fn profile_phase(blend: &Blend, now_us: u64) -> u8 {
    let Shape::Profile(p) = blend.shape() else { return phase::ACCELERATING };
    let t = crate::estimation::history::span_s(blend.start_us(), now_us).unwrap_or(0.0);
    if t < p.accel_s {
        phase::ACCELERATING
    } else if t < p.accel_s + p.coast_s {
        phase::COASTING
    } else {
        phase::DECELERATING
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation_angle;

    fn params(cones: &[KeepOutCone]) -> ManoeuvreParams {
        let mut p = ManoeuvreParams {
            enabled: true,
            max_rate_rad_s: 0.05,
            max_accel_rad_s2: 0.005,
            planning_margin_rad: 0.01,
            ..ManoeuvreParams::OFF
        };
        for (slot, c) in p.cones.iter_mut().zip(cones) {
            *slot = *c;
        }
        p.cone_count = cones.len() as u8;
        p
    }

    /// Sun along inertial +x, Earth along −z far away (tiny disc), no orbit motion.
    fn env() -> ConeEnv {
        ConeEnv { sun: Vec3::x(), nadir: -Vec3::z(), earth_radius_rad: 0.01, orbit_rate_rad_s: 0.0 }
    }

    /// Flies the planner toward a fixed target at 10 Hz; returns the commands.
    fn fly(m: &mut Manoeuvre, from: Quat, to: Quat, env: Option<&ConeEnv>, seconds: f32) -> Vec<Guided> {
        m.begin(&at_rest(from), &at_rest(to));
        let steps = (seconds * 10.0) as u64;
        let mut last = at_rest(from);
        (0..steps)
            .map(|k| {
                last = m.step(&at_rest(to), Some(&last), env, k * 100_000).unwrap_or(at_rest(to));
                last
            })
            .collect()
    }

    #[test]
    fn an_unconstrained_slew_is_the_eigen_axis_bang_coast_bang_profile() {
        let mut m = Manoeuvre::new(&params(&[]));
        let to = quat_exp(&Vec3::new(0.0, 0.0, 1.5));
        let out = fly(&mut m, Quat::identity(), to, Some(&env()), 60.0);
        let p = Profile::plan(1.5, &Limits { rate_rad_s: 0.05, accel_rad_s2: 0.005 }).unwrap();
        // Planned at step 0 (no cones: straight away), flown from step 0.
        for (k, g) in out.iter().enumerate() {
            let t = k as f32 * 0.1;
            let angle = rotation_angle(&g.q);
            let expect = p.at(t).angle_rad.min(1.5);
            assert!((angle - expect).abs() < 2e-4, "t {t}: {angle} vs {expect}");
            assert!(norm(&g.rate_rad_s) <= 0.05 + 1e-6);
            assert!(g.rate_rad_s.x.abs() < 1e-6 && g.rate_rad_s.y.abs() < 1e-6, "eigen-axis: {:?}", g.rate_rad_s);
        }
        assert_eq!(m.counters.planned, 1);
        assert!(!m.busy(), "ended after T = {} s", p.duration_s());
    }

    /// A star tracker along body +y, 30° Sun cone; the direct path (yaw by 180° about z)
    /// sweeps it through the Sun at +x: the planner flies around it.
    #[test]
    fn a_slew_across_a_sun_cone_goes_around_it_and_never_enters() {
        let tracker = KeepOutCone {
            boresight_body: [0.0, 1.0, 0.0],
            sun_half_angle_rad: core::f32::consts::FRAC_PI_6,
            earth_margin_rad: -1.0,
        };
        let mut m = Manoeuvre::new(&params(&[tracker]));
        let from = Quat::identity();
        let to = quat_exp(&Vec3::new(0.0, 0.0, -2.4));
        let e = env();
        let direct = quat_log(&(to * from.conjugate()));
        assert!(e.leg_margin(&[tracker], &from, &direct, 0.0, 0.0) < 0.0, "the direct path must cross the cone");
        let out = fly(&mut m, from, to, Some(&e), 400.0);
        assert_eq!((m.counters.planned, m.counters.with_waypoint, m.counters.refused_total()), (1, 1, 0));
        let worst = out.iter().map(|g| e.margin_at(&[tracker], &g.q)).fold(f32::INFINITY, f32::min);
        assert!(worst >= 0.0, "entered the cone: margin {worst} rad");
        let last = out.last().unwrap();
        assert!(rotation_angle(&(last.q * to.conjugate())) < 1e-4, "did not arrive");
    }

    #[test]
    fn a_target_inside_a_cone_is_refused_and_the_attitude_held() {
        let tracker = KeepOutCone {
            boresight_body: [0.0, 1.0, 0.0],
            sun_half_angle_rad: core::f32::consts::FRAC_PI_6,
            earth_margin_rad: -1.0,
        };
        let mut m = Manoeuvre::new(&params(&[tracker]));
        // Yaw −90°: body +y onto inertial +x, the Sun.
        let to = quat_exp(&Vec3::new(0.0, 0.0, -core::f32::consts::FRAC_PI_2));
        let out = fly(&mut m, Quat::identity(), to, Some(&env()), 5.0);
        assert_eq!(m.refusal(), Some(Refusal::TargetInCone));
        assert!(out.iter().all(|g| rotation_angle(&g.q) < 1e-6), "held at the start");
        assert_eq!(m.counters.refused, [1, 0, 0]);
    }
}
