// Tests compare against nalgebra f64 quaternions and norms (allowed in tests).
#![allow(clippy::disallowed_methods)]
//! The flight estimation stage (`Determination`, fed wire frames through
//! `validation::sensor_samples`) with time-tagged samples: a star tracker slower than the
//! control loop and late by latencies that are not multiples of the control period, in
//! hold and during slews, against an independent truth simulated here in f64 (the exact
//! rotation at a constant rate, a gyro integrated exactly with its noise and bias walk).
//!
//! Consistency: over `RUNS` Monte Carlo runs the mean NEES of the 6-state error stays in
//! its χ² 95 % band and the filter's √tr P_θθ is within 10 % of the actual RMS attitude
//! error, for tracker rates 0.1×–1× the control rate, latencies 0–0.3 s and body rates
//! 0–3°/s. The same runs with the sample times hidden (every sample tagged with the frame
//! time, what protocol ≤ 12 did) are shown inconsistent, so the check has power.
use acs_flight::estimation::determination::Determination;
use acs_flight::fsw::report::estimate_telemetry;
use acs_flight::link::{EstimateTelemetry, SensorFrame, estimate_flags, valid};
use acs_flight::params::{AttitudeSource, EstimationParams};
use acs_flight::validation::sensor_samples;
use acs_test_support::rng::SplitMix64;
use nalgebra::{Matrix6, Quaternion, UnitQuaternion, Vector3, Vector6};

/// Control period, s (5 Hz).
const DT_S: f64 = 0.2;
/// Gyro noise: angle random walk (rad/√s) and bias random walk (rad/s/√s), exactly what
/// the filter is told.
const ARW: f64 = 5.0e-5;
const RRW: f64 = 1.0e-6;
/// Tracker 1σ per axis, rad (10″).
const TRACKER_SIGMA: f64 = 5.0e-5;
/// Initial attitude / bias σ the filter starts with; the true bias is drawn from the
/// latter (rad, rad/s).
const SIGMA_ATT0: f64 = 0.03;
const SIGMA_BIAS0: f64 = 2.0e-4;
const RUNS: usize = 24;
const STEPS: usize = 600;
/// Steps left out of the averages (the start-up transient).
const WARMUP: usize = 150;

#[derive(Clone, Copy, Debug)]
struct Case {
    tracker_hz: f64,
    latency_s: f64,
    rate_deg_s: f64,
    initial_attitude_sigma: f64,
}

const fn case(tracker_hz: f64, latency_s: f64, rate_deg_s: f64) -> Case {
    Case { tracker_hz, latency_s, rate_deg_s, initial_attitude_sigma: SIGMA_ATT0 }
}

/// The flight parameters the cases fly: the filter starts with `initial_attitude_sigma`
/// (SIGMA_ATT0 covers a start on a sample up to 0.3 s old during a 3°/s slew).
fn params(case: &Case) -> EstimationParams {
    EstimationParams {
        source: AttitudeSource::Mekf,
        gyro_arw_rad_sqrt_s: ARW as f32,
        gyro_rrw_rad_s_sqrt_s: RRW as f32,
        initial_attitude_sigma_rad: case.initial_attitude_sigma as f32,
        initial_bias_sigma_rad_s: SIGMA_BIAS0 as f32,
        tracker_sigma_cross_rad: TRACKER_SIGMA as f32,
        tracker_sigma_about_rad: TRACKER_SIGMA as f32,
        ..EstimationParams::SENSOR
    }
}

fn us(t_s: f64) -> u64 {
    (t_s * 1e6).round() as u64
}

/// The truth of one run: constant body rate `w` about a fixed axis from `q0`.
struct Truth {
    q0: UnitQuaternion<f64>,
    w: Vector3<f64>,
}

impl Truth {
    fn at(&self, t_s: f64) -> UnitQuaternion<f64> {
        self.q0 * UnitQuaternion::from_scaled_axis(self.w * t_s)
    }
}

