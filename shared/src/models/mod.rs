//! On-board reference models: what the flight computer knows of its environment without the
//! simulator's help — time, the Sun's direction, the Earth's field, the orbit frame.
//! Inputs of the attitude determination (reference vectors for TRIAD/QUEST/MEKF) and of
//! guidance (LVLH). All f32, no heap, bounded loops.
//!
//! - [`time`]: on-board time as whole days + seconds since J2000, GMST;
//! - [`sun`]: low-precision solar ephemeris (Astronomical Almanac, ~0.01°);
//! - [`magnetic`]: spherical-harmonic geomagnetic field (WMM2025 to a chosen degree);
//! - [`lvlh`]: the local-vertical local-horizontal frame from position and velocity.

pub mod lvlh;
pub mod magnetic;
pub mod orbit;
pub mod sun;
pub mod time;
pub mod wmm2025;
