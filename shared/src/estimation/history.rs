//! Delayed fusion for the MEKF: a short history of filter states so that a sensor sample
//! is fused once, at its own time, even when it arrives late (a star tracker delivers its
//! attitude 50–300 ms after the exposure), and the result is carried forward to now.
//!
//! The history is a ring of [`HISTORY_DEPTH`] nodes, oldest first. A node holds a time on
//! the flight clock (µs, as `SensorFrame::time_us`), the [`Mekf`] after everything up to
//! and including that time, the mean gyro rate of the step that ends there (angle
//! increment / interval; the rate is piecewise constant per step) and, for a sample node,
//! the measurement fused there.
//!
//! - [`History::propagate`] appends one propagation step: mean rate = increment /
//!   interval, [`Mekf::propagate`] over the flight-clock span, then a node.
//! - [`History::fuse_at`] fuses a sample taken at `t_s`: restore the last node at or before
//!   `t_s`, propagate to `t_s` with the rate of the step that contains it, apply the
//!   update, insert a node there, then re-run every later node: propagate with its stored
//!   rate and re-apply its stored measurement (so samples fused out of time order give
//!   exactly what fusing them in time order gives, operation for operation), rewriting
//!   those nodes up to now. A sample at exactly now costs no replay.
//!
//! Every propagation goes through [`span_s`] (flight-clock µs → s), so a filter fed the
//! same samples in time order, with the same piecewise-constant rates, reproduces the
//! history's result bit for bit (`shared/tests/mekf_history.rs`).
//!
//! Refused samples ([`FuseRefusal`]) change nothing and are counted in
//! [`HistoryCounters`] and in the sensor's [`SensorTrack`]: older than the oldest node,
//! later than now, not newer than the sensor's last fused sample (a held sample repeated in
//! every frame), a non-finite or degenerate input. A sample the filter's own chi-square
//! gate rejects is not a refusal: it is an outcome ([`FuseOutcome::result`]), stored and
//! re-offered on later replays like any other sample.
//!
//! Cost (the MCU budget): a sample `k` nodes behind now costs one propagation and one
//! update for itself plus `k` propagations and one update per later sample node, and a
//! copy of up to `k` nodes to open its slot; the worst case is `HISTORY_DEPTH`
//! propagations and updates (every loop is bounded by the depth). RAM:
//! `size_of::<MekfHistory>()` (see [`HISTORY_DEPTH`]). Samples and propagation steps
//! share the depth: it must cover the longest latency at the step rate plus the samples
//! that arrive within it. The method follows the state-history approach of ethzasl_msf /
//! robot_localization rather than PX4 EKF2's delayed horizon (docs/estimation-timing.md);
//! the MEKF is Markley & Crassidis 2014 §6.2.4.

use super::mekf::{Mekf, MekfConfig, MekfError};
use crate::math::{Mat3, Quat, Vec3};

/// Nodes in the flight history. Propagation steps and samples share them: at a 5 Hz control
/// step with one tracker sample per second 32 nodes span about 5 s, far beyond a star
/// tracker's 0.3 s latency; at 100 Hz steps, 0.3 s. RAM: 10,016 B on the Cortex-M4F
/// (`size_of::<MekfHistory>()`, bounded by 10 KiB at compile time below).
pub const HISTORY_DEPTH: usize = 32;

/// The flight history.
pub type MekfHistory = History<HISTORY_DEPTH>;

/// The flight history's storage, with or without a running filter.
pub type MekfHistorySlot = HistorySlot<HISTORY_DEPTH>;

// The RAM it costs, bounded on every target at compile time (10,016 B on the M4F, 10,024 B
// on the x86-64 host: 32 nodes of 312/313 B and the mirror of now).
const _: () = assert!(core::mem::size_of::<MekfHistory>() <= 10 * 1024);
// The parameters' cap on the nodes one late sample may re-run is the depth less one.
const _: () = assert!(crate::params::MAX_REPLAYED_NODES_LIMIT as usize == HISTORY_DEPTH - 1);

/// Seconds between two flight-clock times (µs), or `None` if `t1_us < t0_us`. The one
/// conversion every propagation of the history uses (exact below 2²⁴ µs ≈ 16.7 s).
pub fn span_s(t0_us: u64, t1_us: u64) -> Option<f32> {
    // Precision loss only above 2^24 µs, far beyond any accepted step (`max_dt_s`). Below
    // 2^32 µs through u32: the same rounding of the same integer, but one VCVT on the
    // Cortex-M4F instead of a u64 → f32 library call.
    t1_us.checked_sub(t0_us).map(|d| match u32::try_from(d) {
        Ok(d32) => d32 as f32 / 1.0e6,
        Err(_) => d as f32 / 1.0e6,
    })
}

