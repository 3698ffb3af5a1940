//! Paper 004: which thruster failures the table 2 layout survives (placeholder).
use crate::report::experiment::{Context, Experiment};
use anyhow::Result;

pub fn run(_ctx: &Context) -> Result<Experiment> {
    anyhow::bail!("p004-failures: not yet")
}