/// One tracker sample: taken at `t_s`, delivered from `t_s + latency`.
#[derive(Clone, Copy)]
struct TrackerSample {
    t_s: f64,
    q: UnitQuaternion<f64>,
}

/// Per-step error state and covariance of one run (after the warm-up), and the
/// estimator's fusion counters at the end.
struct RunResult {
    nees: Vec<f64>,
    err2: Vec<f64>,
    trace_p: Vec<f64>,
    telemetry: EstimateTelemetry,
    /// Distinct tracker samples delivered.
    delivered: u32,
}

fn covariance(upper: &[f32; 21]) -> Matrix6<f64> {
    let mut p = Matrix6::zeros();
    let mut k = 0;
    for i in 0..6 {
        for j in i..6 {
            p[(i, j)] = f64::from(upper[k]);
            p[(j, i)] = f64::from(upper[k]);
            k += 1;
        }
    }
    p
}

/// `[δθ; δb]` with `q_true = q_est ⊗ δq(δθ)` (the flight MEKF's convention).
fn error_state(q_true: &UnitQuaternion<f64>, b_true: &Vector3<f64>, t: &EstimateTelemetry) -> Vector6<f64> {
    let [x, y, z, w] = t.q_est_xyzw.map(f64::from);
    let q_est = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    let mut e = (q_est.inverse() * q_true).into_inner();
    if e.w < 0.0 {
        e = -e;
    }
    let dth = e.imag() * 2.0;
    let db = b_true - Vector3::from(t.bias_est_rad_s.map(f64::from));
    Vector6::new(dth.x, dth.y, dth.z, db.x, db.y, db.z)
}

/// The frame of step `k`: the gyro increment over the step (exact integral of the true
/// rate + bias, plus its angle random walk) and the newest tracker sample delivered by
/// now, tagged with its own time — or with the frame's time when `hide_times`.
fn frame(
    k: usize,
    gyro_inc: &Vector3<f64>,
    w_meas: &Vector3<f64>,
    tracker: Option<&TrackerSample>,
    hide_times: bool,
) -> SensorFrame {
    let t_us = us(k as f64 * DT_S);
    let mut f = SensorFrame::empty(k as u32, t_us);
    f.rate_rad_s = w_meas.map(|x| x as f32).into();
    f.gyro_angle_rad = gyro_inc.map(|x| x as f32).into();
    f.gyro_interval_us = us(DT_S) as u32;
    f.valid = valid::RATE;
    if let Some(s) = tracker {
        let c = s.q.coords;
        f.q_ib_xyzw = [c.x as f32, c.y as f32, c.z as f32, c.w as f32];
        f.sampled_at.star_tracker_us = if hide_times { t_us } else { us(s.t_s) };
        f.valid |= valid::ATTITUDE;
    }
    f
}

/// One Monte Carlo run of `case`.
fn run(case: &Case, seed: u64, hide_times: bool) -> RunResult {
    run_observed(case, seed, hide_times, &mut |_, _, _| {})
}

