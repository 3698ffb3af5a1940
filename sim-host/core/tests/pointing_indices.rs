//! The pointing-performance indices (`sim_core::recorder::pointing`) on synthetic error
//! signals whose indices have closed forms: a constant bias, a sine, a ramp and white
//! noise, at several window lengths. Tolerances: the histogram's bin ratio (0.5 %, always
//! on the high side), plus one sample's change for the sampled closed forms and four
//! standard errors of a sample quantile for the noise.

use acs_test_support::rng::SplitMix64;
use sim_core::recorder::pointing::{AxisFigures, MagnitudeQuantile, PointingStats, Windows};
use std::f64::consts::PI;

const RATIO: f64 = MagnitudeQuantile::RATIO;

fn fly(windows: Windows, samples: usize, e: impl Fn(usize) -> [f64; 3]) -> PointingStats {
    let mut s = PointingStats::new(windows);
    for i in 0..samples {
        s.push(e(i));
    }
    s
}

/// `got` is the bound at or above `want` within the bin ratio and `slack` (absolute).
fn assert_bound(what: &str, got: Option<f64>, want: f64, slack: f64) {
    let got = got.unwrap_or_else(|| panic!("{what}: no samples"));
    assert!(
        got >= want - slack && got <= want * RATIO + slack,
        "{what}: {got} against the closed form {want} (slack {slack})"
    );
}

/// An index that must vanish (rounding of sums of ~1e6 terms only).
fn assert_zero(what: &str, f: AxisFigures) {
    for v in [f.x, f.y, f.z, f.total] {
        assert!(v.unwrap() < 1e-9, "{what}: {v:?} should be 0");
    }
}

#[test]
fn a_constant_bias_is_all_absolute_error_and_no_relative_error() {
    let b = [0.02, -0.05, 0.1];
    for (window, sep, stab) in [(1, 1, 1), (10, 3, 7), (250, 2, 100)] {
        let w = Windows { window, drift_separation: sep, stability: stab };
        let s = fly(w, 5_000, |_| b);
        let ape = s.ape.figures(0.95);
        for (got, want) in [(ape.x, 0.02), (ape.y, 0.05), (ape.z, 0.1)] {
            assert_bound("APE axis", got, want, 0.0);
        }
        assert_bound("APE total", ape.total, (0.02f64.powi(2) + 0.05f64.powi(2) + 0.01).sqrt(), 0.0);
        assert_bound("MPE z", s.mpe.figures(0.95).z, 0.1, 1e-15);
        assert_zero("RPE", s.rpe.figures(0.95));
        assert_zero("PDE", s.pde.figures(0.95));
        assert_zero("stability", s.stability.figures(0.95));
    }
}

#[test]
fn a_sine_over_whole_periods_has_the_arcsine_quantiles() {
    // |A sin| spends the fraction (2/π) asin(x/A) of the time below x: its p-quantile is
    // A sin(pπ/2). e(t+Δ) − e(t) = 2A sin(ωΔ/2) cos(ωt + ωΔ/2): the same law, scaled.
    let (a, per_period) = (0.3, 400usize);
    let w_rad = 2.0 * PI / per_period as f64;
    for (periods, stab) in [(1usize, 25usize), (3, 100), (5, 200)] {
        let w = Windows { window: periods * per_period, drift_separation: 2, stability: stab };
        let s = fly(w, 100 * per_period, |i| [a * (w_rad * i as f64).sin(), 0.0, 0.0]);
        let step = a * w_rad; // the most one sample changes the signal
        for p in [0.5, 0.9, 0.95, 0.99] {
            let q = a * (p * PI / 2.0).sin();
            assert_bound("APE", s.ape.figures(p).x, q, step);
            assert_bound("RPE (window mean 0)", s.rpe.figures(p).x, q, step);
            let jitter = 2.0 * a * (w_rad * stab as f64 / 2.0).sin().abs() * (p * PI / 2.0).sin();
            assert_bound("stability", s.stability.figures(p).x, jitter, step);
        }
        assert!(s.mpe.figures(1.0).x.unwrap() < 1e-9, "window means of whole periods vanish");
        assert!(s.pde.figures(1.0).x.unwrap() < 1e-9);
    }
}

#[test]
fn a_ramp_drifts_by_its_slope_times_the_separation() {
    // e = r i: within a window of n samples the RPE runs over r (j − (n−1)/2), so its
    // p-quantile is p r n / 2 to one sample; window means step by r n per window.
    let r = 1e-4;
    for (window, sep, stab) in [(10usize, 1usize, 1usize), (100, 4, 30), (1000, 3, 500)] {
        let w = Windows { window, drift_separation: sep, stability: stab };
        let s = fly(w, 30 * window * sep.max(1), |i| [0.0, r * i as f64, 0.0]);
        for p in [0.5, 0.95, 1.0] {
            assert_bound("RPE", s.rpe.figures(p).y, p * r * window as f64 / 2.0, r);
        }
        assert_bound("PDE", s.pde.figures(0.95).y, r * (window * sep) as f64, 1e-12);
        assert_bound("stability", s.stability.figures(0.95).y, r * stab as f64, 1e-12);
        assert_eq!(s.pde.figures(0.95).samples, 30 * sep as u64 - sep as u64);
    }
}

