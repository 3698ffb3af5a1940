//! Host-side estimators: f64 references written independently of the flight code, used
//! to check it, and the run's estimation figures.
//!
//! - [`mekf_ref`]: the multiplicative EKF of Crassidis & Junkins (Table 7.1) in their
//!   Ξ(q)/Ω̄(ω) formulation, with van Loan's discretisation of the error dynamics; the
//!   f32 flight filter (`acs_flight::estimation::mekf`) must agree with it on the same
//!   measurements (sim-host/core/tests/mekf_reference.rs);
//! - [`stats`]: the flight estimate against the truth over a run (summary keys).

pub mod mekf_ref;
pub mod stats;
