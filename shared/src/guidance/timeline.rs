//! The pointing timeline from the ground (docs/guidance.md, "Timeline"): up to
//! [`MAX_TIMELINE_SEGMENTS`] time-tagged segments, uploaded one per message, armed with
//! their count and CRC-32, then executed by the flight software: segment `k`'s pointing
//! takes over the mission modes `lead_k` before its start, so that its slew arrives by then.
//!
//! Arming checks every segment against the navigation solution propagated to its start
//! (two-body, at most [`TIMELINE_HORIZON_S`] ahead) and refuses, naming the segment:
//! a missing or corrupted upload, an overlap, a start in the past or beyond the horizon,
//! an invalid pointing, a pointing that cannot be computed or that puts a boresight in a
//! keep-out cone at its start, and a slew that cannot fit: `lead_k` = the rest-to-rest
//! profile time over the angle between the previous pointing and this one at its start
//! (doubled, with a 180° bound, when the direct path crosses a cone: a waypoint path is
//! at most two legs of at most 180°), plus the planner's steps, must not reach back before
//! the previous segment's start (for the first, before the arming). Without planned slews
//! the lead is the blend's `transition_s`.
//!
//! Executing: one comparison of times per step. At its start a segment is *met* when no
//! slew is still flying, else *missed* (it arrives late); both counted. A slew the cones
//! refuse in flight is handled by the planner (held attitude, counted there).

use super::directions::Epoch;
use super::manoeuvre::{CANDIDATES, CANDIDATES_PER_STEP};
use super::profile::{Limits, Profile};
use super::{Guided, align::AlignFrame, blend::quat_log};
use crate::checksum::CRC32;
use crate::estimation::navigation::NavSolution;
use crate::math::{Quat, norm};
use crate::models::orbit::propagate_two_body;
use crate::models::time::J2000Time;
use crate::params::timeline::{TIMELINE_HORIZON_S, TimelineFault};
use crate::params::{GuidanceParams, MAX_TIMELINE_SEGMENTS, ManoeuvreParams, TimelineError, TimelineSegment};

/// Seconds from `a` to `b` (f32: exact to ~10 ms over a day).
pub fn seconds_between(a: &J2000Time, b: &J2000Time) -> f32 {
    let days = b.days.saturating_sub(a.days) as f32;
    days * 86_400.0 + (b.seconds - a.seconds)
}

/// Execution counters (saturating) and the segment in force.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TimelineCounters {
    pub met: u16,
    pub missed: u16,
    /// Index + 1 of the segment whose pointing is in force (0: none yet).
    pub in_force: u8,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Armed {
    count: usize,
    leads_s: [f32; MAX_TIMELINE_SEGMENTS],
    /// The next segment to switch to, and whether its pointing already took over.
    next: usize,
    switched: bool,
}

/// Staged segments and the armed timeline. The armed segments are a copy: staging a new
/// timeline while one executes does not change the one executing until it is armed.
#[derive(Clone, Debug, PartialEq)]
pub struct Timeline {
    staged: [Option<TimelineSegment>; MAX_TIMELINE_SEGMENTS],
    segments: [TimelineSegment; MAX_TIMELINE_SEGMENTS],
    armed: Option<Armed>,
    pub counters: TimelineCounters,
}

impl Default for Timeline {
    fn default() -> Self {
        Self::new()
    }
}

/// The CRC-32 the ground computes over segments `0..count` (postcard of each, in order);
/// `None` when a segment does not encode.
pub fn checksum(segments: &[TimelineSegment]) -> Option<u32> {
    checksum_of(segments.iter().map(Some))
}

/// The CRC-32 over segments that must all be present (`None` if one is missing).
fn checksum_of<'a>(segments: impl Iterator<Item = Option<&'a TimelineSegment>>) -> Option<u32> {
    let mut digest = CRC32.digest();
    let mut buf = [0u8; SEGMENT_BUF];
    for s in segments {
        digest.update(postcard::to_slice(s?, &mut buf).ok()?);
    }
    Some(digest.finalize())
}

