//! Sun sensor: one fine sensor head with a conical field of view.
//!
//! Input: the attitude `q_ib`, the Sun direction (inertial, any length) and whether the
//! spacecraft is in eclipse. Output: the measured unit Sun vector in body axes and its
//! validity ([`SunReading`], held between samples; zero when invalid).
//!
//! Error model: the true direction turned by a white angular error normal to the Sun line
//! (σ about each of the two normal axes, total rms √2 σ; three normals drawn, the part
//! along the Sun line dropped). Invalid in eclipse and outside the field of view. Pure
//! helpers: [`sun_in_body`], [`cylindrical_eclipse`].

use super::clock::Clock;
use super::noise::{gauss3, sensor_rng};
use crate::attitude::{Quat, Vec3};
use nalgebra::UnitQuaternion;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SunSensorModel {
    pub rate_hz: f64,
    /// 1σ angular noise about each of the two axes normal to the sun line, rad
    /// (total angular error rms √2 σ).
    pub noise_rad: f64,
    /// Unit boresight, body.
    pub boresight_body: [f64; 3],
    /// Field-of-view cone half angle, rad (sun on the edge counts as inside).
    pub fov_half_angle_rad: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SunReading {
    pub t_s: f64,
    /// Measured unit sun vector, body; zero when invalid.
    pub sun_body: [f64; 3],
    /// False in eclipse, outside the field of view, or before the first sample.
    pub valid: bool,
}

/// Pure: unit sun direction in body axes, `R(q_ib)ᵀ s_i`.
pub fn sun_in_body(q_ib: &Quat, sun_inertial: &[f64; 3]) -> [f64; 3] {
    let s = Vec3::from(*sun_inertial).normalize();
    UnitQuaternion::from_quaternion(*q_ib).inverse_transform_vector(&s).into()
}

/// Pure: cylindrical Earth shadow. `r_m` satellite position and `sun_inertial` sun
/// direction in the same (Earth-centred) frame; Earth radius 6378.137 km.
pub fn cylindrical_eclipse(r_m: &[f64; 3], sun_inertial: &[f64; 3]) -> bool {
    const R_EARTH_M: f64 = 6_378_137.0;
    let (r, s) = (Vec3::from(*r_m), Vec3::from(*sun_inertial).normalize());
    let along = r.dot(&s);
    along < 0.0 && (r - s * along).norm() < R_EARTH_M
}

#[derive(Clone, Debug)]
pub struct SunSensor {
    pub spec: SunSensorModel,
    rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
    last: SunReading,
}

impl SunSensor {
    pub fn new(spec: SunSensorModel, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: SunReading::default(),
        }
    }

    /// Discrete: attitude, sun direction (inertial, any length) and eclipse flag at `t`.
    pub fn update(&mut self, t_s: f64, q_ib: &Quat, sun_inertial: &[f64; 3], in_eclipse: bool) -> SunReading {
        if self.clock.due(t_s).is_some() {
            let e = gauss3(&mut self.rng, &[self.spec.noise_rad; 3]);
            let s = Vec3::from(sun_in_body(q_ib, sun_inertial));
            let bore = Vec3::from(self.spec.boresight_body).normalize();
            let in_fov = s.dot(&bore).clamp(-1.0, 1.0).acos() <= self.spec.fov_half_angle_rad;
            let valid = !in_eclipse && in_fov;
            // Rotate by the noise component normal to the sun line.
            let e_perp = e - s * s.dot(&e);
            let m = UnitQuaternion::from_scaled_axis(e_perp) * s;
            self.last = SunReading { t_s, sun_body: if valid { m.normalize().into() } else { [0.0; 3] }, valid };
        }
        self.last
    }

    pub fn reading(&self) -> SunReading {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn sun_sensor_validity() {
        let spec = SunSensorModel {
            rate_hz: 2.0,
            noise_rad: 1e-3,
            boresight_body: [0.0, 0.0, 1.0],
            fov_half_angle_rad: 60f64.to_radians(),
        };
        let mut s = SunSensor::new(spec, 5, 3);
        let q = Quat::identity();
        // Sun along +z body: valid, close to truth.
        let r = s.update(0.0, &q, &[0.0, 0.0, 1.5e11], false);
        assert!(r.valid && (Vec3::from(r.sun_body) - Vec3::z()).norm() < 6e-3);
        // Eclipse.
        let r = s.update(0.5, &q, &[0.0, 0.0, 1.0], true);
        assert!(!r.valid && r.sun_body == [0.0; 3]);
        // 59° and 61° off boresight; sun behind.
        let dir = |deg: f64| [deg.to_radians().sin(), 0.0, deg.to_radians().cos()];
        assert!(s.update(1.0, &q, &dir(59.0), false).valid);
        assert!(!s.update(1.5, &q, &dir(61.0), false).valid);
        assert!(!s.update(2.0, &q, &[0.0, 0.0, -1.0], false).valid);
        // q_ib = 90° about x maps body z to inertial -y, so an inertial +y sun is body -z.
        let qx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2).into_inner();
        let sb = sun_in_body(&qx, &[0.0, 1.0, 0.0]);
        assert!((Vec3::from(sb) + Vec3::z()).norm() < 1e-15, "{sb:?}");
        // Angular noise: rms total angle ≈ √2 σ.
        let n = 20_000;
        let mut s2 = 0.0;
        for k in 0..n {
            let r = s.update(2.5 + k as f64 / 2.0, &q, &[0.0, 0.0, 1.0], false);
            s2 += Vec3::from(r.sun_body).angle(&Vec3::z()).powi(2);
        }
        let rms = (s2 / n as f64 / 2.0).sqrt();
        assert!((rms / 1e-3 - 1.0).abs() < 0.03, "{rms}");
        // Cylindrical shadow.
        let sun = [1.0, 0.0, 0.0];
        assert!(cylindrical_eclipse(&[-7.0e6, 0.0, 0.0], &sun));
        assert!(!cylindrical_eclipse(&[7.0e6, 0.0, 0.0], &sun));
        assert!(!cylindrical_eclipse(&[-7.0e6, 6.5e6, 0.0], &sun));
    }
}
