//! The star-tracker monitor of the estimation stage: a frozen output, or an attitude the
//! other vector sensors contradict (a 180° flip about the boresight, a misidentified
//! star field). Issue 42; docs/fdir.md "Star tracker".
//!
//! Judged once per fresh tracker sample (a new time tag), before the filter fuses it:
//! - frozen: all four quaternion components repeat their previous value more than
//!   `max_repeats` times in a row ([`super::repeat`]);
//! - witness: each vector sensor seen this step (the measured Sun outside eclipse, the
//!   measured field) against where the tracker's attitude puts its reference direction.
//!   An exceedance is a witness more than `witness_max_rad` from the tracker while the
//!   filter's own attitude agrees with it (the filter, carried by the gyro, is the third
//!   opinion that says the tracker, not the witness, is wrong), or every witness (two or
//!   more) against the tracker when the filter agrees with the tracker (it re-started
//!   from the bad tracker). A single witness against a filter that sides with the
//!   tracker cannot be isolated and does not count. `k` exceedances in the last `n`
//!   judged samples declare the tracker failed.
//!
//! Recovery (in the estimation stage): a failed tracker is no longer fused; a filter that
//! disagrees with the witnesses is restarted, from TRIAD on the Sun and the field.
//! Bounded: two witnesses, four components; no loop over link data.

use super::repeat::Repeats;
use super::window::Persistence;
use crate::math::{Quat, Vec3, f32m, norm, rotate_ref_to_body};
use crate::params::fdir::TrackerFdirParams;

/// A measured direction (body, unit) and its on-board reference (inertial, unit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Witness {
    pub body: Vec3,
    pub reference: Vec3,
}

/// Whether a turn of 180° about the boresight `boresight` (body, unit) would move the
/// measured direction `body` (unit) by more than twice `witness_max_rad`: the move is
/// `2 min(θ, π − θ)`, θ its angle from the boresight, so this is `min(θ, π − θ) > max`,
/// i.e. `|b · d| < cos(max)` (no arc tangent on the step's path). A witness that fails it
/// cannot tell a flipped tracker from a good one with margin (a field 4.6° off the
/// boresight moves only 9.2°).
pub fn flip_visible(boresight: &Vec3, body: &Vec3, witness_max_rad: f32) -> bool {
    libm::fabsf(boresight.dot(body)) < f32m::cos(witness_max_rad)
}

/// Angle between a measured direction and where attitude `q` puts its reference, rad.
pub fn witness_angle_rad(q: &Quat, w: &Witness) -> f32 {
    let predicted = rotate_ref_to_body(q, &w.reference);
    // atan2 of |a × b| and a · b: accurate at small and large angles alike.
    let cross = norm(&w.body.cross(&predicted));
    f32m::atan2(cross, w.body.dot(&predicted))
}

/// Why the tracker was declared failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrackerFault {
    Frozen,
    /// The vector sensors contradict its attitude.
    Witness,
}

/// The monitor's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackerMonitor {
    repeats: Repeats<4>,
    persistence: Persistence,
    last_time_us: Option<u64>,
    failed: Option<TrackerFault>,
    events: u16,
    /// Largest witness angle of the last judged sample, rad (telemetry).
    last_witness_rad: f32,
    /// The last judged sample had a witness and every witness agreed with it.
    last_corroborated: bool,
}

impl TrackerMonitor {
    pub const fn new() -> Self {
        Self {
            repeats: Repeats::EMPTY,
            persistence: Persistence::new(),
            last_time_us: None,
            failed: None,
            events: 0,
            last_witness_rad: 0.0,
            last_corroborated: false,
        }
    }

    /// Judges one tracker sample (`q_ib` at `time_us`; a repeated time tag is not judged)
    /// against the witnesses seen this step, `filter`: the filter's attitude if it runs.
    /// Returns true when this sample declares the tracker failed.
    pub fn judge(
        &mut self,
        p: &TrackerFdirParams,
        time_us: u64,
        q_ib: &Quat,
        witnesses: &[Option<Witness>; 2],
        filter: Option<&Quat>,
    ) -> bool {
        if self.failed.is_some() || self.last_time_us == Some(time_us) {
            return false;
        }
        self.last_time_us = Some(time_us);
        let c = q_ib.coords;
        let frozen = self.repeats.push(p.max_repeats, &[c.x, c.y, c.z, c.w]) == 0b1111;
        let exceeded = self.witness_exceeded(p, q_ib, witnesses, filter);
        let fault = if frozen {
            Some(TrackerFault::Frozen)
        } else if self.persistence.push(&p.window, exceeded) {
            Some(TrackerFault::Witness)
        } else {
            None
        };
        self.failed = fault;
        self.events = self.events.saturating_add(u16::from(fault.is_some()));
        fault.is_some()
    }