/// Postcard buffer of one segment (the largest encodes to well under this; a test checks).
pub const SEGMENT_BUF: usize = 256;

impl Timeline {
    pub const fn new() -> Self {
        Self {
            staged: [None; MAX_TIMELINE_SEGMENTS],
            segments: [PLACEHOLDER; MAX_TIMELINE_SEGMENTS],
            armed: None,
            counters: TimelineCounters { met: 0, missed: 0, in_force: 0 },
        }
    }

    /// Stage segment `index` (its pointing validated; a bad index is out of range). The
    /// armed timeline, if any, keeps executing.
    pub fn stage(&mut self, index: u8, segment: &TimelineSegment) -> Result<(), crate::params::ParamError> {
        segment.guidance.validate()?;
        let slot = self.staged.get_mut(usize::from(index)).ok_or(crate::params::ParamError {
            field: crate::params::ParamField::Pointing,
            reason: crate::params::ParamReason::OutOfRange,
        })?;
        *slot = Some(*segment);
        Ok(())
    }

    /// Drop the timeline (staged and armed) and its counters; the pointing in force stays.
    pub fn clear(&mut self) {
        self.staged = [None; MAX_TIMELINE_SEGMENTS];
        self.armed = None;
        self.counters = TimelineCounters::default();
    }

    pub fn is_armed(&self) -> bool {
        self.armed.is_some()
    }

    /// Segments of the armed timeline (0: none armed).
    pub fn count(&self) -> usize {
        self.armed.map_or(0, |a| a.count)
    }

    /// Arm staged segments `0..count` after checking them (module docs); returns the
    /// checksum. `now`: the latest navigation solution; `from`: the command in force. On
    /// refusal the timeline already armed (if any) keeps executing. The staged segments
    /// stay staged either way (a new arming needs no new upload).
    pub fn arm(
        &mut self,
        count: u8,
        checksum_ground: u32,
        now: Option<&NavSolution>,
        from: Option<Guided>,
        manoeuvre: &ManoeuvreParams,
        dt_s: f32,
    ) -> Result<u32, TimelineError> {
        let n = usize::from(count);
        let fail = |index: usize, fault| TimelineError { index: u8::try_from(index).unwrap_or(u8::MAX), fault };
        if n == 0 || n > MAX_TIMELINE_SEGMENTS {
            return Err(fail(0, TimelineFault::BadCount));
        }
        let staged = self.staged.get(..n).unwrap_or(&[]);
        if let Some(i) = staged.iter().position(Option::is_none) {
            return Err(fail(i, TimelineFault::NotUploaded));
        }
        let sum = checksum_of(staged.iter().map(Option::as_ref)).ok_or(fail(0, TimelineFault::Checksum))?;
        if sum != checksum_ground {
            return Err(fail(0, TimelineFault::Checksum));
        }
        let nav = now.ok_or(fail(0, TimelineFault::NoNavigation))?;
        let mut leads_s = [0.0f32; MAX_TIMELINE_SEGMENTS];
        let mut previous: Option<(f32, Quat)> = None; // (start offset, its command)
        let check = Check { nav, manoeuvre, dt_s, from: from.map(|g| g.q) };
        for (i, (seg, lead_out)) in staged.iter().flatten().zip(leads_s.iter_mut()).enumerate() {
            let (offset, (lead, q)) = check.segment(seg, previous).map_err(|f| fail(i, f))?;
            *lead_out = lead;
            previous = Some((offset, q));
        }
        for (dst, src) in self.segments.iter_mut().zip(self.staged.iter().take(n).flatten()) {
            *dst = *src;
        }
        self.armed = Some(Armed { count: n, leads_s, next: 0, switched: false });
        self.counters = TimelineCounters::default();
        Ok(sum)
    }

    /// Segment `i` of the armed timeline.
    pub fn segment(&self, i: usize) -> Option<&TimelineSegment> {
        self.armed.filter(|a| i < a.count).and_then(|_| self.segments.get(i))
    }