/// A sample the history can fuse and, on a later replay, fuse again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Measurement {
    /// Star tracker: measured attitude (body → reference) and its covariance in body axes,
    /// rad² ([`Mekf::update_attitude`]).
    Attitude { q_meas: Quat, r_rad2: Mat3 },
    /// Unit vector: measured in body axes, its reference direction, 1σ angular noise, rad
    /// ([`Mekf::update_vector`]).
    Vector { body: Vec3, reference: Vec3, sigma_rad: f32 },
}

impl Measurement {
    /// Every number is finite.
    pub fn is_finite(&self) -> bool {
        match self {
            Self::Attitude { q_meas, r_rad2 } => {
                q_meas.coords.iter().all(|v| v.is_finite()) && r_rad2.iter().all(|v| v.is_finite())
            }
            Self::Vector { body, reference, sigma_rad } => {
                body.iter().all(|v| v.is_finite()) && reference.iter().all(|v| v.is_finite()) && sigma_rad.is_finite()
            }
        }
    }

    /// The filter's update for this sample; returns the NIS.
    pub fn apply(&self, filter: &mut Mekf) -> Result<f32, MekfError> {
        match self {
            Self::Attitude { q_meas, r_rad2 } => filter.update_attitude(q_meas, r_rad2),
            Self::Vector { body, reference, sigma_rad } => filter.update_vector(body, reference, *sigma_rad),
        }
    }
}

/// Why a sample was not fused (nothing changed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FuseRefusal {
    /// Taken before the oldest node: the history has passed it.
    TooOld,
    /// Taken after now (after the last propagation).
    FromTheFuture,
    /// Not newer than the sensor's last fused sample (the same sample again).
    Repeated,
    /// A NaN/inf, a zero quaternion or vector, or a non-positive σ.
    NonFiniteInput,
    /// A propagation of the replay failed (non-finite result): now is unchanged and the
    /// history before the failing node is dropped.
    ReplayFailed,
}

/// A fused sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FuseOutcome {
    /// The filter's answer at the sample's time: `Ok(nis)` accepted, `Err(Rejected)` the
    /// gate's rejection, other errors a failed update (state unchanged at that time).
    pub result: Result<f32, MekfError>,
    /// Later nodes re-run to carry the sample forward to now (0 for a sample at now).
    pub replayed_nodes: u32,
}

/// Why a propagation step changed nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepError {
    /// Increment or interval not finite, or interval not positive.
    NonFiniteInput,
    /// `t_end_us` is not after the last node.
    TimeNotIncreasing,
    /// The filter refused the step (e.g. span longer than `max_dt_s`).
    Filter(MekfError),
}

/// Telemetry of the history (all counters saturate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HistoryCounters {
    /// Propagation steps appended / refused.
    pub steps: u32,
    pub steps_refused: u32,
    /// Samples fused at now (no replay) / in the past (with a replay).
    pub fused_now: u32,
    pub fused_late: u32,
    /// Nodes re-run by replays, in total and the most in one replay.
    pub replayed_nodes: u32,
    pub max_replayed_nodes: u32,
    /// Refusals by reason.
    pub too_old: u32,
    pub from_the_future: u32,
    pub repeated: u32,
    pub non_finite: u32,
    pub replay_failed: u32,
}

impl HistoryCounters {
    /// No step, fusion or refusal yet.
    pub const ZERO: Self = Self {
        steps: 0,
        steps_refused: 0,
        fused_now: 0,
        fused_late: 0,
        replayed_nodes: 0,
        max_replayed_nodes: 0,
        too_old: 0,
        from_the_future: 0,
        repeated: 0,
        non_finite: 0,
        replay_failed: 0,
    };

    fn count_refusal(&mut self, reason: FuseRefusal) {
        let c = match reason {
            FuseRefusal::TooOld => &mut self.too_old,
            FuseRefusal::FromTheFuture => &mut self.from_the_future,
            FuseRefusal::Repeated => &mut self.repeated,
            FuseRefusal::NonFiniteInput => &mut self.non_finite,
            FuseRefusal::ReplayFailed => &mut self.replay_failed,
        };
        *c = c.saturating_add(1);
    }

