//! `[[timeline]]`: a pointing timeline uploaded to the flight code at the start of the run
//! (docs/scenario.md "Pointing timeline", docs/guidance.md "Timeline"). Each segment starts
//! `start_s` after the scenario's start and points as a `[guidance]` table says.

use super::{GuidanceSpec, Scenario, bad};
use crate::environment::guidance::TruthSet;
use crate::sensors::j2000_days_seconds;
use acs_flight::params::{MAX_TIMELINE_SEGMENTS, TimelineSegment};
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// One `[[timeline]]` entry.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimelineSpec {
    /// Start, s after the scenario's start (its `[orbit]` epoch).
    pub start_s: f64,
    /// The pointing from `start_s` until the next segment's start (`[guidance]` keys).
    pub guidance: GuidanceSpec,
}

/// A checked segment: its start, what is uploaded, and the truth of its pointing.
#[derive(Clone, Debug, PartialEq)]
pub struct TimelineEntry {
    pub start_s: f64,
    pub segment: TimelineSegment,
    pub truth: TruthSet,
}

impl Scenario {
    /// The checked timeline (empty without `[[timeline]]`); every refusal names its key.
    pub fn timeline_entries(&self) -> Result<Vec<TimelineEntry>> {
        let Some(list) = &self.timeline else { return Ok(Vec::new()) };
        if list.is_empty() {
            return Err(bad("timeline", "empty: give at least one [[timeline]] segment, or none"));
        }
        if list.len() > MAX_TIMELINE_SEGMENTS {
            return Err(bad("timeline", format!("{} segments, at most {MAX_TIMELINE_SEGMENTS}", list.len())));
        }
        if !self.closed_loop() {
            return Err(bad("timeline", "a timeline goes to the flight code: needs a controller or [modes]"));
        }
        if self.orbit.is_none() {
            return Err(bad("timeline", "needs [orbit]: the flight code executes it on its navigation time"));
        }
        let env = self.spacecraft()?.env.ok_or_else(|| bad("timeline", "needs the [orbit] environment"))?;
        let mut last = f64::NEG_INFINITY;
        let mut out = Vec::with_capacity(list.len());
        for (i, s) in list.iter().enumerate() {
            let key = format!("timeline[{i}]");
            let t = s.start_s;
            if !(t.is_finite() && t > 0.0 && t < self.duration_s) {
                return Err(bad(
                    &format!("{key}.start_s"),
                    format!("{t} is outside (0, duration_s = {})", self.duration_s),
                ));
            }
            if t <= last {
                return Err(bad(
                    &format!("{key}.start_s"),
                    format!("{t} s is not after timeline[{}].start_s = {last} s: segments overlap", i - 1),
                ));
            }
            last = t;
            let g = s.guidance.resolve(&format!("{key}.guidance"), true)?;
            let (days, seconds) = j2000_days_seconds(env.julian_date(t));
            let segment = TimelineSegment { start_j2000_days: days, start_j2000_s: seconds, guidance: g.params };
            out.push(TimelineEntry { start_s: t, segment, truth: g.truth() });
        }
        Ok(out)
    }
}
