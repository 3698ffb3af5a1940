//! Recorded samples: the [`Recorder`] a run pushes its rows into, and [`TimeSeries`], the
//! in-memory column store (tests, library use, and the decimated plot data).

use crate::recorder::columns::Col;
use anyhow::Result;

/// Where a run's recorded rows go. [`Recorder::start`] is called once, before the first
/// control step, with the column names and the number of rows the run will record (a
/// recorder may refuse the run there, e.g. when the output would not fit on the disk);
/// then [`Recorder::record`] once per recorded row, in time order.
pub trait Recorder {
    fn start(&mut self, columns: &[String], rows: u64) -> Result<()>;
    fn record(&mut self, row: &[f64]) -> Result<()>;
}

/// A recorder that keeps nothing: runs whose only product is their summary (campaign
/// runs, cycle measurements).
pub struct Discard;

impl Recorder for Discard {
    fn start(&mut self, _: &[String], _: u64) -> Result<()> {
        Ok(())
    }
    fn record(&mut self, _: &[f64]) -> Result<()> {
        Ok(())
    }
}

/// Column store of a run's recorded (decimated) samples. Every column has the same length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeSeries {
    pub names: Vec<String>,
    pub cols: Vec<Vec<f64>>,
}

/// Rows reserved up front by [`TimeSeries::start`]; more grow the columns as needed.
const RESERVE_ROWS: u64 = 1 << 20;

impl TimeSeries {
    pub fn with_columns(names: Vec<String>, capacity: usize) -> Self {
        let cols = names.iter().map(|_| Vec::with_capacity(capacity)).collect();
        Self { names, cols }
    }

    /// The column called `name` (for tests and analyses; the run itself uses indices).
    pub fn col(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|i| self.cols[i].as_slice())
    }

    /// A column of the fixed block, by its index (`None` if this store does not hold the
    /// fixed block first).
    pub fn fixed(&self, c: Col) -> Option<&[f64]> {
        let i = c.index();
        self.names.get(i).filter(|n| *n == c.name()).map(|_| self.cols[i].as_slice())
    }

    pub fn push_row(&mut self, row: &[f64]) {
        for (c, x) in self.cols.iter_mut().zip(row) {
            c.push(*x);
        }
    }

    pub fn len(&self) -> usize {
        self.cols.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Recorder for TimeSeries {
    fn start(&mut self, columns: &[String], rows: u64) -> Result<()> {
        *self = Self::with_columns(columns.to_vec(), rows.min(RESERVE_ROWS) as usize);
        Ok(())
    }

    fn record(&mut self, row: &[f64]) -> Result<()> {
        self.push_row(row);
        Ok(())
    }
}
