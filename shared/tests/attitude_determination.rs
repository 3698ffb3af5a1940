//! TRIAD, QUEST and the MEKF against independent truths: noise-free geometry (exact to
//! f32 rounding), Shuster's covariance over a Monte Carlo, closed-form propagation, and
//! the filter's own consistency (NEES inside its chi-square 95 % band) over seeded runs
//! whose truth is simulated here in f64.

// The truth is simulated in f64 on the host: nalgebra's f64 norms are the reference here.
#![allow(clippy::disallowed_methods)]

use acs_flight::estimation::mekf::{CHI2_2DOF_999, CHI2_3DOF_999, Mekf, MekfConfig, MekfError};
use acs_flight::estimation::quest::{Observation, quest, quest_covariance};
use acs_flight::estimation::triad::{WahbaError, triad};
use acs_flight::math::{Mat3, Quat, Vec3, quat_from_rotation_matrix, rotate_ref_to_body};
use acs_test_support::rng::SplitMix64 as Rng;
use nalgebra::{Matrix3, Quaternion, Vector3};

type Q64 = Quaternion<f64>;
type V64 = Vector3<f64>;

fn rot(q: &Q64, v: &V64) -> V64 {
    (q * Q64::from_imag(*v) * q.conjugate()).imag()
}
fn f32q(q: &Q64) -> Quat {
    Quat::new(q.w as f32, q.i as f32, q.j as f32, q.k as f32)
}
fn f32v(v: &V64) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}
fn f64q(q: &Quat) -> Q64 {
    Q64::new(f64::from(q.w), f64::from(q.i), f64::from(q.j), f64::from(q.k))
}
/// Rotation vector of `a* ⊗ b` (body-frame error of `a` relative to `b`), rad.
fn err_vec(a: &Q64, b: &Q64) -> V64 {
    let mut e = a.conjugate() * b;
    if e.w < 0.0 {
        e = -e;
    }
    let s = e.imag().norm();
    if s < 1e-15 { e.imag() * 2.0 } else { e.imag() * (2.0 * s.atan2(e.w) / s) }
}
/// exp of a rotation vector.
fn qexp(v: &V64) -> Q64 {
    let a = v.norm();
    if a < 1e-15 {
        return Q64::new(1.0, 0.5 * v.x, 0.5 * v.y, 0.5 * v.z).normalize();
    }
    let s = (0.5 * a).sin() / a;
    Q64::new((0.5 * a).cos(), v.x * s, v.y * s, v.z * s)
}

#[test]
fn rotation_matrix_round_trip_including_half_turns() {
    let mut rng = Rng(1);
    let mut qs: Vec<Q64> = (0..2000).map(|_| rng.quat()).collect();
    // Half turns about axes and a generic axis: w = 0.
    qs.extend([Q64::new(0.0, 1.0, 0.0, 0.0), Q64::new(0.0, 0.0, 1.0, 0.0), Q64::new(0.0, 0.0, 0.0, 1.0)]);
    qs.push(Q64::new(0.0, 1.0, 2.0, -2.0).normalize());
    for q in qs {
        let r = Mat3::from_columns(&[f32v(&rot(&q, &V64::x())), f32v(&rot(&q, &V64::y())), f32v(&rot(&q, &V64::z()))]);
        let got = f64q(&quat_from_rotation_matrix(&r).expect("finite"));
        assert!(err_vec(&q, &got).norm() < 2e-6, "{q:?} → {got:?}");
    }
}

