//! Fault detection monitors: residual streams turned into verdicts with a stated
//! false-alarm probability (issue 42; docs/fdir.md).
//!
//! Detection apart from reaction, as PX4's EKF2 keeps *when to fuse* apart from *the
//! fusion math*: each monitor here owns one statistic and its persistence, and says only
//! whether its test fired; isolation (which unit) and recovery (drop the unit, fall back)
//! act on those verdicts one layer up. Every monitor is bounded (fixed-size state, no loop
//! over data from the link), never panics, and treats a non-finite input as an exceedance
//! (a sensor or command that turns non-finite is itself a fault), never as a pass.
//!
//! - [`window`]: k-of-n persistence of a per-sample test (false alarm: the binomial tail);
//! - [`repeat`]: a frozen or stuck output (bit-identical samples despite fresh time tags);
//! - [`wheel`]: a reaction wheel's torque residual, commanded against measured by its
//!   tachometer, normalised by its σ from tachometer noise and quantisation;
//! - [`isolate`]: whether a fired wheel residual names the rotor or its tachometer, from
//!   the body's reaction seen by the gyro;
//! - [`bias`]: a gyro bias step, from the star tracker's innovations the filter's gate
//!   rejects while the Sun or the field corroborate the tracker (the filter restarts with
//!   the step added to its bias);
//! - [`gnss`]: each GNSS fix against the last accepted one propagated to its time (run by
//!   the estimation stage, which does not take an inconsistent fix and drops a failed
//!   receiver);
//! - [`magnetometer`]: the measured field's magnitude against the on-board model, and a
//!   stuck axis (run by the estimation stage, which drops a failed magnetometer);
//! - [`gyro`]: a stuck gyro axis (run by the estimation stage, which reads it as 0);
//! - [`tracker`]: the star tracker frozen, or contradicted by the Sun and the field
//!   (run by the estimation stage, which drops a failed tracker);
//! - [`wheel_chain`]: the three wired together for the flight step, with the recovery
//!   (the wheel dropped from the allocation) and the telemetry.

pub mod bias;
pub mod gnss;
pub mod gyro;
pub mod isolate;
pub mod magnetometer;
pub mod repeat;
pub mod tracker;
pub mod wheel;
pub mod wheel_chain;
pub mod window;
