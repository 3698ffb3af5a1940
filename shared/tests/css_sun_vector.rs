//! Coarse-sun-sensor Sun vector against independent truths: noise-free cosine currents
//! (exact to f32 rounding where the lit heads span 3-D, a closed-form bound where they do
//! not), the first-order noise prediction `σ²(trace M⁻¹ − sᵀM⁻¹s)` over a Monte Carlo, and
//! absurd inputs (no panic, typed errors).

// The truth is computed in f64 on the host: nalgebra's f64 norms are the reference here.
#![allow(clippy::disallowed_methods)]

use acs_flight::estimation::css::{CSS_MAX_TRACE_INV, CssError, CssHeads, CssSolution, sun_vector};
use acs_flight::types::MAX_CSS_HEADS;
use acs_test_support::rng::SplitMix64 as Rng;
use nalgebra::{Matrix3, Vector3};

type V64 = Vector3<f64>;

const THRESHOLD: f32 = 0.05;

/// Six heads on the faces of a cube: ±x ±y ±z.
fn cube() -> CssHeads {
    CssHeads { normals_body: acs_flight::params::CUBE_FACES, count: 6, lit_threshold: THRESHOLD }
}

/// Five-head pyramid: a boresight head on +z and four heads tilted 45° from it at
/// azimuths 0°, 90°, 180°, 270° (the sixth slot unused).
fn pyramid() -> CssHeads {
    let t = std::f64::consts::FRAC_PI_4;
    let mut normals = [[0.0f32; 3]; MAX_CSS_HEADS];
    normals[0] = [0.0, 0.0, 1.0];
    for k in 0..4 {
        let az = k as f64 * std::f64::consts::FRAC_PI_2;
        normals[k + 1] = [(t.sin() * az.cos()) as f32, (t.sin() * az.sin()) as f32, t.cos() as f32];
    }
    CssHeads { normals_body: normals, count: 5, lit_threshold: THRESHOLD }
}

fn normals64(h: &CssHeads) -> Vec<V64> {
    h.normals_body[..h.count as usize]
        .iter()
        .map(|n| V64::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2])))
        .collect()
}

/// Noise-free cosine currents `max(0, n·s)` (f64, then rounded to f32) plus `noise`.
fn currents(h: &CssHeads, s: &V64, noise: &mut dyn FnMut() -> f64) -> [f32; MAX_CSS_HEADS] {
    let mut c = [0.0f32; MAX_CSS_HEADS];
    for (ci, n) in c.iter_mut().zip(normals64(h)) {
        *ci = (n.dot(s).max(0.0) + noise()) as f32;
    }
    c
}

/// The f64 least-squares geometry of the heads lit by `c`: `M = Σ n nᵀ` over them.
fn lit_matrix(h: &CssHeads, c: &[f32; MAX_CSS_HEADS]) -> Matrix3<f64> {
    let mut m = Matrix3::zeros();
    for (n, ci) in normals64(h).iter().zip(c) {
        if *ci > h.lit_threshold {
            m += n * n.transpose();
        }
    }
    m
}

fn angle(a: &V64, b: &V64) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

