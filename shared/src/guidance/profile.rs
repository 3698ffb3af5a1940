//! Rest-to-rest rotation profiles within a rate and an acceleration limit: the
//! time-optimal bang-coast-bang (trapezoidal rate) profile, or bang-bang (triangular rate)
//! when the angle is too small to reach the rate limit (Wie 2008 §7.3; Bilimoria & Wie
//! 1993 for the time-optimal eigen-axis case).
//!
//! For an angle `θ`, rate limit `ω_m` and acceleration limit `α_m`:
//! - `θ ≥ ω_m²/α_m`: accelerate for `t_a = ω_m/α_m`, coast `t_c = θ/ω_m − ω_m/α_m`,
//!   decelerate for `t_a`; duration `T = θ/ω_m + ω_m/α_m`, peak rate `ω_m`;
//! - otherwise: `t_a = √(θ/α_m)`, no coast, `T = 2 t_a`, peak rate `√(θ α_m)`.

use crate::math::f32m::sqrt;

/// Rate and acceleration limits of a manoeuvre (positive, finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub rate_rad_s: f32,
    pub accel_rad_s2: f32,
}

/// One rest-to-rest profile over `angle_rad`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    pub angle_rad: f32,
    /// Acceleration phase, coast phase, s; the deceleration mirrors the acceleration.
    pub accel_s: f32,
    pub coast_s: f32,
    pub accel_rad_s2: f32,
    pub peak_rate_rad_s: f32,
}

/// Angle, rate and acceleration along a profile at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfilePoint {
    pub angle_rad: f32,
    pub rate_rad_s: f32,
    pub accel_rad_s2: f32,
}

impl Profile {
    /// The time-optimal profile over `angle_rad ≥ 0` within `limits`; `None` for a
    /// negative or non-finite angle or limits that are not positive and finite.
    pub fn plan(angle_rad: f32, limits: &Limits) -> Option<Self> {
        let (w, a) = (limits.rate_rad_s, limits.accel_rad_s2);
        if !(angle_rad >= 0.0 && angle_rad.is_finite() && w > 0.0 && w.is_finite() && a > 0.0 && a.is_finite()) {
            return None;
        }
        let p = if angle_rad >= w * w / a {
            Self { angle_rad, accel_s: w / a, coast_s: angle_rad / w - w / a, accel_rad_s2: a, peak_rate_rad_s: w }
        } else {
            let t = sqrt(angle_rad / a);
            Self { angle_rad, accel_s: t, coast_s: 0.0, accel_rad_s2: a, peak_rate_rad_s: a * t }
        };
        Some(p)
    }

    /// Total duration, s.
    pub fn duration_s(&self) -> f32 {
        2.0 * self.accel_s + self.coast_s
    }

    /// The profile at `t_s` after its start (clamped to the start and the end).
    pub fn at(&self, t_s: f32) -> ProfilePoint {
        let (ta, tc, a, w) = (self.accel_s, self.coast_s, self.accel_rad_s2, self.peak_rate_rad_s);
        let t = if t_s > 0.0 { t_s } else { 0.0 };
        let end = self.duration_s();
        if !(t < end) {
            return ProfilePoint { angle_rad: self.angle_rad, rate_rad_s: 0.0, accel_rad_s2: 0.0 };
        }
        if t < ta {
            return ProfilePoint { angle_rad: 0.5 * a * t * t, rate_rad_s: a * t, accel_rad_s2: a };
        }
        let after_accel = 0.5 * a * ta * ta;
        if t < ta + tc {
            return ProfilePoint { angle_rad: after_accel + w * (t - ta), rate_rad_s: w, accel_rad_s2: 0.0 };
        }
        let left = end - t;
        ProfilePoint { angle_rad: self.angle_rad - 0.5 * a * left * left, rate_rad_s: a * left, accel_rad_s2: -a }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_slew_coasts_at_the_rate_limit_and_ends_at_the_angle() {
        let l = Limits { rate_rad_s: 0.02, accel_rad_s2: 0.001 };
        let p = Profile::plan(1.0, &l).unwrap();
        // T = θ/ω + ω/α = 50 + 20 = 70 s.
        assert!((p.duration_s() - 70.0).abs() < 1e-4);
        assert_eq!(p.peak_rate_rad_s, 0.02);
        let mid = p.at(35.0);
        assert_eq!((mid.rate_rad_s, mid.accel_rad_s2), (0.02, 0.0));
        assert!((mid.angle_rad - 0.5).abs() < 1e-5);
        let end = p.at(70.0);
        assert_eq!((end.angle_rad, end.rate_rad_s), (1.0, 0.0));
    }

    #[test]
    fn a_short_slew_is_bang_bang_with_the_closed_form_peak() {
        let l = Limits { rate_rad_s: 0.1, accel_rad_s2: 0.001 };
        let p = Profile::plan(0.5, &l).unwrap();
        // √(θ/α) = √500 s each way, peak √(θ α).
        assert!((p.duration_s() - 2.0 * 500f32.sqrt()).abs() < 1e-3);
        assert!((p.peak_rate_rad_s - (0.5f32 * 0.001).sqrt()).abs() < 1e-7);
        assert_eq!(p.coast_s, 0.0);
    }

    #[test]
    fn the_angle_is_the_integral_of_the_rate() {
        let l = Limits { rate_rad_s: 0.03, accel_rad_s2: 0.002 };
        let p = Profile::plan(2.0, &l).unwrap();
        let (n, dt) = (20_000, p.duration_s() / 20_000.0);
        let mut angle = 0.0f64;
        for k in 0..n {
            angle += f64::from(p.at((k as f32 + 0.5) * dt).rate_rad_s) * f64::from(dt);
        }
        assert!((angle - 2.0).abs() < 1e-4, "{angle}");
    }

    #[test]
    fn bad_inputs_plan_nothing() {
        let l = Limits { rate_rad_s: 0.03, accel_rad_s2: 0.002 };
        assert!(Profile::plan(f32::NAN, &l).is_none());
        assert!(Profile::plan(-1.0, &l).is_none());
        assert!(Profile::plan(1.0, &Limits { rate_rad_s: 0.0, accel_rad_s2: 1.0 }).is_none());
    }
}
