//! The f32 flight filter against the f64 design tools: covariance convergence to the DARE,
//! NEES consistency over Monte Carlo runs, rejection of bad data, steady-state mode, LQR.
use acs_flight::control::lqr::state_feedback;
use acs_flight::estimation::kalman::{KalmanFilter, KfError, LinearModel};
use acs_flight::math::scale_to_peak;
use nalgebra::{DMatrix, DVector, SMatrix, SVector, dmatrix};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sim_core::design::export::to_f32;
use sim_core::design::models::{AttitudeModel, paper002};
use sim_core::design::riccati::dlqr;
use sim_core::design::{c2d, c2d_noise, steady_state_kalman};

/// A discrete plant in f64 (truth and design) with its noise.
struct Plant {
    ad: DMatrix<f64>,
    bd: DMatrix<f64>,
    c: DMatrix<f64>,
    qd: DMatrix<f64>,
    r: DMatrix<f64>,
}

impl Plant {
    /// Double integrator, dt = 0.1 s, white acceleration noise PSD 0.01, position σ 0.1.
    fn double_integrator() -> Self {
        let a = dmatrix![0.0, 1.0; 0.0, 0.0];
        let b = dmatrix![0.0; 1.0];
        let (ad, bd) = c2d(&a, &b, 0.1).unwrap();
        let qd = c2d_noise(&a, &dmatrix![0.0, 0.0; 0.0, 0.01], 0.1).unwrap();
        Self { ad, bd, c: dmatrix![1.0, 0.0], qd, r: dmatrix![0.01] }
    }

    /// Paper 002 linear model (δ₀ = 0), dt = 0.1 s; disturbance torque PSD (1e-3 N m)²·s
    /// per axis (eq 13 `G w`), Euler angles measured with σ = 0.05° (star tracker).
    fn paper002() -> Self {
        Self::paper002_with(1e-3)
    }

    fn paper002_with(torque_sigma: f64) -> Self {
        let m = AttitudeModel::paper002(&[0.0; 4]);
        let (a, b) = m.linear();
        let (ad, bd) = c2d(&a, &b, 0.1).unwrap();
        let mut g = DMatrix::<f64>::zeros(6, 3);
        g.view_mut((3, 0), (3, 3)).copy_from(&(DMatrix::<f64>::identity(3, 3) / paper002::INERTIA_DIAG));
        let qd = c2d_noise(&a, &(&g * g.transpose() * torque_sigma.powi(2)), 0.1).unwrap();
        let s = 0.05f64.to_radians();
        Self { ad, bd, c: DMatrix::identity(3, 6), qd, r: DMatrix::identity(3, 3) * s * s }
    }

    fn model<const N: usize, const M: usize, const P: usize>(&self) -> LinearModel<N, M, P> {
        LinearModel {
            a: to_f32(&self.ad).unwrap(),
            b: to_f32(&self.bd).unwrap(),
            c: to_f32(&self.c).unwrap(),
            q: to_f32(&self.qd).unwrap(),
            r: to_f32(&self.r).unwrap(),
        }
    }
}

fn gauss(rng: &mut ChaCha8Rng, chol: &DMatrix<f64>) -> DVector<f64> {
    let e = DVector::from_fn(chol.ncols(), |_, _| StandardNormal.sample(rng));
    chol * e
}

fn chol(m: &DMatrix<f64>) -> DMatrix<f64> {
    m.clone().cholesky().unwrap().l()
}

fn p_as_f64<const N: usize>(p: &SMatrix<f32, N, N>) -> DMatrix<f64> {
    DMatrix::from_fn(N, N, |r, c| p[(r, c)] as f64)
}

/// Wilson–Hilferty chi-square quantile (|error| < 0.05 % of the value for k ≥ 100).
fn chi2_quantile(k: f64, z: f64) -> f64 {
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + z * h.sqrt()).powi(3)
}

fn covariance_converges<const N: usize, const M: usize, const P: usize>(plant: &Plant, name: &str) {
    let (_, p_dare) = steady_state_kalman(&plant.ad, &plant.c, &plant.qd, &plant.r).unwrap();
    let p0 = SMatrix::<f32, N, N>::identity() * 1.0;
    let mut f = KalmanFilter::<N, M, P>::new(plant.model(), SVector::zeros(), p0).unwrap();
    let mut rel = f64::INFINITY;
    for k in 0..3000 {
        f.predict(&SVector::zeros()).unwrap();
        rel = (p_as_f64(f.covariance()) - &p_dare).norm() / p_dare.norm();
        if k % 500 == 499 {
            println!("{name}: step {}, |P_kf⁻ − P_dare| / |P_dare| = {rel:.2e}", k + 1);
        }
        f.update(&SVector::zeros()).unwrap();
    }
    assert!(rel < 1e-3, "{name}: {rel}");
}