    fn count_fused(&mut self, replayed: u32, late: bool) {
        if late {
            self.fused_late = self.fused_late.saturating_add(1);
        } else {
            self.fused_now = self.fused_now.saturating_add(1);
        }
        self.replayed_nodes = self.replayed_nodes.saturating_add(replayed);
        self.max_replayed_nodes = self.max_replayed_nodes.max(replayed);
    }
}

/// Per-sensor bookkeeping the caller keeps (one per sensor): the time of the last sample
/// fused, for the [`FuseRefusal::Repeated`] check, and the sensor's own counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SensorTrack {
    pub last_fused_us: Option<u64>,
    /// Samples fused (the gate's rejections included) / refused (saturating).
    pub fused: u32,
    pub refused: u32,
}

/// A node as [`History::nodes`] shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeView<'a> {
    /// Flight-clock time, µs.
    pub time_us: u64,
    /// Mean gyro rate of the step that ends here, rad/s (unused for the oldest node).
    pub rate_rad_s: Vec3,
    /// The sample fused here, if any (a gate rejection included).
    pub measurement: Option<Measurement>,
    /// The filter after propagating here and fusing the sample.
    pub filter: &'a Mekf,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    time_us: u64,
    /// Mean gyro rate of the step that ends here, rad/s (a sample node splitting a step
    /// carries that step's rate; unused for the oldest node).
    rate_rad_s: Vec3,
    /// The filter after propagating to `time_us` and fusing `measurement`.
    filter: Mekf,
    measurement: Option<Measurement>,
}

/// The history: a ring of `N` nodes (`N ≥ 2`, checked at compile time), never empty.
/// Equality is of what it holds (its nodes in use, oldest first), not of its storage.
#[derive(Clone, Debug)]
pub struct History<const N: usize> {
    nodes: [Node; N],
    /// Ring index of the oldest node; `len` nodes in use.
    head: usize,
    len: usize,
    /// Mirror of the newest node (now).
    now: Mekf,
    now_us: u64,
    counters: HistoryCounters,
}

impl<const N: usize> History<N> {
    const DEPTH_AT_LEAST_TWO: () = assert!(N >= 2, "a history needs at least two nodes");

    /// A history holding `filter` at `t0_us`. It is `N` nodes (32 filters, about 9 kB):
    /// build it once, at configuration, and [`restart`](Self::restart) it in a step.
    pub const fn new(filter: Mekf, t0_us: u64) -> Self {
        let () = Self::DEPTH_AT_LEAST_TWO;
        let node = Node { time_us: t0_us, rate_rad_s: Vec3::new(0.0, 0.0, 0.0), filter, measurement: None };
        Self { nodes: [node; N], head: 0, len: 1, now: filter, now_us: t0_us, counters: HistoryCounters::ZERO }
    }

    /// In place, the history [`new`](Self::new) gives: only the one node in use is
    /// written (the others are past `len`, never read). Building a new one in the step
    /// copied its `N` nodes: about 10,000 instructions on the Cortex-M4 (docs/timing.md).
    pub fn restart(&mut self, filter: Mekf, t0_us: u64) {
        if let Some(n) = self.nodes.get_mut(0) {
            *n = Node { time_us: t0_us, rate_rad_s: Vec3::zeros(), filter, measurement: None };
        }
        self.head = 0;
        self.len = 1;
        self.now = filter;
        self.now_us = t0_us;
        self.counters = HistoryCounters::ZERO;
    }

    /// The filter at now.
    pub fn filter(&self) -> &Mekf {
        &self.now
    }

    /// Flight-clock time of now (the end of the last propagation step), µs.
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Time of the oldest node: samples before it are refused as too old.
    pub fn oldest_us(&self) -> u64 {
        self.at(0).map_or(self.now_us, |n| n.time_us)
    }

    /// Nodes in use (≤ `N`).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Never true (a history always holds now); for clippy's `len_without_is_empty`.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Nodes later than `t_us`: what fusing a sample taken then would re-run.
    pub fn nodes_after(&self, t_us: u64) -> usize {
        (0..self.len).rev().take_while(|&k| self.at(k).is_some_and(|n| n.time_us > t_us)).count()
    }

    pub fn counters(&self) -> HistoryCounters {
        self.counters
    }

