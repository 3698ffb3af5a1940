//! Sensor-frame validation: the boundary where a wire [`SensorFrame`] becomes typed
//! [`Measurements`] (or is rejected).

use crate::link::SensorFrame;
use crate::math::{Quat, Vec3, quat_from_xyzw, quat_normalized};
use crate::types::{Measurements, Valid};

/// Largest body rate the flight code accepts as a measurement, rad/s.
pub const MAX_RATE_RAD_S: f32 = 50.0;
/// Largest magnetometer component accepted, T (Earth's field is < 7e-5 T; a lab
/// Helmholtz cage a few 1e-4 T).
pub const MAX_FIELD_T: f32 = 1.0e-2;
/// Largest wheel speed accepted, rad/s (≈ 95,000 rpm).
pub const MAX_WHEEL_SPEED_RAD_S: f32 = 1.0e4;

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

fn unit_quat(q: [f32; 4]) -> Option<Quat> {
    let q = quat_from_xyzw(q);
    let n = crate::math::norm(&q.coords);
    if !n.is_finite() || !(0.9..=1.1).contains(&n) {
        return None;
    }
    quat_normalized(&q)
}

/// `None` when anything the configuration needs (`required`) is missing or
/// untrustworthy: NaN/inf, quaternion norm off by > 10 %, rates > 50 rad/s, field
/// components > 1e-2 T, wheel speeds > 1e4 rad/s, gimbal angles > 1e3 rad.
pub fn check_frame(f: &SensorFrame, required: Valid) -> Option<Measurements> {
    let valid = valid_bits(f);
    if !valid.contains(required) {
        return None;
    }
    // An attitude flagged valid must be a unit quaternion; one the law does not need may
    // be absent (identity then, unused).
    let q = if valid.contains(Valid::ATTITUDE) || required.contains(Valid::ATTITUDE) {
        unit_quat(f.q_ib_xyzw)?
    } else {
        Quat::identity()
    };
    let w = Vec3::from(f.rate_rad_s);
    if !finite(&f.rate_rad_s) || w.amax() > MAX_RATE_RAD_S {
        return None;
    }
    if required.contains(Valid::GIMBALS) && !f.gimbal_angle_rad.iter().all(|x| x.is_finite() && libm::fabsf(*x) < 1.0e3)
    {
        return None;
    }
    let within = |xs: &[f32], limit: f32| xs.iter().all(|x| libm::fabsf(*x) <= limit);
    if required.contains(Valid::WHEELS) && !within(&f.wheel_speed_rad_s, MAX_WHEEL_SPEED_RAD_S) {
        return None;
    }
    if required.contains(Valid::MAG) && !within(&f.mag_field_t, MAX_FIELD_T) {
        return None;
    }
    let (q_ref, ref_rate_rad_s) = if required.contains(Valid::REFERENCE) {
        if !finite(&f.ref_rate_rad_s) {
            return None;
        }
        (unit_quat(f.q_ref_xyzw)?, Vec3::from(f.ref_rate_rad_s))
    } else {
        (Quat::identity(), Vec3::zeros())
    };
    Some(Measurements {
        q,
        rate_rad_s: w,
        gimbal_angle_rad: f.gimbal_angle_rad,
        wheel_speed_rad_s: f.wheel_speed_rad_s,
        mag_field_t: Vec3::from(f.mag_field_t),
        q_ref,
        ref_rate_rad_s,
    })
}