    /// How long before its start segment `i`'s pointing takes over, s (armed timeline).
    pub fn lead_s(&self, i: usize) -> Option<f32> {
        self.armed.filter(|a| i < a.count).and_then(|a| a.leads_s.get(i).copied())
    }

    /// One step at navigation time `now`: the pointing that takes over now, if any.
    /// `on_target`: the command in force has arrived (no slew planned or flying, none
    /// refused). A segment is met when it is on target at its start, else missed; a
    /// segment whose successor already takes over before it did (the flight software did
    /// not step the timeline for a while) is skipped and counted missed. At most
    /// 2 × [`MAX_TIMELINE_SEGMENTS`] passes of one comparison each.
    pub fn step(&mut self, now: &J2000Time, on_target: bool) -> Option<GuidanceParams> {
        let mut a = self.armed?;
        let mut out = None;
        for _ in 0..2 * MAX_TIMELINE_SEGMENTS {
            let Some(until_switch) = self.until_switch(&a, a.next, now) else { break };
            if !a.switched {
                if until_switch.0 > 0.0 {
                    break;
                }
                let following = a.next.saturating_add(1);
                if self.until_switch(&a, following, now).is_some_and(|(t, _)| t <= 0.0) {
                    self.counters.missed = self.counters.missed.saturating_add(1);
                    a.next = following;
                    continue;
                }
                a.switched = true;
                self.counters.in_force = u8::try_from(following).unwrap_or(u8::MAX);
                out = self.segments.get(a.next).map(|s| s.guidance);
                break;
            }
            if until_switch.1 > 0.0 {
                break;
            }
            let c = if on_target { &mut self.counters.met } else { &mut self.counters.missed };
            *c = c.saturating_add(1);
            a.next = a.next.saturating_add(1);
            a.switched = false;
        }
        self.armed = Some(a);
        out
    }

    /// Out of the mission modes: every segment whose start has passed is counted missed
    /// (its pointing did not take over, or was not flown to its start) and none takes
    /// over; the timeline goes on from the first segment still ahead. At most
    /// [`MAX_TIMELINE_SEGMENTS`] iterations.
    pub fn skip_overdue(&mut self, now: &J2000Time) {
        let Some(mut a) = self.armed else { return };
        for _ in 0..MAX_TIMELINE_SEGMENTS {
            match self.until_switch(&a, a.next, now) {
                Some((_, to_start)) if to_start <= 0.0 => {
                    self.counters.missed = self.counters.missed.saturating_add(1);
                    a.next = a.next.saturating_add(1);
                    a.switched = false;
                }
                _ => break,
            }
        }
        self.armed = Some(a);
    }

    /// For segment `i`: (s until its pointing takes over, s until its start); `None` past
    /// the last segment.
    fn until_switch(&self, a: &Armed, i: usize, now: &J2000Time) -> Option<(f32, f32)> {
        if i >= a.count {
            return None;
        }
        let seg = self.segments.get(i)?;
        let start = J2000Time::new(seg.start_j2000_days, seg.start_j2000_s)?;
        let to_start = seconds_between(now, &start);
        Some((to_start - a.leads_s.get(i).copied().unwrap_or(0.0), to_start))
    }
}

/// Only fills the unused tail of a fixed array (never executed).
const PLACEHOLDER: TimelineSegment = TimelineSegment {
    start_j2000_days: 0,
    start_j2000_s: 0.0,
    guidance: GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], crate::params::TargetFrame::Inertial),
};

/// What arming checks a segment against.
struct Check<'a> {
    nav: &'a NavSolution,
    manoeuvre: &'a ManoeuvreParams,
    dt_s: f32,
    from: Option<Quat>,
}