    /// The nodes, oldest first: what a test oracle reads to feed a reference filter the
    /// same propagation steps and samples in time order.
    pub fn nodes(&self) -> impl Iterator<Item = NodeView<'_>> {
        (0..self.len).filter_map(|k| self.at(k)).map(|n| NodeView {
            time_us: n.time_us,
            rate_rad_s: n.rate_rad_s,
            measurement: n.measurement,
            filter: &n.filter,
        })
    }

    /// Ring slot of the `k`-th oldest node.
    fn slot(&self, k: usize) -> Option<usize> {
        self.head.checked_add(k).and_then(|i| i.checked_rem(N))
    }

    fn at(&self, k: usize) -> Option<&Node> {
        if k >= self.len {
            return None;
        }
        self.slot(k).and_then(|i| self.nodes.get(i))
    }

    fn at_mut(&mut self, k: usize) -> Option<&mut Node> {
        if k >= self.len {
            return None;
        }
        self.slot(k).and_then(|i| self.nodes.get_mut(i))
    }

    /// Forget the `k` oldest nodes (at most `len − 1`: now is always kept).
    fn drop_oldest(&mut self, k: usize) {
        let k = k.min(self.len.saturating_sub(1));
        if let Some(head) = self.slot(k) {
            self.head = head;
            self.len = self.len.saturating_sub(k);
        }
    }

    /// Put `node` at logical position `p` (1 ≤ p ≤ len), shifting the later nodes up; a
    /// full ring forgets its oldest node first. Returns the node's position.
    fn insert(&mut self, p: usize, node: Node) -> usize {
        let mut p = p;
        if self.len >= N {
            self.drop_oldest(1);
            p = p.saturating_sub(1);
        }
        let old_len = self.len;
        self.len = old_len.saturating_add(1).min(N);
        // Bounded by N: move nodes p..old_len up by one, newest first.
        for k in (p..old_len).rev() {
            if let (Some(moved), Some(dst)) = (self.at(k).copied(), self.at_mut(k.saturating_add(1))) {
                *dst = moved;
            }
        }
        if let Some(dst) = self.at_mut(p) {
            *dst = node;
        }
        p
    }

    /// Append one propagation step ending at `t_end_us`: the gyro's angle increment
    /// `gyro_increment_rad` (body axes) over its integration interval `interval_s` gives
    /// the step's mean rate, held over the flight-clock span from now to `t_end_us`.
    pub fn propagate(&mut self, gyro_increment_rad: &Vec3, interval_s: f32, t_end_us: u64) -> Result<(), StepError> {
        let result = self.try_propagate(gyro_increment_rad, interval_s, t_end_us);
        let c = if result.is_ok() { &mut self.counters.steps } else { &mut self.counters.steps_refused };
        *c = c.saturating_add(1);
        result
    }

    /// Append one propagation step ending at `t_end_us` with the rate `rate_rad_s` held
    /// over it (a gyro that gives rate samples only).
    pub fn propagate_rate(&mut self, rate_rad_s: &Vec3, t_end_us: u64) -> Result<(), StepError> {
        let result = self.try_propagate_rate(*rate_rad_s, t_end_us);
        let c = if result.is_ok() { &mut self.counters.steps } else { &mut self.counters.steps_refused };
        *c = c.saturating_add(1);
        result
    }

    fn try_propagate(&mut self, increment: &Vec3, interval_s: f32, t_end_us: u64) -> Result<(), StepError> {
        if !(interval_s.is_finite() && interval_s > 0.0 && increment.iter().all(|v| v.is_finite())) {
            return Err(StepError::NonFiniteInput);
        }
        self.try_propagate_rate(increment / interval_s, t_end_us)
    }

    fn try_propagate_rate(&mut self, rate: Vec3, t_end_us: u64) -> Result<(), StepError> {
        if !rate.iter().all(|v| v.is_finite()) {
            return Err(StepError::NonFiniteInput);
        }
        let dt = span_s(self.now_us, t_end_us).filter(|dt| *dt > 0.0).ok_or(StepError::TimeNotIncreasing)?;
        let mut filter = self.now;
        filter.propagate(&rate, dt).map_err(StepError::Filter)?;
        let node = Node { time_us: t_end_us, rate_rad_s: rate, filter, measurement: None };
        let end = self.len;
        self.insert(end, node);
        self.now = filter;
        self.now_us = t_end_us;
        Ok(())
    }

    /// Fuse `measurement`, taken at `t_sample_us` by the sensor tracked in `sensor`, at its
    /// own time and carry the result forward to now. Refusals change nothing but the
    /// counters (here and in `sensor`).
    pub fn fuse_at(
        &mut self,
        sensor: &mut SensorTrack,
        t_sample_us: u64,
        measurement: &Measurement,
    ) -> Result<FuseOutcome, FuseRefusal> {
        let result = self.try_fuse(sensor, t_sample_us, measurement);
        match result {
            Ok(outcome) => {
                sensor.last_fused_us = Some(t_sample_us);
                sensor.fused = sensor.fused.saturating_add(1);
                self.counters.count_fused(outcome.replayed_nodes, t_sample_us < self.now_us);
            }
            Err(reason) => {
                sensor.refused = sensor.refused.saturating_add(1);
                self.counters.count_refusal(reason);
            }
        }
        result
    }

    /// Fuse `measurement`, taken at `t_sample_us` after now, when the gyro has caught up
    /// with it: propagate now → `t_sample_us` with `rate_rad_s` (the mean rate of the gyro
    /// step that contains it), apply the update there and keep both in *one* node (a sample
    /// node whose step ends at its time). The result is, operation for operation, that of
    /// propagating to `t_sample_us` and fusing at now, or of fusing it late through
    /// [`Self::fuse_at`] after the whole step (same propagation spans, same update), without
    /// a replay and with one node instead of two. A sample at or before now goes to
    /// [`Self::fuse_at`].
    ///
    /// `Err(step)`: the propagation failed (nothing changed, counted as a refused step);
    /// `Ok(Err(refusal))`: propagated (the node kept, without the sample), sample refused.
    pub fn fuse_ahead(
        &mut self,
        sensor: &mut SensorTrack,
        rate_rad_s: &Vec3,
        t_sample_us: u64,
        measurement: &Measurement,
    ) -> Result<Result<FuseOutcome, FuseRefusal>, StepError> {
        if t_sample_us <= self.now_us {
            return Ok(self.fuse_at(sensor, t_sample_us, measurement));
        }
        if !measurement.is_finite() || sensor.last_fused_us.is_some_and(|last| t_sample_us <= last) {
            // Refused before anything moves: the caller propagates without it.
            return Ok(self.fuse_at(sensor, t_sample_us, measurement));
        }
        self.propagate_rate(rate_rad_s, t_sample_us)?;
        // Now is the propagation node just appended: fuse there (no replay), then fold the
        // sample into that node.
        let mut filter = self.now;
        let result = measurement.apply(&mut filter);
        if matches!(result, Err(MekfError::NonFiniteInput | MekfError::BadConfig | MekfError::BadTimeStep)) {
            sensor.refused = sensor.refused.saturating_add(1);
            self.counters.count_refusal(FuseRefusal::NonFiniteInput);
            return Ok(Err(FuseRefusal::NonFiniteInput));
        }
        let last = self.len.saturating_sub(1);
        if let Some(node) = self.at_mut(last) {
            node.filter = filter;
            node.measurement = Some(*measurement);
        }
        self.now = filter;
        sensor.last_fused_us = Some(t_sample_us);
        sensor.fused = sensor.fused.saturating_add(1);
        self.counters.count_fused(0, false);
        Ok(Ok(FuseOutcome { result, replayed_nodes: 0 }))
    }

    fn try_fuse(&mut self, sensor: &SensorTrack, t_s: u64, m: &Measurement) -> Result<FuseOutcome, FuseRefusal> {
        if !m.is_finite() {
            return Err(FuseRefusal::NonFiniteInput);
        }
        if sensor.last_fused_us.is_some_and(|last| t_s <= last) {
            return Err(FuseRefusal::Repeated);
        }
        if t_s > self.now_us {
            return Err(FuseRefusal::FromTheFuture);
        }
        if t_s < self.oldest_us() {
            return Err(FuseRefusal::TooOld);
        }
        // Position after the last node at or before t_s (1 ≤ p ≤ len: the oldest is at or
        // before t_s); searched from now, where late samples usually land.
        let p = (0..self.len)
            .rev()
            .find(|&k| self.at(k).is_some_and(|n| n.time_us <= t_s))
            .map_or(1, |k| k.saturating_add(1));
        let before = *self.at(p.saturating_sub(1)).ok_or(FuseRefusal::ReplayFailed)?;
        // The rate of the step containing t_s (piecewise constant); irrelevant at now.
        let rate = self.at(p).map_or(before.rate_rad_s, |n| n.rate_rad_s);
        let mut filter = before.filter;
        let dt = span_s(before.time_us, t_s).ok_or(FuseRefusal::ReplayFailed)?;
        if dt > 0.0 {
            filter.propagate(&rate, dt).map_err(|_| FuseRefusal::ReplayFailed)?;
        }
        let result = m.apply(&mut filter);
        if matches!(result, Err(MekfError::NonFiniteInput | MekfError::BadConfig | MekfError::BadTimeStep)) {
            return Err(FuseRefusal::NonFiniteInput);
        }
        let node = Node { time_us: t_s, rate_rad_s: rate, filter, measurement: Some(*m) };
        let p = self.insert(p, node);
        let replayed_nodes = self.replay_after(p)?;
        Ok(FuseOutcome { result, replayed_nodes })
    }

    /// Re-run every node after position `p` from the node at `p`: propagate with its stored
    /// rate, re-apply its stored sample, rewrite it; the last one is now. On a failed
    /// propagation now is left as it was and the nodes before the failing one (rewritten,
    /// or holding the refused sample) are forgotten.
    fn replay_after(&mut self, p: usize) -> Result<u32, FuseRefusal> {
        let Some(&start) = self.at(p) else { return Err(FuseRefusal::ReplayFailed) };
        let (mut t_prev, mut filter) = (start.time_us, start.filter);
        let mut replayed: u32 = 0;
        for k in p.saturating_add(1)..self.len {
            let Some(&node) = self.at(k) else { break };
            let dt = span_s(t_prev, node.time_us).unwrap_or(0.0);
            let mut next = filter;
            if dt > 0.0 && next.propagate(&node.rate_rad_s, dt).is_err() {
                self.drop_oldest(k);
                return Err(FuseRefusal::ReplayFailed);
            }
            if let Some(m) = node.measurement {
                // Its outcome may differ from the first time (the point of the replay); the
                // filter leaves the state unchanged when it refuses.
                let _ = m.apply(&mut next);
            }
            if let Some(dst) = self.at_mut(k) {
                dst.filter = next;
            }
            (t_prev, filter) = (node.time_us, next);
            replayed = replayed.saturating_add(1);
        }
        self.now = filter;
        Ok(replayed)
    }
}

