//! Pointing performance in the indices space requirements are written in (the
//! control-performance framework of ECSS-E-ST-60-10C; definitions in our words in
//! `docs/pointing.md`), computed as the run goes in bounded memory.
//!
//! The input is the attitude-error vector `e(t)` (body axes, small-angle rotation vector
//! of the error quaternion, deg), sampled once per control step (period `dt`). Over the
//! evaluation period (from `from_s` to the end of the run) and with windows of whole
//! samples:
//! - **APE** (absolute performance error): `e(t)` itself;
//! - **MPE** (mean performance error): the mean of `e` over each window of length `Δt`;
//! - **RPE** (relative performance error): `e(t) − ē_w`, the error less the mean of the
//!   window `w` of length `Δt` that contains `t` (windows tile the period back to back);
//! - **PDE** (performance drift error): `ē_{w+m} − ē_w`, the change of the window mean
//!   between two windows whose starts are `Δt_s = m Δt` apart;
//! - **stability** (the "jitter" of older pointing handbooks): `e(t + Δt) − e(t)`.
//!
//! Each index is reported per axis and in total (the Euclidean norm of the index vector:
//! for the APE, the principal error angle to first order) as the value that the index's
//! magnitude stays below for a fraction `p` (the confidence level, e.g. 0.95) of the
//! samples of the period: the temporal statistical interpretation of ECSS-E-ST-60-10C.
//! Over a campaign the runs' figures are then required with a probability and a
//! confidence (the ensemble interpretation; `docs/campaigns.md`).
//!
//! Memory does not grow with the run: each statistic is a log-binned histogram
//! ([`MagnitudeQuantile`], relative resolution [`MagnitudeQuantile::RATIO`]), and the
//! windows hold at most [`MAX_WINDOW_SAMPLES`] samples.

/// Most samples in one window (RPE, stability); longer windows are refused.
pub const MAX_WINDOW_SAMPLES: usize = 1 << 17;
/// Most windows between the two windows of a drift (PDE) pair.
pub const MAX_DRIFT_WINDOWS: usize = 1 << 12;

/// Quantiles of a non-negative magnitude, streamed: a histogram whose bins split every
/// octave (power of two) between [`MagnitudeQuantile::FLOOR`] and
/// [`MagnitudeQuantile::CEILING`] into [`MagnitudeQuantile::SUB_BINS`] equal parts — the
/// bin is read off the float's exponent and top mantissa bits, no logarithm (a few integer
/// operations per sample: the run loop pays it every step). A quantile is reported as the
/// upper edge of its bin, so it over-estimates by less than `RATIO − 1` (0.39 %) and never
/// under-estimates; magnitudes below the floor count as the floor, at or above the
/// ceiling (or non-finite) as +∞.
#[derive(Clone, Debug)]
pub struct MagnitudeQuantile {
    /// Counts per bin (a run has at most `u32::MAX` control steps: `scenario::MAX_STEPS`).
    bins: Vec<u32>,
    below_floor: u64,
    above_ceiling: u64,
    count: u64,
    max: f64,
    /// The largest magnitude within the binned range (caps a quantile's bin edge).
    max_binned: f64,
}

impl Default for MagnitudeQuantile {
    fn default() -> Self {
        Self::new()
    }
}

/// log2 of the bins per octave.
const SUB_BITS: u32 = 8;
/// Binary exponents of the floor and of the ceiling.
const FLOOR_EXP: i32 = -34;
const CEILING_EXP: i32 = 10;

impl MagnitudeQuantile {
    /// Bins per octave.
    pub const SUB_BINS: usize = 1 << SUB_BITS;
    /// Largest ratio of a bin's upper to its lower edge (the first bin of an octave).
    pub const RATIO: f64 = 1.0 + 1.0 / Self::SUB_BINS as f64;
    /// Smallest magnitude resolved, 2⁻³⁴ ≈ 5.8e-11 (deg: far below any sensor's
    /// resolution).
    pub const FLOOR: f64 = 1.0 / (1u64 << (-FLOOR_EXP)) as f64;
    /// Magnitudes from here up are not binned (+∞), 2¹⁰ = 1024 (deg: above any error
    /// vector's norm, ≤ 2π√3 rad).
    pub const CEILING: f64 = (1u64 << CEILING_EXP) as f64;

    pub fn new() -> Self {
        let n = ((CEILING_EXP - FLOOR_EXP) as usize) << SUB_BITS;
        Self { bins: vec![0; n], below_floor: 0, above_ceiling: 0, count: 0, max: 0.0, max_binned: 0.0 }
    }

