//! The scenario's `[[timeline]]` over the link (docs/scenario.md "Pointing timeline"):
//! staged after the upload, armed after the first control step whose navigation lets the
//! flight code check it (retried while it answers `NoNavigation`), followed in the truth
//! when a segment's pointing takes over, and judged at the end (a missed segment fails the
//! run unless `[performance] allow_missed_segments`).

use super::Simulation;
use crate::link::FlightLink;
use crate::recorder::summary::TimelineSummary;
use crate::scenario::TimelineEntry;
use acs_flight::guidance::timeline::checksum;
use acs_flight::link::{FswMsg, HostMsg, TimelineTelemetry};
use acs_flight::params::TimelineFault;
use anyhow::{Result, bail};

/// The timeline of a run and what the flight code reported of it.
#[derive(Clone, Debug, Default)]
pub(super) struct TimelineRun {
    pub(super) entries: Vec<TimelineEntry>,
    pub(super) allow_missed: bool,
    /// Time the flight code armed it, s (`None`: not yet).
    pub(super) armed_at_s: Option<f64>,
    /// The latest step report's counters.
    pub(super) report: TimelineTelemetry,
    /// Time of the latest flight step, s.
    pub(super) last_step_s: f64,
}

/// A segment that started this long before the last flight step must have been counted
/// met or missed by the flight code (one control step, and the on-board f32 time's
/// rounding, well inside it), s.
const ACCOUNTING_SLACK_S: f64 = 1.0;

impl TimelineRun {
    /// Stage every segment; a refusal fails the run with the segment and why.
    pub(super) fn stage(&self, link: &mut dyn FlightLink) -> Result<()> {
        for (i, e) in self.entries.iter().enumerate() {
            let index = u8::try_from(i)?;
            match link.request(&HostMsg::UploadTimelineSegment { index, segment: e.segment })? {
                FswMsg::Ack => {}
                FswMsg::ParamsRejected(err) => bail!("timeline[{i}]: the flight code refused the segment: {err}"),
                other => bail!("timeline[{i}]: unexpected reply to its upload: {other:?}"),
            }
        }
        Ok(())
    }

    /// Arm after the step at `t` unless armed; `NoNavigation` is retried at the next step
    /// until the first segment's start, every other refusal fails the run.
    pub(super) fn arm_if_due(&mut self, link: &mut dyn FlightLink, t: f64) -> Result<()> {
        if self.entries.is_empty() || self.armed_at_s.is_some() {
            return Ok(());
        }
        let segments: Vec<_> = self.entries.iter().map(|e| e.segment).collect();
        let Some(crc32) = checksum(&segments) else { bail!("timeline: a segment does not encode") };
        let count = u8::try_from(segments.len())?;
        match link.request(&HostMsg::ArmTimeline { count, crc32 })? {
            FswMsg::TimelineArmed { checksum } if checksum == crc32 => self.armed_at_s = Some(t),
            FswMsg::TimelineArmed { checksum } => {
                bail!("timeline checksum mismatch: flight {checksum:#010x}, host {crc32:#010x}")
            }
            FswMsg::TimelineRejected(e) if e.fault == TimelineFault::NoNavigation => {
                let first = self.entries.first().map_or(0.0, |e| e.start_s);
                if t >= first {
                    bail!(
                        "timeline not armed by its first segment's start ({first} s): no navigation solution on board"
                    );
                }
            }
            FswMsg::TimelineRejected(e) => {
                let start = self.entries.get(usize::from(e.index)).map_or(f64::NAN, |s| s.start_s);
                bail!(
                    "the flight code refused the timeline at t = {t:.3} s: timeline[{}] (start_s = {start}): {:?}",
                    e.index,
                    e.fault
                )
            }
            other => bail!("unexpected reply to ArmTimeline: {other:?}"),
        }
        Ok(())
    }

    pub(super) fn summary(&self) -> Option<TimelineSummary> {
        (!self.entries.is_empty()).then(|| TimelineSummary {
            segments: self.entries.len(),
            met: self.report.met,
            missed: self.report.missed,
            pending: (self.entries.len() as u32)
                .saturating_sub(u32::from(self.report.met) + u32::from(self.report.missed)),
            armed_at_s: self.armed_at_s,
            allow_missed: self.allow_missed,
        })
    }

    /// Why the run fails for its timeline, if it does.
    /// A segment the flight code never accounted for (started before the last step, yet
    /// neither met nor missed: e.g. no navigation since) fails the run whatever
    /// `allow_missed_segments` says: the timeline was not executed as reported.
    pub(super) fn failure_reason(&self) -> Option<String> {
        let (n, missed) = (self.entries.len(), self.report.missed);
        let accounted = usize::from(self.report.met) + usize::from(missed);
        let started = self.entries.iter().filter(|e| e.start_s + ACCOUNTING_SLACK_S < self.last_step_s).count();
        if started > accounted {
            return Some(format!(
                "{} of {n} timeline segments started before the last flight step (t = {:.3} s) but the flight \
                 code counted them neither met nor missed (met {}, missed {missed})",
                started - accounted,
                self.last_step_s,
                self.report.met
            ));
        }
        (n > 0 && missed > 0 && !self.allow_missed).then(|| {
            format!(
                "{missed} of {n} timeline segments missed (not on target at their start; \
                 [performance] allow_missed_segments = true accepts that)"
            )
        })
    }
}

impl Simulation<'_> {
    /// After the flight step at `t`: the segment now in force into the truth, then arming.
    pub(super) fn timeline_after_step(&mut self, t: f64, report: TimelineTelemetry) -> Result<()> {
        if self.timeline.entries.is_empty() {
            return Ok(());
        }
        let before = self.timeline.report.in_force;
        self.timeline.report = report;
        self.timeline.last_step_s = t;
        if report.in_force != before
            && let Some(e) = usize::from(report.in_force).checked_sub(1).and_then(|i| self.timeline.entries.get(i))
        {
            let set = e.truth.clone();
            self.retarget_truth(None, Some(set));
        }
        if self.info.is_some() {
            self.timeline.arm_if_due(&mut *self.link, t)?;
        }
        Ok(())
    }
}
