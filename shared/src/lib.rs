//! Attitude-control flight software: the algorithms that run on the on-board computer.
//!
//! `no_std`, no heap, no panics on any input, f32 throughout (the Cortex-M4F FPU is
//! single precision; no f64 anywhere, soft-double routines would be software on the MCU).
//! Elementary functions come from [`math::f32m`] (pure f32 operations, so the host build
//! and the MCU build produce the same bits).
//!
//! Architecture:
//! `Fsw::step` runs the data path of one step: sample (the wire frame, less the torquers'
//! field at the magnetometer, into typed samples)
//! → estimate (navigation, reference models, attitude determination; every step, whatever
//! the mode) → mode (the mode manager picks the parameter set in force) → validate (the
//! frame and the estimate against what that mode needs; else the safe command) → guide
//! → control → momentum management → allocate → report.
//!
//! Module layers, bottom to top; a module uses only modules below it (no cycle between
//! top-level modules):
//! 1. [`math`], [`checksum`]: the one quaternion convention, f32 elementary functions,
//!    the project CRC;
//! 2. [`types`]: what the algorithms exchange (typed sensor samples, validated
//!    measurements, set point, demand, the flag sets [`types::Valid`] and
//!    [`types::Status`], the array capacities);
//! 3. [`models`]: on-board reference models (time, Sun, geomagnetic field, orbit, LVLH);
//! 4. [`params`]: every algorithm's parameter type (one rule: all parameters live here),
//!    the typed, versioned, checksummed flight parameter set, and the mode-table types
//!    ([`params::Mode`]); imports no algorithm module;
//! 5. [`link`]: wire messages and their COBS + CRC framing;
//! 6. [`validation`]: the wire frame into typed, validated samples, and the sensor limits;
//! 7. [`estimation`]: state estimators and the estimation stage (MEKF, TRIAD, QUEST, CSS,
//!    navigation, Kalman/LQG);
//! 8. [`guidance`]: target and reference frames, the GSR dither clock;
//! 9. [`control`]: attitude laws behind one trait, each owning its state, one file per
//!    law; momentum management;
//! 10. [`allocation`]: actuator effectiveness apart from the allocation methods, every
//!     family behind one trait with one result type;
//! 11. [`fdir`]: fault detection monitors (residual tests with persistence), below the
//!     isolation and recovery that act on their verdicts;
//! 12. [`modes`]: the mode manager (detumble → sun-safe → stabilise → manoeuvre → hold);
//! 13. [`fsw`]: [`fsw::Fsw`], the one synchronous `step` the firmware and the simulator
//!     call;
//! 14. [`session`]: the flight side of a link session (the firmware's link task and the
//!     simulator's virtual flight computer).
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
pub mod fdir;
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
