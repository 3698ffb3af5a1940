//! Low-precision solar ephemeris (The Astronomical Almanac, section C, "low precision
//! formulas for the Sun": 0.01° from 1950 to 2050), in f32.
//!
//! `n` days from J2000: mean longitude `L = 280.460° + 0.9856474° n`, mean anomaly
//! `g = 357.528° + 0.9856003° n`, ecliptic longitude `λ = L + 1.915° sin g + 0.020° sin 2g`,
//! obliquity `ε = 23.439° − 0.0000004° n`; unit vector in the mean equator and equinox of
//! date `[cos λ, cos ε sin λ, sin ε sin λ]`; distance `1.00014 − 0.01671 cos g − 0.00014 cos 2g` AU.
//! The whole-day products are reduced modulo 360° before the fraction is added (f32).
//! Eclipse: the cylindrical shadow test of the simulator's SRP model, for the sun-safe
//! logic to know when not to expect the Sun.

use super::time::{J2000Time, wrap_360};
use crate::math::Vec3;
use crate::math::f32m::{sin_cos, sqrt};

/// Mean Earth radius used by the shadow test, m.
pub const EARTH_RADIUS_M: f32 = 6_378_137.0;

/// Unit vector from the Earth to the Sun (ECI, mean of date) and the distance in AU.
pub fn sun_direction_eci(t: &J2000Time) -> (Vec3, f32) {
    let d = t.days as f32;
    let f = t.day_fraction();
    let l = wrap_360(280.460 + wrap_360(0.985_647_4 * d) + 0.985_647_4 * f);
    let g = wrap_360(357.528 + wrap_360(0.985_600_3 * d) + 0.985_600_3 * f).to_radians();
    let (sg, cg) = sin_cos(g);
    let (s2g, c2g) = sin_cos(2.0 * g);
    let lam = (l + 1.915 * sg + 0.020 * s2g).to_radians();
    let eps = (23.439 - 0.000_000_4 * (d + f)).to_radians();
    let (sl, cl) = sin_cos(lam);
    let (se, ce) = sin_cos(eps);
    let dist_au = 1.000_14 - 0.016_71 * cg - 0.000_14 * c2g;
    (Vec3::new(cl, ce * sl, se * sl), dist_au)
}

/// Whether a spacecraft at `r_eci_m` is in the Earth's cylindrical shadow for the Sun
/// direction `sun_unit` (anti-Sun side and within one Earth radius of the Earth–Sun line).
pub fn in_eclipse(r_eci_m: &Vec3, sun_unit: &Vec3) -> bool {
    let along = r_eci_m.dot(sun_unit);
    if !(along < 0.0) {
        return false;
    }
    let perp = r_eci_m - sun_unit * along;
    sqrt(perp.norm_squared()) < EARTH_RADIUS_M
}