fn v64(v: &acs_flight::math::Vec3) -> V64 {
    V64::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

#[test]
fn exact_on_noise_free_cosine_currents_and_bounded_when_coarse() {
    // The coarse bound for orthogonal heads: the components whose heads are below the
    // threshold are dropped; at most two of them, each below the threshold.
    let cube_coarse_bound = (2f64.sqrt() * f64::from(THRESHOLD)).asin();
    for (name, heads, seed) in [("cube", cube(), 11u64), ("pyramid", pyramid(), 12)] {
        heads.validate().unwrap();
        let mut rng = Rng(seed);
        let (mut n_ls, mut n_coarse, mut n_boundary, mut n_unseen) = (0, 0, 0, 0);
        let (mut worst_ls, mut worst_int, mut worst_coarse) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..10_000 {
            let s = rng.unit();
            let c = currents(&heads, &s, &mut || 0.0);
            let m = lit_matrix(&heads, &c);
            // Independent decision: f64 inverse of the lit heads' M.
            let tr_inv = m.try_inverse().map(|mi| mi.trace()).filter(|t| t.is_finite() && *t > 0.0);
            let expect_ls = tr_inv.is_some_and(|t| t <= f64::from(CSS_MAX_TRACE_INV));
            let near_boundary = tr_inv.is_some_and(|t| (t / f64::from(CSS_MAX_TRACE_INV) - 1.0).abs() < 1e-3);
            let lit = c.iter().take(heads.count as usize).filter(|x| **x > THRESHOLD).count();
            match sun_vector(&heads, &c) {
                Err(CssError::NotSeen) => {
                    assert_eq!(lit, 0, "{name}: NotSeen with {lit} lit heads, s = {s:?}");
                    n_unseen += 1;
                }
                Err(e) => panic!("{name}: unexpected {e:?} for s = {s:?}"),
                Ok(sun) => {
                    assert_eq!(usize::from(sun.lit), lit);
                    let err = angle(&v64(&sun.dir_body), &s);
                    if near_boundary {
                        n_boundary += 1;
                        continue;
                    }
                    match sun.solution {
                        CssSolution::LeastSquares => {
                            assert!(expect_ls, "{name}: LS where f64 says ill-conditioned, s = {s:?}");
                            assert!(err < 1e-5, "{name}: LS error {err:e} rad, s = {s:?}");
                            worst_ls = worst_ls.max(err);
                            worst_int = worst_int.max((f64::from(sun.intensity) - 1.0).abs());
                            n_ls += 1;
                        }
                        CssSolution::Coarse => {
                            assert!(!expect_ls, "{name}: coarse where f64 says well-conditioned, s = {s:?}");
                            if name == "cube" {
                                assert!(err <= cube_coarse_bound + 1e-6, "cube coarse error {err} rad > bound");
                            }
                            worst_coarse = worst_coarse.max(err);
                            n_coarse += 1;
                        }
                    }
                }
            }
        }
        println!(
            "{name}: {n_ls} least squares (worst {worst_ls:.2e} rad, |intensity-1| {worst_int:.1e}), \
             {n_coarse} coarse (worst {:.2} deg), {n_unseen} not seen, {n_boundary} at the conditioning boundary",
            worst_coarse.to_degrees()
        );
        assert!(worst_int < 1e-5);
        if name == "cube" {
            // All three components above the threshold: (1 - P(|s_i| <= 0.05))³ ≈ 0.857.
            assert!(n_ls > 8_300 && n_ls < 8_800, "cube LS fraction {n_ls}");
            assert_eq!(n_unseen, 0, "the cube sees every direction");
        } else {
            // Unseen: every head at or below the threshold, a cone around -z.
            assert!(n_unseen > 0 && n_ls > 3_000);
        }
    }
}

#[test]
fn not_seen_and_documented_degeneracies() {
    let h = cube();
    assert_eq!(sun_vector(&h, &[0.0; 6]), Err(CssError::NotSeen));
    assert_eq!(sun_vector(&h, &[THRESHOLD; 6]), Err(CssError::NotSeen), "at the threshold is unlit");
    assert_eq!(sun_vector(&h, &[-0.7; 6]), Err(CssError::NotSeen), "negative counts as 0");
    // One lit head: its normal, flagged coarse.
    let one = sun_vector(&h, &[0.0, 0.0, 0.0, 0.0, 0.8, 0.0]).unwrap();
    assert_eq!(one.solution, CssSolution::Coarse);
    assert_eq!(one.lit, 1);
    assert!((v64(&one.dir_body) - V64::z()).norm() < 1e-7);
    assert!((one.intensity - 0.8).abs() < 1e-7);
    // Two lit heads: the Sun in their plane, exact when the third component is zero.
    let s = V64::new(0.6, 0.8, 0.0);
    let two = sun_vector(&h, &currents(&h, &s, &mut || 0.0)).unwrap();
    assert_eq!(two.solution, CssSolution::Coarse);
    assert!(angle(&v64(&two.dir_body), &s) < 1e-7);
    // Opposite heads both lit (impossible for cosine detectors, a failed head): the
    // weighted normals cancel, M is singular -> refused as not seen, no NaN.
    assert_eq!(sun_vector(&h, &[0.5, 0.5, 0.0, 0.0, 0.0, 0.0]), Err(CssError::NotSeen));
    // Three lit heads nearly coplanar: the f64 trace(M⁻¹) exceeds the bound, coarse.
    let a = 0.1f64; // tilt of the third normal out of the x-y plane
    let mut tilted = h;
    tilted.count = 3;
    tilted.normals_body = [[0.0; 3]; 6];
    tilted.normals_body[0] = [1.0, 0.0, 0.0];
    tilted.normals_body[1] = [0.0, 1.0, 0.0];
    tilted.normals_body[2] = [(a.cos() * 0.5f64.sqrt()) as f32, (a.cos() * 0.5f64.sqrt()) as f32, a.sin() as f32];
    tilted.validate().unwrap();
    let s = V64::new(1.0, 1.0, 0.5).normalize();
    let c = currents(&tilted, &s, &mut || 0.0);
    let tr = lit_matrix(&tilted, &c).try_inverse().unwrap().trace();
    assert!(tr > f64::from(CSS_MAX_TRACE_INV), "trace(M⁻¹) = {tr}");
    assert_eq!(sun_vector(&tilted, &c).unwrap().solution, CssSolution::Coarse);
}

#[test]
fn noise_matches_first_order_prediction() {
    // First order: s_hat = s + M⁻¹ Σ δIᵢ nᵢ with δIᵢ ~ N(0, σ²) independent, so the
    // solution error has covariance σ² M⁻¹; the angular error is its part perpendicular
    // to the unit s: E[θ²] = σ² (trace M⁻¹ − sᵀ M⁻¹ s). Averaged over the samples, the
    // measured RMS angle must match sqrt(mean predicted θ²) within 10 %.
    let sigma = 0.005f64;
    for (name, heads, seed) in [("cube", cube(), 21u64), ("pyramid", pyramid(), 22)] {
        let mut rng = Rng(seed);
        let mut noise_rng = Rng(seed + 100);
        let (mut sum_meas, mut sum_pred, mut n) = (0.0f64, 0.0f64, 0usize);
        let mut sum_int = 0.0f64;
        while n < 20_000 {
            let s = rng.unit();
            let c = currents(&heads, &s, &mut || sigma * noise_rng.normal());
            let Ok(sun) = sun_vector(&heads, &c) else { continue };
            if sun.solution != CssSolution::LeastSquares {
                continue;
            }
            let mi = lit_matrix(&heads, &c).try_inverse().unwrap();
            sum_pred += sigma * sigma * (mi.trace() - s.dot(&(mi * s)));
            sum_meas += angle(&v64(&sun.dir_body), &s).powi(2);
            sum_int += f64::from(sun.intensity);
            n += 1;
        }
        let (meas, pred) = ((sum_meas / n as f64).sqrt(), (sum_pred / n as f64).sqrt());
        println!(
            "{name}: sigma {sigma}: angular error RMS {:.4} deg measured vs {:.4} deg predicted ({:+.2} %), \
             mean intensity {:.4}",
            meas.to_degrees(),
            pred.to_degrees(),
            100.0 * (meas / pred - 1.0),
            sum_int / n as f64
        );
        assert!((meas / pred - 1.0).abs() < 0.10);
    }
}

#[test]
fn absurd_inputs_never_panic() {
    let h = cube();
    let mut c = [0.9f32, 0.0, 0.3, 0.0, 0.2, 0.0];
    c[2] = f32::NAN;
    assert_eq!(sun_vector(&h, &c), Err(CssError::NonFinite));
    c[2] = f32::INFINITY;
    assert_eq!(sun_vector(&h, &c), Err(CssError::NonFinite));
    c[2] = f32::NEG_INFINITY;
    assert_eq!(sun_vector(&h, &c), Err(CssError::NonFinite));
    c[2] = 1e30;
    assert_eq!(sun_vector(&h, &c), Err(CssError::OutOfRange));
    c[2] = -1e30; // negative: counts as 0
    assert_eq!(sun_vector(&h, &c).unwrap().lit, 2);
    c[2] = f32::MAX;
    assert_eq!(sun_vector(&h, &c), Err(CssError::OutOfRange));
    // Unused slots are not read.
    let mut p = pyramid();
    let mut c = currents(&p, &V64::z(), &mut || 0.0);
    c[5] = f32::NAN;
    assert!(sun_vector(&p, &c).is_ok());
    // Bad geometry.
    p.count = 0;
    assert_eq!(sun_vector(&p, &c), Err(CssError::BadCount));
    p.count = 7;
    assert_eq!(p.validate(), Err(CssError::BadCount));
    p.count = 255;
    assert_eq!(p.validate(), Err(CssError::BadCount));
    let mut p = pyramid();
    p.normals_body[1] = [1.0, 0.0, 0.01]; // |n| - 1 = 5e-5: accepted
    assert!(p.validate().is_ok());
    p.normals_body[1] = [1.0, 0.0, 0.1];
    assert_eq!(p.validate(), Err(CssError::BadNormal));
    p.normals_body[1] = [f32::NAN, 0.0, 1.0];
    assert_eq!(p.validate(), Err(CssError::BadNormal));
    p.normals_body[1] = [1e30, 1e30, 1e30];
    assert_eq!(p.validate(), Err(CssError::BadNormal));
    let mut p = pyramid();
    for t in [0.0, 1.0, -0.1, f32::NAN, f32::INFINITY] {
        p.lit_threshold = t;
        assert_eq!(p.validate(), Err(CssError::BadThreshold));
    }
    // Random bit patterns as currents and as geometry: only typed results, and any Sun
    // returned is a finite unit vector.
    let mut rng = Rng(31);
    let (mut ok, mut err) = (0, 0);
    for k in 0..200_000 {
        let mut heads = if k % 2 == 0 { cube() } else { pyramid() };
        let mut c = [0.0f32; 6];
        for x in c.iter_mut() {
            *x = match rng.next_u64() % 4 {
                0 => f32::from_bits(rng.next_u64() as u32),
                1 => (rng.uniform() * 2.0 - 0.5) as f32,
                2 => (rng.normal() * 1e3) as f32,
                _ => 0.0,
            };
        }
        if k % 7 == 0 {
            heads.count = (rng.next_u64() % 9) as u8;
            heads.lit_threshold = f32::from_bits(rng.next_u64() as u32);
            heads.normals_body[(rng.next_u64() % 6) as usize] = [f32::from_bits(rng.next_u64() as u32), 0.0, 0.0];
        }
        match sun_vector(&heads, &c) {
            Ok(s) => {
                let n = v64(&s.dir_body).norm();
                assert!((n - 1.0).abs() < 1e-6 && s.intensity.is_finite() && s.intensity > 0.0);
                ok += 1;
            }
            Err(_) => err += 1,
        }
    }
    println!("fuzz: {ok} Sun vectors, {err} typed errors");
    assert!(ok > 1000 && err > 1000);
}
