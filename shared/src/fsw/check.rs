//! The validate step of `Fsw::step`: a wire [`SensorFrame`] and the estimation stage's
//! [`Estimate`] checked against what one configuration needs, into typed
//! [`Measurements`] (or rejected, with the reason). The sensor limits are
//! [`crate::validation`]'s.

use crate::estimation::determination::Estimate;
use crate::link::SensorFrame;
use crate::math::{Quat, Vec3};
use crate::params::AttitudeSource;
use crate::types::{Measurements, Valid};
use crate::validation::{MAX_FIELD_T, MAX_GIMBAL_ANGLE_RAD, MAX_WHEEL_SPEED_RAD_S, valid_bits};

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
/// components > 1e-2 T, wheel speeds > 1e4 rad/s, gimbal angles > 1e3 rad; a sensor
/// whose newest sample is older than `max_sample_age_s` (`Estimate::stale`) counts as
/// missing, whatever its valid bit (the mode manager's "input lost").
pub fn check_frame(
    f: &SensorFrame,
    required: Valid,
    needs_navigation: bool,
    est: &Estimate,
) -> Result<Measurements, Missing> {
    let valid = valid_bits(f).difference(est.stale);
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
