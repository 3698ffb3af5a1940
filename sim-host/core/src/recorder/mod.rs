//! What a run leaves behind: the recorded columns and their rows, decimation of long
//! runs, the summary, the output files (CSV, `summary.json`) and the figures.
//! - [`columns`]: the column set of a run (names, units);
//! - [`series`]: the [`series::Recorder`] trait and the in-memory [`series::TimeSeries`];
//! - [`decimate`]: bounded-memory row decimation of long runs;
//! - [`summary`]: `summary.json` and the statistics it is built from;
//! - [`momentum`]: stored-momentum statistics (every control step);
//! - [`output`]: the streamed files of `sim-host run`;
//! - [`plots`]: the PNG figures;
//! - [`pointing`]: pointing-performance indices (APE, MPE, RPE, PDE, stability), streamed.

pub mod columns;
pub mod decimate;
pub mod momentum;
pub mod output;
pub mod plots;
pub mod pointing;
pub mod series;
pub mod summary;
