//! Steering: from a body-torque demand to actuator commands, reporting what was achieved.

pub mod cmg;
pub use cmg::{CmgPyramid, SteeringOutput};
