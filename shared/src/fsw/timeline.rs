//! The pointing timeline in the flight software (docs/guidance.md, "Timeline"): staged
//! and armed from the ground, stepped each control step while a mission mode (manoeuvre,
//! hold; the single set without a mode table) is in force, its segments' pointing
//! replacing the mission modes' pointing as a ground `SetPointing` does (a planned slew
//! when the set's `[manoeuvre]` is enabled, else the blend).

use super::Fsw;
use crate::estimation::determination::Estimate;
use crate::guidance::flags;
use crate::guidance::timeline::{Timeline, TimelineCounters};
use crate::params::{Mode, ParamError, TimelineError, TimelineFault, TimelineSegment};

/// Guidance flags under which the command in force has not arrived at its pointing.
const NOT_ON_TARGET: u8 = flags::SLEWING | flags::KEEPOUT_REFUSED | flags::HELD;

impl Fsw {
    /// Slot `i` runs the mission pointing (the one the timeline and `SetPointing` replace).
    pub(super) fn is_mission_slot(&self, i: usize) -> bool {
        !self.table || i == Mode::Manoeuvre.index() || i == Mode::Hold.index()
    }

    /// Stage segment `index` of a timeline (`HostMsg::UploadTimelineSegment`).
    pub fn stage_timeline_segment(&mut self, index: u8, segment: &TimelineSegment) -> Result<(), ParamError> {
        self.timeline.stage(index, segment)
    }

    /// Arm staged segments `0..count` (`HostMsg::ArmTimeline`) against the latest
    /// navigation solution, the command in force and the mission set's slew limits and
    /// cones; returns the checksum. Refused (`NoMissionMode` without a configured mission
    /// set) with the timeline in force, if any, unchanged.
    pub fn arm_timeline(&mut self, count: u8, checksum: u32) -> Result<u32, TimelineError> {
        let mission = (0..self.slots.len())
            .filter(|i| self.is_mission_slot(*i))
            .filter_map(|i| self.slots.get(i).and_then(Option::as_ref))
            .next()
            .map(|c| (c.params.manoeuvre, c.dt_s))
            .filter(|_| self.is_configured());
        let Some((manoeuvre, dt_s)) = mission else {
            return Err(TimelineError { index: 0, fault: TimelineFault::NoMissionMode });
        };
        let from = self.active_cfg().and_then(|c| c.guidance.last());
        self.timeline.arm(count, checksum, self.nav_last.as_ref(), from, &manoeuvre, dt_s)
    }

    /// Drop the timeline (`HostMsg::ClearTimeline`); the pointing in force stays.
    pub fn clear_timeline(&mut self) {
        self.timeline.clear();
    }

    /// The timeline's counters (met, missed, segment in force).
    pub fn timeline_counters(&self) -> TimelineCounters {
        self.timeline.counters
    }

    pub fn timeline(&self) -> &Timeline {
        &self.timeline
    }

    /// One timeline step (before guidance): in a mission mode with a navigation solution,
    /// a segment that takes over replaces the mission modes' pointing. Out of the mission
    /// modes no segment takes over and each one whose start passes is counted missed then
    /// ([`Timeline::skip_overdue`]); without navigation the timeline waits, and segments
    /// overdue by then are skipped as missed ([`Timeline::step`]).
    pub(super) fn step_timeline(&mut self, est: &Estimate) {
        if let Some(nav) = &est.nav {
            self.nav_last = Some(*nav);
        }
        let Some(nav) = est.nav.as_ref() else { return };
        if !self.timeline.is_armed() {
            return;
        }
        if !self.is_mission_slot(self.active) {
            self.timeline.skip_overdue(&nav.time);
            return;
        }
        let on_target = self.active_cfg().is_some_and(|c| c.guidance.report().flags & NOT_ON_TARGET == 0);
        if let Some(g) = self.timeline.step(&nav.time, on_target) {
            // Validated at staging and a mission slot is in force: not refused. Were it
            // refused, the previous pointing would stay and the segment count missed.
            if self.set_pointing(&g).is_err() {
                self.timeline.counters.missed = self.timeline.counters.missed.saturating_add(1);
            }
        }
    }
}
