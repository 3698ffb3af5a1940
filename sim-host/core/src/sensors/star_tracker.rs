//! Attitude sensor: star tracker or AHRS.
//!
//! Input: the true attitude `q_ib` (body → inertial), the body rate (rad/s, for the rate
//! limit) and, when known, where the Sun and the Earth are ([`ExclusionGeometry`]). Output:
//! the measured `q_ib` and its validity ([`AttitudeReading`], held between samples).
//!
//! Error model: `q_m = q_ib ⊗ exp(b/2) ⊗ exp(n/2)`, a constant misalignment b and a white
//! small rotation n (rad, 1σ per axis; three normals per sample), both body-frame
//! perturbations, the multiplicative error convention of the MEKF (Markley & Crassidis
//! 2014, §6.2). With a boresight the noise is given per tracker axis (cross-boresight x,
//! y; about-boresight z). The reading is invalid above the rate limit and when the Sun (not
//! behind the Earth) or the limb of a lit Earth is inside its exclusion cone around the
//! boresight.

use super::clock::Clock;
use super::noise::{gauss3, sensor_rng};
use crate::attitude::{Quat, Vec3};
use nalgebra::UnitQuaternion;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Small rotation `exp(θ/2)` of a rotation vector θ (rad).
fn small_rot(theta: &Vec3) -> Quat {
    UnitQuaternion::from_scaled_axis(*theta).into_inner()
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttitudeSensorModel {
    pub rate_hz: f64,
    /// 1σ small-rotation noise about each body axis, rad.
    pub noise_rad: [f64; 3],
    /// Constant misalignment, rotation vector in body axes, rad (zero = none).
    pub bias_rad: [f64; 3],
    /// Above this body rate the tracker loses its stars (the reading is invalid), rad/s;
    /// `None` = no limit.
    pub max_rate_rad_s: Option<f64>,
    /// Boresight, unit vector in body axes. `Some`: `noise_rad` is per axis of the tracker
    /// frame (x, y cross-boresight, z = boresight; the shortest-arc rotation from body z to
    /// the boresight) and the exclusion angles are measured from it. `None`: body axes,
    /// boresight body z.
    #[serde(default)]
    pub boresight_body: Option<[f64; 3]>,
    /// Invalid when the Sun is closer than this to the boresight, rad (`None`: no rule).
    #[serde(default)]
    pub sun_exclusion_rad: Option<f64>,
    /// Invalid when the Earth's limb is closer than this to the boresight (or the
    /// boresight is on the Earth), rad (`None`: no rule).
    #[serde(default)]
    pub earth_exclusion_rad: Option<f64>,
}

/// Where the bright bodies are, for the tracker's exclusion rules (inertial axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExclusionGeometry {
    /// Unit vector spacecraft → Sun.
    pub sun_ref: Vec3,
    /// Unit vector spacecraft → Earth's centre.
    pub nadir_ref: Vec3,
    /// Earth's angular radius seen from the spacecraft, asin(R_E / r), rad.
    pub earth_half_angle_rad: f64,
    /// Some of the Earth's visible cap is sunlit (the Earth rule applies only then: a
    /// wholly dark Earth does not blind the tracker).
    pub earth_lit: bool,
}