    /// Whether the witnesses contradict the tracker (module doc); records the largest
    /// witness angle. A non-finite angle (a NaN quaternion) counts as a contradiction.
    fn witness_exceeded(
        &mut self,
        p: &TrackerFdirParams,
        q_ib: &Quat,
        witnesses: &[Option<Witness>; 2],
        filter: Option<&Quat>,
    ) -> bool {
        let max = p.witness_max_rad;
        let (mut seen, mut against, mut isolated, mut largest) = (0u8, 0u8, false, 0.0f32);
        for w in witnesses.iter().flatten() {
            let a = witness_angle_rad(q_ib, w);
            let off = !(a <= max);
            // NaN stays NaN in the telemetry (`max` would drop it).
            largest = if a.is_nan() || largest.is_nan() { f32::NAN } else { largest.max(a) };
            seen = seen.saturating_add(1);
            against = against.saturating_add(u8::from(off));
            let filter_agrees = filter.is_some_and(|f| witness_angle_rad(f, w) <= max);
            isolated |= off && filter_agrees;
        }
        self.last_witness_rad = largest;
        self.last_corroborated = seen >= 1 && against == 0;
        isolated || (seen >= 2 && against == seen)
    }

    /// Whether the sample at `time_us` was judged and the Sun or the field corroborate it:
    /// at least one witness, none against it, no exceedance in the window, and not an
    /// exact repeat of the sample before (the bias-step monitor's isolation,
    /// [`super::bias`]). A repeat is the frozen test's evidence, not the tracker's: a frozen
    /// output agrees with the witnesses until the body has turned by their threshold, while
    /// its innovations grow at the body's rate, a slope the bias test would take for a gyro
    /// step (found by the timing search's frozen-tracker seed: declared a bias step one
    /// sample before the frozen test fired).
    pub fn corroborates(&self, time_us: u64) -> bool {
        self.failed.is_none()
            && self.last_time_us == Some(time_us)
            && self.last_corroborated
            // The last judged sample (the tag matched) repeated the one before in all four.
            && self.repeats.repeating() != 0b1111
            && self.persistence.count() == 0
    }

    /// Whether the tracker is declared failed (and by which test).
    pub fn failed(&self) -> Option<TrackerFault> {
        self.failed
    }

    /// Tracker failures declared since boot (saturating; a clear does not lower it).
    pub fn events(&self) -> u16 {
        self.events
    }

    pub fn last_witness_rad(&self) -> f32 {
        self.last_witness_rad
    }