#[test]
fn covariance_converges_to_dare_double_integrator() {
    covariance_converges::<2, 1, 1>(&Plant::double_integrator(), "double integrator");
}

#[test]
fn covariance_converges_to_dare_paper002() {
    covariance_converges::<6, 4, 3>(&Plant::paper002(), "paper 002");
}

/// Monte Carlo NEES: for each step k the sum over R runs of `eᵀ P⁺⁻¹ e` is χ²(R·n) when
/// the filter is consistent, so its run-average must lie in
/// `[χ²_{0.025}(Rn), χ²_{0.975}(Rn)] / R` at 95 % of the steps.
fn nees_monte_carlo<const N: usize, const M: usize, const P: usize>(
    plant: &Plant,
    runs: usize,
    steps: usize,
    seed: u64,
    name: &str,
) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (lq, lr) = (chol(&plant.qd), chol(&plant.r));
    let p0 = DMatrix::<f64>::identity(N, N) * 1e-2;
    let lp0 = chol(&p0);
    let mut nees = vec![0.0f64; steps];
    let mut run_means = vec![];
    for _ in 0..runs {
        let mut x = gauss(&mut rng, &lp0);
        let mut f = KalmanFilter::<N, M, P>::new(plant.model(), SVector::zeros(), to_f32(&p0).unwrap()).unwrap();
        let mut acc = 0.0;
        for (k, nk) in nees.iter_mut().enumerate() {
            let u = DVector::from_fn(M, |i, _| 0.01 * ((k as f64) * 0.05 + i as f64).sin());
            x = &plant.ad * &x + &plant.bd * &u + gauss(&mut rng, &lq);
            let z = &plant.c * &x + gauss(&mut rng, &lr);
            f.predict(&SVector::<f32, M>::from_fn(|i, _| u[i] as f32)).unwrap();
            f.update(&SVector::<f32, P>::from_fn(|i, _| z[i] as f32)).unwrap();
            let e = &x - DVector::from_fn(N, |i, _| f.state()[i] as f64);
            let pinv = p_as_f64(f.covariance()).cholesky().unwrap().inverse();
            let v = (e.transpose() * pinv * &e)[(0, 0)];
            *nk += v / runs as f64;
            acc += v / steps as f64;
        }
        run_means.push(acc);
    }
    let dof = (runs * N) as f64;
    let (lo, hi) = (chi2_quantile(dof, -1.959964) / runs as f64, chi2_quantile(dof, 1.959964) / runs as f64);
    let inside = nees.iter().filter(|&&v| v >= lo && v <= hi).count() as f64 / steps as f64;
    let mean = nees.iter().sum::<f64>() / steps as f64;
    let sd = (run_means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (runs as f64 - 1.0)).sqrt();
    let half = 1.96 * sd / (runs as f64).sqrt();
    println!(
        "{name}: {runs} runs × {steps} steps, n = {N}: per-step 95 % bounds [{lo:.3}, {hi:.3}], inside {:.1} %; mean NEES {mean:.3} (expected {N}, 95 % CI of the mean ±{half:.3})",
        inside * 100.0
    );
    assert!(inside >= 0.88, "{name}: only {inside} of the steps inside");
    assert!((mean - N as f64).abs() < 2.0 * half.max(0.01 * N as f64), "{name}: mean NEES {mean}");
}

#[test]
fn nees_double_integrator_100_runs() {
    nees_monte_carlo::<2, 1, 1>(&Plant::double_integrator(), 100, 400, 7, "double integrator");
}

#[test]
fn nees_paper002_50_runs() {
    nees_monte_carlo::<6, 4, 3>(&Plant::paper002(), 50, 400, 11, "paper 002");
}

