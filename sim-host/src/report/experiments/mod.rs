//! The experiments that explain the published numbers we do not match (issue 13), one
//! file each. Every experiment is listed in [`ALL`]; the report runs them all and its
//! outcome table refers to them by id.

pub mod p000_rig;

use super::experiment::{Context, Experiment};
use anyhow::Result;

/// An experiment's entry point.
pub type Runner = fn(&Context) -> Result<Experiment>;

/// Every experiment: (id, paper, runner).
pub const ALL: &[(&str, &str, Runner)] = &[("p000-rig-effects", "000", p000_rig::run)];