/// p-quantile of |N(0, 1)| at p = 0.95 and of the norm of three of them (√χ²₃(0.95)).
const Z_95: f64 = 1.959_963_985;
const CHI3_95: f64 = 2.795_483_482;

#[test]
fn white_noise_indices_follow_from_its_variance() {
    // Independent N(0, σ²) per axis and sample. Window mean: σ/√n. Deviation from the
    // window's own mean: σ √(1 − 1/n). Difference of two window means: σ √(2/n). Of two
    // samples: σ √2. Standard error of a 0.95-quantile over N samples: √(p(1−p)/N) / f(q)
    // with f the density at the quantile: 1.86 σ/√N for |N| (0.95/√N relative to 1.96 σ),
    // 1.74 σ/√N for the norm of three (0.62/√N relative); four of them are allowed.
    let sigma = 0.01;
    let mut rng = SplitMix64(20261126);
    let noise: Vec<[f64; 3]> = (0..1_000_000).map(|_| [0; 3].map(|_| sigma * rng.normal())).collect();
    for (n, sep, stab) in [(20usize, 1usize, 1usize), (50, 5, 10)] {
        let s = fly(Windows { window: n, drift_separation: sep, stability: stab }, noise.len(), |i| noise[i]);
        let rel = |count: u64| 4.0 * 0.95 / (count as f64).sqrt() + (RATIO - 1.0);
        let check = |what: &str, f: AxisFigures, scale: f64| {
            for (axis, got) in [("x", f.x), ("y", f.y), ("z", f.z)] {
                let want = scale * Z_95;
                let got = got.unwrap();
                assert!((got / want - 1.0).abs() < rel(f.samples), "{what} {axis}: {got} vs {want}");
            }
            let (got, want) = (f.total.unwrap(), scale * CHI3_95);
            assert!((got / want - 1.0).abs() < rel(f.samples), "{what} total: {got} vs {want}");
        };
        let nf = n as f64;
        check("APE", s.ape.figures(0.95), sigma);
        check("MPE", s.mpe.figures(0.95), sigma / nf.sqrt());
        check("RPE", s.rpe.figures(0.95), sigma * (1.0 - 1.0 / nf).sqrt());
        check("PDE", s.pde.figures(0.95), sigma * (2.0 / nf).sqrt());
        check("stability", s.stability.figures(0.95), sigma * 2f64.sqrt());
    }
}

/// Nearest-rank p-quantile of `xs` (the definition the streamed bound must not undercut).
fn nearest_rank(mut xs: Vec<f64>, p: f64) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[((p * xs.len() as f64).ceil() as usize).clamp(1, xs.len()) - 1]
}

#[test]
fn a_run_reports_the_indices_of_its_recorded_error() {
    // Paper 000 test 1 (inertial target), every step recorded, indices from 20 s. The APE
    // is checked against the recorded error: the total against the `error_deg` column, the
    // axes against the small-angle error 2 vec(q_t* ⊗ q) of the recorded quaternion and the
    // target quaternion built here from the scenario's Euler angles (nalgebra's own
    // composition, not the simulator's).
    use sim_core::link::in_process::InProcess;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper000/test1.toml");
    let mut sc = sim_core::scenario::Scenario::load(&path).unwrap();
    sc.timing.output_every = 1;
    sc.performance.from_s = 20.0;
    let run = sim_core::runner::run(&sc, &mut InProcess::new(), false).unwrap();
    let p = &run.summary.pointing;
    assert_eq!((p.from_s, p.confidence, p.window_s, p.stability_window_s), (20.0, 0.95, 10.0, 1.0));
    let ts = &run.series;
    let t = ts.col("t_s").unwrap();
    let after: Vec<usize> = (0..t.len()).filter(|&i| t[i] >= 20.0).collect();
    assert_eq!(p.ape_deg.samples, after.len() as u64);
    let err = ts.col("error_deg").unwrap();
    let exact = nearest_rank(after.iter().map(|&i| err[i]).collect(), 0.95);
    let got = p.ape_deg.total.unwrap();
    assert!(got >= exact && got <= exact * RATIO, "APE total {got} vs recorded {exact}");
    let [r, pi, y] = sc.target.as_ref().unwrap().euler_deg.unwrap().map(f64::to_radians);
    let q_t = nalgebra::UnitQuaternion::from_euler_angles(r, pi, y);
    let q = ["q_x", "q_y", "q_z", "q_w"].map(|c| ts.col(c).unwrap());
    for (axis, got) in [p.ape_deg.x, p.ape_deg.y, p.ape_deg.z].into_iter().enumerate() {
        let e_axis: Vec<f64> = after
            .iter()
            .map(|&i| {
                let qi = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    q[3][i], q[0][i], q[1][i], q[2][i],
                ));
                let e = q_t.inverse() * qi;
                let s = if e.w < 0.0 { -2.0 } else { 2.0 };
                (s * e.imag()[axis]).to_degrees()
            })
            .collect();
        let exact = nearest_rank(e_axis.iter().map(|x| x.abs()).collect(), 0.95);
        let got = got.unwrap();
        // small-angle: 2 sin(θ/2) against θ, 1e-6 relative at these errors
        assert!(got >= exact * (1.0 - 1e-6) && got <= exact * RATIO * (1.0 + 1e-6), "axis {axis}: {got} vs {exact}");
    }
}