    /// Bin of a magnitude in [FLOOR, CEILING): octave above the floor, then the top
    /// `SUB_BITS` bits of the mantissa.
    fn bin(m: f64) -> usize {
        let bits = m.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32 - 1023;
        let sub = ((bits >> (52 - SUB_BITS)) as usize) & (Self::SUB_BINS - 1);
        (((exp - FLOOR_EXP) as usize) << SUB_BITS) | sub
    }

    /// Upper edge of bin `i`: `2^e (1 + (sub + 1) / SUB_BINS)`.
    fn upper_edge(i: usize) -> f64 {
        let exp = (i >> SUB_BITS) as i32 + FLOOR_EXP;
        let sub = (i & (Self::SUB_BINS - 1)) as f64;
        2f64.powi(exp) * (1.0 + (sub + 1.0) / Self::SUB_BINS as f64)
    }

    /// Adds one magnitude (its absolute value; NaN counts as +∞: it fails any bound).
    pub fn push(&mut self, x: f64) {
        let m = x.abs();
        self.count += 1;
        if !(m < Self::CEILING) {
            self.above_ceiling += 1;
            self.max = f64::INFINITY;
            return;
        }
        self.max = self.max.max(m);
        self.max_binned = self.max_binned.max(m);
        if m < Self::FLOOR {
            self.below_floor += 1;
            return;
        }
        if let Some(b) = self.bins.get_mut(Self::bin(m)) {
            *b = b.saturating_add(1);
        }
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    /// Empties the histogram (as new, without reallocating).
    pub fn clear(&mut self) {
        self.bins.fill(0);
        (self.below_floor, self.above_ceiling, self.count, self.max, self.max_binned) = (0, 0, 0, 0.0, 0.0);
    }

    /// The largest magnitude pushed (exact).
    pub fn max(&self) -> f64 {
        self.max
    }

    /// The smallest bound that at least a fraction `p` of the magnitudes stay at or below
    /// (nearest-rank), `None` when empty or `p` is outside (0, 1].
    pub fn quantile(&self, p: f64) -> Option<f64> {
        let bins = self.bins.iter().enumerate().map(|(i, n)| (i, u64::from(*n)));
        nearest_rank(p, self.count, self.below_floor, self.max_binned, bins)
    }
}

/// The nearest-rank quantile `p` of a histogram: `count` magnitudes, `below_floor` of them
/// under the floor, the occupied bins in increasing order (bin, count); the rest (above
/// the ceiling) are +∞.
fn nearest_rank(
    p: f64,
    count: u64,
    below_floor: u64,
    max_binned: f64,
    bins: impl Iterator<Item = (usize, u64)>,
) -> Option<f64> {
    if count == 0 || !(p > 0.0 && p <= 1.0) {
        return None;
    }
    let rank = ((p * count as f64).ceil() as u64).clamp(1, count);
    let mut seen = below_floor;
    if seen >= rank {
        return Some(MagnitudeQuantile::FLOOR.min(max_binned));
    }
    for (i, n) in bins {
        seen += n;
        if seen >= rank {
            return Some(MagnitudeQuantile::upper_edge(i).min(max_binned));
        }
    }
    Some(f64::INFINITY)
}

/// Several [`MagnitudeQuantile`]s added together (a mission pointing's figures over all
/// its segments): the same bins, kept sparse (memory grows with the occupied bins, at
/// most the samples absorbed), so the pooled quantile is exactly the one a single
/// histogram of all the samples would give.
#[derive(Clone, Debug, Default)]
pub struct PooledQuantile {
    bins: std::collections::BTreeMap<usize, u64>,
    below_floor: u64,
    count: u64,
    max_binned: f64,
}

impl PooledQuantile {
    /// Adds every magnitude `q` holds.
    pub fn absorb(&mut self, q: &MagnitudeQuantile) {
        for (i, n) in q.bins.iter().enumerate().filter(|(_, n)| **n > 0) {
            *self.bins.entry(i).or_insert(0) += u64::from(*n);
        }
        self.below_floor += q.below_floor;
        self.count += q.count;
        self.max_binned = self.max_binned.max(q.max_binned);
    }

    pub fn quantile(&self, p: f64) -> Option<f64> {
        let bins = self.bins.iter().map(|(i, n)| (*i, *n));
        nearest_rank(p, self.count, self.below_floor, self.max_binned, bins)
    }
}

/// [`AxisQuantiles`] pooled ([`PooledQuantile`]).
#[derive(Clone, Debug, Default)]
pub struct PooledAxes {
    axes: [PooledQuantile; 3],
    total: PooledQuantile,
}

impl PooledAxes {
    pub fn absorb(&mut self, q: &AxisQuantiles) {
        for (pool, part) in self.axes.iter_mut().zip(&q.axes) {
            pool.absorb(part);
        }
        self.total.absorb(&q.total);
    }

