//! Pointing timeline parameters (protocol 19): a bounded, time-tagged list of pointing
//! segments the ground uploads one segment per message, then arms with its count and
//! checksum ([`crate::guidance::timeline`], docs/guidance.md "Timeline").

use super::{GuidanceParams, ParamError};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Most segments of a timeline.
pub const MAX_TIMELINE_SEGMENTS: usize = 16;
/// Farthest a segment may start after the arming, s: the on-board two-body propagation's
/// limit, over which the arming checks each segment's geometry.
pub const TIMELINE_HORIZON_S: f32 = 86_400.0;

/// One segment: from `start` (on-board J2000 time) until the next segment's start, the
/// mission modes point as `guidance` says.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimelineSegment {
    /// Start: whole days and seconds since J2000.0 (as the navigation's time).
    pub start_j2000_days: i32,
    pub start_j2000_s: f32,
    pub guidance: GuidanceParams,
}

/// Why a timeline was not armed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TimelineFault {
    /// No segments, or more than [`MAX_TIMELINE_SEGMENTS`].
    BadCount,
    /// A segment of `0..count` was not uploaded.
    NotUploaded,
    /// The checksum of the uploaded segments differs from the ground's.
    Checksum,
    /// No navigation solution: the geometry cannot be checked.
    NoNavigation,
    /// The segment starts before the previous one (or at the same time): they overlap.
    NotIncreasing,
    /// The segment starts in the past.
    InThePast,
    /// The segment starts more than [`TIMELINE_HORIZON_S`] ahead.
    BeyondHorizon,
    /// The segment's pointing is invalid (the parameter error).
    Pointing(ParamError),
    /// Its pointing cannot be computed at its start (e.g. degenerate geometry).
    NoCommand,
    /// At its start its pointing puts a boresight inside a keep-out cone.
    KeepOutAtStart,
    /// The slew into it (from the previous segment's pointing at its start, within the
    /// slew limits, plus planning) does not fit after the previous segment's start.
    Unreachable,
    /// The start time is not a finite time (NaN, infinite, or days out of range).
    BadStart,
    /// No parameter set of a mission mode (manoeuvre, hold; a single set) is in force or
    /// armed: nothing to execute the timeline with.
    NoMissionMode,
}

/// A refused timeline: the first offending segment and why.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimelineError {
    pub index: u8,
    pub fault: TimelineFault,
}
