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
//!
//! The same samples are also pooled by mission pointing (`mission_pointings`): one entry
//! for the scenario's pointing and one for each ground command that sets one, known
//! before the run starts, so its keys are the same in every run whatever modes and
//! segments the run goes through (a campaign's requirements address them). Each branch's
//! figures are those of the union of the samples of every segment of that pointing and
//! branch, in whatever mode without a pointing of its own (exact: the histograms' counts
//! are added, [`PooledAxes`]).

use super::pointing::{AxisFigures, PointingStats, PooledAxes, Windows};
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

/// One branch of a mission pointing, pooled over its segments (`summary.json`
/// `mission_pointings.pN.pointing` / `.otherwise`), deg.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BranchFigures {
    /// Segments of this pointing and branch (with or without samples).
    pub segments: u64,
    pub ape_deg: AxisFigures,
    pub rpe_deg: AxisFigures,
    /// The primary (boresight) error apart; no samples (null) for a fixed attitude.
    pub primary_ape_deg: AxisFigures,
    pub primary_rpe_deg: AxisFigures,
}

/// One mission pointing (`summary.json` `mission_pointings.pN`: `p0` the scenario's,
/// `pN` the N-th ground command that sets a pointing or a target).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionPointing {
    pub label: String,
    /// When it takes effect (the command's `at_s`; 0 for the scenario's), s.
    pub at_s: f64,
    pub pointing: BranchFigures,
    pub otherwise: BranchFigures,
}

/// Every mission pointing, serialised as a map `p0`, `p1`, … in the order they take
/// effect.
#[derive(Clone, Debug, PartialEq)]
pub struct MissionPointings(pub Vec<MissionPointing>);

impl Serialize for MissionPointings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().enumerate().map(|(i, m)| (format!("p{i}"), m)))
    }
}

#[derive(Clone, Default)]
struct BranchPool {
    segments: u64,
    ape: PooledAxes,
    rpe: PooledAxes,
    primary_ape: PooledAxes,
    primary_rpe: PooledAxes,
}

impl BranchPool {
    fn figures(&self, p: f64) -> BranchFigures {
        BranchFigures {
            segments: self.segments,
            ape_deg: self.ape.figures(p),
            rpe_deg: self.rpe.figures(p),
            primary_ape_deg: self.primary_ape.figures(p),
            primary_rpe_deg: self.primary_rpe.figures(p),
        }
    }
}

#[derive(Clone)]
struct Pool {
    label: String,
    at_s: f64,
    main: BranchPool,
    otherwise: BranchPool,
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
    /// The mission pointings, indexed by [`SegmentKey::pointing`].
    pools: Vec<Pool>,
}

