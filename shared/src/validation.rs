//! Sensor-frame validation: the boundary where a wire [`SensorFrame`] becomes typed,
//! validated [`SensorSamples`] (flagged, finite, within range), the estimation stage's
//! only input. Below [`crate::estimation`], above the wire ([`crate::link`]); the check of
//! a frame and the estimate against what a mode needs is [`crate::fsw::check`].

use crate::link::SensorFrame;
use crate::math::{Quat, Vec3, quat_from_xyzw, quat_normalized};
use crate::types::{
    CssOutputs, GnssFix, GyroIncrement, GyroRate, MagnetometerField, SensorSamples, StarTrackerAttitude,
    SunSensorDirection, Valid,
};

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

/// The gyro's angle increment if it gives one (`gyro_interval_us > 0`), finite, with a
/// mean rate within `MAX_RATE_RAD_S`; otherwise `None` (the rates are used instead).
pub fn gyro_increment(f: &SensorFrame) -> Option<GyroIncrement> {
    if f.gyro_interval_us == 0 || !finite(&f.gyro_angle_rad) {
        return None;
    }
    // ≤ 2^32 µs: the conversion rounds, never overflows.
    #[allow(clippy::cast_precision_loss)]
    let interval_s = f.gyro_interval_us as f32 * 1.0e-6;
    let angle_rad = Vec3::from(f.gyro_angle_rad);
    (angle_rad.amax() <= MAX_RATE_RAD_S * interval_s).then_some(GyroIncrement { angle_rad, interval_s })
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

/// The typed samples of one frame, each at its own time (`SensorFrame::sampled_at`; their
/// plausibility against the frame's time is the estimation stage's): a sample is present
/// when flagged valid and (gyro, star tracker, magnetometer) usable — gyro finite and
/// within [`MAX_RATE_RAD_S`], tracker quaternion finite with a norm within 10 % of 1
/// (normalised), magnetometer finite. The Sun sensors and the GNSS fix are handed over as
/// flagged: their plausibility is the estimators' (unit direction, the CSS fit, the fix's
/// orbit and time checks).
// Inlined: the samples are built in place in `Fsw::step` (no copy of the struct).
#[inline(always)]
pub fn sensor_samples(f: &SensorFrame) -> SensorSamples {
    let valid = valid_bits(f);
    let at = &f.sampled_at;
    SensorSamples {
        time_us: f.time_us,
        gyro: rate(f).map(|rate_rad_s| GyroRate { time_us: at.gyro_us, rate_rad_s, increment: gyro_increment(f) }),
        star_tracker: valid
            .contains(Valid::ATTITUDE)
            .then(|| unit_quat(f.q_ib_xyzw))
            .flatten()
            .map(|q_ib| StarTrackerAttitude { time_us: at.star_tracker_us, q_ib }),
        sun_sensor: valid
            .contains(Valid::SUN)
            .then(|| SunSensorDirection { time_us: at.sun_sensor_us, dir_body: Vec3::from(f.sun_dir) }),
        css: valid.contains(Valid::CSS).then_some(CssOutputs { time_us: at.css_us, output: f.css_output }),
        magnetometer: (valid.contains(Valid::MAG) && finite(&f.mag_field_t))
            .then(|| MagnetometerField { time_us: at.magnetometer_us, field_body_t: Vec3::from(f.mag_field_t) }),
        gnss: valid.contains(Valid::GNSS).then(|| GnssFix {
            time_us: at.gnss_us,
            pos_eci_m: Vec3::from(f.gnss_pos_m),
            vel_eci_m_s: Vec3::from(f.gnss_vel_m_s),
            j2000_days: f.gnss_j2000_days,
            j2000_s: f.gnss_j2000_s,
        }),
    }
}
