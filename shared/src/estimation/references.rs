//! Reference vectors of attitude determination at the rate they change: the Sun's and the
//! geomagnetic field's directions in the inertial frame, for the MEKF's vector updates and
//! TRIAD ([`super::determination`]).
//!
//! Evaluating the degree-12 field every control step (≈ 31,600 instructions on the
//! Cortex-M4F, more than half of the whole flight step) is wasted: seen from the spacecraft
//! the inertial field direction turns at about twice the orbital rate (≈ 0.1°/s in LEO) and
//! smoothly, the Sun's by 1°/day. So:
//!
//! - **Field**: evaluated at *nodes* [`FIELD_NODE_INTERVAL_S`] apart on the flight clock
//!   (or `FIELD_STEPS + 2` control periods if that is longer), at the position and time
//!   the navigation predicts for the node ([`Navigation::predict`]: two-body from the
//!   last fix, as the every-step path would have propagated it). Each evaluation is spread
//!   over the steps before its node is needed: one step sets it up (prediction, ECEF
//!   position), then [`FIELD_TERMS_PER_STEP`] terms `(n, m)` per step
//!   ([`FieldEvaluation`]; 10 steps at degree 12), the last of them rotating the result to
//!   the inertial frame. Between two nodes the direction is interpolated linearly and
//!   normalised. The interpolation error is the chord's departure from the arc,
//!   ≈ |d²b̂/dt²| T²/8: measured over a day of a 617 km sun-synchronous orbit at 2 Hz,
//!   at most 0.0011° (shared/tests/reference_rates.rs), three orders of magnitude below
//!   the magnetometer σ the filter is configured with (1° in the shipped scenarios).
//! - **Sun**: the ephemeris is re-evaluated when the navigation time is
//!   [`SUN_INTERVAL_S`] or more from the last evaluation, and held in between (the Sun
//!   moves 2.0e-7 rad/s: ≤ 1.2e-5 rad, 0.0007°).
//! - **Position**: unchanged — the navigation's solution of the step (a fresh fix, or the
//!   last one propagated over its age) is what the eclipse test and LVLH use.
//!
//! What this costs in latency: a field direction exists only between two evaluated nodes,
//! from about `2 (FIELD_STEPS + 1)` steps after the first navigation solution (11 s at
//! 2 Hz with the default degree): until then the filter has no field reference (no
//! magnetometer update, no TRIAD initialisation). The same restart happens when the nodes
//! no longer agree with the navigation — a fix that moved the orbit by more than
//! [`FIELD_JUMP_TOLERANCE_M`] beyond the interpolation's own chord error, a time jump of
//! more than [`FIELD_TIME_TOLERANCE_S`], the flight clock going backwards — and when the
//! navigation is lost or the field not wanted (attitude from the sensor).
//!
//! No heap, no panics; every step does at most one slice of bounded work.

use super::navigation::{NavSolution, Navigation};
use crate::math::{Vec3, f32m};
use crate::models::magnetic::{FieldEvaluation, field_terms};
use crate::models::orbit::MU_EARTH_M3_S2;
use crate::models::sun::sun_direction_eci;
use crate::models::time::{J2000Time, ecef_to_eci, eci_to_ecef};

/// Flight-clock interval between two field nodes, s (the least: see the module doc).
pub const FIELD_NODE_INTERVAL_S: f32 = 10.0;
/// Field terms `(n, m)` evaluated per control step (about 350 instructions each on the
/// Cortex-M4F; a degree-12 evaluation has 90).
pub const FIELD_TERMS_PER_STEP: usize = 9;
/// A node bracket whose interpolated position is further than this (plus the chord's
/// own error) from the navigation's is stale (a fix moved the orbit): start over, m.
pub const FIELD_JUMP_TOLERANCE_M: f32 = 1000.0;
/// Largest disagreement between the navigation's time and the node bracket's, s.
pub const FIELD_TIME_TOLERANCE_S: f32 = 1.0;
/// Navigation time between two evaluations of the Sun's ephemeris, s.
pub const SUN_INTERVAL_S: f32 = 60.0;

/// The Sun's direction (ECI unit vector) and the time it was evaluated at.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SunSample {
    time: J2000Time,
    dir_eci: Vec3,
}

/// A field node: the inertial field direction at a flight-clock time, with the position
/// and time it was evaluated at (to check that the navigation still agrees).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    time_us: u64,
    time: J2000Time,
    r_m: Vec3,
    field_eci: Vec3,
    /// The field's magnitude there, T (the magnetometer monitor's reference).
    field_t: f32,
}

/// A node being evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pending {
    time_us: u64,
    time: J2000Time,
    r_m: Vec3,
    eval: FieldEvaluation,
}

