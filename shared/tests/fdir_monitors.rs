//! The fault detection monitors against closed forms (issue 42; docs/fdir.md):
//! (a) k-of-n persistence on i.i.d. exceedances fires on the binomial tail `P(X ≥ k)`;
//! (b) a healthy wheel's torque residual has the σ of its noise model
//!     `(I_w/Δt) √(2 (σ_t² + q²/12 + σ_g²))` and, at a 2σ threshold, the Gaussian tail;
//!     a seized rotor, a motor that lost its torque and a runaway are declared after exactly
//!     `k` steps; a repeated frame (Δt = 0) is not judged;
//! (c) a quantised, noisy constant reading repeats `r` times in a row with probability
//!     `Σ_k p_k^(r+1)` (p_k: the probability of quantisation step k, from erf).
//! (d) a fired wheel residual is named rotor or tachometer from the body's mismatch: the
//!     mismatch of a rigid body integrated here (RK4, f64) is zero with honest tachometers
//!     and `−r aⱼ` with a lying one; with noise the unit is misnamed at `Φ(−|r|/(2σ_m))`.
//! (e) the magnetometer's field-magnitude residual `|B + n| − |B_model|` has σ = σ_m (the
//!     noise along the field) and exceeds `γ σ` at the two-sided Gaussian tail; a bias
//!     along the field is declared after exactly `k` samples, one across it never.
//! (f) the GNSS residual (a fix against the last one propagated to its time) is χ²₃ in
//!     units of `σ_d² = 2σ_r² + (σ_v Δt)²` on an exact circular orbit.
//! Noise from a seeded SplitMix64 (acs-test-support); f64 oracles written here.

#![allow(clippy::disallowed_methods)] // test-side oracles may use nalgebra's own sqrt

use acs_flight::fdir::isolate::{WheelIsolation, body_mismatch_nm, isolate_wheel};
use acs_flight::fdir::magnetometer::MagnetometerMonitor;
use acs_flight::fdir::repeat::Repeats;
use acs_flight::fdir::wheel::{WheelMonitor, WheelStep, residual_sigma_nm};
use acs_flight::fdir::window::{KOfN, Persistence};
use acs_flight::math::{Mat3, Vec3};
use acs_flight::params::fdir::{MagnetometerFdirParams, WheelMonitorParams, WheelResidualNoise};
use acs_flight::types::MAX_WHEELS;
use acs_test_support::rng::SplitMix64;
use nalgebra::Vector3;

fn binomial_tail(n: u32, k: u32, p: f64) -> f64 {
    let mut c = 1.0f64; // C(n, j)
    let mut tail = 0.0;
    for j in 0..=n {
        if j >= k {
            tail += c * p.powi(j as i32) * (1.0 - p).powi((n - j) as i32);
        }
        c = c * f64::from(n - j) / f64::from(j + 1);
    }
    tail
}

#[test]
fn k_of_n_fires_on_iid_exceedances_at_the_binomial_tail() {
    // 2e6 steps; the firing indicator is correlated over n steps, so the standard error
    // is that of N/n independent draws; tolerance 5 of them.
    let steps = 2_000_000usize;
    for (k, n, p) in [(3u8, 10u8, 0.05f64), (2, 4, 0.1), (5, 32, 0.08), (1, 1, 0.01)] {
        let w = KOfN { k, n };
        let mut rng = SplitMix64(0xF00D ^ u64::from(k) << 8 ^ u64::from(n));
        let mut pers = Persistence::default();
        let mut fired = 0usize;
        for i in 0..steps {
            let f = pers.push(&w, rng.uniform() < p);
            if i >= usize::from(n) && f {
                fired += 1;
            }
        }
        let got = fired as f64 / (steps - usize::from(n)) as f64;
        let want = binomial_tail(u32::from(n), u32::from(k), p);
        let se = (want * (1.0 - want) / (steps as f64 / f64::from(n))).sqrt();
        println!("k {k} of n {n}, p {p}: fired {got:.5}, binomial tail {want:.5} (se {se:.1e})");
        assert!((got - want).abs() < 5.0 * se, "k {k} n {n} p {p}: {got} vs {want}");
    }
}

