// The test compares against nalgebra norms as an independent reference (allowed in tests).
#![allow(clippy::disallowed_methods)]
//! Flight Kalman filter on its own (no host design tools): rejection of bad data leaves the
//! filter untouched, singular innovation, mode switching, limited LQR. The comparisons
//! against the f64 DARE, Monte Carlo NEES and the LQG loop are in
//! `sim-host/core/tests/flight_kalman.rs` (they need `sim_host::design`).
use acs_flight::control::lqr::state_feedback;
use acs_flight::estimation::kalman::{KalmanFilter, KfError, LinearModel};
use acs_flight::math::scale_to_peak;
use nalgebra::{SMatrix, SVector};

/// Double integrator, dt = 0.1 s, closed-form ZOH and Van Loan noise (acceleration PSD q).
fn double_integrator() -> LinearModel<2, 1, 1> {
    let (dt, q) = (0.1f32, 0.01f32);
    LinearModel {
        a: SMatrix::<f32, 2, 2>::new(1.0, dt, 0.0, 1.0),
        b: SMatrix::<f32, 2, 1>::new(0.5 * dt * dt, dt),
        c: SMatrix::<f32, 1, 2>::new(1.0, 0.0),
        q: SMatrix::<f32, 2, 2>::new(q * dt.powi(3) / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt),
        r: SMatrix::<f32, 1, 1>::new(0.01),
    }
}

#[test]
fn rejected_calls_leave_the_filter_untouched() {
    let mut f = KalmanFilter::<2, 1, 1>::new(double_integrator(), SVector::zeros(), SMatrix::identity()).unwrap();
    for k in 0..200 {
        f.predict(&SVector::from([0.01])).unwrap();
        let before = f;
        let z = match k % 5 {
            1 => f32::NAN,
            3 => f32::NEG_INFINITY,
            _ => 0.1,
        };
        match f.update(&SVector::from([z])) {
            Err(e) => {
                assert_eq!(e, KfError::NonFiniteMeasurement);
                assert_eq!(f, before);
            }
            Ok(info) => assert!(info.nis.is_finite() && info.nis >= 0.0),
        }
    }
    let before = f;
    assert_eq!(f.predict(&SVector::from([f32::INFINITY])), Err(KfError::NonFiniteInput));
    assert_eq!(f.set_state(SVector::from([f32::NAN, 0.0])), Err(KfError::NonFiniteParameter));
    assert_eq!(f.set_steady_state_gain(SMatrix::from([[f32::NAN, 0.0]])), Err(KfError::NonFiniteParameter));
    assert_eq!(f, before);
    // The covariance stays symmetric positive definite.
    let p = f.covariance();
    assert!((p[(0, 1)] - p[(1, 0)]).abs() <= f32::EPSILON * p.norm());
    assert!(p.cholesky().is_some());
}

#[test]
fn singular_innovation_is_rejected() {
    let mut m = double_integrator();
    m.r = SMatrix::zeros();
    let mut f = KalmanFilter::<2, 1, 1>::new(m, SVector::from([1.0, 2.0]), SMatrix::zeros()).unwrap();
    let before = f;
    assert_eq!(f.update(&SVector::from([3.0])), Err(KfError::SingularInnovation));
    assert_eq!(f, before);
    let mut bad = double_integrator();
    bad.a[(0, 1)] = f32::NAN;
    assert_eq!(
        KalmanFilter::<2, 1, 1>::new(bad, SVector::zeros(), SMatrix::identity()),
        Err(KfError::NonFiniteParameter)
    );
}

#[test]
fn steady_state_mode_and_back() {
    let mut f = KalmanFilter::<2, 1, 1>::new(double_integrator(), SVector::zeros(), SMatrix::identity()).unwrap();
    for _ in 0..500 {
        f.predict(&SVector::zeros()).unwrap();
        f.update(&SVector::zeros()).unwrap();
    }
    // Converged gain K = P⁻ Cᵀ / (C P⁻ Cᵀ + R) from the converged a-priori covariance.
    f.predict(&SVector::zeros()).unwrap();
    let p = *f.covariance();
    let k = SMatrix::<f32, 2, 1>::new(p[(0, 0)], p[(1, 0)]) / (p[(0, 0)] + 0.01);
    let mut ss = f;
    ss.set_steady_state_gain(k).unwrap();
    assert!(ss.is_steady_state());
    for i in 0..50 {
        let z = SVector::from([0.05 * (i as f32 * 0.3).sin()]);
        f.update(&z).unwrap();
        ss.update(&z).unwrap();
        assert!((f.state() - ss.state()).norm() <= 1e-5 * (1.0 + f.state().norm()));
        f.predict(&SVector::zeros()).unwrap();
        ss.predict(&SVector::zeros()).unwrap();
    }
    let frozen = *ss.covariance();
    assert_eq!(ss.covariance(), &frozen);
    ss.set_covariance_mode(SMatrix::identity()).unwrap();
    assert!(!ss.is_steady_state());
    assert_eq!(ss.covariance(), &SMatrix::<f32, 2, 2>::identity());
}

#[test]
fn lqr_feedback_and_peak_limit_scale_the_whole_command() {
    // The flight LQR (`control::lqr`) with the whole-vector limiter the gimbal rates use.
    let k = [[2.0f32, 1.0], [-1.0, 3.0]];
    let (x, xr) = ([1.0f32, 0.5], [0.5f32, 0.0]);
    let u = state_feedback(&k, &[x[0] - xr[0], x[1] - xr[1]]);
    assert_eq!(u, [-1.5, -1.0]);
    let mut ul = u;
    assert!(!scale_to_peak(&mut ul, 10.0));
    assert_eq!(ul, u);
    let mut ul = u;
    assert!(scale_to_peak(&mut ul, 0.3));
    assert!(ul.iter().zip(u).all(|(a, b)| (a - b * 0.2).abs() < 1e-6));
}
