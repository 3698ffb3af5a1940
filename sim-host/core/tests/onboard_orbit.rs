//! The on-board f32 two-body propagator (`acs_flight::models::orbit`) against f64
//! references written here: an RK4 integration of `r'' = −μ r/|r|³` with a 0.5 s step and
//! a classical-elements Kepler solution (two independent methods, checked against each
//! other first), from the same f32 fix. Also: how far two-body drifts from a J2 orbit over
//! one GNSS outage (the model error of propagating between fixes, not a failure), typed
//! errors and random inputs.

#![allow(clippy::disallowed_methods)]

use acs_flight::math::Vec3;
use acs_flight::models::orbit::{MU_EARTH_M3_S2, OrbitError, propagate_two_body};
use acs_test_support::rng::SplitMix64 as Rng;
use nalgebra::Vector3;

type V64 = Vector3<f64>;

/// μ as the flight code uses it (the f32 constant widened), so that the comparison
/// measures the algorithm, not a difference in constants.
fn mu() -> f64 {
    f64::from(MU_EARTH_M3_S2)
}
const R_EARTH_M: f64 = 6_378_137.0;
const J2: f64 = 1.082_626_68e-3;

fn accel(r: &V64, j2: bool) -> V64 {
    let rn = r.norm();
    let mut a = -mu() * r / (rn * rn * rn);
    if j2 {
        // Vallado eq 8-30 (zonal J2, z the Earth's spin axis).
        let k = -1.5 * J2 * mu() * R_EARTH_M * R_EARTH_M / rn.powi(5);
        let z2 = 5.0 * r.z * r.z / (rn * rn);
        a += k * V64::new(r.x * (1.0 - z2), r.y * (1.0 - z2), r.z * (3.0 - z2));
    }
    a
}

