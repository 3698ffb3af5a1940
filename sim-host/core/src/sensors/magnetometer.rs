//! Magnetometer: a three-axis fluxgate or magnetoresistive sensor.
//!
//! Input: the true field in body axes, T, and the torquers' realised dipole, A m², body.
//! Output: the measured field, T, in the sensor's axes ([`MagReading`], held between
//! samples).
//!
//! Error model: `B_m = R(θ)ᵀ B_body + C m_rods + b + n`: misalignment R(θ), the
//! torquers' field at the sensor through the calibrated coupling matrix C, a constant
//! (hard-iron) bias b and white noise n (three normals per sample), the linear sensor
//! model of Markley & Crassidis 2014, ch. 4.

use super::clock::Clock;
use super::noise::{gauss3, sensor_rng};
use crate::attitude::Vec3;
use nalgebra::{Matrix3, UnitQuaternion};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MagnetometerModel {
    pub rate_hz: f64,
    /// 1σ white noise per axis, T.
    pub noise_t: [f64; 3],
    /// Constant bias per axis, T, in the magnetometer's axes: the spacecraft's own field at
    /// the sensor (hard iron; put the constant residual dipole's field here) plus any
    /// sensor offset.
    pub bias_t: [f64; 3],
    /// Field at the magnetometer per unit rod dipole, row-major 3×3, T per A m²:
    /// `B_err = C m_rods` with `m_rods` the rods' body dipole
    /// ([`crate::plant::magnetorquers::MagnetorquerSet::rod_dipole_am2`]).
    pub coupling_t_per_am2: [[f64; 3]; 3],
    /// Misalignment: the sensor's axes are the body axes turned by this rotation vector
    /// (rad); it senses `R(θ)ᵀ B_body` (as the gyro's). Zero: none.
    #[serde(default)]
    pub misalignment_rad: [f64; 3],
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MagReading {
    pub t_s: f64,
    pub b_body_t: [f64; 3],
    pub valid: bool,
}

/// Magnetometer: `B_m = R(θ)ᵀ B_body + C m_rods + b + n`: the Earth's field seen along the
/// misaligned sensor axes, then the torquers' field (C as calibrated, in sensor axes), the
/// bias and the noise.
#[derive(Clone, Debug)]
pub struct Magnetometer {
    pub spec: MagnetometerModel,
    rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
    last: MagReading,
}

impl Magnetometer {
    pub fn new(spec: MagnetometerModel, scenario_seed: u64, index: u32) -> Self {
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            rng: sensor_rng(scenario_seed, index),
            last: MagReading::default(),
        }
    }

    /// Pure: noise-free reading for a true field and rod dipole.
    pub fn ideal(&self, b_body_t: &[f64; 3], rod_dipole_am2: &[f64; 3]) -> [f64; 3] {
        let c = Matrix3::from_row_slice(self.spec.coupling_t_per_am2.as_flattened());
        let mut b = Vec3::from(*b_body_t);
        // Skipped when zero so that magnetometers without misalignment keep their exact bits.
        if self.spec.misalignment_rad != [0.0; 3] {
            b = UnitQuaternion::from_scaled_axis(Vec3::from(self.spec.misalignment_rad)).inverse() * b;
        }
        (b + c * Vec3::from(*rod_dipole_am2) + Vec3::from(self.spec.bias_t)).into()
    }

    /// Discrete: true body field (T) and realised rod dipole (A m², body) at `t`.
    pub fn update(&mut self, t_s: f64, b_body_t: &[f64; 3], rod_dipole_am2: &[f64; 3]) -> MagReading {
        if self.clock.due(t_s).is_some() {
            let n = gauss3(&mut self.rng, &self.spec.noise_t);
            self.last = MagReading {
                t_s,
                b_body_t: (Vec3::from(self.ideal(b_body_t, rod_dipole_am2)) + n).into(),
                valid: true,
            };
        }
        self.last
    }

    pub fn reading(&self) -> MagReading {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magnetometer_sees_torquers_only_when_on() {
        use crate::plant::magnetorquers::MagnetorquerSet;
        let spec = MagnetometerModel {
            rate_hz: 10.0,
            noise_t: [0.0; 3],
            bias_t: [0.0; 3],
            coupling_t_per_am2: [[2e-6, 0.0, 1e-7], [0.0, -3e-6, 0.0], [5e-7, 0.0, 1e-6]],
            misalignment_rad: [0.0; 3],
        };
        let rig = MagnetorquerSet::paper003_rig();
        let b = [20e-6, -5e-6, 40e-6];
        let mut m = Magnetometer::new(spec, 9, 2);
        // Off, and commanded inside the dead band (the rods produce nothing): truth.
        assert_eq!(m.update(0.0, &b, &rig.rod_dipole_am2(&rig.realised(&[0.0; 3]))).b_body_t, b);
        assert_eq!(m.update(0.1, &b, &rig.rod_dipole_am2(&rig.realised(&[1.0, -1.0, 1.5]))).b_body_t, b);
        // On: B + C m.
        let dip = rig.rod_dipole_am2(&rig.realised(&[5.0, 0.0, -3.0]));
        let r = m.update(0.2, &b, &dip).b_body_t;
        let want = [20e-6 + 10e-6 - 3e-7, -5e-6, 40e-6 + 2.5e-6 - 3e-6];
        for a in 0..3 {
            assert!((r[a] - want[a]).abs() < 1e-18, "{r:?}");
        }
        // Noise and bias statistics.
        let spec = MagnetometerModel { noise_t: [1e-7, 2e-7, 5e-8], bias_t: [1e-6, 0.0, -1e-6], ..spec };
        let mut m = Magnetometer::new(spec, 9, 2);
        let n = 20_000;
        let (mut s1, mut s2) = (Vec3::zeros(), Vec3::zeros());
        for k in 0..n {
            let e = Vec3::from(m.update(k as f64 / 10.0, &b, &[0.0; 3]).b_body_t) - Vec3::from(b);
            s1 += e;
            s2 += e.component_mul(&e);
        }
        for a in 0..3 {
            let mean = s1[a] / n as f64;
            let sd = (s2[a] / n as f64 - mean * mean).sqrt();
            assert!((mean - spec.bias_t[a]).abs() < 4.0 * spec.noise_t[a] / (n as f64).sqrt());
            assert!((sd / spec.noise_t[a] - 1.0).abs() < 0.03);
        }
    }

    /// Independent rotation: Rodrigues' formula for the components of `v` in axes turned
    /// by the rotation vector `th` (i.e. R(θ)ᵀ v).
    fn rodrigues_transpose(th: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
        let ang = (th[0] * th[0] + th[1] * th[1] + th[2] * th[2]).sqrt();
        let k = [th[0] / ang, th[1] / ang, th[2] / ang];
        let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        let kxv = [k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]];
        let (s, c) = ang.sin_cos();
        [0, 1, 2].map(|i| v[i] * c - s * kxv[i] + (1.0 - c) * kv * k[i])
    }

    #[test]
    fn magnetometer_misalignment_rotates_the_field_exactly() {
        let b: [f64; 3] = [23e-6, -7e-6, 41e-6];
        let bn = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        for th_deg in [[0.0, 0.0, 90.0], [1.0, -2.0, 0.5], [30.0, 20.0, -45.0]] {
            let th = th_deg.map(f64::to_radians);
            let spec = MagnetometerModel {
                rate_hz: 10.0,
                noise_t: [0.0; 3],
                bias_t: [0.0; 3],
                coupling_t_per_am2: [[0.0; 3]; 3],
                misalignment_rad: th,
            };
            let r = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[0.0; 3]).b_body_t;
            let want = rodrigues_transpose(&th, &b);
            let err = (0..3).map(|i| (r[i] - want[i]).powi(2)).sum::<f64>().sqrt() / bn;
            println!("magnetometer misalignment {th_deg:?} deg: relative error {err:.1e}");
            assert!(err < 1e-15, "{th_deg:?}: {r:?} vs {want:?}");
            // Bias and coupling come after the rotation (in sensor axes), unrotated.
            let spec =
                MagnetometerModel { bias_t: [1e-6, 2e-6, -3e-6], coupling_t_per_am2: [[1e-6, 0.0, 0.0]; 3], ..spec };
            let r2 = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[2.0, 0.0, 0.0]).b_body_t;
            for i in 0..3 {
                assert!((r2[i] - (want[i] + spec.bias_t[i] + 2e-6)).abs() < 1e-15 * bn, "{r2:?}");
            }
        }
        // 90° about z: sensor x = body y, sensor y = body −x.
        let spec = MagnetometerModel {
            rate_hz: 1.0,
            noise_t: [0.0; 3],
            bias_t: [0.0; 3],
            coupling_t_per_am2: [[0.0; 3]; 3],
            misalignment_rad: [0.0, 0.0, std::f64::consts::FRAC_PI_2],
        };
        let r = Magnetometer::new(spec, 1, 3).update(0.0, &b, &[0.0; 3]).b_body_t;
        assert!((r[0] - b[1]).abs() < 1e-15 * bn && (r[1] + b[0]).abs() < 1e-15 * bn && r[2] == b[2], "{r:?}");
    }
}
