//! Coarse sun sensors: cosine-law photocells, one normalised output per head.
//!
//! Input: the attitude `q_ib` and where the Sun and the Earth are ([`CssGeometry`]: unit
//! spacecraft → Sun vector, position in m, eclipse flag). Output: each head's normalised
//! output (1 = Sun along its normal, ≥ 0; [`CssReading`], held between samples).
//!
//! Error model: direct Sun by the cosine law (Wertz 1978, §7.1), a crude one-source
//! Earth-albedo term (see Bhanderi 2005 for a full model) and white noise, one normal per
//! head and sample, the sum floored at 0; see [`CoarseSunSensors`].

use super::clock::Clock;
use super::noise::sensor_rng;
use crate::attitude::{Quat, Vec3};
use nalgebra::UnitQuaternion;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Most heads a coarse sun sensor suite can have (`SensorFrame::css_output`).
pub const MAX_CSS_HEADS: usize = acs_flight::types::MAX_CSS_HEADS;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CssModel {
    pub rate_hz: f64,
    /// Outward unit normals of the heads, body axes (1 … [`MAX_CSS_HEADS`]; normalised
    /// here); the order is the output index.
    pub normals_body: Vec<[f64; 3]>,
    /// 1σ white noise of each head's normalised output (1 = Sun along the normal).
    pub noise: f64,
    /// Earth albedo coefficient a (0: no albedo).
    pub albedo: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CssReading {
    pub t_s: f64,
    /// Normalised output per head (≥ 0), unused heads 0.
    pub output: [f64; MAX_CSS_HEADS],
    /// False before the first sample.
    pub valid: bool,
}

/// Where the Sun and the Earth are, for the coarse sun sensors (inertial axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CssGeometry {
    /// Unit vector spacecraft → Sun.
    pub sun_ref: Vec3,
    /// Spacecraft position from the Earth's centre, m.
    pub r_m: Vec3,
    /// In the Earth's shadow.
    pub eclipse: bool,
}

/// Coarse sun sensors: cosine-law photocells. Head i with outward normal nᵢ reads
///
/// `yᵢ = max(0, nᵢ·ŝ + a (R_E/r)² max(0, nᵢ·(−r̂)) max(0, ŝ·r̂) + εᵢ)`, ε ~ N(0, σ²),
///
/// all vectors in body axes, ŝ the unit spacecraft → Sun vector, r̂ the unit position
/// vector. The first term is the direct Sun (cosine law, 0 behind the head or in eclipse:
/// Wertz, *Spacecraft Attitude Determination and Control*, §7.1). The second is a crude
/// albedo model, an approximation: the sunlit Earth seen as one Lambertian source along
/// nadir whose irradiance, relative to the Sun's, is the albedo coefficient times the
/// solid-angle factor (R_E/r)², weighted by the head's cosine to nadir and by how sunlit
/// the sub-satellite point is (ŝ·r̂); it ignores the Earth's finite extent, the phase of
/// the lit crescent and the reflectivity's variation (for those see Bhanderi, *Spacecraft
/// Attitude Determination with Earth Albedo Corrected Sun Sensor Measurements*, 2005).
/// The noise is added last and the sum floored at 0 (a photocell does not read negative).
#[derive(Clone, Debug)]
pub struct CoarseSunSensors {
    pub spec: CssModel,
    normals: Vec<Vec3>,
    rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
    last: CssReading,
}

impl CoarseSunSensors {
    pub fn new(spec: CssModel, scenario_seed: u64, index: u32) -> Self {
        assert!(
            (1..=MAX_CSS_HEADS).contains(&spec.normals_body.len()),
            "coarse sun sensors need 1 to {MAX_CSS_HEADS} heads"
        );
        let normals = spec.normals_body.iter().map(|n| Vec3::from(*n).normalize()).collect();
        Self {
            clock: Clock::new(spec.rate_hz),
            spec,
            normals,
            rng: sensor_rng(scenario_seed, index),
            last: CssReading::default(),
        }
    }