    pub fn figures(&self, p: f64) -> AxisFigures {
        let [x, y, z] = [0, 1, 2].map(|i| self.axes[i].quantile(p));
        AxisFigures { x, y, z, total: self.total.quantile(p), samples: self.total.count }
    }
}

/// One index's statistics: the three body axes and the norm.
#[derive(Clone, Debug, Default)]
pub struct AxisQuantiles {
    axes: [MagnitudeQuantile; 3],
    total: MagnitudeQuantile,
}

impl AxisQuantiles {
    fn push(&mut self, v: [f64; 3]) {
        for (q, x) in self.axes.iter_mut().zip(v) {
            q.push(x);
        }
        self.total.push((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
    }

    /// The figures at confidence `p` (`None` where the index had no sample).
    pub fn figures(&self, p: f64) -> AxisFigures {
        let [x, y, z] = [0, 1, 2].map(|i| self.axes[i].quantile(p));
        AxisFigures { x, y, z, total: self.total.quantile(p), samples: self.total.count() }
    }
}

/// An index at the stated confidence: per body axis and the norm, in the unit of the
/// error signal (deg), with the number of samples it was taken over.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct AxisFigures {
    pub x: Option<f64>,
    pub y: Option<f64>,
    pub z: Option<f64>,
    pub total: Option<f64>,
    pub samples: u64,
}

/// Window lengths of the indices, in samples (control steps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Windows {
    /// `Δt` of the MPE, RPE and PDE windows.
    pub window: usize,
    /// Separation of the two PDE windows' starts, in windows (`Δt_s / Δt`, ≥ 1).
    pub drift_separation: usize,
    /// `Δt` of the stability index.
    pub stability: usize,
}

impl Windows {
    /// Window lengths from seconds at a sample period `dt_s`: each rounded to whole
    /// samples (at least one: a window shorter than a sample is one sample), the drift
    /// separation to whole windows (at least one). Refuses lengths
    /// beyond [`MAX_WINDOW_SAMPLES`] / [`MAX_DRIFT_WINDOWS`] (memory) and non-finite input.
    pub fn from_seconds(dt_s: f64, window_s: f64, drift_separation_s: f64, stability_s: f64) -> Result<Self, String> {
        let samples = |what: &str, s: f64, unit: f64, cap: usize| -> Result<usize, String> {
            let n = (s / unit).round().max(1.0);
            if !(s > 0.0 && n <= cap as f64) {
                return Err(format!("{what} = {s} s must be positive and at most {cap} × {unit} s"));
            }
            Ok(n as usize)
        };
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(format!("sample period {dt_s} s must be positive"));
        }
        let window = samples("window_s", window_s, dt_s, MAX_WINDOW_SAMPLES)?;
        let w_s = window as f64 * dt_s;
        Ok(Self {
            window,
            drift_separation: samples("drift_separation_s", drift_separation_s, w_s, MAX_DRIFT_WINDOWS)?,
            stability: samples("stability_window_s", stability_s, dt_s, MAX_WINDOW_SAMPLES)?,
        })
    }
}

/// The streamed indices of one error signal (see the module documentation).
#[derive(Clone, Debug)]
pub struct PointingStats {
    windows: Windows,
    pub ape: AxisQuantiles,
    pub mpe: AxisQuantiles,
    pub rpe: AxisQuantiles,
    pub pde: AxisQuantiles,
    pub stability: AxisQuantiles,
    /// Samples of the window being filled.
    current: Vec<[f64; 3]>,
    /// Means of the last `drift_separation + 1` complete windows, oldest first.
    means: std::collections::VecDeque<[f64; 3]>,
    /// The last `stability` samples, oldest first.
    recent: std::collections::VecDeque<[f64; 3]>,
}

impl PointingStats {
    pub fn new(windows: Windows) -> Self {
        Self {
            windows,
            ape: AxisQuantiles::default(),
            mpe: AxisQuantiles::default(),
            rpe: AxisQuantiles::default(),
            pde: AxisQuantiles::default(),
            stability: AxisQuantiles::default(),
            current: Vec::with_capacity(windows.window),
            means: std::collections::VecDeque::with_capacity(windows.drift_separation + 1),
            recent: std::collections::VecDeque::with_capacity(windows.stability + 1),
        }
    }

    pub fn windows(&self) -> Windows {
        self.windows
    }

    /// Adds the error of one sample, deg (body axes).
    pub fn push(&mut self, e: [f64; 3]) {
        self.ape.push(e);
        self.recent.push_back(e);
        if self.recent.len() > self.windows.stability
            && let Some(old) = self.recent.pop_front()
        {
            self.stability.push(sub(e, old));
        }
        self.current.push(e);
        if self.current.len() == self.windows.window {
            self.close_window();
        }
    }

