//! Pointing performance per segment (docs/pointing.md, "Per segment"): a segment is a
//! maximal span of control steps with one flight mode, one pointing (the mission's until a
//! ground command replaces it, or the mode's own) and one branch of it (a gated pointing's
//! "visible" or "otherwise"). Each segment's APE and RPE ([`PointingStats`]) are taken
//! over the segment from `segment_settle_s` after its start (acquisition and transition
//! left out), of the attitude error and, for two-vector pointing, of the primary
//! (boresight) error apart.
//!
//! Memory: one segment's statistics are live at a time; a closed segment keeps its
//! figures only. At most [`MAX_LISTED_SEGMENTS`] are listed; later ones are counted
//! (`pointing_segments_unlisted`).

use super::pointing::{AxisFigures, PointingStats, Windows};
use crate::environment::guidance::Branch;
use serde::Serialize;

/// Most segments `summary.json` lists.
pub const MAX_LISTED_SEGMENTS: usize = 512;

/// What makes a segment: the flight mode (its code; `None` without a mode manager), the
/// pointing (a number that changes whenever the pointing in force does) and its branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SegmentKey {
    pub mode: Option<u8>,
    pub pointing: u32,
    pub branch: Branch,
}

/// One segment's figures (`summary.json` `pointing_segments[i]`), deg.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SegmentSummary {
    /// The flight mode's name (absent without a mode manager).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode: Option<String>,
    /// The pointing's label (`[guidance] label`, its directions, or `target`).
    pub pointing: String,
    /// `"pointing"`, or `"otherwise"` while a gated site does not see the spacecraft.
    pub branch: &'static str,
    /// First and last control step of the segment, s.
    pub start_s: f64,
    pub end_s: f64,
    /// The indices are taken from here (`start_s + segment_settle_s`, not before
    /// `[performance] from_s`) to `end_s`.
    pub from_s: f64,
    pub ape_deg: AxisFigures,
    pub rpe_deg: AxisFigures,
    /// The primary (boresight) error apart (two-vector pointing only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub primary_ape_deg: Option<AxisFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub primary_rpe_deg: Option<AxisFigures>,
}

#[derive(Clone)]
struct Live {
    key: SegmentKey,
    summary: SegmentSummary,
    attitude: PointingStats,
    primary: Option<PointingStats>,
}

/// The segments of a run, streamed.
#[derive(Clone)]
pub struct Segments {
    windows: Windows,
    confidence: f64,
    settle_s: f64,
    from_s: f64,
    live: Option<Live>,
    done: Vec<SegmentSummary>,
    unlisted: u64,
    /// Segments begun so far (the index of the live one is this minus one).
    count: u64,
}

impl Segments {
    pub fn new(windows: Windows, confidence: f64, settle_s: f64, from_s: f64) -> Self {
        Self { windows, confidence, settle_s, from_s, live: None, done: Vec::new(), unlisted: 0, count: 0 }
    }

    /// The index of the segment the last sample went to (`None` before any).
    pub fn current(&self) -> Option<u64> {
        self.count.checked_sub(1)
    }

    /// One control step at `t_s`: its key and label, the attitude error (body axes, deg)
    /// and the primary error (body axes, deg; `None` for a fixed attitude).
    pub fn push(
        &mut self,
        t_s: f64,
        key: SegmentKey,
        labels: (Option<String>, &str),
        err: [f64; 3],
        primary: Option<[f64; 3]>,
    ) {
        if self.live.as_ref().is_none_or(|l| l.key != key) {
            self.close();
            let from_s = (t_s + self.settle_s).max(self.from_s);
            let summary = SegmentSummary {
                mode: labels.0,
                pointing: labels.1.to_string(),
                branch: match key.branch {
                    Branch::Main => "pointing",
                    Branch::Otherwise => "otherwise",
                },
                start_s: t_s,
                end_s: t_s,
                from_s,
                ape_deg: AxisFigures::default(),
                rpe_deg: AxisFigures::default(),
                primary_ape_deg: None,
                primary_rpe_deg: None,
            };
            self.live = Some(Live { key, summary, attitude: PointingStats::new(self.windows), primary: None });
            self.count += 1;
        }
        let Some(live) = self.live.as_mut() else { return };
        live.summary.end_s = t_s;
        if t_s < live.summary.from_s {
            return;
        }
        live.attitude.push(err);
        if let Some(p) = primary {
            live.primary.get_or_insert_with(|| PointingStats::new(self.windows)).push(p);
        }
    }

    /// Ends the live segment (at the end of the run, or before a new one).
    pub fn close(&mut self) {
        let Some(Live { mut summary, attitude, primary, .. }) = self.live.take() else { return };
        let p = self.confidence;
        summary.ape_deg = attitude.ape.figures(p);
        summary.rpe_deg = attitude.rpe.figures(p);
        summary.primary_ape_deg = primary.as_ref().map(|s| s.ape.figures(p));
        summary.primary_rpe_deg = primary.as_ref().map(|s| s.rpe.figures(p));
        if self.done.len() < MAX_LISTED_SEGMENTS {
            self.done.push(summary);
        } else {
            self.unlisted += 1;
        }
    }

    /// Every segment (the live one closed), and how many were not listed.
    pub fn finish(mut self) -> (Vec<SegmentSummary>, u64) {
        self.close();
        (self.done, self.unlisted)
    }
}
