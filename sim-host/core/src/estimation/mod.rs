//! Host-side estimation figures: the flight estimate against the truth over a run.
//!
//! - [`stats`]: the flight estimate against the truth over a run (summary keys).
//!
//! The f64 reference MEKF that checks the flight filter (Crassidis & Junkins Table 7.1)
//! is a test oracle: it lives in the test-support crate (`acs_test_support::mekf_ref`,
//! tests/support/), used by sim-host/core/tests/mekf_reference.rs.

pub mod stats;
