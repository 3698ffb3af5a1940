//! Test support shared by the tests, benches and examples of every crate of the workspace
//! (`acs-flight`, `sim-core`, `sim-host`, `acs-tests`). It depends on nothing in the
//! workspace, so any crate may dev-depend on it without a cycle in the crate graph.
//! - [`rng`]: the seeded generators of the tests (SplitMix64 with Box–Muller normals,
//!   and Knuth's 64-bit LCG), bit-identical to the copies they replace, so seeded tests
//!   draw the same numbers;
//! - [`cases`]: the worker pool of the seeded fuzz tests (every case once, each in its own
//!   directory, verdicts in case order);
//! - [`vec3`]: `[f64; 3]` vector helpers (`dot`, `cross`, `norm`, …) for tests whose
//!   data are plain arrays;
//! - [`loop_reference`]: the analytic discrete open-loop response of a rigid-body axis under
//!   quaternion-feedback PD (ZOH, delays, actuator lag) and margins computed from any
//!   response, the reference of `sim-host margins` (issue 25);
//! - `mekf_ref` (feature `mekf-ref`): the f64 multiplicative EKF of Crassidis & Junkins,
//!   the oracle of the flight MEKF (sim-host/core/tests/mekf_reference.rs).

pub mod cases;
pub mod loop_reference;
#[cfg(feature = "mekf-ref")]
pub mod mekf_ref;
pub mod rng;
pub mod vec3;
