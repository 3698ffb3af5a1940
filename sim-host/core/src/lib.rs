//! Simulator core (f64): the spacecraft, its environment and sensors, the links to the
//! flight code, the scenario format, the run loop and its recorder. The command-line
//! tools (report, campaigns, timing, cycles, analysis) and the tests are built on this
//! library and nothing else, and so is the Python package (`sim-host/python`).
//!
//! The flight software is never re-implemented here: every run calls the `acs-flight`
//! crate, either directly (in-process) or on the flight computer over the postcard link.
//!
//! The module tree follows the data path of one control step:
//! - [`scenario`]: the TOML format, parsed once into typed values ([`scenario::Resolved`]);
//! - [`design`]: gain synthesis (Riccati, linear models, discretisation, steady-state
//!   Kalman) used when a scenario's LQR/LQG gains are resolved;
//! - [`environment`]: orbit, frames, field, disturbance torques;
//! - [`faults`]: the typed faults of `[[faults]]` (issue 42) that plant, sensors and
//!   actuation apply;
//! - [`plant`]: rigid body and actuators (wheels, CMGs, torquers, thrusters, the rig);
//! - [`sensors`]: what the flight computer is given (noise, quantisation, latency);
//! - [`link`]: the flight computer behind one trait (in-process, QEMU, TCP, serial);
//! - [`simulation`]: one control step of plant + sensors + flight code, and the
//!   [`simulation::probe`] through which an analysis drives a run from outside;
//! - [`runner`]: the run loop, and "fly one scenario" ([`runner::fly`]);
//! - [`recorder`]: columns, series, decimation, summary, output files and figures;
//! - [`estimation`]: estimation-error statistics of a run; [`attitude`]: f64 quaternion
//!   helpers of the truth side; [`vec3`]: `[f64; 3]` dot, cross and norm (nalgebra's
//!   arithmetic); [`files`]: atomic file writes.

// Index loops over parallel fixed-size arrays (gimbals, state slots) read better than zips.
#![allow(clippy::needless_range_loop)]

pub mod attitude;
pub mod design;
pub mod environment;
pub mod estimation;
pub mod faults;
pub mod files;
pub mod link;
pub mod plant;
pub mod recorder;
pub mod runner;
pub mod scenario;
pub mod sensors;
pub mod simulation;
pub mod vec3;