impl Check<'_> {
    /// The segment's start offset from now and `(lead, command at its start)`.
    fn segment(
        &self,
        seg: &TimelineSegment,
        previous: Option<(f32, Quat)>,
    ) -> Result<(f32, (f32, Quat)), TimelineFault> {
        seg.guidance.validate().map_err(TimelineFault::Pointing)?;
        let start = J2000Time::new(seg.start_j2000_days, seg.start_j2000_s).ok_or(TimelineFault::BadStart)?;
        let offset = seconds_between(&self.nav.time, &start);
        if !(offset > 0.0) {
            return Err(if previous.is_some_and(|(p, _)| offset <= p) {
                TimelineFault::NotIncreasing
            } else {
                TimelineFault::InThePast
            });
        }
        if previous.is_some_and(|(p, _)| offset <= p) {
            return Err(TimelineFault::NotIncreasing);
        }
        if offset > TIMELINE_HORIZON_S {
            return Err(TimelineFault::BeyondHorizon);
        }
        let epoch = self.epoch_at(offset, &seg.guidance).ok_or(TimelineFault::NoCommand)?;
        let q = command_at(&seg.guidance, &epoch).ok_or(TimelineFault::NoCommand)?;
        let env = super::cone_env(&epoch);
        let cones = self.manoeuvre.active_cones();
        if let Some(e) = env.filter(|_| !cones.is_empty())
            && e.margin_at(cones, &q) < 0.0
        {
            return Err(TimelineFault::KeepOutAtStart);
        }
        // The slew into it: from the previous segment's pointing (or the command in force).
        let from = previous.map(|(_, q)| q).or(self.from).unwrap_or(q);
        let lead = self.lead_s(&from, &q, &seg.guidance, env.as_ref());
        let window_start = previous.map_or(0.0, |(p, _)| p);
        if !(offset - lead >= window_start) {
            return Err(TimelineFault::Unreachable);
        }
        Ok((offset, (lead, q)))
    }

    /// The navigation solution carried `offset` s ahead (two-body) as a guidance epoch.
    fn epoch_at(&self, offset: f32, g: &GuidanceParams) -> Option<Epoch> {
        let (r, v) = propagate_two_body(&self.nav.r_m, &self.nav.v_m_s, offset).ok()?;
        let time = self.nav.time.add_seconds(offset)?;
        Some(Epoch { r_m: r, v_m_s: v, time, ut1_minus_clock_s: g.ut1_minus_clock_s })
    }

    /// How long before its start a segment's pointing must take over.
    fn lead_s(&self, from: &Quat, to: &Quat, g: &GuidanceParams, env: Option<&super::manoeuvre::ConeEnv>) -> f32 {
        if !self.manoeuvre.enabled {
            return g.transition_s;
        }
        let limits =
            Limits { rate_rad_s: self.manoeuvre.max_rate_rad_s, accel_rad_s2: self.manoeuvre.max_accel_rad_s2 };
        let rotation = quat_log(&(to * from.conjugate()));
        let direct_clear = env.is_none_or(|e| {
            let p = self.manoeuvre;
            let widen = p.planning_margin_rad;
            e.margin_along(p.active_cones(), from, &rotation, widen) >= 0.0
        });
        let angle = if direct_clear { norm(&rotation) } else { core::f32::consts::PI };
        let legs = if direct_clear { 1.0 } else { 2.0 };
        let slew = Profile::plan(angle, &limits).map_or(f32::INFINITY, |p| p.duration_s()) * legs;
        let planning = (CANDIDATES / CANDIDATES_PER_STEP) as f32 * self.dt_s;
        // 10 % for the target's own motion during the slew.
        1.1 * slew + planning + self.dt_s
    }
}

/// The command of `g` at `epoch` (its gate evaluated there), for checks ahead of time.
pub fn command_at(g: &GuidanceParams, epoch: &Epoch) -> Option<Quat> {
    let pointing = match (g.min_elevation_rad, g.pointing.primary_site()) {
        (Some(min), Some((lat, lon, alt))) => {
            let site = super::directions::Site::geodetic(lat, lon, alt);
            let visible = epoch.elevation_sine(&site)? >= crate::math::f32m::sin(min);
            if visible { g.pointing } else { g.otherwise }
        }
        _ => g.pointing,
    };
    AlignFrame::new(&pointing).attitude_at(epoch, g.parallel_threshold_rad)
}
