//! The simulator's tools, on top of the [`sim_core`] library: the generated report,
//! Monte Carlo campaigns, the worst-case timing search, cycle bounds on the emulated MCU
//! and the analysis helpers. The `sim-host` command line (`main.rs`) is a thin layer on
//! these modules and on `sim_core`.
//! - [`report`]: `docs/results.md` and its figures (the papers' outcomes, experiments);
//! - [`campaign`]: plan / run / merge of dispersed runs (local or Slurm);
//! - [`timing`]: the search for the slowest flight step and its corpus;
//! - [`cycles`]: cycle bounds of the firmware under QEMU (TCG plugin);
//! - [`analysis`]: post-run analyses (thruster allocation envelopes);
//! - [`margins`]: stability margins measured through the flight step;
//! - [`view`]: the 3D replay page of a run (`sim-host view`);
//! - [`format`]: number formatting of the text outputs.

// Index loops over parallel fixed-size arrays read better than zips.
#![allow(clippy::needless_range_loop)]

pub mod analysis;
pub mod campaign;
pub mod cycles;
pub mod fly;
pub mod format;
pub mod margins;
pub mod report;
pub mod timing;
pub mod view;
