//! Attitude-control flight software: the algorithms that run on the on-board computer.
//!
//! `no_std`, no heap, no panics on any input, f32 throughout (the Cortex-M4F FPU is
//! single precision). Transcendental math goes through `libm` explicitly so that the
//! host build and the MCU build produce the same bits.
//!
//! Architecture:
//! - [`math`]: the one quaternion convention of the project and Euler conversions.
//! - [`control`]: control laws producing a desired body torque.
//! - [`estimation`]: state estimators (linear Kalman filter) and LQR state feedback.
//! - [`steering`]: maps a body torque onto an actuator set (CMG pyramid here).
//! - [`params`]: the typed, versioned, checksummed flight parameter set.
//! - [`protocol`]: wire messages and the COBS + CRC framing of the host link.
//! - [`modes`]: the mode manager (detumble → stabilise → manoeuvre → hold).
//! - [`fsw`]: [`fsw::Fsw`], the one synchronous `step` the firmware and the simulator call.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
// `!(x > y)` is used on purpose in numerical code: it is also true for NaN (fail-safe).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// No heap in flight code: large enum variants cannot be boxed, and they are all `Copy` data.
#![allow(clippy::large_enum_variant)]

pub mod allocation;
pub mod control;
pub mod estimation;
pub mod fsw;
pub mod math;
pub mod modes;
pub mod params;
pub mod protocol;
pub mod session;
pub mod steering;

pub use fsw::Fsw;