impl ExclusionGeometry {
    /// The Sun is behind the Earth's disc (its rule does not apply).
    pub fn sun_occulted(&self) -> bool {
        self.sun_ref.normalize().dot(&self.nadir_ref.normalize()).clamp(-1.0, 1.0).acos() < self.earth_half_angle_rad
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeReading {
    pub t_s: f64,
    /// Measured `q_ib`.
    pub q_ib: Quat,
    pub valid: bool,
}

/// Star tracker / AHRS: `q_m = q_ib ⊗ exp(b/2) ⊗ exp(n/2)`, body-frame perturbations.
#[derive(Clone, Debug)]
pub struct AttitudeSensor {
    pub spec: AttitudeSensorModel,
    rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
    last: AttitudeReading,
}

impl AttitudeSensor {
    pub fn new(spec: AttitudeSensorModel, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: AttitudeReading { t_s: 0.0, q_ib: Quat::identity(), valid: false },
        }
    }

    /// Discrete: true `q_ib` (and body rate, for the rate limit) at `t`; samples if due,
    /// returns the held reading.
    pub fn update(&mut self, t_s: f64, q_ib_true: &Quat, rate_rad_s: &Vec3) -> AttitudeReading {
        self.update_with(t_s, q_ib_true, rate_rad_s, None)
    }

    /// Boresight in body axes (body z without `boresight_body`).
    pub fn boresight(&self) -> Vec3 {
        self.spec.boresight_body.map_or(Vec3::z(), |b| Vec3::from(b).normalize())
    }

    /// Angles boresight–Sun and boresight–Earth limb (negative: the boresight is on the
    /// Earth), rad, for a true attitude `q_ib`.
    pub fn exclusion_angles_rad(&self, q_ib: &Quat, g: &ExclusionGeometry) -> (f64, f64) {
        let b_ref = UnitQuaternion::from_quaternion(*q_ib) * self.boresight();
        let ang = |u: &Vec3| b_ref.dot(&u.normalize()).clamp(-1.0, 1.0).acos();
        (ang(&g.sun_ref), ang(&g.nadir_ref) - g.earth_half_angle_rad)
    }

    /// As [`Self::update`], with the Sun and Earth geometry for the exclusion rules
    /// (`None`: not known, rules not applied).
    pub fn update_with(
        &mut self,
        t_s: f64,
        q_ib_true: &Quat,
        rate_rad_s: &Vec3,
        geometry: Option<&ExclusionGeometry>,
    ) -> AttitudeReading {
        if self.clock.due(t_s).is_some() {
            let mut n = gauss3(&mut self.rng, &self.spec.noise_rad);
            if self.spec.boresight_body.is_some() {
                // Tracker frame → body: shortest arc z → boresight (identity if along z).
                let r = UnitQuaternion::rotation_between(&Vec3::z(), &self.boresight())
                    .unwrap_or_else(|| UnitQuaternion::from_scaled_axis(Vec3::x() * std::f64::consts::PI));
                n = r * n;
            }
            let q = q_ib_true.normalize() * small_rot(&Vec3::from(self.spec.bias_rad)) * small_rot(&n);
            let mut valid = self.spec.max_rate_rad_s.is_none_or(|m| rate_rad_s.norm() <= m);
            if let Some(g) = geometry {
                let (sun, limb) = self.exclusion_angles_rad(q_ib_true, g);
                valid &= g.sun_occulted() || self.spec.sun_exclusion_rad.is_none_or(|x| sun >= x);
                valid &= !g.earth_lit || self.spec.earth_exclusion_rad.is_none_or(|x| limb >= x);
            }
            self.last = AttitudeReading { t_s, q_ib: q, valid };
        }
        self.last
    }

    pub fn reading(&self) -> AttitudeReading {
        self.last
    }
}

impl AttitudeSensorModel {
    /// True when an exclusion rule needs the Sun and Earth geometry.
    pub fn has_exclusion(&self) -> bool {
        self.sun_exclusion_rad.is_some() || self.earth_exclusion_rad.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    fn ideal_tracker() -> AttitudeSensorModel {
        AttitudeSensorModel {
            rate_hz: 5.0,
            noise_rad: [0.0; 3],
            bias_rad: [0.0; 3],
            max_rate_rad_s: None,
            boresight_body: None,
            sun_exclusion_rad: None,
            earth_exclusion_rad: None,
        }
    }

    #[test]
    fn tracker_noise_split_cross_and_about_boresight() {
        // Boresight (1, 1, 0)/√2. The error rotation's covariance, projected on the
        // boresight and on two perpendicular axes chosen here (body z and b × z, not the
        // model's own tracker axes), must be diag(cross², cross², about²).
        let (cross, about) = (2e-4, 1.5e-3);
        let b = Vec3::new(1.0, 1.0, 0.0).normalize();
        let spec = AttitudeSensorModel {
            noise_rad: [cross, cross, about],
            boresight_body: Some([1.0, 1.0, 0.0]),
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 11, 2);
        let q_true = UnitQuaternion::from_euler_angles(-0.4, 0.7, 2.0);
        let axes = [Vec3::z(), b.cross(&Vec3::z()), b];
        let n = 20_000;
        let mut c = Matrix3::zeros();
        for k in 0..n {
            let r = s.update(k as f64 / 5.0, q_true.quaternion(), &Vec3::zeros());
            let e = (q_true.inverse() * UnitQuaternion::from_quaternion(r.q_ib)).scaled_axis();
            let et = Vec3::from_fn(|i, _| axes[i].dot(&e));
            c += et * et.transpose() / n as f64;
        }
        let want = [cross * cross, cross * cross, about * about];
        println!(
            "tracker covariance / expected diagonal: {:.4} {:.4} {:.4}",
            c[(0, 0)] / want[0],
            c[(1, 1)] / want[1],
            c[(2, 2)] / want[2]
        );
        for i in 0..3 {
            // 20 000 samples: 1σ of a variance estimate √(2/n) = 1 %; tolerance 4 %.
            assert!((c[(i, i)] / want[i] - 1.0).abs() < 0.04, "{i}: {}", c[(i, i)] / want[i]);
            for j in 0..i {
                // Correlation coefficient: 1σ = 1/√n = 0.7 %; tolerance 3 %.
                let rho = c[(i, j)] / (c[(i, i)] * c[(j, j)]).sqrt();
                assert!(rho.abs() < 0.03, "rho {i}{j} = {rho}");
            }
        }
    }

    #[test]
    fn tracker_sun_and_earth_exclusion() {
        // Boresight body z; the body turned by α about y puts it at (sin α, 0, cos α) in
        // inertial axes. Sun along inertial x: boresight–Sun angle |90° − α|. Earth centre
        // along −z with angular radius 60°: boresight–limb angle (180° − α) − 60°.
        let geo = ExclusionGeometry {
            sun_ref: Vec3::x(),
            nadir_ref: -Vec3::z(),
            earth_half_angle_rad: 60f64.to_radians(),
            earth_lit: true,
        };
        let att = |deg: f64| UnitQuaternion::from_axis_angle(&Vec3::y_axis(), deg.to_radians()).into_inner();
        let sun_only = AttitudeSensorModel { sun_exclusion_rad: Some(30f64.to_radians()), ..ideal_tracker() };
        let earth_only = AttitudeSensorModel { earth_exclusion_rad: Some(20f64.to_radians()), ..ideal_tracker() };
        let mut k = 0.0;
        let mut flag = |spec: AttitudeSensorModel, a: f64, g: Option<&ExclusionGeometry>| {
            let mut s = AttitudeSensor::new(spec, 1, 2);
            k += 1.0;
            s.update_with(k, &att(a), &Vec3::zeros(), g).valid
        };
        for (a, valid) in
            [(0.0, true), (59.99, true), (60.01, false), (90.0, false), (119.99, false), (120.01, true), (150.0, true)]
        {
            assert_eq!(flag(sun_only, a, Some(&geo)), valid, "sun, α = {a}");
        }
        // Limb angle 120° − α ≥ 20° ⇔ α ≤ 100°.
        for (a, valid) in [(0.0, true), (99.99, true), (100.01, false), (180.0, false)] {
            assert_eq!(flag(earth_only, a, Some(&geo)), valid, "earth, α = {a}");
        }
        // Unknown geometry: no rule applied.
        assert!(flag(sun_only, 90.0, None));
        // Closed-form angles, also for a boresight off body z (body x, identity attitude):
        // Sun at 25° from x in the x-y plane; Earth centre along −x.
        let s = AttitudeSensor::new(AttitudeSensorModel { boresight_body: Some([2.0, 0.0, 0.0]), ..sun_only }, 1, 2);
        let g2 = ExclusionGeometry {
            sun_ref: Vec3::new(25f64.to_radians().cos(), 25f64.to_radians().sin(), 0.0),
            nadir_ref: -Vec3::x(),
            earth_half_angle_rad: 0.5,
            earth_lit: true,
        };
        let (sun, limb) = s.exclusion_angles_rad(&Quat::identity(), &g2);
        assert!((sun - 25f64.to_radians()).abs() < 1e-12 && (limb - (std::f64::consts::PI - 0.5)).abs() < 1e-12);
        let mut s = s;
        assert!(!s.update_with(0.0, &Quat::identity(), &Vec3::zeros(), Some(&g2)).valid);
    }

    #[test]
    fn attitude_sensor_noise_and_bias() {
        let q_true = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1).into_inner();
        // Bias only: exact.
        let bias = [0.01, -0.02, 0.005];
        let spec = AttitudeSensorModel {
            rate_hz: 5.0,
            noise_rad: [0.0; 3],
            bias_rad: bias,
            max_rate_rad_s: Some(0.03),
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 3, 1);
        let r = s.update(0.0, &q_true, &Vec3::new(0.0, 0.02, 0.0));
        assert!(r.valid);
        let err =
            (UnitQuaternion::from_quaternion(q_true).inverse() * UnitQuaternion::from_quaternion(r.q_ib)).scaled_axis();
        assert!((err - Vec3::from(bias)).norm() < 1e-15);
        // Noise: per-axis rms of the body-frame error rotation.
        let sig = [1e-3, 2e-3, 4e-4];
        // Beyond its rate limit the tracker's reading is invalid.
        assert!(!s.update(1.0, &q_true, &Vec3::new(0.0, 0.02, 0.025)).valid);
        let spec = AttitudeSensorModel {
            rate_hz: 5.0,
            noise_rad: sig,
            bias_rad: [0.0; 3],
            max_rate_rad_s: None,
            ..ideal_tracker()
        };
        let mut s = AttitudeSensor::new(spec, 3, 1);
        let n = 20_000;
        let mut ss = Vec3::zeros();
        for k in 0..n {
            let r = s.update(k as f64 / 5.0, &q_true, &Vec3::new(1.0, 0.0, 0.0));
            let e = (UnitQuaternion::from_quaternion(q_true).inverse() * UnitQuaternion::from_quaternion(r.q_ib))
                .scaled_axis();
            ss += e.component_mul(&e);
        }
        for a in 0..3 {
            let rms = (ss[a] / n as f64).sqrt();
            assert!((rms / sig[a] - 1.0).abs() < 0.03, "axis {a}: {rms}");
        }
    }
}