/// [`run`], showing `observe` every frame, the tracker samples taken up to it and the
/// telemetry it produced.
fn run_observed(
    case: &Case,
    seed: u64,
    hide_times: bool,
    observe: &mut dyn FnMut(&SensorFrame, &[TrackerSample], &EstimateTelemetry),
) -> RunResult {
    let mut rng = SplitMix64(seed);
    let axis = rng.unit();
    let truth = Truth { q0: UnitQuaternion::from_quaternion(rng.quat()), w: axis * case.rate_deg_s.to_radians() };
    let mut bias = rng.vec() * SIGMA_BIAS0;
    let mut est = Determination::new(&params(case)).unwrap();
    let period = 1.0 / case.tracker_hz;
    // Samples taken but not yet delivered, oldest first; the newest delivered one.
    let mut pending: Vec<TrackerSample> = Vec::new();
    let mut next_sample_s = rng.uniform() * period;
    let mut delivered: Option<TrackerSample> = None;
    let mut taken: Vec<TrackerSample> = Vec::new();
    let mut out = RunResult {
        nees: vec![],
        err2: vec![],
        trace_p: vec![],
        telemetry: EstimateTelemetry::default(),
        delivered: 0,
    };
    let mut inc = Vector3::zeros();
    for k in 0..STEPS {
        let t = k as f64 * DT_S;
        // Tracker exposures up to now (their truth at their own time).
        while next_sample_s <= t + 1e-9 {
            let noise = UnitQuaternion::from_scaled_axis(rng.vec() * TRACKER_SIGMA);
            pending.push(TrackerSample { t_s: next_sample_s, q: truth.at(next_sample_s) * noise });
            taken.push(TrackerSample { t_s: next_sample_s, q: truth.at(next_sample_s) * noise });
            next_sample_s += period;
        }
        while pending.first().is_some_and(|s| s.t_s + case.latency_s <= t + 1e-9) {
            delivered = Some(pending.remove(0));
            out.delivered += 1;
        }
        let w_meas = truth.w + bias + rng.vec() * (ARW / DT_S.sqrt());
        let f = frame(k, &inc, &w_meas, delivered.as_ref(), hide_times);
        let t_tel = estimate_telemetry(&est.step(&sensor_samples(&f)).status);
        observe(&f, &taken, &t_tel);
        if k >= WARMUP && t_tel.flags & estimate_flags::MEKF != 0 {
            let x = error_state(&truth.at(t), &bias, &t_tel);
            let p = covariance(&t_tel.covariance_upper);
            out.nees.push(x.dot(&p.cholesky().expect("P positive definite").solve(&x)));
            out.err2.push(x.fixed_rows::<3>(0).norm_squared());
            out.trace_p.push(p[(0, 0)] + p[(1, 1)] + p[(2, 2)]);
        }
        out.telemetry = t_tel;
        // The gyro over the next step: ∫(ω + b) dt exactly (ω constant, b at the step's
        // start), its angle random walk, then the bias walks.
        inc = (truth.w + bias) * DT_S + rng.vec() * (ARW * DT_S.sqrt());
        bias += rng.vec() * (RRW * DT_S.sqrt());
    }
    out
}

/// Mean NEES, √(mean tr P_θθ) / RMS error, and the χ² 95 % band of the mean NEES over the
/// runs at one time (6 × RUNS degrees of freedom; the time average is tighter, so this
/// band is the conservative one).
struct Figures {
    nees: f64,
    sigma_over_rms: f64,
    band: (f64, f64),
    fused_late: u32,
}

fn figures(case: &Case, hide_times: bool, runs: usize) -> Figures {
    let results: Vec<RunResult> = (0..runs).map(|r| run(case, 1000 + r as u64, hide_times)).collect();
    let n: usize = results.iter().map(|r| r.nees.len()).sum();
    let nees = results.iter().flat_map(|r| &r.nees).sum::<f64>() / n as f64;
    let rms = (results.iter().flat_map(|r| &r.err2).sum::<f64>() / n as f64).sqrt();
    let sigma = (results.iter().flat_map(|r| &r.trace_p).sum::<f64>() / n as f64).sqrt();
    // Wilson–Hilferty: χ²(ν) quantiles ≈ ν (1 − 2/(9ν) ± z √(2/(9ν)))³, z = 1.96.
    let nu = 6.0 * runs as f64;
    let q = |z: f64| nu * (1.0 - 2.0 / (9.0 * nu) + z * (2.0 / (9.0 * nu)).sqrt()).powi(3) / runs as f64;
    Figures {
        nees,
        sigma_over_rms: sigma / rms,
        band: (q(-1.96), q(1.96)),
        fused_late: results.iter().map(|r| r.telemetry.fusion.fused_late).sum(),
    }
}