#[test]
fn non_finite_measurements_are_rejected_and_the_filter_goes_on() {
    let plant = Plant::double_integrator();
    let (_, p_dare) = steady_state_kalman(&plant.ad, &plant.c, &plant.qd, &plant.r).unwrap();
    let mut f = KalmanFilter::<2, 1, 1>::new(plant.model(), SVector::zeros(), SMatrix::identity()).unwrap();
    let mut rejected = 0;
    for k in 0..2000 {
        f.predict(&SVector::zeros()).unwrap();
        let before = f;
        let z = match k % 7 {
            3 => f32::NAN,
            5 => f32::INFINITY,
            _ => 0.0,
        };
        match f.update(&SVector::from([z])) {
            Err(KfError::NonFiniteMeasurement) => {
                rejected += 1;
                assert_eq!(f, before, "a rejected update must leave the filter untouched");
            }
            r => assert!(r.is_ok()),
        }
    }
    assert!(rejected > 500);
    assert!(f.state().iter().all(|v| v.is_finite()));
    // Once the data are good again the covariance returns to the DARE fixed point.
    for _ in 0..300 {
        f.predict(&SVector::zeros()).unwrap();
        f.update(&SVector::zeros()).unwrap();
    }
    f.predict(&SVector::zeros()).unwrap();
    let rel = (p_as_f64(f.covariance()) - &p_dare).norm() / p_dare.norm();
    assert!(rel < 1e-3, "{rel}");
    // Non-finite inputs to predict are rejected too.
    let before = f;
    assert_eq!(f.predict(&SVector::from([f32::NAN])), Err(KfError::NonFiniteInput));
    assert_eq!(f, before);
}

#[test]
fn singular_innovation_is_rejected() {
    let mut m = Plant::double_integrator().model::<2, 1, 1>();
    m.r = SMatrix::zeros();
    let mut f = KalmanFilter::<2, 1, 1>::new(m, SVector::from([1.0, 2.0]), SMatrix::zeros()).unwrap();
    let before = f;
    assert_eq!(f.update(&SVector::from([3.0])), Err(KfError::SingularInnovation));
    assert_eq!(f, before);
    // Two identical noiseless position sensors: S is rank one.
    let m2 = LinearModel::<2, 1, 2> {
        a: m.a,
        b: m.b,
        c: SMatrix::<f32, 2, 2>::new(1.0, 0.0, 1.0, 0.0),
        q: m.q,
        r: SMatrix::zeros(),
    };
    let mut f2 = KalmanFilter::new(m2, SVector::zeros(), SMatrix::identity()).unwrap();
    let before = f2;
    assert_eq!(f2.update(&SVector::from([1.0, 1.0])), Err(KfError::SingularInnovation));
    assert_eq!(f2, before);
    assert!(KalmanFilter::<2, 1, 1>::new(m, SVector::from([f32::NAN, 0.0]), SMatrix::identity()).is_err());
}

#[test]
fn steady_state_mode_matches_converged_covariance_mode() {
    let plant = Plant::paper002();
    let (k, _) = steady_state_kalman(&plant.ad, &plant.c, &plant.qd, &plant.r).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (lq, lr) = (chol(&plant.qd), chol(&plant.r));
    let mut cov = KalmanFilter::<6, 4, 3>::new(plant.model(), SVector::zeros(), SMatrix::identity() * 1e-2).unwrap();
    let mut ss = cov;
    ss.set_steady_state_gain(to_f32(&k).unwrap()).unwrap();
    assert!(ss.is_steady_state());
    let mut x = DVector::<f64>::zeros(6);
    let mut worst = 0.0f64;
    for step in 0..1500 {
        x = &plant.ad * &x + gauss(&mut rng, &lq);
        let z = &plant.c * &x + gauss(&mut rng, &lr);
        let zf = SVector::<f32, 3>::from_fn(|i, _| z[i] as f32);
        for f in [&mut cov, &mut ss] {
            f.predict(&SVector::zeros()).unwrap();
            f.update(&zf).unwrap();
        }
        if step > 1000 {
            let sigma = cov.covariance().diagonal().map(f32::sqrt);
            let d = (cov.state() - ss.state()).component_div(&sigma).abs().max();
            worst = worst.max(d as f64);
        }
    }
    println!("steady-state vs covariance mode after convergence: max |Δx|/σ = {worst:.2e}");
    assert!(worst < 1e-2);
}

/// The flight LQR `u = -K (x - x_ref)` (`control::lqr::state_feedback`), then the
/// whole-vector gimbal-rate limit `max |u_i| <= u_max` (`math::scale_to_peak`).
fn lqr_flight(
    k: &SMatrix<f32, 4, 6>,
    x: &SVector<f32, 6>,
    x_ref: &SVector<f32, 6>,
    u_max: Option<f32>,
) -> SVector<f32, 4> {
    let rows: [[f32; 6]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)]));
    let dx: [f32; 6] = std::array::from_fn(|i| x[i] - x_ref[i]);
    let mut u = state_feedback(&rows, &dx);
    if let Some(m) = u_max {
        scale_to_peak(&mut u, m);
    }
    SVector::from(u)
}

