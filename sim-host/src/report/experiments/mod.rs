//! The experiments that explain the published numbers we do not match (issue 13), one
//! file each. Every experiment is listed in [`ALL`]; the report runs them all and its
//! outcome table refers to them by id.

pub mod p000_rig;
pub mod p001_dmcs;
pub mod p003_ranking;
pub mod p004_failures;
pub mod p004_unknowns;

use super::experiment::{Context, Experiment};
use anyhow::Result;

/// An experiment's entry point.
pub type Runner = fn(&Context) -> Result<Experiment>;

/// Every experiment: (id, paper, runner), in paper order.
pub const ALL: &[(&str, &str, Runner)] = &[
    ("p000-rig-effects", "000", p000_rig::run),
    ("p001-dmcs", "001", p001_dmcs::run),
    ("p003-ranking", "003", p003_ranking::run),
    ("p004-unknowns", "004", p004_unknowns::run),
    ("p004-failures", "004", p004_failures::run),
];