    /// Pure: noise-free outputs (direct + albedo) per head for attitude `q_ib`.
    pub fn ideal(&self, q_ib: &Quat, g: &CssGeometry) -> [f64; MAX_CSS_HEADS] {
        let q = UnitQuaternion::from_quaternion(*q_ib);
        let s_body = q.inverse_transform_vector(&g.sun_ref.normalize());
        let r = g.r_m.norm();
        let r_hat = g.r_m / r;
        let nadir_body = q.inverse_transform_vector(&-r_hat);
        let lit = g.sun_ref.normalize().dot(&r_hat).max(0.0);
        let scale = self.spec.albedo * (crate::environment::orbit::R_E / r).powi(2) * lit;
        let mut out = [0.0; MAX_CSS_HEADS];
        for (o, n) in out.iter_mut().zip(&self.normals) {
            let direct = if g.eclipse { 0.0 } else { n.dot(&s_body).max(0.0) };
            let albedo = if scale > 0.0 { scale * n.dot(&nadir_body).max(0.0) } else { 0.0 };
            *o = direct + albedo;
        }
        out
    }

    /// Discrete: attitude and geometry at `t`; samples if due (one normal per head),
    /// returns the held reading.
    pub fn update(&mut self, t_s: f64, q_ib: &Quat, g: &CssGeometry) -> CssReading {
        if self.clock.due(t_s).is_some() {
            let mut out = self.ideal(q_ib, g);
            for o in out.iter_mut().take(self.normals.len()) {
                let n: f64 = StandardNormal.sample(&mut self.rng);
                *o = (*o + n * self.spec.noise).max(0.0);
            }
            self.last = CssReading { t_s, output: out, valid: true };
        }
        self.last
    }

    pub fn heads(&self) -> usize {
        self.normals.len()
    }