impl<const N: usize> PartialEq for History<N> {
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len
            && (0..self.len).all(|k| self.at(k) == other.at(k))
            && self.now == other.now
            && self.now_us == other.now_us
            && self.counters == other.counters
    }
}

/// One history's storage, running a filter or not. A filter starts in place
/// ([`History::restart`]): the `N` nodes are built once, at configuration, never in a
/// step (an `Option<History>` rebuilt on each start cost the step ~10,000 instructions).
#[derive(Clone, Debug)]
pub struct HistorySlot<const N: usize> {
    history: History<N>,
    running: bool,
}

impl<const N: usize> HistorySlot<N> {
    /// No filter running; `cfg` only fills the storage.
    pub const fn idle(cfg: MekfConfig) -> Self {
        Self { history: History::new(Mekf::placeholder(cfg), 0), running: false }
    }

    /// The running filter's history.
    pub fn get(&self) -> Option<&History<N>> {
        if self.running { Some(&self.history) } else { None }
    }

    pub fn get_mut(&mut self) -> Option<&mut History<N>> {
        if self.running { Some(&mut self.history) } else { None }
    }

    pub fn is_running(&self) -> bool {
        self.running
    }

    /// Start (or start again) with `filter` at `t0_us`.
    pub fn start(&mut self, filter: Mekf, t0_us: u64) {
        self.history.restart(filter, t0_us);
        self.running = true;
    }

