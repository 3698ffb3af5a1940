//! Sensor-frame validation: the boundary where a wire [`SensorFrame`] and the estimation
//! stage's [`Estimate`] become typed [`Measurements`] for one configuration (or are
//! rejected, with the reason).

use crate::estimation::determination::Estimate;
use crate::link::SensorFrame;
use crate::math::{Quat, Vec3, quat_from_xyzw, quat_normalized};
use crate::params::AttitudeSource;
use crate::types::{Measurements, Valid};

/// Largest body rate the flight code accepts as a measurement, rad/s.
pub const MAX_RATE_RAD_S: f32 = 50.0;
/// Largest magnetometer component accepted, T (Earth's field is < 7e-5 T; a lab
/// Helmholtz cage a few 1e-4 T).
pub const MAX_FIELD_T: f32 = 1.0e-2;
/// Largest wheel speed accepted, rad/s (≈ 95,000 rpm).
pub const MAX_WHEEL_SPEED_RAD_S: f32 = 1.0e4;
/// Gimbal angles accepted are below this in magnitude, rad (a multi-turn reading; beyond
/// it the encoder value is garbage).
pub const MAX_GIMBAL_ANGLE_RAD: f32 = 1.0e3;

/// The frame's validity bits (unknown bits from the wire are kept and ignored).
pub fn valid_bits(f: &SensorFrame) -> Valid {
    Valid::from_bits_retain(f.valid)
}

pub(crate) fn finite(xs: &[f32]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// The measured body rate if it is flagged valid, finite and within `MAX_RATE_RAD_S`.
pub fn rate(f: &SensorFrame) -> Option<Vec3> {
    let w = Vec3::from(f.rate_rad_s);
    if !valid_bits(f).contains(Valid::RATE) || !finite(&f.rate_rad_s) || w.amax() > MAX_RATE_RAD_S {
        return None;
    }
    Some(w)
}

/// A measured quaternion as a unit quaternion: `None` when not finite or its norm is off
/// by more than 10 %.
pub(crate) fn unit_quat(q: [f32; 4]) -> Option<Quat> {
    let q = quat_from_xyzw(q);
    let n = crate::math::norm(&q.coords);
    if !n.is_finite() || !(0.9..=1.1).contains(&n) {
        return None;
    }
    quat_normalized(&q)
}

/// Why a frame cannot run a configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Missing {
    /// A sensor input is missing or untrustworthy (`Status::BAD_INPUT`).
    Sensor,
    /// The fine attitude estimate or the navigation solution is not available
    /// (`Status::NO_ESTIMATE`).
    Estimate,
}

/// The validated measurements for a configuration that needs the sensor bits `required`
/// (`Valid::ATTITUDE` there means the attitude from the estimation stage) and, with
/// `needs_navigation`, the navigation solution. Rejects NaN/inf, rates > 50 rad/s, field
/// components > 1e-2 T, wheel speeds > 1e4 rad/s, gimbal angles > 1e3 rad.
pub fn check_frame(
    f: &SensorFrame,
    required: Valid,
    needs_navigation: bool,
    est: &Estimate,
) -> Result<Measurements, Missing> {
    let valid = valid_bits(f);
    if !valid.contains(required.difference(Valid::ATTITUDE)) {
        return Err(Missing::Sensor);
    }
    let attitude_missing = match est.source {
        AttitudeSource::Sensor => Missing::Sensor,
        AttitudeSource::Mekf => Missing::Estimate,
    };
    let q = match est.attitude {
        Some(q) => q,
        None if required.contains(Valid::ATTITUDE) => return Err(attitude_missing),
        // A law that needs no attitude gets identity (unused).
        None => Quat::identity(),
    };
    let w = est.rate_rad_s.ok_or(Missing::Sensor)?;
    if required.contains(Valid::GIMBALS)
        && !f.gimbal_angle_rad.iter().all(|x| x.is_finite() && libm::fabsf(*x) < MAX_GIMBAL_ANGLE_RAD)
    {
        return Err(Missing::Sensor);
    }
    let within = |xs: &[f32], limit: f32| xs.iter().all(|x| libm::fabsf(*x) <= limit);
    if required.contains(Valid::WHEELS) && !within(&f.wheel_speed_rad_s, MAX_WHEEL_SPEED_RAD_S) {
        return Err(Missing::Sensor);
    }
    if required.contains(Valid::MAG) && !within(&f.mag_field_t, MAX_FIELD_T) {
        return Err(Missing::Sensor);
    }
    let (q_ref, ref_rate_rad_s) = match est.nav {
        Some(n) => (n.q_lvlh, n.lvlh_rate_rad_s),
        None if needs_navigation => return Err(Missing::Estimate),
        None => (Quat::identity(), Vec3::zeros()),
    };
    Ok(Measurements {
        q,
        rate_rad_s: w,
        gimbal_angle_rad: f.gimbal_angle_rad,
        wheel_speed_rad_s: f.wheel_speed_rad_s,
        mag_field_t: Vec3::from(f.mag_field_t),
        q_ref,
        ref_rate_rad_s,
        sun_body: est.sun_body,
        eclipse: est.eclipse,
    })
}