    pub fn reading(&self) -> CssReading {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::super::noise::gauss3;
    use super::*;
    use nalgebra::Matrix3;

    fn css_spec(noise: f64, albedo: f64) -> CssModel {
        CssModel {
            rate_hz: 10.0,
            normals_body: vec![
                [1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            noise,
            albedo,
        }
    }

    /// Independent body components of an inertial vector: Rᵀ v with R the direction cosine
    /// matrix of the unit quaternion (x, y, z, w) written out (Markley & Crassidis eq. 2.125).
    fn to_body(q: &[f64; 4], v: &Vec3) -> Vec3 {
        let [x, y, z, w] = *q;
        let r = Matrix3::new(
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        );
        r.transpose() * v
    }

    #[test]
    fn css_cosine_response_is_exact_for_random_attitudes() {
        let mut css = CoarseSunSensors::new(css_spec(0.0, 0.0), 1, 5);
        let mut rng = sensor_rng(2024, 77);
        let sun = Vec3::new(0.3, -0.8, 0.52).normalize();
        let g = CssGeometry { sun_ref: sun, r_m: Vec3::new(7.0e6, 0.0, 0.0), eclipse: false };
        let mut worst = 0.0_f64;
        for k in 0..2000 {
            let v = gauss3(&mut rng, &[1.0; 3]);
            let w: f64 = StandardNormal.sample(&mut rng);
            let nq = (v.norm_squared() + w * w).sqrt();
            let qv = [v.x / nq, v.y / nq, v.z / nq, w / nq];
            let r = css.update(k as f64 / 10.0, &Quat::new(qv[3], qv[0], qv[1], qv[2]), &g);
            assert!(r.valid);
            let s_b = to_body(&qv, &sun);
            for (i, n) in css.spec.normals_body.clone().iter().enumerate() {
                let want = Vec3::from(*n).normalize().dot(&s_b).max(0.0);
                worst = worst.max((r.output[i] - want).abs());
            }
        }
        println!("css cosine law: worst |error| {worst:.1e}");
        // Two rounding paths (nalgebra's quaternion rotation vs the DCM above): a few ulps.
        assert!(worst < 5e-15, "{worst}");
    }

    #[test]
    fn css_eclipse_and_albedo_closed_forms() {
        // Identity attitude, r along +x at 7000 km: nadir is body −x (head 1), zenith +x
        // (head 0). Sun at β from r̂ in the x-y plane. Closed forms: head 0 reads cos β
        // (direct only, it cannot see nadir); head 1 sees no Sun (β < 90°) and the albedo
        // a (R_E/r)² cos β; head 2 (+y) reads sin β directly plus nothing from nadir.
        let (a, r) = (0.3, 7.0e6);
        let css = CoarseSunSensors::new(css_spec(0.0, a), 1, 5);
        let q = Quat::identity();
        for beta_deg in [0.0, 30.0, 60.0, 89.0] {
            let beta = f64::to_radians(beta_deg);
            let g = CssGeometry {
                sun_ref: Vec3::new(beta.cos(), beta.sin(), 0.0),
                r_m: Vec3::new(r, 0.0, 0.0),
                eclipse: false,
            };
            let y = css.ideal(&q, &g);
            let albedo = a * (crate::environment::orbit::R_E / r).powi(2) * beta.cos();
            assert!((y[0] - beta.cos()).abs() < 1e-15, "{beta_deg}: {y:?}");
            assert!((y[1] - albedo).abs() < 1e-15 * albedo.max(1e-300), "{beta_deg}: {} vs {albedo}", y[1]);
            assert!((y[2] - beta.sin()).abs() < 1e-15, "{beta_deg}: {y:?}");
        }
        // Sub-satellite point in the night (Sun behind the Earth): no albedo.
        let night = CssGeometry { sun_ref: -Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: false };
        assert_eq!(css.ideal(&q, &night)[1], 1.0, "nadir head sees the Sun directly, no albedo");
        // Eclipse: the direct term vanishes on every head; with albedo off all read 0.
        let ecl = CssGeometry { sun_ref: -Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: true };
        assert_eq!(css.ideal(&q, &ecl), [0.0; MAX_CSS_HEADS]);
        let mut dark = CoarseSunSensors::new(css_spec(0.0, 0.0), 1, 5);
        let lit_but_flagged = CssGeometry { sun_ref: Vec3::x(), r_m: Vec3::new(r, 0.0, 0.0), eclipse: true };
        let rd = dark.update(0.0, &q, &lit_but_flagged);
        assert!(rd.valid && rd.output == [0.0; MAX_CSS_HEADS], "{rd:?}");
    }

    #[test]
    fn css_noise_sigma() {
        // Head 0 faces the Sun at 60°: mean 0.5, 1σ 0.01 (50σ above the floor at 0).
        let sigma = 0.01;
        let mut css = CoarseSunSensors::new(css_spec(sigma, 0.0), 8, 5);
        let b = 60f64.to_radians();
        let g =
            CssGeometry { sun_ref: Vec3::new(b.cos(), b.sin(), 0.0), r_m: Vec3::new(7.0e6, 0.0, 0.0), eclipse: false };
        let n = 20_000;
        let (mut s1, mut s2) = (0.0, 0.0);
        for k in 0..n {
            let e = css.update(k as f64 / 10.0, &Quat::identity(), &g).output[0] - 0.5;
            s1 += e;
            s2 += e * e;
        }
        let mean = s1 / n as f64;
        let sd = (s2 / n as f64 - mean * mean).sqrt();
        println!("css noise: mean {mean:.2e}, sd / σ = {:.4}", sd / sigma);
        // 20 000 samples: 1σ of the sd estimate 0.5 %; tolerance 3 %.
        assert!((sd / sigma - 1.0).abs() < 0.03, "{sd}");
        assert!(mean.abs() < 4.0 * sigma / (n as f64).sqrt(), "{mean}");
        // Floored at 0: a head facing away reads max(0, noise) ≥ 0, about half the time > 0.
        let mut pos = 0;
        for k in n..n + 2000 {
            let y = css.update(k as f64 / 10.0, &Quat::identity(), &g).output[1];
            assert!(y >= 0.0);
            pos += usize::from(y > 0.0);
        }
        assert!((pos as f64 / 2000.0 - 0.5).abs() < 0.05, "{pos}");
    }
}