impl Segments {
    /// `mission`: each mission pointing's label and start (s), in the order they take
    /// effect (the index is [`SegmentKey::pointing`]).
    pub fn new(windows: Windows, confidence: f64, settle_s: f64, from_s: f64, mission: Vec<(String, f64)>) -> Self {
        let pools = mission
            .into_iter()
            .map(|(label, at_s)| Pool { label, at_s, main: BranchPool::default(), otherwise: BranchPool::default() })
            .collect();
        Self { windows, confidence, settle_s, from_s, live: None, done: Vec::new(), unlisted: 0, count: 0, pools }
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
        let Some(Live { key, mut summary, attitude, primary }) = self.live.take() else { return };
        // A mode's own pointing (keyed from u32::MAX down) is not a mission pointing.
        if let Some(pool) = self.pools.get_mut(key.pointing as usize) {
            let b = match key.branch {
                Branch::Main => &mut pool.main,
                Branch::Otherwise => &mut pool.otherwise,
            };
            b.segments += 1;
            b.ape.absorb(&attitude.ape);
            b.rpe.absorb(&attitude.rpe);
            if let Some(pr) = &primary {
                b.primary_ape.absorb(&pr.ape);
                b.primary_rpe.absorb(&pr.rpe);
            }
        }
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

    /// Every segment (the live one closed), how many were not listed, and the mission
    /// pointings' pooled figures.
    pub fn finish(mut self) -> (Vec<SegmentSummary>, u64, MissionPointings) {
        self.close();
        let p = self.confidence;
        let mission = self
            .pools
            .iter()
            .map(|m| MissionPointing {
                label: m.label.clone(),
                at_s: m.at_s,
                pointing: m.main.figures(p),
                otherwise: m.otherwise.figures(p),
            })
            .collect();
        (self.done, self.unlisted, MissionPointings(mission))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recorder::pointing::MagnitudeQuantile;

    fn err(i: usize) -> [f64; 3] {
        // Deterministic, varied magnitudes (no two alike).
        let x = i as f64;
        [0.01 * (0.37 * x).sin(), 0.02 * (0.11 * x + 1.0).cos(), 0.001 * x / (1.0 + x)]
    }

    /// The pooled figures of a mission pointing are those of one statistic fed every sample
    /// of its segments (segments of whole windows, so the RPE windows coincide); the APE
    /// also against a nearest-rank quantile of the sorted norms (histogram edge: at most
    /// `RATIO` above, never below); a mode's own pointing and another branch stay apart.
    #[test]
    fn mission_pointings_pool_their_segments_exactly() {
        let w = Windows { window: 4, drift_separation: 1, stability: 1 };
        let p = 0.95;
        let mission = vec![("nadir".to_string(), 0.0), ("pass".to_string(), 30.0)];
        let mut seg = Segments::new(w, p, 0.0, 0.0, mission);
        let mut single = PointingStats::new(w);
        let mut norms = Vec::new();
        let key = |mode, pointing, branch| SegmentKey { mode: Some(mode), pointing, branch };
        // p0 in mode 2 (12 steps), p0 in mode 3 (8 steps), a mode's own pointing (8),
        // p0 in mode 2 again (16), then p1 while its site is hidden (8).
        let plan = [(2u8, 0u32, Branch::Main, 12), (3, 0, Branch::Main, 8), (4, u32::MAX - 4, Branch::Main, 8)];
        let plan = plan.into_iter().chain([(2, 0, Branch::Main, 16), (2, 1, Branch::Otherwise, 8)]);
        let mut i = 0;
        for (mode, pointing, branch, n) in plan {
            for _ in 0..n {
                let e = err(i);
                seg.push(i as f64, key(mode, pointing, branch), (None, "x"), e, Some(e));
                if pointing == 0 {
                    single.push(e);
                    norms.push((e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt());
                }
                i += 1;
            }
        }
        let (list, _, MissionPointings(m)) = seg.finish();
        assert_eq!(list.len(), 5);
        assert_eq!(m.len(), 2);
        let p0 = &m[0].pointing;
        assert_eq!(p0.segments, 3);
        assert_eq!(p0.ape_deg, single.ape.figures(p));
        assert_eq!(p0.rpe_deg, single.rpe.figures(p));
        assert_eq!(p0.primary_ape_deg, single.ape.figures(p));
        assert_eq!(p0.ape_deg.samples, 36);
        assert_eq!(p0.rpe_deg.samples, 36);
        norms.sort_by(f64::total_cmp);
        let exact = norms[(p * norms.len() as f64).ceil() as usize - 1];
        let pooled = p0.ape_deg.total.unwrap();
        assert!(pooled >= exact && pooled <= exact * MagnitudeQuantile::RATIO, "{pooled} vs {exact}");
        assert_eq!(m[0].otherwise.segments, 0);
        assert_eq!(m[0].otherwise.ape_deg.total, None);
        assert_eq!(m[1].pointing.segments, 0);
        assert_eq!(m[1].otherwise.ape_deg.samples, 8);
        assert_eq!((m[1].label.as_str(), m[1].at_s), ("pass", 30.0));
        let json = serde_json::to_value(MissionPointings(m)).unwrap();
        assert!(json["p0"]["pointing"]["primary_ape_deg"]["total"].is_number());
        assert!(json["p1"]["pointing"]["primary_ape_deg"]["total"].is_null());
    }
}
