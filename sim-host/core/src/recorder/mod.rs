//! What a run leaves behind: the recorded columns and their rows, decimation of long
//! runs, the summary, the output files (`timeseries.parquet` or `.csv`, `summary.json`)
//! and the figures.
//! - [`columns`]: the column set of a run (names, units);
//! - [`series`]: the [`series::Recorder`] trait and the in-memory [`series::TimeSeries`];
//! - [`decimate`]: bounded-memory row decimation of long runs;
//! - [`summary`]: `summary.json` and the statistics it is built from;
//! - [`control_lost`]: the verdicts of a run with faults that lost control (unnoticed, or
//!   after a declared fault whose recovery failed);
//! - [`propellant`]: the verdict of a run that used more propellant than its budget;
//! - [`momentum`]: stored-momentum statistics (every control step);
//! - [`csv`]: `timeseries.csv`, written with a fast shortest round-trip float formatter;
//! - [`parquet`]: `timeseries.parquet`, typed columns with units and the run's metadata;
//! - [`output`]: the streamed files of `sim-host run` and [`output::read_run`];
//! - [`plots`]: the PNG figures;
//! - [`pointing`]: pointing-performance indices (APE, MPE, RPE, PDE, stability), streamed;
//! - [`segments`]: the APE and RPE of each pointing segment (mode × pointing × branch).

pub mod columns;
pub mod control_lost;
pub mod csv;
pub mod decimate;
pub mod fdir;
pub mod keepout;
pub mod momentum;
pub mod output;
pub mod parquet;
pub mod plots;
pub mod pointing;
pub mod propellant;
pub mod segments;
pub mod series;
pub mod summary;