    /// Stop the filter; true when one was running.
    pub fn stop(&mut self) -> bool {
        core::mem::replace(&mut self.running, false)
    }
}

/// Equal when neither runs, or both run equal histories (the storage of a stopped one is
/// not state).
impl<const N: usize> PartialEq for HistorySlot<N> {
    fn eq(&self, other: &Self) -> bool {
        self.get() == other.get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::mekf::MekfConfig;

    fn history() -> History<4> {
        let cfg = MekfConfig {
            gyro_arw_rad_sqrt_s: 1e-4,
            gyro_rrw_rad_s_sqrt_s: 1e-6,
            initial_attitude_sigma_rad: 0.01,
            initial_bias_sigma_rad_s: 1e-4,
            max_dt_s: 1.0,
            gate_attitude: 16.266,
            gate_vector: 13.816,
        };
        let filter = Mekf::new(cfg, Quat::identity(), Vec3::zeros()).unwrap();
        History::new(filter, 0)
    }

    #[test]
    fn counters_saturate() {
        let mut h = history();
        h.counters = HistoryCounters {
            steps: u32::MAX,
            fused_now: u32::MAX,
            replayed_nodes: u32::MAX,
            too_old: u32::MAX,
            ..HistoryCounters::default()
        };
        h.propagate(&Vec3::zeros(), 0.1, 100_000).unwrap();
        let mut sensor = SensorTrack { fused: u32::MAX, refused: u32::MAX, ..SensorTrack::default() };
        let m = Measurement::Attitude { q_meas: Quat::identity(), r_rad2: Mat3::identity() * 1e-6 };
        h.fuse_at(&mut sensor, 100_000, &m).unwrap();
        assert_eq!(h.fuse_at(&mut SensorTrack::default(), 200_000, &m), Err(FuseRefusal::FromTheFuture));
        for t in 2..10 {
            h.propagate(&Vec3::zeros(), 0.1, t * 100_000).unwrap();
        }
        assert_eq!(h.fuse_at(&mut sensor, 150_000, &m), Err(FuseRefusal::TooOld));
        let c = h.counters();
        assert_eq!((c.steps, c.fused_now, c.replayed_nodes, c.too_old), (u32::MAX, u32::MAX, u32::MAX, u32::MAX));
        assert_eq!((sensor.fused, sensor.refused), (u32::MAX, u32::MAX));
        assert_eq!(h.len(), 4);
    }

    #[test]
    fn a_failed_replay_keeps_now_and_forgets_what_it_rewrote() {
        let mut h = history();
        for k in 1..=3u64 {
            h.propagate(&Vec3::new(0.001, 0.0, 0.0), 0.1, k * 100_000).unwrap();
        }
        let now = *h.filter();
        // A node whose stored rate cannot be propagated (stands for an overflow on replay).
        h.at_mut(2).unwrap().rate_rad_s.x = f32::NAN;
        let m = Measurement::Attitude { q_meas: Quat::identity(), r_rad2: Mat3::identity() * 1e-6 };
        let mut sensor = SensorTrack::default();
        assert_eq!(h.fuse_at(&mut sensor, 50_000, &m), Err(FuseRefusal::ReplayFailed));
        assert_eq!(format!("{:?}", h.filter()), format!("{now:?}"));
        // Inserted at 1, rewritten up to 1, failed at 3 (the corrupted node, shifted up):
        // the nodes from 3 on (the old 200 000 and 300 000 µs) remain.
        assert_eq!((h.len(), h.oldest_us(), h.now_us()), (2, 200_000, 300_000));
        assert_eq!((h.counters().replay_failed, sensor.refused, sensor.last_fused_us), (1, 1, None));
    }

    #[test]
    fn fusing_ahead_is_propagating_then_fusing_at_now_in_one_node() {
        let rate = Vec3::new(0.01, -0.02, 0.005);
        let m = Measurement::Vector { body: Vec3::new(0.6, 0.8, 0.0), reference: Vec3::x(), sigma_rad: 0.01 };
        let (mut a, mut b) = (history(), history());
        let (mut sa, mut sb) = (SensorTrack::default(), SensorTrack::default());
        let outcome = a.fuse_ahead(&mut sa, &rate, 70_000, &m).unwrap().unwrap();
        b.propagate_rate(&rate, 70_000).unwrap();
        let reference = b.fuse_at(&mut sb, 70_000, &m).unwrap();
        assert_eq!(outcome, reference);
        assert_eq!(a.filter(), b.filter());
        assert_eq!((a.len(), b.len(), a.now_us()), (2, 3, 70_000));
        assert_eq!((sa, a.counters().fused_now, a.counters().steps), (sb, 1, 1));
        // Then carried on with the same rate to the gyro's time, and a replay that passes over
        // the folded node re-applies its sample: the same as the two-node history.
        a.propagate_rate(&rate, 100_000).unwrap();
        b.propagate_rate(&rate, 100_000).unwrap();
        let late = Measurement::Vector { body: Vec3::y(), reference: Vec3::y(), sigma_rad: 0.02 };
        a.fuse_at(&mut SensorTrack::default(), 40_000, &late).unwrap();
        b.fuse_at(&mut SensorTrack::default(), 40_000, &late).unwrap();
        assert_eq!(a.filter(), b.filter());
        // Refusals change nothing but the counters; a non-finite rate is a failed step.
        let before = a.clone();
        assert_eq!(a.fuse_ahead(&mut sa, &rate, 60_000, &m), Ok(Err(FuseRefusal::Repeated)));
        let nan = Measurement::Vector { body: Vec3::new(f32::NAN, 0.0, 0.0), reference: Vec3::x(), sigma_rad: 0.01 };
        assert_eq!(a.fuse_ahead(&mut sa, &rate, 200_000, &nan), Ok(Err(FuseRefusal::NonFiniteInput)));
        assert_eq!(a.fuse_ahead(&mut sa, &Vec3::new(f32::NAN, 0.0, 0.0), 200_000, &m), Err(StepError::NonFiniteInput));
        assert_eq!((a.filter(), a.now_us(), a.len()), (before.filter(), before.now_us(), before.len()));
    }

    #[test]
    fn ring_keeps_time_order_across_wraps() {
        let mut h = history();
        let m = Measurement::Vector { body: Vec3::x(), reference: Vec3::x(), sigma_rad: 0.01 };
        let mut sensor = SensorTrack::default();
        for k in 1..=11u64 {
            h.propagate(&Vec3::zeros(), 0.1, k * 100_000).unwrap();
            if k % 3 == 0 {
                h.fuse_at(&mut sensor, k * 100_000 - 50_000, &m).unwrap();
            }
            let times: Vec<u64> = (0..h.len()).map(|i| h.at(i).unwrap().time_us).collect();
            assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
            assert_eq!(*times.last().unwrap(), h.now_us());
        }
    }

    /// Propagations (one wrapping the ring), samples at now, late ones (replays over the
    /// nodes a previous use left behind) and refusals: every outcome, in order.
    fn exercise(h: &mut History<4>, t0_us: u64) -> Vec<String> {
        let mut seen = Vec::new();
        let mut sensor = SensorTrack::default();
        let v = Measurement::Vector { body: Vec3::new(0.6, 0.8, 0.0), reference: Vec3::x(), sigma_rad: 0.01 };
        let q = Measurement::Attitude { q_meas: Quat::new(0.999, 0.02, -0.01, 0.03), r_rad2: Mat3::identity() * 1e-6 };
        for k in 1..=7u64 {
            let t = t0_us + k * 100_000;
            seen.push(format!("{:?}", h.propagate(&Vec3::new(1e-3 * k as f32, -2e-3, 5e-4), 0.1, t)));
            seen.push(format!("{:?}", h.fuse_at(&mut sensor, t - 30_000 * (k % 3), if k % 2 == 0 { &v } else { &q })));
        }
        seen.push(format!("{:?}", h.fuse_at(&mut sensor, t0_us, &v)));
        seen.extend(h.nodes().map(|n| format!("{} {:?} {:?} {:?}", n.time_us, n.rate_rad_s, n.measurement, n.filter)));
        seen.push(format!("{:?} {:?} {}", h.counters(), sensor, h.now_us()));
        seen
    }

    /// A restart in place is the history `new` builds: equal, and every later outcome
    /// the same to the bit (Debug prints each f32 exactly), though the old nodes stay in
    /// the storage past `len`.
    #[test]
    fn a_restarted_history_is_a_new_one() {
        let mut used = history();
        let before = exercise(&mut used, 0);
        assert_eq!(used.len(), 4, "the first use fills the ring");
        let f = Mekf::new(*used.filter().config(), Quat::new(0.8, 0.0, 0.6, 0.0), Vec3::new(1e-4, 0.0, -2e-4)).unwrap();
        used.restart(f, 5_000_000);
        let mut fresh = History::new(f, 5_000_000);
        assert_eq!(used, fresh);
        assert_eq!(exercise(&mut used, 5_000_000), exercise(&mut fresh, 5_000_000));
        assert_ne!(before, exercise(&mut history(), 5_000_000), "the script's outcomes depend on its start");
        assert_eq!(used, fresh);
        // A slot: no history until started; stopped, it compares as never started.
        let mut slot = HistorySlot::<4>::idle(*f.config());
        assert!(slot.get().is_none() && !slot.stop());
        slot.start(f, 7);
        assert_eq!((slot.get().map(History::now_us), slot.stop()), (Some(7), true));
        assert_eq!(slot, HistorySlot::idle(*f.config()));
    }
}
