//! End to end (simulator sensor clocks → link protocol 13 → flight MEKF with its state
//! history): a star tracker that is late or slower than the control loop during a 1°/s
//! eigen-axis slew. The inertial hold of `scenarios/estimation/mekf-hold.toml` retargeted
//! by 150° (the law's 1°/s slew-rate limit), the filter on gyro + tracker only, the gyro's
//! noise exactly the filter's model (angle and bias random walk; no bias instability),
//! several sensor seeds.
//!
//! Asserted (the proof): with the tracker 0.2 s late the attitude-estimation error
//! over the slew is within 10 % of the on-time run's, and the mean NEES is in its χ² band
//! for every timing below — late by 0–0.3 s, not a multiple of the control period, and a
//! tracker at 3 Hz against a 2 Hz control loop.

use acs_tests::{run_in_process, scenario};
use sim_core::recorder::columns::Col;
use sim_core::scenario::Scenario;

const SEEDS: u64 = 8;

/// The slew scenario with the tracker at `tracker_hz`, `latency_s` late, control at
/// `control_hz`, sensor seed `seed`.
fn slew(tracker_hz: f64, latency_s: f64, control_hz: f64, seed: u64, arw: f64) -> Scenario {
    let mut sc = scenario("estimation/mekf-hold.toml");
    sc.duration_s = 400.0;
    sc.timing.control_rate_hz = control_hz;
    // Sensor sample times are quantised to the substep: 1/32 s at 4 Hz.
    sc.timing.dynamics_substeps = (32.0 / control_hz).round() as u32;
    sc.timing.output_every = 1;
    sc.target.as_mut().unwrap().euler_deg = Some([30.0, -20.0, 270.0]);
    sc.sensors.seed = seed;
    let g = sc.sensors.gyro.as_mut().unwrap();
    g.bias_instability_rad_s = 0.0;
    g.arw_rad_sqrt_s = arw;
    let t = sc.sensors.star_tracker.as_mut().unwrap();
    t.timing.rate_hz = Some(tracker_hz);
    t.timing.latency_s = latency_s;
    let e = sc.estimation.as_mut().unwrap();
    (e.magnetometer_sigma_deg, e.css_sigma_deg, e.sun_sensor_sigma_deg) = (None, None, None);
    e.gyro_arw_rad_sqrt_s = arw;
    sc
}

/// Over the steps where the body turns faster than 0.5°/s (the slew), all seeds: mean
/// NEES, RMS attitude-estimation error and RMS of the filter's own σ (deg), steps, and the
/// samples fused late per run.
struct OverTheSlew {
    nees: f64,
    rms_deg: f64,
    sigma_deg: f64,
    steps: usize,
    fused_late: f64,
}

fn over_the_slew(tracker_hz: f64, latency_s: f64, control_hz: f64, arw: f64) -> OverTheSlew {
    let (mut nees, mut err2, mut sig2, mut n, mut late) = (0.0, 0.0, 0.0, 0usize, 0.0);
    for seed in 1..=SEEDS {
        let r = run_in_process(&slew(tracker_hz, latency_s, control_hz, seed, arw));
        let ts = &r.series;
        let c = |n: Col| ts.fixed(n).unwrap().to_vec();
        let (wx, wy, wz) = (c(Col::RateX), c(Col::RateY), c(Col::RateZ));
        let col = |n: &str| ts.col(n).unwrap_or_else(|| panic!("column {n}")).to_vec();
        let (e, x, sg) = (col("est_error_deg"), col("est_nees"), col("est_sigma_deg"));
        for i in 0..wx.len() {
            let w_deg_s = (wx[i].powi(2) + wy[i].powi(2) + wz[i].powi(2)).sqrt().to_degrees();
            if w_deg_s > 0.5 && x[i].is_finite() {
                nees += x[i];
                err2 += e[i] * e[i];
                sig2 += sg[i] * sg[i];
                n += 1;
            }
        }
        late += r.summary.sample_fusion.map_or(0.0, |f| f64::from(f.fused_late));
    }
    let k = n as f64;
    OverTheSlew {
        nees: nees / k,
        rms_deg: (err2 / k).sqrt(),
        sigma_deg: (sig2 / k).sqrt(),
        steps: n,
        fused_late: late / SEEDS as f64,
    }
}

/// χ² 95 % band of a mean of 6-dof NEES over `SEEDS` runs at one time (the time average
/// over the slew is tighter, so this band is the conservative one).
fn band() -> (f64, f64) {
    let nu = 6.0 * SEEDS as f64;
    let q = |z: f64| nu * (1.0 - 2.0 / (9.0 * nu) + z * (2.0 / (9.0 * nu)).sqrt()).powi(3) / SEEDS as f64;
    (q(-1.96), q(1.96))
}

/// The gyro grades flown: the scenario's MEMS gyro (ARW 1e-4 rad/√s) and a tactical-grade
/// one (1e-5 rad/√s).
const MEMS_ARW: f64 = 1.0e-4;
const TACTICAL_ARW: f64 = 1.0e-5;

#[test]
fn a_late_tracker_during_a_slew_is_fused_at_its_time() {
    let (lo, hi) = band();
    for arw in [MEMS_ARW, TACTICAL_ARW] {
        let on_time = over_the_slew(2.0, 0.0, 4.0, arw);
        eprintln!(
            "ARW {arw:e}: on time: {} slew steps, NEES {:.2}, error RMS {:.5} deg, σ RMS {:.5} deg (band [{lo:.2}, {hi:.2}])",
            on_time.steps, on_time.nees, on_time.rms_deg, on_time.sigma_deg
        );
        assert!(on_time.steps > 1000, "{}", on_time.steps);
        assert!((lo..=hi).contains(&on_time.nees), "{}", on_time.nees);
        for (tracker_hz, latency_s, control_hz) in
            [(2.0, 0.2, 4.0), (2.0, 0.13, 4.0), (2.0, 0.3, 4.0), (3.0, 0.13, 2.0)]
        {
            let r = over_the_slew(tracker_hz, latency_s, control_hz, arw);
            let (err_ratio, sigma_ratio) = (r.rms_deg / on_time.rms_deg, r.sigma_deg / on_time.sigma_deg);
            eprintln!(
                "  tracker {tracker_hz} Hz, {latency_s} s late, control {control_hz} Hz: NEES {:.2}, error RMS {:.5} deg \
                 ({:+.1} % vs on time; the filter's σ {:+.1} %), {:.0} samples fused late per run",
                r.nees,
                r.rms_deg,
                100.0 * (err_ratio - 1.0),
                100.0 * (sigma_ratio - 1.0),
                r.fused_late
            );
            assert!((lo..=hi).contains(&r.nees), "NEES {} outside [{lo}, {hi}]", r.nees);
            assert!(r.fused_late > 100.0, "late samples went through the history: {}", r.fused_late);
            // What latency costs is the gyro's drift over it, which the filter predicts:
            // the actual error grows as its own σ does (within 5 %).
            assert!((err_ratio / sigma_ratio - 1.0).abs() <= 0.05, "{err_ratio} vs {sigma_ratio}");
            if (tracker_hz, latency_s, control_hz, arw) == (2.0, 0.2, 4.0, TACTICAL_ARW) {
                assert!(
                    (err_ratio - 1.0).abs() <= 0.10,
                    "0.2 s late: RMS {} vs {} on time",
                    r.rms_deg,
                    on_time.rms_deg
                );
            }
        }
    }
}
