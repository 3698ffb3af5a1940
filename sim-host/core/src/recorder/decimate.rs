//! Bounded-memory decimation of recorded rows for the plots: a min/max envelope over at
//! most [`Envelope::MAX_BUCKETS`] buckets of consecutive rows. Each bucket starts as one
//! row; when all buckets are full, neighbours are merged pairwise and each bucket then
//! covers twice as many rows. Memory is `O(MAX_BUCKETS × columns)`, whatever the duration.
//!
//! A bucket of one row is returned as that row (so runs of up to `MAX_BUCKETS` recorded
//! rows plot exactly as recorded); a bucket of several rows as two rows, the column-wise
//! minimum and maximum of its finite values (NaN where it has none). For the time column,
//! which increases, these are the first and the last time of the bucket, so a line through
//! them draws the bucket's envelope.

use crate::recorder::series::{Recorder, TimeSeries};
use anyhow::Result;

#[derive(Clone, Debug, Default)]
pub struct Envelope {
    names: Vec<String>,
    /// Rows per full bucket (a power of two).
    per_bucket: u64,
    /// Rows in each bucket so far; `lo`/`hi` hold `columns` values per bucket.
    counts: Vec<u64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl Envelope {
    /// Most buckets held (even); the plots are 1200 px wide.
    pub const MAX_BUCKETS: usize = 4096;

    pub fn new() -> Self {
        Self::default()
    }

    fn width(&self) -> usize {
        self.names.len()
    }

    /// Merges neighbouring buckets pairwise (all buckets are full when this is called).
    fn halve(&mut self) {
        let w = self.width();
        let n = self.counts.len() / 2;
        for b in 0..n {
            self.counts[b] = self.counts[2 * b] + self.counts[2 * b + 1];
            for c in 0..w {
                let (i, j, k) = (b * w + c, 2 * b * w + c, (2 * b + 1) * w + c);
                self.lo[i] = self.lo[j].min(self.lo[k]);
                self.hi[i] = self.hi[j].max(self.hi[k]);
            }
        }
        self.counts.truncate(n);
        self.lo.truncate(n * w);
        self.hi.truncate(n * w);
        self.per_bucket *= 2;
    }

    /// The decimated series: one row per single-row bucket, (min, max) rows otherwise.
    pub fn series(&self) -> TimeSeries {
        let w = self.width();
        let mut ts = TimeSeries::with_columns(self.names.clone(), 2 * self.counts.len());
        for (b, n) in self.counts.iter().enumerate() {
            ts.push_row(&self.lo[b * w..(b + 1) * w]);
            if *n > 1 {
                ts.push_row(&self.hi[b * w..(b + 1) * w]);
            }
        }
        ts
    }
}

impl Recorder for Envelope {
    fn start(&mut self, columns: &[String], _rows: u64) -> Result<()> {
        *self = Self { names: columns.to_vec(), per_bucket: 1, ..Self::default() };
        Ok(())
    }

    fn record(&mut self, row: &[f64]) -> Result<()> {
        let w = self.width();
        let full = self.counts.last().is_none_or(|n| *n >= self.per_bucket);
        if full && self.counts.len() == Self::MAX_BUCKETS {
            self.halve();
        }
        if self.counts.last().is_none_or(|n| *n >= self.per_bucket) {
            self.counts.push(0);
            // f64::min/max ignore NaN: a bucket's extremes are those of its finite values.
            self.lo.extend(std::iter::repeat_n(f64::NAN, w));
            self.hi.extend(std::iter::repeat_n(f64::NAN, w));
        }
        let b = self.counts.len() - 1;
        self.counts[b] += 1;
        for (c, x) in row.iter().take(w).enumerate() {
            let i = b * w + c;
            self.lo[i] = self.lo[i].min(*x);
            self.hi[i] = self.hi[i].max(*x);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(n: u64) -> Envelope {
        let mut e = Envelope::new();
        e.start(&["t".into(), "y".into()], n).unwrap();
        for k in 0..n {
            let t = k as f64;
            // A sawtooth with period 7 and a NaN every 5th row.
            let y = if k % 5 == 4 { f64::NAN } else { (k % 7) as f64 };
            e.record(&[t, y]).unwrap();
        }
        e
    }

    #[test]
    fn short_runs_are_kept_exactly() {
        let e = feed(100);
        let ts = e.series();
        assert_eq!(ts.len(), 100);
        assert_eq!(ts.col("t").unwrap()[37], 37.0);
        assert_eq!(ts.col("y").unwrap()[37], (37 % 7) as f64);
        assert!(ts.col("y").unwrap()[4].is_nan());
    }

    #[test]
    fn long_runs_stay_bounded_and_keep_the_envelope() {
        let n = 1_000_003;
        let e = feed(n);
        let ts = e.series();
        assert!(ts.len() <= 2 * Envelope::MAX_BUCKETS, "{}", ts.len());
        assert!(ts.len() >= Envelope::MAX_BUCKETS / 2, "{}", ts.len());
        let t = ts.col("t").unwrap();
        let y = ts.col("y").unwrap();
        // Time spans the run and never decreases.
        assert_eq!((t[0], t[t.len() - 1]), (0.0, (n - 1) as f64));
        assert!(t.windows(2).all(|w| w[1] >= w[0]));
        // Every bucket covers > 7 rows, so each sees the sawtooth's full range 0..6.
        assert!(y.iter().all(|v| *v == 0.0 || *v == 6.0), "{:?}", &y[..8]);
        // All rows are accounted for.
        assert_eq!(e.counts.iter().sum::<u64>(), n);
        assert!(e.counts.len() <= Envelope::MAX_BUCKETS);
    }
}