#[test]
fn triad_is_exact_on_noise_free_vectors_and_refuses_parallel_ones() {
    let mut rng = Rng(2);
    let mut worst = 0.0_f64;
    for _ in 0..2000 {
        let q = rng.quat();
        let (r1, r2) = (rng.unit(), rng.unit());
        if r1.cross(&r2).norm() < 0.1 {
            continue;
        }
        let (b1, b2) = (rot(&q.conjugate(), &r1), rot(&q.conjugate(), &r2));
        let got = triad(&f32v(&b1), &f32v(&b2), &f32v(&r1), &f32v(&r2)).expect("observable");
        worst = worst.max(err_vec(&q, &f64q(&got)).norm());
    }
    // f32 rounding of inputs (6e-8 relative) amplified by 1/sin(angle) ≤ 10: a few µrad.
    assert!(worst < 5e-6, "TRIAD worst error {worst} rad");
    let v = Vec3::new(0.3, -0.2, 0.9);
    assert_eq!(triad(&v, &(v * 2.0), &v, &Vec3::x()), Err(WahbaError::Degenerate));
    assert_eq!(triad(&v, &(-v), &v, &Vec3::x()), Err(WahbaError::Degenerate));
    assert_eq!(triad(&Vec3::zeros(), &v, &v, &Vec3::x()), Err(WahbaError::BadInput));
    assert_eq!(triad(&Vec3::new(f32::NAN, 0.0, 0.0), &v, &v, &Vec3::x()), Err(WahbaError::BadInput));
}

#[test]
fn quest_is_exact_on_noise_free_vectors_including_half_turns() {
    let mut rng = Rng(3);
    let mut qs: Vec<Q64> = (0..1000).map(|_| rng.quat()).collect();
    qs.extend([Q64::new(0.0, 1.0, 0.0, 0.0), Q64::new(0.0, 0.0, 0.0, 1.0), Q64::new(0.0, 0.6, 0.0, 0.8)]);
    let mut worst = 0.0_f64;
    for q in qs {
        let obs: Vec<Observation> = (0..3)
            .map(|_| {
                let r = rng.unit();
                Observation { body: f32v(&rot(&q.conjugate(), &r)), reference: f32v(&r), sigma_rad: 1e-3 }
            })
            .collect();
        let got = quest(&obs).expect("observable");
        worst = worst.max(err_vec(&q, &f64q(&got)).norm());
    }
    assert!(worst < 3e-6, "QUEST worst error {worst} rad");
    let v = Vec3::new(0.3, -0.2, 0.9);
    let par = [
        Observation { body: v, reference: v, sigma_rad: 1e-3 },
        Observation { body: v * 3.0, reference: v, sigma_rad: 1e-3 },
    ];
    assert_eq!(quest(&par), Err(WahbaError::Degenerate));
    assert_eq!(quest(&par[..1]), Err(WahbaError::BadInput));
}

#[test]
fn quest_error_matches_shusters_covariance() {
    // Sun (σ 0.5°) and field (σ 2°) directions 70° apart plus a third weak one; 4000 trials.
    let mut rng = Rng(4);
    let q = rng.quat();
    let refs = [V64::new(1.0, 0.0, 0.0), V64::new(0.34, 0.94, 0.0).normalize(), V64::new(0.2, 0.3, 0.93).normalize()];
    let sig = [0.5_f64.to_radians(), 2.0_f64.to_radians(), 3.0_f64.to_radians()];
    let truth_b: Vec<V64> = refs.iter().map(|r| rot(&q.conjugate(), r)).collect();
    let mut nees = 0.0;
    let mut cov = Matrix3::<f64>::zeros();
    let n = 4000;
    let mut p_pred = Matrix3::<f64>::zeros();
    for _ in 0..n {
        let obs: Vec<Observation> = (0..3)
            .map(|i| {
                // Noise perpendicular to the true direction (Shuster's model), σ per axis.
                let b = truth_b[i];
                let e = rng.vec() * sig[i];
                let bn = (b + (e - b * b.dot(&e))).normalize();
                Observation { body: f32v(&bn), reference: f32v(&refs[i]), sigma_rad: sig[i] as f32 }
            })
            .collect();
        let est = f64q(&quest(&obs).expect("observable"));
        let p = quest_covariance(&obs).expect("observable").map(f64::from);
        p_pred = p;
        let e = err_vec(&est, &q);
        cov += e * e.transpose();
        nees += e.dot(&(p.try_inverse().expect("invertible") * e));
    }
    cov /= f64::from(n);
    nees /= f64::from(n);
    // Mean NEES of a 3-dof Gaussian: 3 ± 1.96·√(6/n) = ±0.076.
    assert!((nees - 3.0).abs() < 0.1, "mean NEES {nees}");
    let ratio = cov.trace() / p_pred.trace();
    assert!((ratio - 1.0).abs() < 0.06, "sample/predicted trace {ratio}");
}