#[test]
fn late_and_slow_tracker_samples_keep_the_filter_consistent() {
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for rate_deg_s in [0.0, 1.0, 3.0] {
        for tracker_hz in [5.0, 2.5, 1.0, 0.5] {
            for latency_s in [0.0, 0.13, 0.23, 0.3] {
                let case = case(tracker_hz, latency_s, rate_deg_s);
                let f = figures(&case, false, RUNS);
                let ok = (f.band.0..=f.band.1).contains(&f.nees) && (f.sigma_over_rms - 1.0).abs() <= 0.10;
                rows.push(format!(
                    "| {rate_deg_s} | {tracker_hz} | {latency_s} | {:.2} | [{:.2}, {:.2}] | {:.3} | {} |{}",
                    f.nees,
                    f.band.0,
                    f.band.1,
                    f.sigma_over_rms,
                    f.fused_late,
                    if ok { "" } else { " FAIL" }
                ));
                if !ok {
                    failures.push(case);
                }
            }
        }
    }
    println!("| rate °/s | tracker Hz | latency s | mean NEES | χ² 95 % band | √tr P / RMS | fused late |");
    println!("|---|---|---|---|---|---|---|");
    for r in &rows {
        println!("{r}");
    }
    assert!(failures.is_empty(), "inconsistent: {failures:?}");
}

#[test]
fn samples_older_than_the_history_are_refused_counted_and_the_filter_stays_consistent() {
    // Every tracker sample 8 s late: beyond the latency horizon (`max_sample_latency_s`,
    // 0.5 s) and the history (32 nodes of 0.2 s steps plus samples, < 6.4 s). The first
    // one starts the filter (at rest its age does not matter); each later one is refused
    // as too old, once; the filter runs on the gyro alone and says so (its
    // covariance grows with the truth's error). It starts with the σ its starting sample
    // has, so that its claim can be checked.
    let case = Case { initial_attitude_sigma: TRACKER_SIGMA, ..case(1.0, 8.0, 0.0) };
    for r in 0..RUNS {
        let res = run(&case, 1000 + r as u64, false);
        let f = res.telemetry.fusion;
        assert_eq!(f.too_old, res.delivered - 1, "run {r}: {f:?}");
        // The first sample started the filter (now, its age covered by the initial σ).
        assert_eq!((f.fused_now, f.fused_late, f.out_of_order, f.from_the_future, f.bad_input), (0, 0, 0, 0, 0));
    }
    // An unobserved random walk is strongly correlated in time: 4× the runs for the RMS.
    let f = figures(&case, false, 4 * RUNS);
    println!("8 s late tracker: mean NEES {:.2} (band {:.2?}), √tr P / RMS {:.3}", f.nees, f.band, f.sigma_over_rms);
    assert!((f.band.0..=f.band.1).contains(&f.nees), "NEES {} outside {:?}", f.nees, f.band);
    assert!((f.sigma_over_rms - 1.0).abs() <= 0.10, "{}", f.sigma_over_rms);
}

#[test]
fn hiding_the_sample_times_is_inconsistent() {
    // What protocol ≤ 12 did: every sample as if taken at the frame's time. A held
    // sample is then new every frame (fused again) and a late one is fused as current.
    for case in [case(1.0, 0.0, 0.0), case(5.0, 0.23, 1.0)] {
        let f = figures(&case, true, RUNS);
        println!("{case:?}: sample times hidden: mean NEES {:.1}, band {:.2?}", f.nees, f.band);
        assert!(f.nees > f.band.1, "{case:?}: NEES {} not outside the band {:?}", f.nees, f.band);
    }
}