/// The reference models' state ([`References::sun_eci`], [`References::field_eci`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct References {
    sun: Option<SunSample>,
    /// The bracket: `a` before `b` on the flight clock, one node interval apart.
    a: Option<Node>,
    b: Option<Node>,
    /// An evaluated node waiting for the bracket to move on.
    ready: Option<Node>,
    pending: Option<Pending>,
    last_time_us: Option<u64>,
    /// The last step interval, µs (0: not known yet).
    step_us: u64,
}

impl Default for References {
    fn default() -> Self {
        Self::new()
    }
}

/// Seconds from `from` to `to` (f32; days apart times 86,400 plus the seconds).
fn seconds_between(from: &J2000Time, to: &J2000Time) -> f32 {
    #[allow(clippy::cast_precision_loss)] // whole days: exact to 2^24
    let days = to.days.saturating_sub(from.days) as f32;
    days * 86_400.0 + (to.seconds - from.seconds)
}

/// µs → s.
#[allow(clippy::cast_precision_loss)] // a node interval: far below 2^24 µs of rounding
fn seconds(us: u64) -> f32 {
    us as f32 * 1.0e-6
}

impl References {
    pub const fn new() -> Self {
        Self { sun: None, a: None, b: None, ready: None, pending: None, last_time_us: None, step_us: 0 }
    }

    /// The Sun's direction (ECI, unit) at the navigation time `time`: the held evaluation
    /// while it is within [`SUN_INTERVAL_S`] of `time`, else a new one.
    pub fn sun_eci(&mut self, time: &J2000Time) -> Vec3 {
        match self.sun {
            Some(s) if libm::fabsf(seconds_between(&s.time, time)) < SUN_INTERVAL_S => s.dir_eci,
            _ => {
                let dir_eci = sun_direction_eci(time).0;
                self.sun = Some(SunSample { time: *time, dir_eci });
                dir_eci
            }
        }
    }

    /// Forget the field nodes and any evaluation in progress (the field is not wanted, or
    /// the navigation is lost).
    pub fn clear_field(&mut self) {
        (self.a, self.b, self.ready, self.pending) = (None, None, None, None);
    }

    /// The field direction (ECI, unit) at the step time `time_us`, interpolated between
    /// the nodes that bracket it (`None` before two nodes exist); does this step's slice of
    /// the evaluation of the next node, predicted by `nav`, to degree `degree`. `now` is
    /// the navigation's solution at `time_us`.
    pub fn field_eci(&mut self, time_us: u64, nav: &Navigation, now: &NavSolution, degree: usize) -> Option<Vec3> {
        match self.last_time_us.map(|t| time_us.checked_sub(t)) {
            Some(Some(dt)) => self.step_us = dt,
            // The clock went backwards: nothing evaluated so far is on this clock.
            Some(None) => {
                self.clear_field();
                self.step_us = 0;
            }
            None => {}
        }
        self.last_time_us = Some(time_us);
        if !self.agrees(time_us, now) {
            self.clear_field();
        }
        // The first step knows no step interval: it plans nothing.
        if self.step_us > 0 {
            self.work(time_us, nav, degree);
        }
        self.place(time_us);
        self.interpolate(time_us)
    }

    /// Steps of one evaluation after its set-up step.
    fn evaluation_steps(degree: usize) -> u64 {
        let steps = field_terms(degree).div_ceil(FIELD_TERMS_PER_STEP);
        u64::try_from(steps).unwrap_or(u64::MAX)
    }

    /// This step's slice: set up the next node's evaluation, or advance the one in
    /// progress (finishing it when its last terms are done).
    fn work(&mut self, time_us: u64, nav: &Navigation, degree: usize) {
        if let Some(mut p) = self.pending {
            if p.eval.advance(FIELD_TERMS_PER_STEP) {
                self.pending = None;
                let field = p.eval.field_ecef_t().and_then(Result::ok);
                self.ready =
                    field.and_then(|b| unit(&ecef_to_eci(&p.time, &b)).map(|d| (d, b))).map(|(field_eci, b)| Node {
                        time_us: p.time_us,
                        time: p.time,
                        r_m: p.r_m,
                        field_eci,
                        field_t: f32m::sqrt(b.norm_squared()),
                    });
            } else {
                self.pending = Some(p);
            }
            return;
        }
        if self.ready.is_some() {
            return;
        }
        // An evaluation set up now is done `lead` later. A node must be done by the time
        // of the node before it (when the bracket moves on to need it); the first node of a
        // fresh start is placed so far ahead that the second is done by then too. Nodes
        // are at least `steps + 3` step intervals apart, so that in the steady state each
        // evaluation, started a step after the bracket moved, ends with time to spare.
        let steps = Self::evaluation_steps(degree);
        let lead_us = self.step_us.saturating_mul(steps.saturating_add(1));
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // 1e7 µs
        let nominal_us = (FIELD_NODE_INTERVAL_S * 1.0e6) as u64;
        let interval_us = nominal_us.max(self.step_us.saturating_mul(steps.saturating_add(3)));
        let ready_by = time_us.saturating_add(lead_us);
        let target_us = match self.b.or(self.a) {
            Some(last) if last.time_us >= ready_by => last.time_us.saturating_add(interval_us),
            // No node, or the next one could not be ready in time: start over.
            _ => {
                self.clear_field();
                ready_by.saturating_add(lead_us).saturating_add(self.step_us)
            }
        };
        self.pending = nav.predict(target_us).and_then(|(r_m, time)| {
            let r_ecef = eci_to_ecef(&time, &r_m);
            let eval = FieldEvaluation::start(&r_ecef, time.decimal_year(), degree).ok()?;
            Some(Pending { time_us: target_us, time, r_m, eval })
        });
    }

