//! On-board time: whole days and seconds since J2000.0 (2000-01-01 12:00 TT), kept apart
//! so f32 keeps sub-millisecond resolution for decades (a single f32 of seconds since
//! J2000 has a 64 s quantum today). UTC, TT and UT1 are not distinguished: their ≤ 70 s
//! differences move the Sun by < 0.001° and the Earth by < 0.3° — the GNSS receiver's
//! time (GPS, UTC + 18 s) is the source, and the models' errors are stated against that.

use crate::math::Vec3;
use crate::math::f32m::{floor, sin_cos};

/// Time since J2000.0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct J2000Time {
    pub days: i32,
    /// Seconds into the day, [0, 86400).
    pub seconds: f32,
}

impl J2000Time {
    /// Normalises `seconds` into [0, 86400) by whole days (saturating on absurd input;
    /// `None` when `seconds` is not finite).
    pub fn new(days: i32, seconds: f32) -> Option<Self> {
        if !seconds.is_finite() {
            return None;
        }
        let whole = floor(seconds / 86_400.0);
        // |whole| ≤ 2^31 checked before the cast: no wrap.
        if whole.abs() > 1.0e9 {
            return None;
        }
        // Integral and within ±1e9, checked above: the cast is exact.
        #[allow(clippy::cast_possible_truncation)]
        let d = days.checked_add(whole as i32)?;
        let s = seconds - whole * 86_400.0;
        let s = if (0.0..86_400.0).contains(&s) { s } else { 0.0 };
        Some(Self { days: d, seconds: s })
    }

    /// Advance by `dt_s` (any sign); `None` on overflow or non-finite input.
    pub fn add_seconds(&self, dt_s: f32) -> Option<Self> {
        Self::new(self.days, self.seconds + dt_s)
    }

    /// Fraction of a day since J2000 as (whole days, fraction in [0, 1)).
    pub fn day_fraction(&self) -> f32 {
        self.seconds / 86_400.0
    }

    /// Decimal year (for the field model's secular variation), to about 1e-4 yr.
    pub fn decimal_year(&self) -> f32 {
        // J2000.0 is 2000-01-01 12:00, half a day after 2000.0 (leap-day detail < 0.003 yr).
        2000.0 + (self.days as f32 + self.day_fraction() + 0.5) / 365.25
    }
}

/// Reduces `a` (deg) to [0, 360).
pub fn wrap_360(a: f32) -> f32 {
    let r = a - 360.0 * floor(a / 360.0);
    if (0.0..360.0).contains(&r) { r } else { 0.0 }
}

/// Greenwich mean sidereal time, rad (IAU 1982, linear term only: < 0.1″/century error
/// from the omitted higher terms; the whole-day product is reduced before adding the
/// fraction, so f32 keeps ~1e-3° over decades).
pub fn gmst_rad(t: &J2000Time) -> f32 {
    // θ = 280.46061837° + 360.98564736629° d; 360.98564736629 d = 360 d + 0.98564736629 d.
    let whole = wrap_360(0.985_647_4 * t.days as f32);
    let frac = 360.985_66 * t.day_fraction();
    wrap_360(280.460_62 + whole + frac).to_radians()
}

/// Rotation of a vector from ECEF to ECI (about z by GMST).
pub fn ecef_to_eci(t: &J2000Time, v: &Vec3) -> Vec3 {
    let (s, c) = sin_cos(gmst_rad(t));
    Vec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z)
}

/// Rotation of a vector from ECI to ECEF.
pub fn eci_to_ecef(t: &J2000Time, v: &Vec3) -> Vec3 {
    let (s, c) = sin_cos(gmst_rad(t));
    Vec3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z)
}
