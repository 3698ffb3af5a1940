//! Actuator effectiveness (PX4 style: kept apart from the allocation methods): how the
//! commands of an actuator family map to body torque and stored momentum, from its
//! geometry. The methods that invert these maps are beside this module
//! ([`super::cmg`] steering, [`super::wheels`] pseudo-inverse).
//!
//! - [`cmg`]: the CMG pyramid's momentum, Jacobian and body torque (paper 000 eqs 4, 6-8);
//! - [`wheels`]: the wheel array's spin axes, stored momentum and body torque (paper 001).

pub mod cmg;
pub mod wheels;