/// RK4 over `t_s` (either sign) with steps of at most 0.5 s.
fn rk4(r0: &V64, v0: &V64, t_s: f64, j2: bool) -> (V64, V64) {
    let steps = (t_s.abs() / 0.5).ceil().max(1.0) as usize;
    let h = t_s / steps as f64;
    let (mut r, mut v) = (*r0, *v0);
    for _ in 0..steps {
        let (k1r, k1v) = (v, accel(&r, j2));
        let (k2r, k2v) = (v + 0.5 * h * k1v, accel(&(r + 0.5 * h * k1r), j2));
        let (k3r, k3v) = (v + 0.5 * h * k2v, accel(&(r + 0.5 * h * k2r), j2));
        let (k4r, k4v) = (v + h * k3v, accel(&(r + h * k3r), j2));
        r += h / 6.0 * (k1r + 2.0 * k2r + 2.0 * k3r + k4r);
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
    (r, v)
}

/// Classical-elements Kepler solution (f64): perifocal frame from the eccentricity and
/// angular-momentum vectors, E from M by Newton to 1e-15. Needs e ≥ 1e-4 (perifocal axes).
fn kepler_elements(r0: &V64, v0: &V64, t_s: f64) -> (V64, V64) {
    let h = r0.cross(v0);
    let ev = v0.cross(&h) / mu() - r0.normalize();
    let e = ev.norm();
    assert!((1e-4..1.0).contains(&e));
    let a = 1.0 / (2.0 / r0.norm() - v0.norm_squared() / mu());
    let p_hat = ev / e;
    let q_hat = h.normalize().cross(&p_hat);
    let b = a * (1.0 - e * e).sqrt();
    // E0 from r0 in the perifocal frame: x = a (cos E − e), y = b sin E.
    let e0 = (r0.dot(&q_hat) / b).atan2(r0.dot(&p_hat) / a + e);
    let n = (mu() / a.powi(3)).sqrt();
    let m = e0 - e * e0.sin() + n * t_s;
    let mut ea = m;
    for _ in 0..100 {
        let d = (ea - e * ea.sin() - m) / (1.0 - e * ea.cos());
        ea -= d;
        if d.abs() < 1e-15 {
            break;
        }
    }
    let (s, c) = ea.sin_cos();
    let r = a * (c - e) * p_hat + b * s * q_hat;
    let edot = n / (1.0 - e * c);
    let v = -a * s * edot * p_hat + b * c * edot * q_hat;
    (r, v)
}

fn f32v(v: &V64) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}
fn f64v(v: &Vec3) -> V64 {
    V64::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

/// A fix at true anomaly `nu`, argument of perigee `w`, RAAN `raan`, inclination `inc`,
/// rounded to f32 as the flight code receives it; returned in f64 (exactly those values).
fn fix(a: f64, e: f64, inc: f64, raan: f64, w: f64, nu: f64) -> (V64, V64) {
    let p = a * (1.0 - e * e);
    let r_pf = p / (1.0 + e * nu.cos()) * V64::new(nu.cos(), nu.sin(), 0.0);
    let v_pf = (mu() / p).sqrt() * V64::new(-nu.sin(), e + nu.cos(), 0.0);
    let rot = nalgebra::Rotation3::from_axis_angle(&V64::z_axis(), raan)
        * nalgebra::Rotation3::from_axis_angle(&V64::x_axis(), inc)
        * nalgebra::Rotation3::from_axis_angle(&V64::z_axis(), w);
    (f64v(&f32v(&(rot * r_pf))), f64v(&f32v(&(rot * v_pf))))
}

fn leo_circular() -> (V64, V64) {
    fix(R_EARTH_M + 617e3, 0.0, 97.8f64.to_radians(), 0.3, 0.0, 1.1)
}
fn eccentric() -> (V64, V64) {
    // a = 7,500 km, e = 0.1: perigee 372 km, apogee 1,872 km altitude.
    fix(7.5e6, 0.1, 51.6f64.to_radians(), 2.0, 0.7, 0.5)
}

#[test]
fn references_agree() {
    // The two f64 references, independent methods, must agree far below the f32 errors.
    let (r0, v0) = eccentric();
    for dt in [100.0, 6000.0, 20_000.0, -3000.0] {
        let (ra, va) = rk4(&r0, &v0, dt, false);
        let (rb, vb) = kepler_elements(&r0, &v0, dt);
        let (dr, dv) = ((ra - rb).norm(), (va - vb).norm());
        println!("references, dt {dt:>7} s: RK4 vs elements {dr:.2e} m, {dv:.2e} m/s");
        assert!(dr < 1e-3 && dv < 1e-6);
    }
}

#[test]
fn f32_two_body_error_against_f64_reference() {
    // Bound on the f32 error: the mean anomaly change ΔM = n dt is formed in f32 from
    // the scaled state; n = α^{3/2} with α = 2 − v² (scaled) inherits every rounding of
    // the scaling (L, T = L√(L/μ), L/T, v0/(L/T), v², 2 − v²: about 8 ulp in α for a
    // near-circular orbit, ×1.5 in n, plus the product with dt/T), so ΔM carries up to
    // ~14 ulp of max(ΔM, 1) worst case; along track that is r·δΔM. Bound: position error
    // ≤ 16 · 2⁻²⁴ · r · (1 + |ΔM|), velocity error ≤ 16 · 2⁻²⁴ · v · (1 + |ΔM|).
    // (Measured worst over the random sweep below: 11.4 ulp, i.e. 0.71 of the bound.)
    let ulp = 2f64.powi(-24);
    println!("orbit     dt (s)   |dr| (m)   bound (m)  |dv| (m/s)  bound (m/s)  LVLH angle (deg)");
    for (name, (r0, v0)) in [("LEO 617", leo_circular()), ("e = 0.1", eccentric())] {
        let a = 1.0 / (2.0 / r0.norm() - v0.norm_squared() / mu());
        let n = (mu() / a.powi(3)).sqrt();
        for dt in [1.0f64, 10.0, 100.0, 1000.0, 6000.0, 20_000.0, -1000.0] {
            let (r_ref, v_ref) = rk4(&r0, &v0, dt, false);
            let (r, v) = propagate_two_body(&f32v(&r0), &f32v(&v0), dt as f32).unwrap();
            let dr = (f64v(&r) - r_ref).norm();
            let dv = (f64v(&v) - v_ref).norm();
            let grow = 1.0 + n * dt.abs();
            let (br, bv) = (16.0 * ulp * r_ref.norm() * grow, 16.0 * ulp * v_ref.norm() * grow);
            // The LVLH frame is built from r and v: its error is the position error seen
            // from the Earth's centre (and the velocity error over v).
            let ang = (dr / r_ref.norm()).max(dv / v_ref.norm()).to_degrees();
            println!("{name}  {dt:>8}  {dr:>9.3}  {br:>9.3}  {dv:>10.2e}  {bv:>10.2e}   {ang:.2e}");
            assert!(dr <= br, "{name} dt {dt}: {dr} m > {br} m");
            assert!(dv <= bv, "{name} dt {dt}: {dv} m/s > {bv} m/s");
        }
    }
}

#[test]
fn random_elliptic_orbits_within_the_same_bound() {
    // 300 random orbits: perigee radius 6,600–20,000 km, e in [0, 0.89], any true
    // anomaly, |r0| ≤ 1e8 m; dt uniform in ±20,000 s. Reference: f64 elements Kepler
    // (e ≥ 1e-4) or RK4 (nearly circular). The bound of the table test with r and v
    // replaced by their maxima along the orbit and the growth by 1/(1 − e) (the
    // periapsis passage amplifies a timing error by up to √((1+e)/(1−e)) in position).
    let mut rng = Rng(41);
    let ulp = 2f64.powi(-24);
    let (mut worst_ratio, mut n) = (0.0f64, 0);
    while n < 300 {
        let rp = 6.6e6 + rng.uniform() * 13.4e6;
        let e = if n % 5 == 0 { rng.uniform() * 1e-4 } else { rng.uniform() * 0.89 };
        let a = rp / (1.0 - e);
        let (r0, v0) = fix(
            a,
            e,
            rng.uniform() * 3.1,
            rng.uniform() * std::f64::consts::TAU,
            rng.uniform() * std::f64::consts::TAU,
            rng.uniform() * std::f64::consts::TAU,
        );
        if r0.norm() > 1e8 {
            continue;
        }
        let dt = (rng.uniform() * 2.0 - 1.0) * 20_000.0;
        let e_true = (v0.cross(&r0.cross(&v0)) / mu() - r0.normalize()).norm();
        let (r_ref, v_ref) = if e_true >= 1e-4 { kepler_elements(&r0, &v0, dt) } else { rk4(&r0, &v0, dt, false) };
        let (r, v) = propagate_two_body(&f32v(&r0), &f32v(&v0), dt as f32).unwrap();
        let nn = (mu() / a.powi(3)).sqrt();
        // At high e the radius and speed vary along the orbit: scale by their maxima.
        let (r_max, v_max) = (a * (1.0 + e), (mu() / a * (1.0 + e) / (1.0 - e)).sqrt());
        let grow = (1.0 + nn * dt.abs()) / (1.0 - e);
        let ratio_r = (f64v(&r) - r_ref).norm() / (16.0 * ulp * r_max * grow);
        let ratio_v = (f64v(&v) - v_ref).norm() / (16.0 * ulp * v_max * grow);
        if ratio_r.max(ratio_v) > worst_ratio {
            worst_ratio = ratio_r.max(ratio_v);
            println!(
                "  new worst {worst_ratio:.3} (position {ratio_r:.3}, velocity {ratio_v:.3}): e {e:.4}, a {a:.3e} m, |r0| {:.3e} m, dt {dt:.0} s, n dt {:.2} rad",
                r0.norm(),
                nn * dt.abs()
            );
        }
        n += 1;
    }
    println!("300 random orbits: worst error / bound = {worst_ratio:.3}");
    assert!(worst_ratio <= 1.0);
}

#[test]
fn two_body_vs_j2_over_one_gnss_outage() {
    // Not a failure criterion: the model error of propagating between fixes. From the
    // same osculating state the J2 orbit has a different mean motion (the osculating
    // semi-major axis differs from the mean one by O(J2 R²/a)) and moving perigee and
    // node, so the along-track separation grows like J2 (R/a)² · n t · a times a factor
    // of order one depending on inclination and latitude. Checked: the measured
    // separation after 6,000 s is within [0.5, 5] times that scale.
    for (name, (r0, v0)) in [("LEO 617", leo_circular()), ("e = 0.1", eccentric())] {
        for dt in [600.0, 6000.0] {
            let (r2, v2) = rk4(&r0, &v0, dt, false);
            let (rj, vj) = rk4(&r0, &v0, dt, true);
            let dr = (r2 - rj).norm();
            println!(
                "{name}: two-body vs J2 after {dt} s: {:.2} km, {:.2} m/s ({:.3} deg seen from the Earth's centre)",
                dr / 1e3,
                (v2 - vj).norm(),
                (dr / rj.norm()).to_degrees()
            );
            if dt == 6000.0 {
                let a = 1.0 / (2.0 / r0.norm() - v0.norm_squared() / mu());
                let scale = J2 * (R_EARTH_M / a).powi(2) * (mu() / a.powi(3)).sqrt() * dt * a;
                println!("  J2 scale J2 (R/a)² n t a = {:.1} km; measured / scale = {:.2}", scale / 1e3, dr / scale);
                assert!(dr > 0.5 * scale && dr < 5.0 * scale);
            }
        }
    }
}

#[test]
fn typed_errors_and_random_inputs() {
    let (r0, v0) = leo_circular();
    let (r, v) = (f32v(&r0), f32v(&v0));
    assert_eq!(propagate_two_body(&r, &v, f32::NAN), Err(OrbitError::NonFinite));
    assert_eq!(propagate_two_body(&Vec3::new(f32::INFINITY, 0.0, 0.0), &v, 1.0), Err(OrbitError::NonFinite));
    assert_eq!(propagate_two_body(&r, &Vec3::new(0.0, f32::NAN, 0.0), 1.0), Err(OrbitError::NonFinite));
    assert_eq!(propagate_two_body(&r, &v, 86_401.0), Err(OrbitError::TimeOutOfRange));
    assert_eq!(propagate_two_body(&r, &v, -1e30), Err(OrbitError::TimeOutOfRange));
    assert_eq!(propagate_two_body(&(r * 0.8), &v, 1.0), Err(OrbitError::RadiusOutOfRange));
    assert_eq!(propagate_two_body(&(r * 20.0), &v, 1.0), Err(OrbitError::RadiusOutOfRange));
    assert_eq!(propagate_two_body(&Vec3::new(1e30, 1e30, 0.0), &v, 1.0), Err(OrbitError::RadiusOutOfRange));
    // Escape speed √2 v_circ and above: not elliptic.
    assert_eq!(propagate_two_body(&r, &(v * 1.42), 1.0), Err(OrbitError::NotElliptic));
    assert_eq!(propagate_two_body(&r, &(v * 1e30), 1.0), Err(OrbitError::NotElliptic));
    // Zero velocity (e = 1, falling straight down) and e = 0.95.
    assert_eq!(propagate_two_body(&r, &Vec3::zeros(), 1.0), Err(OrbitError::TooEccentric));
    let (r95, v95) = fix(7.5e6 / 0.05, 0.95, 1.0, 0.0, 0.0, 0.0);
    assert_eq!(propagate_two_body(&f32v(&r95), &f32v(&v95), 1.0), Err(OrbitError::TooEccentric));
    // Just below the eccentricity limit: accepted and accurate (checked above in general).
    let (r89, v89) = fix(7.0e6 / 0.11, 0.89, 1.0, 0.0, 0.0, 1.0);
    assert!(propagate_two_body(&f32v(&r89), &f32v(&v89), 5000.0).is_ok());
    // dt = 0 returns the fix.
    let (r1, v1) = propagate_two_body(&r, &v, 0.0).unwrap();
    assert!((r1 - r).amax() <= 1.0 && (v1 - v).amax() <= 1e-3);
    // Random bit patterns and random magnitudes: only typed results, finite states.
    let mut rng = Rng(43);
    let (mut ok, mut err) = (0, 0);
    for k in 0..100_000 {
        let pick = |rng: &mut Rng, scale: f64| -> f32 {
            if k % 3 == 0 {
                f32::from_bits(rng.next_u64() as u32)
            } else {
                ((rng.uniform() * 2.0 - 1.0) * scale) as f32
            }
        };
        let rr = Vec3::new(pick(&mut rng, 2e7), pick(&mut rng, 2e7), pick(&mut rng, 2e7));
        let vv = Vec3::new(pick(&mut rng, 1e4), pick(&mut rng, 1e4), pick(&mut rng, 1e4));
        let dt = pick(&mut rng, 1e5);
        match propagate_two_body(&rr, &vv, dt) {
            Ok((a, b)) => {
                assert!(a.iter().chain(b.iter()).all(|x| x.is_finite()));
                ok += 1;
            }
            Err(OrbitError::NoConvergence) => panic!("Kepler did not converge for {rr:?} {vv:?} {dt}"),
            Err(_) => err += 1,
        }
    }
    println!("fuzz: {ok} propagated, {err} typed errors");
    assert!(ok > 1000 && err > 1000);
}
