//! The fault detection monitors against closed forms (issue 42; docs/fdir.md):
//! (a) k-of-n persistence on i.i.d. exceedances fires on the binomial tail `P(X ≥ k)`;
//! (b) a healthy wheel's torque residual has the σ of its noise model
//!     `(I_w/Δt) √(2 (σ_t² + q²/12 + σ_g²))` and, at a 2σ threshold, the Gaussian tail;
//!     a seized rotor, a motor that lost its torque and a runaway are declared after exactly
//!     `k` steps; a repeated frame (Δt = 0) is not judged;
//! (c) a quantised, noisy constant reading repeats `r` times in a row with probability
//!     `Σ_k p_k^(r+1)` (p_k: the probability of quantisation step k, from erf).
//! Noise from a seeded SplitMix64 (acs-test-support); f64 oracles written here.

use acs_flight::fdir::repeat::Repeats;
use acs_flight::fdir::wheel::{WheelMonitor, WheelStep, residual_sigma_nm};
use acs_flight::fdir::window::{KOfN, Persistence};
use acs_flight::params::fdir::{WheelMonitorParams, WheelResidualNoise};
use acs_flight::types::MAX_WHEELS;
use acs_test_support::rng::SplitMix64;

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