fn cfg() -> MekfConfig {
    MekfConfig {
        gyro_arw_rad_sqrt_s: 3e-5, // 0.1°/√h
        gyro_rrw_rad_s_sqrt_s: 3e-8,
        initial_attitude_sigma_rad: 0.02,
        initial_bias_sigma_rad_s: 2e-4,
        max_dt_s: 1.0,
        gate_attitude: CHI2_3DOF_999,
        gate_vector: CHI2_2DOF_999,
    }
}

#[test]
fn noise_free_propagation_follows_the_closed_form_rotation() {
    let mut f = Mekf::new(cfg(), Quat::identity(), Vec3::zeros()).expect("config");
    let w = V64::new(0.01, -0.02, 0.05);
    for _ in 0..1000 {
        f.propagate(&f32v(&w), 0.1).expect("step");
    }
    let exact = qexp(&(w * 100.0));
    let e = err_vec(&exact, &f64q(&f.attitude())).norm();
    assert!(e < 2e-5, "error after 100 s: {e} rad");
}

struct Truth {
    q: Q64,
    bias: V64,
}

/// One seeded run: truth rotating at a slowly varying rate, gyro with ARW/RRW noise and a
/// constant + random-walk bias, tracker at 1 Hz with σ 10″/axis, MEKF at 10 Hz. Returns the
/// NEES at the sample times and the final bias error vs its 3σ.
fn mekf_run(seed: u64, seconds: u32, tracker: bool, vectors: bool) -> (Vec<f64>, Mekf, Truth) {
    let c = cfg();
    let mut rng = Rng(seed);
    let dt = 0.1_f64;
    let mut t = Truth { q: rng.quat(), bias: rng.vec() * f64::from(c.initial_bias_sigma_rad_s) };
    let q0 = t.q * qexp(&(rng.vec() * f64::from(c.initial_attitude_sigma_rad)));
    let mut f = Mekf::new(c, f32q(&q0), Vec3::zeros()).expect("config");
    let sv = f64::from(c.gyro_arw_rad_sqrt_s);
    let su = f64::from(c.gyro_rrw_rad_s_sqrt_s);
    let st = (10.0_f64 / 3600.0).to_radians();
    let sun = V64::new(0.6, 0.8, 0.0);
    let mag = V64::new(0.0, 0.3, -0.95).normalize();
    let mut nees = Vec::new();
    let steps = (f64::from(seconds) / dt) as u32;
    for k in 0..steps {
        let time = f64::from(k) * dt;
        let w = V64::new(0.01 * (0.01 * time).sin(), 0.005, -0.008 * (0.02 * time).cos());
        // Farrenkopf: the measured rate over the step averages true rate + bias + ARW.
        let b_next = t.bias + rng.vec() * (su * dt.sqrt());
        let meas = w + 0.5 * (t.bias + b_next) + rng.vec() * (sv / dt.sqrt());
        t.q = (t.q * qexp(&(w * dt))).normalize();
        t.bias = b_next;
        f.propagate(&f32v(&meas), dt as f32).expect("propagate");
        if k % 10 == 9 {
            if tracker {
                let qm = t.q * qexp(&(rng.vec() * st));
                let r = Matrix3::identity() * (st * st) as f32;
                let _ = f.update_attitude(&f32q(&qm), &r);
            }
            if vectors {
                for (r, s) in [(sun, 0.2_f64.to_radians()), (mag, 1.0_f64.to_radians())] {
                    let b = rot(&t.q.conjugate(), &r);
                    let e = rng.vec() * s;
                    let bn = (b + (e - b * b.dot(&e))).normalize();
                    let _ = f.update_vector(&f32v(&bn), &f32v(&r), s as f32);
                }
            }
            let e_att = err_vec(&f64q(&f.attitude()), &t.q);
            let e_b = t.bias
                - V64::new(f64::from(f.bias_rad_s().x), f64::from(f.bias_rad_s().y), f64::from(f.bias_rad_s().z));
            let ex = nalgebra::Vector6::new(e_att.x, e_att.y, e_att.z, e_b.x, e_b.y, e_b.z);
            let p = f.covariance().map(f64::from);
            nees.push(ex.dot(&(p.try_inverse().expect("P invertible") * ex)));
        }
    }
    (nees, f, t)
}