/// Normal CDF.
fn phi(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// A wheel integrated exactly under a random held command, read by a noisy quantised
/// tachometer, the body's axial rate change read by a noisy gyro (truth: 0, the body is
/// held); the residuals over `steps`.
fn healthy_residuals(p: &WheelMonitorParams, dt_s: f64, steps: usize, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    let (j, nz) = (f64::from(p.inertia_kgm2), p.noise);
    let q = f64::from(nz.tach_lsb_rad_s);
    let tach = |w: f64, rng: &mut SplitMix64| {
        let x = w + f64::from(nz.tach_sigma_rad_s) * rng.normal();
        (if q > 0.0 { (x / q).round() * q } else { x }) as f32
    };
    let mut mon = WheelMonitor::default();
    let mut w = 50.0f64;
    let mut gyro_prev = 0.0f64;
    let mut out = Vec::new();
    let mut cmd = [0f32; MAX_WHEELS];
    for i in 0..steps {
        let u = 0.01 * (rng.uniform() * 2.0 - 1.0);
        w += u * dt_s / j;
        cmd[0] = u as f32;
        let gyro = f64::from(nz.gyro_sigma_rad_s) * rng.normal();
        let mut step = WheelStep {
            applied_command_nm: cmd,
            speed_rad_s: [0.0; MAX_WHEELS],
            axial_body_rate_change_rad_s: [0.0; MAX_WHEELS],
            dt_s: dt_s as f32,
            not_judged: 0,
        };
        step.speed_rad_s[0] = tach(w, &mut rng);
        step.axial_body_rate_change_rad_s[0] = (gyro - gyro_prev) as f32;
        gyro_prev = gyro;
        let v = mon.step(p, 1, &step);
        assert_eq!(v.judged, i > 0);
        if v.judged {
            out.push(f64::from(v.residual_nm[0]));
        }
    }
    out
}

fn wheel_params() -> WheelMonitorParams {
    WheelMonitorParams {
        noise: WheelResidualNoise { tach_sigma_rad_s: 0.02, tach_lsb_rad_s: 0.05, gyro_sigma_rad_s: 0.0 },
        inertia_kgm2: 1.6e-5 * 100.0,
        threshold_sigma: 2.0,
        floor_nm: 0.0,
        window: KOfN { k: 1, n: 1 },
    }
}

#[test]
fn a_healthy_wheels_residual_has_the_sigma_of_its_noise_model() {
    let dt = 0.1;
    for (tach, lsb, gyro) in [(0.02f32, 0.05f32, 0.0f32), (0.05, 0.0, 0.0), (0.0, 0.1, 0.0), (0.02, 0.02, 0.01)] {
        let mut p = wheel_params();
        p.noise = WheelResidualNoise { tach_sigma_rad_s: tach, tach_lsb_rad_s: lsb, gyro_sigma_rad_s: gyro };
        let r = healthy_residuals(&p, dt, 200_000, 7);
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        let sd = (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt();
        let j = f64::from(p.inertia_kgm2);
        let want =
            j / dt * (2.0 * (f64::from(tach).powi(2) + f64::from(lsb).powi(2) / 12.0 + f64::from(gyro).powi(2))).sqrt();
        let flight = f64::from(residual_sigma_nm(&p.noise, p.inertia_kgm2, dt as f32));
        println!("tach {tach} lsb {lsb} gyro {gyro}: residual sd {sd:.4e} N m, closed form {want:.4e}");
        assert!((sd / want - 1.0).abs() < 0.02, "sd {sd} vs {want}");
        assert!((flight / want - 1.0).abs() < 1e-6, "flight σ {flight} vs {want}");
        assert!(mean.abs() < 0.01 * want, "no bias: {mean}");
    }
}

#[test]
fn a_healthy_wheel_exceeds_a_2_sigma_threshold_at_the_gaussian_tail() {
    // Tachometer noise equal to its step: the residual is near Gaussian (a uniform
    // quantisation error carries 1/12 of the variance), so the two-sided 2σ tail, 4.55 %.
    let mut p = wheel_params();
    p.noise.tach_lsb_rad_s = p.noise.tach_sigma_rad_s;
    let r = healthy_residuals(&p, 0.1, 400_000, 11);
    let sigma = f64::from(residual_sigma_nm(&p.noise, p.inertia_kgm2, 0.1));
    let got = r.iter().filter(|x| x.abs() > 2.0 * sigma).count() as f64 / r.len() as f64;
    let want = 2.0 * (1.0 - phi(2.0));
    println!("2σ exceedances {got:.5} vs Gaussian {want:.5}");
    assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
}

#[test]
fn seized_weak_and_runaway_wheels_are_declared_after_exactly_k_steps() {
    let mut p = wheel_params();
    p.threshold_sigma = 5.0;
    p.window = KOfN { k: 4, n: 6 };
    let dt = 0.1f32;
    let sigma = residual_sigma_nm(&p.noise, p.inertia_kgm2, dt);
    // Commands well above the threshold (5σ): 20σ.
    let u = 20.0 * sigma;
    // (name, commanded, torque the rotor actually gets)
    for (name, cmd, actual) in [("seized", u, None), ("no torque", u, Some(0.0)), ("runaway", 0.0, Some(u))] {
        let mut mon = WheelMonitor::default();
        let mut w = 100.0f32;
        let mut declared = None;
        for k in 0..12 {
            if k > 0 {
                // `None`: the rotor is seized (relative speed frozen at 100 rad/s).
                if let Some(a) = actual {
                    w += a * dt / p.inertia_kgm2;
                }
            }
            let mut s = WheelStep {
                applied_command_nm: [0.0; MAX_WHEELS],
                speed_rad_s: [0.0; MAX_WHEELS],
                axial_body_rate_change_rad_s: [0.0; MAX_WHEELS],
                dt_s: dt,
                not_judged: 0,
            };
            s.applied_command_nm[1] = cmd;
            s.speed_rad_s[1] = w;
            let v = mon.step(&p, 2, &s);
            assert_eq!(v.failed & 0b01, 0, "{name}: the healthy wheel 0 is never declared");
            if v.failed & 0b10 != 0 && declared.is_none() {
                declared = Some(k);
            }
        }
        // Step 0 only primes the difference; steps 1..=4 are the four exceedances.
        assert_eq!(declared, Some(4), "{name}");
    }
}

#[test]
fn a_repeated_frame_is_not_judged_and_absurd_inputs_never_pass() {
    let p = wheel_params();
    let mut mon = WheelMonitor::default();
    let mut s = WheelStep {
        applied_command_nm: [0.0; MAX_WHEELS],
        speed_rad_s: [10.0; MAX_WHEELS],
        axial_body_rate_change_rad_s: [0.0; MAX_WHEELS],
        dt_s: 0.1,
        not_judged: 0,
    };
    assert!(!mon.step(&p, 4, &s).judged);
    for dt in [0.0, -0.1, f32::NAN, f32::INFINITY] {
        s.dt_s = dt;
        let v = mon.step(&p, 4, &s);
        assert!(!v.judged && v.failed == 0, "dt {dt}");
    }
    s.dt_s = 0.1;
    assert!(mon.step(&p, 4, &s).judged, "the speeds before the repeated frames are kept");
    s.speed_rad_s[2] = f32::NAN;
    let v = mon.step(&p, 4, &s);
    assert_eq!(v.failed, 0b100, "a NaN tachometer is an exceedance (k = 1)");
    // More wheels than the arrays hold: bounded, no panic.
    assert!(mon.step(&p, usize::MAX, &s).judged);
}

#[test]
fn a_quantised_noisy_constant_repeats_at_the_closed_form_rate() {
    // Per sample, the run of repeats reaches r with probability Σ_k p_k^(r+1).
    let (q, sigma) = (1.0f64, 0.7f64);
    let steps = 1_000_000usize;
    for r in [1u16, 2, 3] {
        let mut rng = SplitMix64(0xBEEF + u64::from(r));
        let mu = 0.3; // the truth, off the quantisation grid
        let mut mon = Repeats::<1>::default();
        let mut fired = 0usize;
        for _ in 0..steps {
            let x = ((mu + sigma * rng.normal()) / q).round() * q;
            if mon.push(r - 1, &[x as f32]) != 0 {
                fired += 1;
            }
        }
        let got = fired as f64 / steps as f64;
        let want: f64 = (-20..=20)
            .map(|k| {
                let (a, b) = ((f64::from(k) - 0.5) * q, (f64::from(k) + 0.5) * q);
                (phi((b - mu) / sigma) - phi((a - mu) / sigma)).powi(i32::from(r) + 1)
            })
            .sum();
        // Runs overlap: standard error of ~steps/(r+1) independent draws; 5 of them.
        let se = (want * (1.0 - want) / (steps as f64 / f64::from(r + 1))).sqrt();
        println!("run of {r} repeats: {got:.5} per sample vs closed form {want:.5}");
        assert!((got - want).abs() < 5.0 * se, "r {r}: {got} vs {want}");
    }
}

/// A rigid body with four pyramid wheels (β = 54.74°) flown by RK4 in f64 over one 0.1 s
/// step under held rotor torques `tau`; the body rate before and after and the wheel
/// momentum (body axes) at the step's midpoint.
fn pyramid_step(tau: [f64; 4], w0: [f64; 3]) -> ([Vec3; 4], Vec3, Vec3, Vec3) {
    let (sb, cb) = (54.7356f64.to_radians().sin(), 54.7356f64.to_radians().cos());
    let axes = [[cb, 0.0, sb], [0.0, cb, sb], [-cb, 0.0, sb], [0.0, -cb, sb]];
    let j = [[0.9, 0.02, -0.01], [0.02, 1.1, 0.03], [-0.01, 0.03, 0.7]];
    let mv = |m: &[[f64; 3]; 3], v: [f64; 3]| [0, 1, 2].map(|r| (0..3).map(|c| m[r][c] * v[c]).sum::<f64>());
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    // J ω̇ = −Σ aᵢ τᵢ − ω × (J ω + h), h = Σ aᵢ hᵢ, ḣᵢ = τᵢ; the state is (ω, h_1..4).
    let jinv = nalgebra::Matrix3::from_fn(|r, c| j[r][c]).try_inverse().unwrap();
    let deriv = |w: [f64; 3], hw: [f64; 4]| {
        let mut h = [0.0; 3];
        let mut t = [0.0; 3];
        for i in 0..4 {
            for k in 0..3 {
                h[k] += axes[i][k] * hw[i];
                t[k] -= axes[i][k] * tau[i];
            }
        }
        let jw = mv(&j, w);
        let g = cross(w, [jw[0] + h[0], jw[1] + h[1], jw[2] + h[2]]);
        let rhs = nalgebra::Vector3::new(t[0] - g[0], t[1] - g[1], t[2] - g[2]);
        let a = jinv * rhs;
        ([a.x, a.y, a.z], tau)
    };
    let (dt, n) = (0.1f64, 100);
    let h = dt / f64::from(n);
    let (mut w, mut hw) = (w0, [0.5, -0.3, 0.2, 0.4]);
    let mut h_mid = [0.0; 3];
    for s in 0..n {
        if s == n / 2 {
            for i in 0..4 {
                for k in 0..3 {
                    h_mid[k] += axes[i][k] * hw[i];
                }
            }
        }
        let add = |x: [f64; 3], d: [f64; 3], f: f64| [x[0] + f * d[0], x[1] + f * d[1], x[2] + f * d[2]];
        let add4 = |x: [f64; 4], d: [f64; 4], f: f64| [0, 1, 2, 3].map(|i| x[i] + f * d[i]);
        let (k1w, k1h) = deriv(w, hw);
        let (k2w, k2h) = deriv(add(w, k1w, h / 2.0), add4(hw, k1h, h / 2.0));
        let (k3w, k3h) = deriv(add(w, k2w, h / 2.0), add4(hw, k2h, h / 2.0));
        let (k4w, k4h) = deriv(add(w, k3w, h), add4(hw, k3h, h));
        for k in 0..3 {
            w[k] += h / 6.0 * (k1w[k] + 2.0 * k2w[k] + 2.0 * k3w[k] + k4w[k]);
        }
        for i in 0..4 {
            hw[i] += h / 6.0 * (k1h[i] + 2.0 * k2h[i] + 2.0 * k3h[i] + k4h[i]);
        }
    }
    let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    (axes.map(f), f(w0), f(w), f(h_mid))
}

#[test]
fn the_body_mismatch_is_zero_with_honest_tachometers_and_minus_r_a_j_with_a_lying_one() {
    let jb = Mat3::new(0.9, 0.02, -0.01, 0.02, 1.1, 0.03, -0.01, 0.03, 0.7);
    let tau = [2e-3, -1e-3, 0.5e-3, 1.5e-3];
    let (axes, w0, w1, h) = pyramid_step(tau, [0.01, -0.02, 0.005]);
    let tach_axes = |t: [f64; 4]| (0..4).fold(Vec3::zeros(), |acc, i| acc + axes[i] * t[i] as f32);
    let honest = body_mismatch_nm(&jb, &w0, &w1, 0.1, &h, &tach_axes(tau));
    // The flight code takes ω at the step's middle as the mean of its ends: off by
    // ω̈ Δt²/8 ≈ 9e-3 · 0.01 / 8 = 1.1e-5 rad/s here, times |h| ≈ 0.6 N m s: 7e-6 N m of
    // bias (beside a gyroscopic torque of 1.4e-2 N m and rotor torques of 1e-3 N m).
    assert!(honest.norm() < 1e-5, "honest mismatch {honest:?}");
    // Wheel 2's tachometer reads 1e-3 N m less than the rotor got: r = u − τᵗ = +1e-3.
    let mut lying = tau;
    lying[2] -= 1e-3;
    let m = body_mismatch_nm(&jb, &w0, &w1, 0.1, &h, &tach_axes(lying));
    // The lie adds exactly −r a₂ (f32 rounding only).
    let want = -axes[2] * 1e-3;
    assert!((m - honest - want).norm() < 1e-9, "{m:?} vs {want:?}");
    assert_eq!(isolate_wheel(1e-3, &axes[2], &m, 1e-5, 3.0), WheelIsolation::Tachometer);
    // The rotor got nothing although commanded 1e-3 more (a rotor fault): honest tachs.
    assert_eq!(isolate_wheel(1e-3, &axes[2], &honest, 1e-5, 3.0), WheelIsolation::Rotor);
}

#[test]
fn wheel_isolation_misnames_at_the_closed_form_rate_and_does_not_guess_below_its_ratio() {
    let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
    let sigma = 1e-4f32;
    let draws = 40_000;
    for ratio in [2.0f32, 3.0, 4.0] {
        let r = ratio * sigma;
        let mut rng = SplitMix64(0x150 + ratio as u64);
        let mut wrong = 0;
        for i in 0..draws {
            let tach_fault = i % 2 == 0;
            let noise = Vec3::new(rng.normal() as f32, rng.normal() as f32, rng.normal() as f32) * sigma;
            let m = if tach_fault { -axis * r + noise } else { noise };
            let got = isolate_wheel(r, &axis, &m, sigma, 1.0);
            let right = if tach_fault { WheelIsolation::Tachometer } else { WheelIsolation::Rotor };
            if got != right {
                wrong += 1;
            }
        }
        let got = f64::from(wrong) / f64::from(draws);
        let want = phi(-f64::from(ratio) / 2.0);
        let se = (want * (1.0 - want) / f64::from(draws)).sqrt();
        println!("|r|/σ_m = {ratio}: misnamed {got:.4} vs Φ(−|r|/2σ) {want:.4}");
        assert!((got - want).abs() < 5.0 * se, "ratio {ratio}: {got} vs {want}");
    }
    assert_eq!(isolate_wheel(2e-4, &axis, &Vec3::zeros(), 1e-4, 3.0), WheelIsolation::Ambiguous);
    assert_eq!(isolate_wheel(f32::NAN, &axis, &Vec3::zeros(), 1e-4, 3.0), WheelIsolation::Ambiguous);
    assert_eq!(isolate_wheel(1.0, &axis, &Vec3::repeat(f32::NAN), 1e-4, 3.0), WheelIsolation::Ambiguous);
    assert_eq!(isolate_wheel(0.0, &axis, &Vec3::zeros(), 0.0, 0.0), WheelIsolation::Ambiguous);
}

fn magnetometer_params(threshold_sigma: f32) -> MagnetometerFdirParams {
    MagnetometerFdirParams {
        noise_t: 1.0e-7,
        model_sigma_t: 0.0,
        threshold_sigma,
        window: acs_flight::params::fdir::KOfN { k: 3, n: 4 },
        max_repeats: 3,
    }
}

/// A field of LEO strength (20-50 µT) in a random direction, with white noise σ_m per
/// axis (f64 truth, the reading rounded to f32 as the link carries it); the model knows
/// the truth's magnitude. Returns the monitor's residual and threshold per sample.
fn magnetometer_residuals(p: &MagnetometerFdirParams, samples: u64, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = SplitMix64(seed);
    let mut m = MagnetometerMonitor::new();
    let sigma = f64::from(p.noise_t);
    (0..samples)
        .map(|i| {
            let b = rng.unit() * rng.range(2.0e-5, 5.0e-5);
            let read = b + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sigma;
            let field = Vec3::new(read.x as f32, read.y as f32, read.z as f32);
            m.judge(p, i, &field, Some(b.norm() as f32));
            let (r, t) = m.last_residual_t();
            (f64::from(r), f64::from(t))
        })
        .collect()
}

#[test]
fn the_field_magnitude_residual_has_the_magnetometers_sigma_and_its_gaussian_tail() {
    // σ: 100,000 samples estimate it within 0.5 % (4.5 standard errors of a sample σ);
    // f32 rounding of a 50 µT reading (≈ 4e-12 T) is far below.
    let n = 100_000;
    let r = magnetometer_residuals(&magnetometer_params(5.0), n, 7);
    let mean = r.iter().map(|x| x.0).sum::<f64>() / n as f64;
    let sd = (r.iter().map(|x| (x.0 - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
    println!("magnitude residual: mean {mean:.3e}, sigma {sd:.4e} (sigma_m 1e-7)");
    assert!((sd / 1.0e-7 - 1.0).abs() < 0.005, "{sd}");
    assert!(mean.abs() < 4.0 * 1.0e-7 / (n as f64).sqrt(), "{mean}");
    // The per-sample exceedance rate at γ = 2 against 2 (1 − Φ(2)) = 0.0455, within 4σ of
    // the binomial.
    let r = magnetometer_residuals(&magnetometer_params(2.0), n, 8);
    let got = r.iter().filter(|(x, t)| x.abs() > *t).count() as f64 / n as f64;
    let want = 2.0 * (1.0 - phi(2.0));
    let se = (want * (1.0 - want) / n as f64).sqrt();
    println!("exceedance rate at 2 sigma: {got:.5}, Gaussian tail {want:.5} (se {se:.1e})");
    assert!((got - want).abs() < 4.0 * se, "{got} vs {want}");
}

#[test]
fn a_bias_along_the_field_is_declared_after_k_samples_and_one_across_it_never() {
    // Threshold 5σ = 0.5 µT; a 2 µT bias along the field moves |B| by 2 µT (40σ), across
    // it by |B|(√(1 + (2/30)²) − 1) = 0.067 µT (0.7σ): never, whatever the noise does
    // in 200 samples (5σ − 0.7σ = 4.3σ per sample: P ≈ 1.7e-5 each, k = 3 of 4 needed).
    let p = magnetometer_params(5.0);
    let mut rng = SplitMix64(9);
    let b = Vector3::new(0.0, 1.8e-5, 2.4e-5); // 30 µT
    let across = Vector3::new(2.0e-6, 0.0, 0.0);
    let along = b.normalize() * 2.0e-6;
    for (bias, declared_at) in [(along, Some(2u64)), (across, None)] {
        let mut m = MagnetometerMonitor::new();
        let mut first = None;
        for i in 0..200u64 {
            let read = b + bias + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 1.0e-7;
            m.judge(&p, i, &Vec3::new(read.x as f32, read.y as f32, read.z as f32), Some(b.norm() as f32));
            if m.failed() && first.is_none() {
                first = Some(i);
            }
        }
        assert_eq!(first, declared_at, "bias {bias:?}");
    }
}

/// `Q(x) = P(χ²₃ > x) = erfc(√(x/2)) + √(2x/π) e^(−x/2)`.
fn chi2_3_tail(x: f64) -> f64 {
    libm::erfc((x / 2.0).sqrt()) + (2.0 * x / std::f64::consts::PI).sqrt() * (-x / 2.0).exp()
}

/// (f) the GNSS monitor's residual: each fix against the last one carried to its time by
/// the flight's two-body step. On an exact circular orbit (f64, closed form) with white
/// noise σ_r on the position and σ_v on the velocity of every fix, `d²/σ_d²` with
/// `σ_d² = 2σ_r² + (σ_v Δt)²` is χ²₃: mean 3, and the monitor's exceedances at
/// `γ σ_d + ROUNDING_M` (no model acceleration) follow `Q(((γ σ_d + 4)/σ_d)²)`. The
/// velocity residual likewise with `σ_e² = 2σ_v²`.
#[test]
fn the_gnss_residual_is_chi2_3_on_a_circular_orbit() {
    use acs_flight::estimation::navigation::Navigation;
    use acs_flight::fdir::gnss::{GnssMonitor, ROUNDING_M};
    use acs_flight::params::fdir::GnssFdirParams;
    use acs_flight::types::GnssFix;
    let (radius_m, mu) = (6_988_000.0f64, 3.986_004_418e14f64);
    let n_rad_s = (mu / radius_m.powi(3)).sqrt();
    let (sr, sv, gamma) = (5.0f64, 0.05f64, 2.0f64);
    let p = GnssFdirParams {
        position_sigma_m: sr as f32,
        velocity_sigma_m_s: sv as f32,
        model_accel_m_s2: 0.0,
        threshold_sigma: gamma as f32,
        window: KOfN { k: 32, n: 32 },
    };
    let mut rng = SplitMix64(20_261_129);
    let (mut nav, mut monitor) = (Navigation::new(), GnssMonitor::new());
    let (mut sum, mut exceeded, mut judged) = (0.0f64, 0usize, 0usize);
    let sigma_d = (2.0 * sr * sr + sv * sv).sqrt(); // Δt = 1 s
    // The velocity: 2σ_v² (the gravity gradient's share, 1.9e-5 m/s, is below the
    // tolerance's reach: 1e-7 of the variance).
    let sigma_e = (2.0 * sv * sv).sqrt();
    let (mut sum_v, mut exceeded_v) = (0.0f64, 0usize);
    for k in 0..20_000u64 {
        let t = k as f64; // one fix a second
        let (s, c) = (n_rad_s * t).sin_cos();
        let r = [radius_m * c, radius_m * s, 0.0];
        let v = [-radius_m * n_rad_s * s, radius_m * n_rad_s * c, 0.0];
        let noisy = |x: [f64; 3], sigma: f64, rng: &mut SplitMix64| {
            Vec3::new(
                (x[0] + sigma * rng.normal()) as f32,
                (x[1] + sigma * rng.normal()) as f32,
                x[2] as f32 + (sigma * rng.normal()) as f32,
            )
        };
        let fix = GnssFix {
            time_us: k * 1_000_000,
            pos_eci_m: noisy(r, sr, &mut rng),
            vel_eci_m_s: noisy(v, sv, &mut rng),
            j2000_days: 9_800,
            j2000_s: t as f32,
        };
        let predicted = nav.predict_fix(fix.time_us);
        monitor.judge(&p, fix.time_us, (&fix.pos_eci_m, &fix.vel_eci_m_s), predicted.as_ref());
        if predicted.is_some() {
            let (d, threshold) = monitor.last_residual_m();
            sum += (f64::from(d) / sigma_d).powi(2);
            exceeded += usize::from(d > threshold);
            let (e, threshold_v) = monitor.last_velocity_residual_m_s();
            sum_v += (f64::from(e) / sigma_e).powi(2);
            exceeded_v += usize::from(e > threshold_v);
            judged += 1;
        }
        // Every fix is taken, so that each residual spans one second.
        nav.update(fix.time_us, Some(&fix));
    }
    let mean = sum / judged as f64;
    // χ²₃ has variance 6: the mean of 20,000 has σ 0.017; 3 % is 5σ.
    assert!((mean - 3.0).abs() < 0.09, "mean d²/σ_d² = {mean}, want 3");
    let want = chi2_3_tail(((gamma * sigma_d + f64::from(ROUNDING_M)) / sigma_d).powi(2));
    let got = exceeded as f64 / judged as f64;
    let se = (want * (1.0 - want) / judged as f64).sqrt();
    println!("GNSS residual: mean d²/σ_d² {mean:.4} (3), exceedances {got:.5} against {want:.5} (se {se:.5})");
    assert!((got - want).abs() < 4.0 * se, "exceedance rate {got} against the χ²₃ tail {want}");
    // The velocity residual: the same law, its threshold γ σ_e + the truncation and
    // rounding terms (no model acceleration), taken from the monitor's formula's parts.
    let mean_v = sum_v / judged as f64;
    assert!((mean_v - 3.0).abs() < 0.09, "mean e²/σ_e² = {mean_v}, want 3");
    let extra = f64::from(GnssMonitor::velocity_threshold_m_s(&p, 1.0)) - gamma * sigma_e;
    assert!((0.012..0.0125).contains(&extra), "truncation + rounding {extra} m/s");
    let want_v = chi2_3_tail(((gamma * sigma_e + extra) / sigma_e).powi(2));
    let got_v = exceeded_v as f64 / judged as f64;
    let se_v = (want_v * (1.0 - want_v) / judged as f64).sqrt();
    println!(
        "GNSS velocity residual: mean e²/σ_e² {mean_v:.4} (3), exceedances {got_v:.5} against {want_v:.5} (se {se_v:.5})"
    );
    assert!((got_v - want_v).abs() < 4.0 * se_v, "velocity exceedance rate {got_v} against the χ²₃ tail {want_v}");
}

/// (g) one fix with a good position and a corrupt velocity, through the estimation stage.
/// Before the velocity test such a fix was taken: the next good fixes looked like jumps
/// against the orbit carried with its velocity, the healthy receiver was declared failed 3
/// fixes later and the navigation carried the bad state (26.9 km, 53.8 km and 537 km off
/// after 500 s for 50, 100 and 1,000 m/s). Now the fix is refused, nothing is declared,
/// and the navigation at 500 s is within the receiver's noise of the truth (a closed-form
/// circular orbit, f64). A velocity that stays corrupt is declared on its third fix (3 of
/// 4) as the velocity test's, and the navigation keeps the last good fix.
#[test]
fn a_corrupt_gnss_velocity_is_refused_and_the_orbit_kept() {
    use acs_flight::estimation::determination::Determination;
    use acs_flight::params::EstimationParams;
    use acs_flight::params::fdir::GnssFdirParams;
    use acs_flight::types::{GnssFix, SensorSamples};
    let (radius_m, mu) = (6_988_000.0f64, 3.986_004_418e14f64);
    let n_rad_s = (mu / radius_m.powi(3)).sqrt();
    let state = |t: f64| {
        let (s, c) = (n_rad_s * t).sin_cos();
        let (r, v) = ([radius_m * c, 0.0, radius_m * s], [-radius_m * n_rad_s * s, 0.0, radius_m * n_rad_s * c]);
        (Vector3::from(r), Vector3::from(v))
    };
    let gnss = GnssFdirParams {
        position_sigma_m: 5.0,
        velocity_sigma_m_s: 0.05,
        model_accel_m_s2: 0.02,
        threshold_sigma: 5.0,
        window: KOfN { k: 3, n: 4 },
    };
    let params = EstimationParams { gnss_fdir: Some(gnss), ..EstimationParams::SENSOR };
    // (jump, last corrupt fix): one fix, or every fix from 50 s on.
    for (jump_m_s, last) in [(50.0, 50u64), (100.0, 50), (1000.0, 50), (-100.0, 50), (100.0, 500)] {
        let mut d = Determination::new(&params).unwrap();
        let mut rng = SplitMix64(20_261_130);
        let mut declared_at = None;
        let mut nav_error_m = f64::NAN;
        for k in 0..=500u64 {
            let t = k as f64;
            let (r, v) = state(t);
            let noise =
                |s: f64, rng: &mut SplitMix64| Vector3::new(s * rng.normal(), s * rng.normal(), s * rng.normal());
            let (r_fix, mut v_fix) = (r + noise(5.0, &mut rng), v + noise(0.05, &mut rng));
            if (50..=last).contains(&k) {
                v_fix += v.normalize() * jump_m_s;
            }
            let fix = GnssFix {
                time_us: k * 1_000_000,
                pos_eci_m: Vec3::new(r_fix.x as f32, r_fix.y as f32, r_fix.z as f32),
                vel_eci_m_s: Vec3::new(v_fix.x as f32, v_fix.y as f32, v_fix.z as f32),
                j2000_days: 9_800,
                j2000_s: t as f32,
            };
            let samples = SensorSamples {
                time_us: fix.time_us,
                gyro: None,
                star_tracker: None,
                sun_sensor: None,
                css: None,
                magnetometer: None,
                gnss: Some(fix),
            };
            let estimate = d.step(&samples);
            let monitor = d.gnss_monitor();
            if k == 50 {
                let (e, threshold) = monitor.last_velocity_residual_m_s();
                assert!(f64::from(e) > jump_m_s.abs() - 1.0 && e > threshold, "{jump_m_s}: {e} against {threshold}");
                assert!(monitor.last_residual_m().0 < monitor.last_residual_m().1, "the position was good");
            }
            if monitor.failed() && declared_at.is_none() {
                declared_at = Some(k);
                let (e, threshold) = monitor.last_velocity_residual_m_s();
                assert!(e > threshold, "declared by the velocity test");
            }
            if let Some(nav) = estimate.nav {
                let r_nav = Vector3::new(f64::from(nav.r_m.x), f64::from(nav.r_m.y), f64::from(nav.r_m.z));
                nav_error_m = (r_nav - r).norm();
            }
        }
        println!(
            "velocity jump {jump_m_s} m/s to {last} s: declared at {declared_at:?}, nav error at 500 s {nav_error_m:.1} m"
        );
        if last == 50 {
            assert_eq!(declared_at, None, "{jump_m_s}: a healthy receiver declared");
            // One fix's noise: 5 m per axis (3σ of the norm ≈ 20 m), plus ROUNDING_M.
            assert!(nav_error_m < 30.0, "{jump_m_s}: {nav_error_m} m");
        } else {
            assert_eq!(declared_at, Some(52), "3 of 4 from the first corrupt fix");
            // The last good fix (49 s) carried 451 s by the Kepler step: its position noise
            // and its velocity noise × 451 s (0.05 m/s: 3σ 68 m) on a closed-form orbit.
            assert!(nav_error_m < 120.0, "{nav_error_m} m");
        }
    }
}
