//! Host simulator: f64 plant models, sensors, the links to the flight code (in-process,
//! QEMU, TCP, serial), the scenario format, the run loop and its outputs.
//!
//! The flight software is never re-implemented here: every run calls the `acs-flight`
//! crate, either directly (in-process) or on the flight computer over the postcard link.

// Index loops over parallel fixed-size arrays (gimbals, state slots) read better than zips.
#![allow(clippy::needless_range_loop)]

pub mod analysis;
pub mod attitude;
pub mod campaign;
pub mod columns;
pub mod cycles;
pub mod decimate;
pub mod design;
pub mod environment;
pub mod estimation;
pub mod files;
pub mod link;
pub mod momentum;
pub mod output;
pub mod plant;
pub mod plots;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod sensors;
pub mod series;
pub mod simulation;
pub mod summary;
pub mod timing;
