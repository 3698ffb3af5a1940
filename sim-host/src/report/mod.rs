//! `sim-host report`: every shipped scenario flown, each published outcome beside ours
//! with a verdict, the paper's figures redrawn, and the experiments that explain the gaps.

pub mod experiment;
pub mod experiments;