#[test]
fn lqr_apply_matches_design_and_limits() {
    let plant = Plant::paper002();
    let q = DMatrix::from_diagonal(&DVector::from_row_slice(&[32.8, 32.8, 32.8, 3283.0, 3283.0, 3283.0]));
    let r = DMatrix::<f64>::identity(4, 4) * 69.4;
    let (k, _) = dlqr(&plant.ad, &plant.bd, &(&q * 0.1), &(&r * 0.1)).unwrap();
    let kf32: SMatrix<f32, 4, 6> = to_f32(&k).unwrap();
    let x = DVector::from_row_slice(&[0.1, -0.05, 0.2, 0.01, 0.0, -0.02]);
    let xr = DVector::from_row_slice(&[0.0, 0.0, 0.1, 0.0, 0.0, 0.0]);
    let u64v = -(&k * (&x - &xr));
    let xf = SVector::<f32, 6>::from_fn(|i, _| x[i] as f32);
    let xrf = SVector::<f32, 6>::from_fn(|i, _| xr[i] as f32);
    let u = lqr_flight(&kf32, &xf, &xrf, None);
    for i in 0..4 {
        assert!((u[i] as f64 - u64v[i]).abs() <= 1e-5 * u64v.abs().max());
    }
    let ul = lqr_flight(&kf32, &xf, &xrf, Some(0.12));
    let peak = ul.abs().max();
    assert!(peak <= 0.12 + 1e-7 && (u.normalize() - ul.normalize()).norm() < 1e-5);
    let mut bad = xf;
    bad[2] = f32::NAN;
    // Non-finite state: the command is non-finite, which `Fsw::step` reports as LAW_FAULT.
    assert!(!lqr_flight(&kf32, &bad, &xrf, Some(0.12)).iter().all(|v| v.is_finite()));
}

/// LQG on the discretised paper-002 plant, all flight-side maths in f32: steady-state
/// filter + discrete LQR + gimbal-rate limit, from Euler [10, 10, 10]° (table 3).
/// Disturbance torque PSD (1e-4 N m)²·s; Bryson weights 1°, 1°/s, 0.12 rad/s.
#[test]
fn lqg_closed_loop_paper002() {
    let plant = Plant::paper002_with(1e-4);
    let dt = 0.1;
    let a = 1f64.to_radians().powi(-2);
    let w = 1f64.to_radians().powi(-2);
    let q = DMatrix::from_diagonal(&DVector::from_row_slice(&[a, a, a, w, w, w]));
    let r = DMatrix::<f64>::identity(4, 4) / paper002::GIMBAL_RATE_MAX.powi(2);
    let (k, _) = dlqr(&plant.ad, &plant.bd, &(&q * dt), &(&r * dt)).unwrap();
    let (l, _) = steady_state_kalman(&plant.ad, &plant.c, &plant.qd, &plant.r).unwrap();
    let kf32: SMatrix<f32, 4, 6> = to_f32(&k).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (lq, lr) = (chol(&plant.qd), chol(&plant.r));
    let mut x = DVector::from_row_slice(&[10f64.to_radians(), 10f64.to_radians(), 10f64.to_radians(), 0.0, 0.0, 0.0]);
    let x0 = SVector::<f32, 6>::from_fn(|i, _| x[i] as f32);
    let mut f = KalmanFilter::<6, 4, 3>::new(plant.model(), x0, SMatrix::identity() * 1e-4).unwrap();
    f.set_steady_state_gain(to_f32(&l).unwrap()).unwrap();
    let mut settle = None;
    let mut worst_after = 0.0f64;
    for step in 0..1200 {
        let z = &plant.c * &x + gauss(&mut rng, &lr);
        f.update(&SVector::<f32, 3>::from_fn(|i, _| z[i] as f32)).unwrap();
        let u = lqr_flight(&kf32, f.state(), &SVector::zeros(), Some(paper002::GIMBAL_RATE_MAX as f32));
        let ud = DVector::from_fn(4, |i, _| u[i] as f64);
        x = &plant.ad * &x + &plant.bd * &ud + gauss(&mut rng, &lq);
        f.predict(&u).unwrap();
        let err = x.rows(0, 3).abs().max().to_degrees();
        if settle.is_none() && err < 0.2 {
            settle = Some(step as f64 * dt);
        }
        if step as f64 * dt > 30.0 {
            worst_after = worst_after.max(err);
        }
    }
    println!(
        "LQG paper 002 (linear plant): first |angle| < 0.2° at {settle:?} s; max |angle| after 30 s {worst_after:.3}°"
    );
    assert!(worst_after < 0.2);
}