#[test]
fn mekf_is_consistent_over_a_seeded_monte_carlo() {
    // 50 runs × 600 s, tracker at 1 Hz. Average NEES over runs at each of the last 300
    // samples, then over time: for a consistent filter each per-time average is χ²(300)/50,
    // 95 % band [5.08, 7.00]; the time average is tighter, assert it in the band and ≥ 95 %
    // of the per-time averages inside it (some correlation between neighbouring samples).
    let runs = 50;
    let per: Vec<Vec<f64>> = (0..runs).map(|s| mekf_run(100 + s, 600, true, false).0).collect();
    let n = per[0].len();
    let avg: Vec<f64> = (n - 300..n).map(|i| per.iter().map(|r| r[i]).sum::<f64>() / f64::from(runs as u32)).collect();
    let inside = avg.iter().filter(|a| (5.08..=7.00).contains(*a)).count();
    let mean = avg.iter().sum::<f64>() / avg.len() as f64;
    assert!((5.08..=7.00).contains(&mean), "time-averaged NEES {mean}");
    assert!(inside as f64 >= 0.9 * avg.len() as f64, "{inside} of {} per-time averages inside", avg.len());
}

#[test]
fn mekf_on_sun_and_field_vectors_converges_and_bias_lies_within_3_sigma() {
    let (nees, f, t) = mekf_run(7, 1200, false, true);
    let b = f.bias_rad_s();
    let p = f.covariance();
    for i in 0..3 {
        let e = t.bias[i] - f64::from(b[i]);
        let s = f64::from(p[(i + 3, i + 3)]).sqrt();
        assert!(e.abs() < 3.0 * s, "axis {i}: bias error {e} vs 3σ {}", 3.0 * s);
    }
    let att = err_vec(&f64q(&f.attitude()), &t.q).norm();
    let sig = f64::from(f.health().attitude_variance_rad2).sqrt();
    assert!(att < 3.0 * sig, "attitude error {att} vs 3σ {}", 3.0 * sig);
    assert!(nees.iter().all(|x| x.is_finite()));
}

#[test]
fn a_ten_degree_tracker_outlier_is_rejected_and_counted() {
    let (_, mut f, t) = mekf_run(9, 120, true, false);
    let before = (f.attitude(), *f.covariance(), f.health().rejected);
    let bad = t.q * qexp(&V64::new(10.0_f64.to_radians(), 0.0, 0.0));
    let st = (10.0_f64 / 3600.0).to_radians();
    let r = Matrix3::identity() * (st * st) as f32;
    match f.update_attitude(&f32q(&bad), &r) {
        Err(MekfError::Rejected { nis }) => assert!(nis > CHI2_3DOF_999),
        other => panic!("outlier accepted: {other:?}"),
    }
    assert_eq!((f.attitude(), *f.covariance()), (before.0, before.1));
    assert_eq!(f.health().rejected, before.2 + 1);
}