    /// A full window: its mean feeds the MPE and the drift, its samples the RPE.
    fn close_window(&mut self) {
        let n = self.current.len() as f64;
        let mut mean = [0.0; 3];
        for s in &self.current {
            for k in 0..3 {
                mean[k] += s[k] / n;
            }
        }
        for s in &self.current {
            self.rpe.push(sub(*s, mean));
        }
        self.current.clear();
        self.mpe.push(mean);
        self.means.push_back(mean);
        if self.means.len() > self.windows.drift_separation
            && let Some(old) = self.means.pop_front()
        {
            self.pde.push(sub(mean, old));
        }
    }
}

/// The indices of a run (`summary.json` `pointing`): the evaluation period's start, the
/// confidence level, the windows in seconds (whole control steps) and each index's
/// figures, deg.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointingSummary {
    pub from_s: f64,
    pub confidence: f64,
    pub window_s: f64,
    pub drift_separation_s: f64,
    pub stability_window_s: f64,
    pub ape_deg: AxisFigures,
    pub mpe_deg: AxisFigures,
    pub rpe_deg: AxisFigures,
    pub pde_deg: AxisFigures,
    pub stability_deg: AxisFigures,
}

impl PointingStats {
    /// The figures at confidence `p`, for samples `dt_s` apart taken from `from_s`.
    pub fn summary(&self, from_s: f64, p: f64, dt_s: f64) -> PointingSummary {
        let w = self.windows;
        let window_s = w.window as f64 * dt_s;
        PointingSummary {
            from_s,
            confidence: p,
            window_s,
            drift_separation_s: w.drift_separation as f64 * window_s,
            stability_window_s: w.stability as f64 * dt_s,
            ape_deg: self.ape.figures(p),
            mpe_deg: self.mpe.figures(p),
            rpe_deg: self.rpe.figures(p),
            pde_deg: self.pde.figures(p),
            stability_deg: self.stability.figures(p),
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_bounds_the_exact_order_statistic_within_the_bin_ratio() {
        let mut q = MagnitudeQuantile::new();
        let xs: Vec<f64> = (1..=1000).map(|i| i as f64 * 1e-3).collect();
        for x in &xs {
            q.push(-x);
        }
        for p in [0.5, 0.9, 0.95, 0.99, 1.0] {
            let exact = xs[((p * 1000.0) as usize).max(1) - 1];
            let got = q.quantile(p).unwrap();
            assert!(got >= exact && got <= exact * MagnitudeQuantile::RATIO, "p {p}: {got} vs {exact}");
        }
        assert_eq!(q.max(), 1.0);
        assert_eq!(q.quantile(0.0), None);
    }

    #[test]
    fn every_bin_edge_brackets_its_values() {
        // Bins from the floor to the ceiling: each value lies in [lower, upper) of its
        // bin, and upper / lower ≤ RATIO.
        let mut x = MagnitudeQuantile::FLOOR;
        while x < MagnitudeQuantile::CEILING {
            let i = MagnitudeQuantile::bin(x);
            let (lo, hi) = (
                if i == 0 { MagnitudeQuantile::FLOOR } else { MagnitudeQuantile::upper_edge(i - 1) },
                MagnitudeQuantile::upper_edge(i),
            );
            assert!(lo <= x && x < hi && hi / lo <= MagnitudeQuantile::RATIO * (1.0 + 1e-15), "{x}: [{lo}, {hi})");
            x *= 1.0007;
        }
    }

    #[test]
    fn nan_counts_as_unbounded() {
        let mut q = MagnitudeQuantile::new();
        for _ in 0..9 {
            q.push(1.0);
        }
        q.push(f64::NAN);
        assert!(q.quantile(0.9).unwrap() <= 1.0);
        assert_eq!(q.quantile(0.95), Some(f64::INFINITY));
    }

    #[test]
    fn windows_refuse_what_would_not_fit() {
        assert!(Windows::from_seconds(0.1, 10.0, 100.0, 1.0).is_ok());
        assert!(Windows::from_seconds(0.1, 0.0, 100.0, 1.0).is_err());
        assert!(Windows::from_seconds(0.1, 1e9, 100.0, 1.0).is_err());
        assert!(Windows::from_seconds(0.1, 10.0, f64::NAN, 1.0).is_err());
        let w = Windows::from_seconds(0.1, 10.0, 100.0, 1.0).unwrap();
        assert_eq!(w, Windows { window: 100, drift_separation: 10, stability: 10 });
    }
}