    /// Move an evaluated node into the bracket: as its first or second node, or in place
    /// of `b` once the step has reached `b`. A bracket the step has passed with nothing
    /// ready keeps `b` as the start of the next one.
    fn place(&mut self, time_us: u64) {
        if let Some(r) = self.ready {
            match (self.a, self.b) {
                (None, _) => self.a = Some(r),
                (Some(a), None) if r.time_us > a.time_us => self.b = Some(r),
                (Some(_), Some(b)) if time_us >= b.time_us && r.time_us > b.time_us => {
                    (self.a, self.b) = (Some(b), Some(r));
                }
                // Not needed yet: keep it.
                (Some(_), Some(b)) if time_us < b.time_us => return,
                // Out of order (not expected: targets follow the last node): start over on it.
                _ => (self.a, self.b) = (Some(r), None),
            }
            self.ready = None;
        }
        if let Some(b) = self.b.filter(|b| time_us > b.time_us) {
            (self.a, self.b) = (Some(b), None);
        }
    }

    /// Where the step falls in the bracket: the fraction from `a` to `b`, if inside.
    fn fraction(&self, time_us: u64) -> Option<(Node, Node, f32)> {
        let (a, b) = (self.a?, self.b?);
        if !(a.time_us <= time_us && time_us <= b.time_us && a.time_us < b.time_us) {
            return None;
        }
        let s = seconds(time_us.saturating_sub(a.time_us)) / seconds(b.time_us.saturating_sub(a.time_us));
        Some((a, b, s))
    }

    /// Whether the bracket (if any) still agrees with the navigation: time within
    /// [`FIELD_TIME_TOLERANCE_S`], position within [`FIELD_JUMP_TOLERANCE_M`] of the chord
    /// plus the chord's own departure from the orbit (gravity × interval² / 8).
    fn agrees(&self, time_us: u64, now: &NavSolution) -> bool {
        let Some((a, b, s)) = self.fraction(time_us) else {
            return true;
        };
        let elapsed = seconds(time_us.saturating_sub(a.time_us));
        if !(libm::fabsf(seconds_between(&a.time, &now.time) - elapsed) <= FIELD_TIME_TOLERANCE_S) {
            return false;
        }
        let span = seconds(b.time_us.saturating_sub(a.time_us));
        let gravity = MU_EARTH_M3_S2 / a.r_m.norm_squared();
        let tolerance = FIELD_JUMP_TOLERANCE_M + gravity * span * span * 0.125;
        let chord = a.r_m + (b.r_m - a.r_m) * s;
        (now.r_m - chord).norm_squared() <= tolerance * tolerance
    }

    /// The field's magnitude at `time_us`, T: the bracket's two nodes interpolated
    /// linearly (`None` outside a bracket). Call after [`Self::field_eci`] of the step.
    /// The magnitude changes by about a factor 2 over half an orbit, smoothly: the chord's
    /// error over a 10 s bracket is ≈ |d²|B|/dt²| T²/8, nanotesla at most.
    pub fn field_magnitude_t(&self, time_us: u64) -> Option<f32> {
        let (a, b, s) = self.fraction(time_us)?;
        Some(a.field_t * (1.0 - s) + b.field_t * s)
    }

    /// The field direction at the step: `a` and `b` interpolated linearly, normalised.
    fn interpolate(&self, time_us: u64) -> Option<Vec3> {
        let (a, b, s) = self.fraction(time_us)?;
        unit(&(a.field_eci * (1.0 - s) + b.field_eci * s))
    }
}

/// A direction, or `None` for a zero or non-finite vector (TRIAD's normalisation, as the
/// every-step evaluation used).
fn unit(v: &Vec3) -> Option<Vec3> {
    super::triad::unit(v).ok()
}