#[test]
fn covariance_stays_symmetric_positive_definite_over_a_day() {
    // 24 h at 10 Hz with a 1 Hz tracker: 864,000 propagations in f32.
    let mut f = Mekf::new(cfg(), Quat::identity(), Vec3::zeros()).expect("config");
    let st = (10.0_f32 / 3600.0).to_radians();
    let r = Matrix3::identity() * (st * st);
    let w = Vec3::new(0.001, -0.002, 0.0005);
    let mut truth = Quat::identity();
    for k in 0..864_000u32 {
        f.propagate(&w, 0.1).expect("propagate");
        truth = rotate_q(&truth, &w, 0.1);
        if k % 10 == 9 {
            f.update_attitude(&truth, &r).expect("consistent measurement accepted");
        }
    }
    let p = f.covariance().map(f64::from);
    assert!((p - p.transpose()).abs().max() == 0.0, "not symmetric");
    assert!(p.cholesky().is_some(), "not positive definite: {p}");
    // Steady state: attitude σ per axis below the tracker's σ, above zero.
    let s = (f64::from(f.health().attitude_variance_rad2) / 3.0).sqrt();
    assert!(s > 0.0 && s < f64::from(st), "attitude σ {s}");
}

fn rotate_q(q: &Quat, w: &Vec3, dt: f32) -> Quat {
    let q64 = f64q(q) * qexp(&(V64::new(f64::from(w.x), f64::from(w.y), f64::from(w.z)) * f64::from(dt)));
    f32q(&q64.normalize())
}

#[test]
fn bad_input_changes_nothing() {
    let mut f = Mekf::new(cfg(), Quat::identity(), Vec3::zeros()).expect("config");
    let before = f;
    assert_eq!(f.propagate(&Vec3::new(f32::NAN, 0.0, 0.0), 0.1), Err(MekfError::NonFiniteInput));
    assert_eq!(f.propagate(&Vec3::zeros(), 0.0), Err(MekfError::BadTimeStep));
    assert_eq!(f.propagate(&Vec3::zeros(), 5.0), Err(MekfError::BadTimeStep));
    assert_eq!(f.propagate(&Vec3::zeros(), f32::INFINITY), Err(MekfError::BadTimeStep));
    assert_eq!(f.update_attitude(&Quat::new(0.0, 0.0, 0.0, 0.0), &Matrix3::identity()), Err(MekfError::NonFiniteInput));
    assert_eq!(f.update_vector(&Vec3::zeros(), &Vec3::x(), 0.01), Err(MekfError::NonFiniteInput));
    assert_eq!(f.update_vector(&Vec3::x(), &Vec3::x(), -1.0), Err(MekfError::NonFiniteInput));
    assert!(f.update_vector(&Vec3::x(), &Vec3::x(), 1e30).is_err(), "σ² overflows: refused");
    assert_eq!(f.attitude(), before.attitude());
    assert_eq!(f.covariance(), before.covariance());
    let mut c = cfg();
    c.max_dt_s = f32::NAN;
    assert_eq!(Mekf::new(c, Quat::identity(), Vec3::zeros()).err(), Some(MekfError::BadConfig));
    // A vector update rotates the estimate toward the measurement (sign of H).
    let mut g = Mekf::new(cfg(), Quat::identity(), Vec3::zeros()).expect("config");
    let truth = f32q(&qexp(&V64::new(0.0, 0.0, 0.01)));
    let r = Vec3::x();
    let b = rotate_ref_to_body(&truth, &r);
    g.update_vector(&b, &r, 1e-3).expect("accepted");
    let e_before = err_vec(&Q64::identity(), &f64q(&truth)).norm();
    let e_after = err_vec(&f64q(&g.attitude()), &f64q(&truth)).norm();
    assert!(e_after < 0.1 * e_before, "{e_before} → {e_after}");
}