/// The independent f64 reference MEKF (`acs_test_support::mekf_ref`, C&J's textbook
/// filter) fed the same gyro increments and tracker samples strictly in time order: the
/// flight filter, which receives them late and fuses them through its history, agrees at
/// every frame by which every sample taken has arrived (≪ its own 1σ).
#[test]
fn late_fusion_agrees_with_the_f64_reference_fed_in_time_order() {
    use acs_test_support::mekf_ref::{MekfRef, MekfRefConfig};
    use nalgebra::Matrix3;
    let case = case(1.0, 0.23, 1.0);
    let mut frames = Vec::new();
    let mut samples = Vec::new();
    let mut telemetry = Vec::new();
    run_observed(&case, 77, false, &mut |f, taken, t| {
        frames.push(*f);
        telemetry.push(*t);
        samples = taken.to_vec();
    });
    let k0 = telemetry.iter().position(|t| t.flags & estimate_flags::MEKF != 0).unwrap();
    let [x, y, z, w] = frames[k0].q_ib_xyzw.map(f64::from);
    let init_us = frames[k0].sampled_at.star_tracker_us;
    let cfg = MekfRefConfig {
        gyro_arw_rad_sqrt_s: ARW,
        gyro_rrw_rad_s_sqrt_s: RRW,
        gate_attitude: 16.266,
        gate_vector: 13.816,
    };
    let p0 = Matrix6::from_diagonal(&Vector6::new(
        SIGMA_ATT0.powi(2),
        SIGMA_ATT0.powi(2),
        SIGMA_ATT0.powi(2),
        SIGMA_BIAS0.powi(2),
        SIGMA_BIAS0.powi(2),
        SIGMA_BIAS0.powi(2),
    ));
    let mut r = MekfRef::new(cfg, &Quaternion::new(w, x, y, z), Vector3::zeros(), p0);
    let r_meas = Matrix3::identity() * TRACKER_SIGMA.powi(2);
    // The flight refuses samples taken before its start (older than its history).
    let later: Vec<&TrackerSample> = samples.iter().filter(|s| us(s.t_s) > frames[k0].time_us).collect();
    assert_ne!(later.first().map(|s| us(s.t_s)), Some(init_us));
    let (mut compared, mut worst, mut rejected) = (0, 0.0f64, 0u32);
    for k in k0 + 1..frames.len() {
        let (t0, t1) = (frames[k - 1].time_us, frames[k].time_us);
        let interval_s = f64::from(frames[k].gyro_interval_us as f32 * 1.0e-6);
        let rate = Vector3::from(frames[k].gyro_angle_rad.map(f64::from)) / interval_s;
        let mut t = t0;
        for s in later.iter().filter(|s| (t0 + 1..=t1).contains(&us(s.t_s))) {
            r.propagate(&rate, (us(s.t_s) - t) as f64 * 1e-6);
            // A gated sample changes nothing in either filter.
            if let Err(nis) = r.update_attitude(&s.q.into_inner(), &r_meas) {
                rejected += 1;
                println!("reference gated the sample at {} s: NIS {nis:.1}", s.t_s);
            }
            t = us(s.t_s);
        }
        r.propagate(&rate, (t1 - t) as f64 * 1e-6);
        // Compare where every sample taken by now has arrived.
        let in_flight = later.iter().any(|s| us(s.t_s) <= t1 && us(s.t_s + case.latency_s) > t1);
        if in_flight {
            continue;
        }
        let tel = &telemetry[k];
        let [x, y, z, w] = tel.q_est_xyzw.map(f64::from);
        let flight = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let reference = UnitQuaternion::from_quaternion(r.attitude());
        let p = covariance(&tel.covariance_upper);
        let sigma = (p[(0, 0)].max(p[(1, 1)]).max(p[(2, 2)])).sqrt();
        worst = worst.max(flight.angle_to(&reference) / sigma);
        compared += 1;
    }
    println!("f32 flight vs f64 reference over {compared} frames: worst |Δθ| = {worst:.4} σ");
    assert_eq!(rejected, telemetry.last().unwrap().rejected, "the same samples gated");
    assert!(compared > 400, "{compared}");
    assert!(worst < 0.05, "{worst}");
}