    /// The ground re-enables the tracker: failure and history forgotten, events kept.
    pub fn clear(&mut self) {
        *self = Self { events: self.events, ..Self::new() };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotate_body_to_ref;
    use crate::params::fdir::KOfN;

    fn params() -> TrackerFdirParams {
        TrackerFdirParams { witness_max_rad: 0.35, window: KOfN { k: 3, n: 4 }, max_repeats: 3 }
    }

    fn q(axis: [f32; 3], angle_rad: f32) -> Quat {
        let a = Vec3::from(axis).normalize() * libm::sinf(angle_rad / 2.0);
        Quat::new(libm::cosf(angle_rad / 2.0), a.x, a.y, a.z)
    }

    /// Witnesses measured at the true attitude `truth`.
    fn seen(truth: &Quat, refs: &[[f32; 3]]) -> [Option<Witness>; 2] {
        let mut out = [None, None];
        for (o, r) in out.iter_mut().zip(refs) {
            let reference = Vec3::from(*r).normalize();
            *o = Some(Witness { body: rotate_ref_to_body(truth, &reference), reference });
        }
        out
    }

    #[test]
    fn the_witness_angle_is_the_rotation_between_measured_and_predicted() {
        // A flip of π about the boresight z moves a direction θ off z by 2θ (θ ≤ 90°).
        let truth = q([0.3, -0.2, 0.9], 0.7);
        for theta_deg in [10.0f32, 30.0, 60.0, 85.0] {
            let t = theta_deg.to_radians();
            let body = Vec3::new(libm::sinf(t), 0.0, libm::cosf(t));
            let w = Witness { body, reference: rotate_body_to_ref(&truth, &body) };
            let flipped = truth * q([0.0, 0.0, 1.0], core::f32::consts::PI);
            let a = witness_angle_rad(&flipped, &w);
            assert!((a - 2.0 * t).abs() < 1e-5, "θ {theta_deg}°: {a} vs {}", 2.0 * t);
            assert!(witness_angle_rad(&truth, &w) < 1e-5);
        }
    }

    #[test]
    fn a_flipped_tracker_is_declared_after_k_samples_with_the_filter_as_tiebreak() {
        let truth = q([0.0, 1.0, 0.0], 0.4);
        let flipped = truth * q([0.0, 0.0, 1.0], core::f32::consts::PI);
        let w = seen(&truth, &[[1.0, 0.2, 0.1]]);
        let mut m = TrackerMonitor::new();
        let fired: heapless::Vec<bool, 8> =
            (0..5u64).map(|i| m.judge(&params(), 1000 * (i + 1), &flipped, &w, Some(&truth))).collect();
        assert_eq!(fired.as_slice(), &[false, false, true, false, false]);
        assert_eq!((m.failed(), m.events()), (Some(TrackerFault::Witness), 1));
        m.clear();
        assert_eq!((m.failed(), m.events()), (None, 1));
    }

    #[test]
    fn one_witness_against_tracker_and_filter_together_is_not_isolated_but_two_are() {
        let truth = q([0.0, 1.0, 0.0], 0.4);
        let flipped = truth * q([0.0, 0.0, 1.0], core::f32::consts::PI);
        let mut m = TrackerMonitor::new();
        // The same quaternion every sample: the frozen test is kept out of this one.
        let p = TrackerFdirParams { max_repeats: 100, ..params() };
        let one = seen(&truth, &[[1.0, 0.2, 0.1]]);
        // The filter restarted from the flipped tracker: it sides with it.
        assert!(!(0..8u64).any(|i| m.judge(&p, i + 1, &flipped, &one, Some(&flipped))));
        // Two directions 60° and 75° off the boresight (body axes): moved by 120° and 150°.
        let body = |t: f32| Vec3::new(libm::sinf(t.to_radians()), 0.3, libm::cosf(t.to_radians())).normalize();
        let two =
            [60.0f32, 105.0].map(|t| Some(Witness { body: body(t), reference: rotate_body_to_ref(&truth, &body(t)) }));
        assert!((20..28u64).any(|i| m.judge(&p, i, &flipped, &two, Some(&flipped))));
        assert_eq!(m.failed(), Some(TrackerFault::Witness));
    }

    #[test]
    fn a_healthy_tracker_a_repeated_tag_and_no_witness_never_fire_but_frozen_does() {
        let truth = q([1.0, 1.0, 0.0], 1.1);
        let w = seen(&truth, &[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        let mut m = TrackerMonitor::new();
        for i in 0..50u64 {
            // A live tracker: a slowly moving attitude (never bit-identical).
            let live = truth * q([0.0, 0.0, 1.0], 1e-4 * i as f32);
            assert!(!m.judge(&params(), i + 1, &live, &w, Some(&truth)));
            assert!(!m.judge(&params(), i + 1, &live, &[None, None], None), "a repeated tag is not judged");
        }
        // Frozen: the same quaternion with fresh tags; 3 repeats allowed, the 4th fires.
        // The witnesses still agree with it, but a repeat is never corroborated (the
        // bias-step test must not read a frozen output's growing innovation as a step).
        let fired: heapless::Vec<(bool, bool), 8> = (0..5u64)
            .map(|i| (m.judge(&params(), 100 + i, &truth, &w, Some(&truth)), m.corroborates(100 + i)))
            .collect();
        let want = [(false, true), (false, false), (false, false), (false, false), (true, false)];
        assert_eq!(fired.as_slice(), &want);
        assert_eq!(m.failed(), Some(TrackerFault::Frozen));
    }

    #[test]
    fn a_flip_is_visible_when_it_moves_a_witness_by_twice_the_threshold() {
        // The move of a direction θ from the boresight under a flip, measured: the angle
        // between it and its image turned 180° about the boresight (z).
        let b = Vec3::z();
        let max = 20.0f32.to_radians();
        for deg in [0.0f32, 4.6, 15.0, 19.0, 21.0, 45.0, 90.0, 135.0, 159.0, 161.0, 175.4, 180.0] {
            let t = deg.to_radians();
            let d = Vec3::new(f32m::sin(t), 0.0, f32m::cos(t));
            let flipped = Vec3::new(-d.x, -d.y, d.z);
            let moved = f32m::atan2(norm(&d.cross(&flipped)), d.dot(&flipped));
            assert_eq!(flip_visible(&b, &d, max), moved > 2.0 * max, "{deg} deg: moved {moved} rad");
        }
    }
}
