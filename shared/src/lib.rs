//! Attitude-control flight software: the algorithms that run on the on-board computer.
//!
//! `no_std`, no heap, no panics on any input, f32 throughout (the Cortex-M4F FPU is
//! single precision; no f64 anywhere, soft-double routines would be software on the MCU).
//! Elementary functions come from [`math::f32m`] (pure f32 operations, so the host build
//! and the MCU build produce the same bits).
//!
//! Architecture:
//! The module tree is the data path of one step (`Fsw::step`: validate → mode → estimate
//! → guide → control → allocate → report):
//! - [`types`]: what the algorithms exchange (measurements, set point, demand, the typed
//!   flag sets [`types::Valid`] and [`types::Status`]);
//! - [`math`]: the one quaternion convention of the project and Euler conversions;
//! - [`modes`]: the mode manager (detumble → stabilise → manoeuvre → hold);
//! - [`estimation`]: state estimators (linear Kalman filter, the LQG estimator);
//! - [`guidance`]: target and reference frames, the GSR dither clock;
//! - [`control`]: attitude laws behind one trait, each owning its state;
//! - [`allocation`]: every actuator family (CMG steering included) behind one trait with
//!   one result type;
//! - [`params`]: the typed, versioned, checksummed flight parameter set;
//! - [`link`]: wire messages, COBS + CRC framing, the flight side of a session;
//! - [`fsw`]: [`fsw::Fsw`], the one synchronous `step` the firmware and the simulator call.
#![cfg_attr(not(feature = "std"), no_std)]
// Flight rules on top of the workspace baseline (`[workspace.lints]` in the root
// Cargo.toml; a crate cannot extend that table, hence crate attributes): no panics
// (unwrap/expect/panic/out-of-range indexing), no truncating, sign-losing or wrapping
// casts (`try_from` with a documented fallback instead), no unchecked integer arithmetic
// (checked/saturating forms). nalgebra's float operators are exempt from
// `arithmetic_side_effects` (shared/clippy.toml). The firmware repeats these in its
// `[lints]` table. Unit tests may unwrap and index.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::arithmetic_side_effects
)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_possible_wrap,
        clippy::arithmetic_side_effects,
        // Tests may use nalgebra's norms, f32::clamp and libm as independent references.
        clippy::disallowed_methods
    )
)]
// No heap in flight code: large enum variants cannot be boxed, and they are all `Copy` data.
#![allow(clippy::large_enum_variant)]

pub mod allocation;
pub mod checksum;
pub mod control;
pub mod estimation;
pub mod fsw;
pub mod guidance;
pub mod link;
pub mod math;
pub mod models;
pub mod modes;
pub mod params;
pub mod session;
pub mod types;
pub mod validation;

pub use fsw::Fsw;
