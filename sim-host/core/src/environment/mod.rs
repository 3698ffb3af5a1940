//! Orbit and environment models for the attitude simulator (host side, f64).
//!
//! * [`orbit`]: circular / Kepler / J2 (RK4) / TLE (SGP4) propagation in ECI.
//! * [`frames`]: Earth rotation (GMST), ECI <-> ECEF, WGS-84 geodetic, LVLH, orbit rate.
//! * [`guidance`]: the truth of pointing: directions, the ideal two-vector attitude, the
//!   errors of the true attitude from it.
//! * [`magnetic`]: tilted dipole and WMM (2020-2029) field in ECI.
//! * [`torques`]: gravity gradient, drag, SRP, residual dipole, harmonic external torques.
//!
//! Conventions: SI units; time `t` = seconds since the scenario epoch; attitude quaternion
//! `q_ib` (nalgebra `UnitQuaternion`, Hamilton) maps body vectors to ECI, `v_I = q_ib * v_B`;
//! project storage `[x, y, z, w]` = `q.coords`.
pub mod frames;
pub mod guidance;
pub mod magnetic;
pub mod model;
pub mod orbit;
pub mod torques;

pub use frames::{EarthRotation, orbit_synchronous_rate, q_lvlh_to_eci};
pub use magnetic::{FieldModel, MagneticField};
pub use orbit::{OrbitModel, OrbitPropagator, PropagatorOptions};
pub use torques::Disturbances;
