//! Design analyses that run on the host (f64), not in flight.

pub mod thrusters;
