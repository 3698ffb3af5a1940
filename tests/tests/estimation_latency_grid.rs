// Tests compare against nalgebra f64 quaternions and norms (allowed in tests).
#![allow(clippy::disallowed_methods)]
//! The estimator latency grid (issue 37): `scenarios/estimation/mekf-hold.toml` (MEKF on
//! a MEMS gyro, a 2 Hz star tracker, six coarse sun sensors and a magnetometer; 4 Hz
//! control) with the gyro, the tracker and the Sun/field sensors (CSS and magnetometer
//! together) each late by 0, 100 µs, 10 ms or 0.2 s, in all 64 combinations, at the
//! scenario's own 4 Hz control (every latency below the 0.25 s period reaches the next
//! frame: 100 µs, 10 ms and 0.2 s are one class there) and at 20 Hz (2 substeps: 0.2 s is
//! four frames, so the tracker's samples are replayed over 4 nodes and a 0.2 s gyro keeps
//! samples waiting over 4 frames). For every combination:
//!
//! - every sample is fused: no refusal of any kind (too old, from the future, out of
//!   order, bad input, dropped while waiting) but of samples taken before the filter
//!   started (too old for it, counted; none after the frame that delivered the last of
//!   them), every tracker sample delivered after the
//!   filter's start fused at its own time (at most one per sensor still waiting at the
//!   end), the coarse vectors fused as often as on time (±2: their 5 s decorrelation
//!   interval picks the samples);
//! - the filter is consistent: the mean NEES over `SEEDS` runs (after `WARMUP_S`) in the
//!   χ² 95 % band of a `SEEDS`-run mean (6 × `SEEDS` dof; the time average is tighter, so
//!   this band is the conservative one);
//! - it equals the f64 reference filter (`acs_test_support::mekf_ref`, written apart from
//!   the flight MEKF) fed the same gyro steps and samples strictly in time order: attitude
//!   within `TOL_SIGMA` of the flight filter's own 1σ and bias within `TOL_SIGMA` of its
//!   bias σ, at every frame by which every sample taken up to the filter's time has
//!   arrived. The samples and rates are read from the flight history's nodes (a twin of
//!   the flight estimator driven by the same frames, checked bit for bit against the
//!   telemetry of the flight code the simulator flew), and each sample's time and value
//!   checked against the frame that delivered it.
use acs_flight::estimation::determination::Determination;
use acs_flight::estimation::history::Measurement;
use acs_flight::estimation::mekf::{CHI2_2DOF_999, CHI2_3DOF_999, Mekf};
use acs_flight::fsw::report::estimate_telemetry;
use acs_flight::link::{EstimateTelemetry, FusionCounters, SensorFrame, valid};
use acs_flight::math::Vec3;
use acs_flight::validation::sensor_samples;
use acs_test_support::mekf_ref::{MekfRef, MekfRefConfig};
use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3};
use sim_core::link::in_process::InProcess;
use sim_core::link::tap::{Tap, Tapped};
use sim_core::runner;
use sim_core::scenario::Scenario;

const LATENCIES_S: [f64; 4] = [0.0, 1.0e-4, 0.01, 0.2];
const SEEDS: u64 = 4;
const WARMUP_S: f64 = 60.0;
/// Flight (f32, out of order) against the f64 reference (in time order), in the flight
/// filter's own σ.
const TOL_SIGMA: f64 = 0.05;

/// Control rate, Hz, and run length, s, of a grid.
#[derive(Clone, Copy)]
struct Grid {
    control_hz: f64,
    duration_s: f64,
}

fn grid_scenario(grid: Grid, (gyro_s, tracker_s, vectors_s): (f64, f64, f64), seed: u64) -> Scenario {
    let mut sc = acs_tests::scenario("estimation/mekf-hold.toml");
    sc.duration_s = grid.duration_s;
    sc.timing.control_rate_hz = grid.control_hz;
    sc.timing.output_every = 1;
    sc.sensors.seed = seed;
    sc.sensors.gyro.as_mut().unwrap().timing.latency_s = gyro_s;
    sc.sensors.star_tracker.as_mut().unwrap().timing.latency_s = tracker_s;
    sc.sensors.magnetometer.as_mut().unwrap().timing.latency_s = vectors_s;
    sc.sensors.css.as_mut().unwrap().timing.latency_s = vectors_s;
    sc.validate().unwrap_or_else(|e| panic!("{gyro_s}/{tracker_s}/{vectors_s}: {e:#}"));
    sc
}

/// Mean NEES after the warm-up of one run, with its step count.
fn nees_sum(r: &runner::RunResult) -> (f64, usize) {
    let t = r.series.col("t_s").unwrap();
    let x = r.series.col("est_nees").unwrap();
    let v: Vec<f64> = t.iter().zip(x).filter(|(t, x)| **t >= WARMUP_S && x.is_finite()).map(|(_, x)| *x).collect();
    (v.iter().sum(), v.len())
}

/// One entry of the time-ordered tape the flight history ran: a node's time, the rate of
/// the gyro step ending there, the sample fused there, and the frame it first appeared in.
#[derive(Clone, Copy, Debug)]
struct Entry {
    time_us: u64,
    rate: Vec3,
    m: Option<Measurement>,
    first_seen: usize,
}

/// What a traced run gives: the tape, the filter's state at the start, and per frame the
/// flight filter's time and state, with the frames and the flight's telemetry.
struct Traced {
    tape: Vec<Entry>,
    start: Option<Mekf>,
    at_frame: Vec<Option<(u64, Mekf)>>,
    frames: Vec<SensorFrame>,
    telemetry: Vec<EstimateTelemetry>,
}

impl Traced {
    /// Add the history's nodes not seen yet, each after the tape's entries at or before
    /// its time (the history's own insertion rule).
    fn scan(&mut self, d: &Determination, k: usize) {
        let Some(h) = d.history() else {
            self.at_frame.push(None);
            return;
        };
        for n in h.nodes() {
            if self.start.is_none() {
                self.start = Some(*n.filter);
            }
            let known =
                self.tape.iter().rev().take_while(|e| e.time_us >= n.time_us).any(|e| {
                    e.time_us == n.time_us && e.m == n.measurement && (e.m.is_some() || e.rate == n.rate_rad_s)
                });
            if !known {
                let at = self.tape.iter().rposition(|e| e.time_us <= n.time_us).map_or(0, |i| i + 1);
                let e = Entry { time_us: n.time_us, rate: n.rate_rad_s, m: n.measurement, first_seen: k };
                self.tape.insert(at, e);
            }
        }
        self.at_frame.push(Some((h.now_us(), *h.filter())));
    }
}

/// Flies `sc` in process behind a tap; a twin of the flight estimator steps on the same
/// frames (and must answer what the flight code answered, bit for bit).
fn traced(sc: &Scenario) -> (Traced, runner::RunResult) {
    let css = sc.sensors.css.as_ref().map(|c| &c.normals_body[..]);
    let params = sc.estimation.as_ref().unwrap().params(css).unwrap();
    let mut twin = Determination::new(&params).unwrap();
    let mut tr = Traced { tape: vec![], start: None, at_frame: vec![], frames: vec![], telemetry: vec![] };
    let r = {
        let mut link = Tap::new(InProcess::new(), |t: Tapped<'_>| {
            if let Tapped::Step(f, reply) = t {
                let mine = estimate_telemetry(&twin.step(&sensor_samples(f)).status);
                assert_eq!(mine, reply.cmd.estimate, "the twin answers as the flight code at frame {}", f.seq);
                let k = tr.frames.len();
                tr.scan(&twin, k);
                tr.frames.push(*f);
                tr.telemetry.push(mine);
            }
        });
        runner::run(sc, &mut link, false).unwrap()
    };
    (tr, r)
}

fn to_f64(q: &acs_flight::math::Quat) -> Quaternion<f64> {
    Quaternion::new(f64::from(q.w), f64::from(q.i), f64::from(q.j), f64::from(q.k))
}

fn v64(v: &Vec3) -> Vector3<f64> {
    v.map(f64::from)
}

/// The reference fed the tape in time order; the worst flight − reference difference in
/// σ (attitude, bias) over the frames where every sample up to the filter's time had
/// arrived, and how many frames that was.
fn against_reference(tr: &Traced, arw: f64, rrw: f64) -> (f64, f64, usize) {
    let m0 = tr.start.unwrap();
    let cfg = MekfRefConfig {
        gyro_arw_rad_sqrt_s: arw,
        gyro_rrw_rad_s_sqrt_s: rrw,
        gate_attitude: f64::from(CHI2_3DOF_999),
        gate_vector: f64::from(CHI2_2DOF_999),
    };
    let p0 = Matrix6::from_fn(|i, j| f64::from(m0.covariance()[(i, j)]));
    let mut r = MekfRef::new(cfg, &to_f64(&m0.attitude()), v64(&m0.bias_rad_s()), p0);
    // Frames in the order of their filter time (it never goes back).
    let mut frames: Vec<(usize, u64, Mekf)> =
        tr.at_frame.iter().enumerate().filter_map(|(k, x)| x.map(|(t, m)| (k, t, m))).collect();
    frames.sort_by_key(|(k, t, _)| (*t, *k));
    let (mut worst_att, mut worst_bias, mut compared) = (0.0f64, 0.0f64, 0usize);
    let mut next = 0usize;
    let mut last_seen = 0usize;
    let mut t_prev = tr.tape[0].time_us;
    for (i, e) in tr.tape.iter().enumerate() {
        if i > 0 {
            let dt = (e.time_us - t_prev) as f64 * 1e-6;
            if dt > 0.0 {
                r.propagate(&v64(&e.rate), dt);
            }
            match e.m {
                Some(Measurement::Attitude { q_meas, r_rad2 }) => {
                    let _ = r.update_attitude(&to_f64(&q_meas), &Matrix3::from_fn(|a, b| f64::from(r_rad2[(a, b)])));
                }
                Some(Measurement::Vector { body, reference, sigma_rad }) => {
                    let _ = r.update_vector(&v64(&body), &v64(&reference), f64::from(sigma_rad));
                }
                None => {}
            }
            t_prev = e.time_us;
        }
        last_seen = last_seen.max(e.first_seen);
        // The reference is at e.time_us once the tape's entries at that time are applied.
        if tr.tape.get(i + 1).is_some_and(|n| n.time_us == e.time_us) {
            continue;
        }
        while let Some((k, t, m)) = frames.get(next).copied().filter(|(_, t, _)| *t <= e.time_us) {
            next += 1;
            if t != e.time_us || last_seen > k {
                continue;
            }
            let p = m.covariance();
            let s_att = f64::from(p[(0, 0)].max(p[(1, 1)]).max(p[(2, 2)])).sqrt();
            let s_bias = f64::from(p[(3, 3)].max(p[(4, 4)]).max(p[(5, 5)])).sqrt();
            let qf = UnitQuaternion::from_quaternion(to_f64(&m.attitude()));
            let qr = UnitQuaternion::from_quaternion(r.attitude());
            worst_att = worst_att.max(qf.angle_to(&qr) / s_att);
            worst_bias = worst_bias.max((v64(&m.bias_rad_s()) - r.bias_rad_s()).norm() / s_bias);
            compared += 1;
        }
    }
    (worst_att, worst_bias, compared)
}

/// Distinct sample times a sensor delivered in the frames from `k0` on.
fn delivered(frames: &[SensorFrame], k0: usize, bit: u16, at: fn(&SensorFrame) -> u64) -> Vec<u64> {
    let mut v: Vec<u64> = frames[k0..].iter().filter(|f| f.valid & bit != 0).map(at).collect();
    v.dedup();
    v
}

/// The distinct (sensor, time) samples of the frames taken before `start_us`.
fn pre_start(frames: &[SensorFrame], start_us: u64) -> Vec<(u16, u64)> {
    let mut v: Vec<(u16, u64)> = frames
        .iter()
        .flat_map(|f| {
            [
                (valid::ATTITUDE, f.sampled_at.star_tracker_us),
                (valid::CSS, f.sampled_at.css_us),
                (valid::MAG, f.sampled_at.magnetometer_us),
            ]
            .into_iter()
            .filter(move |(bit, t)| f.valid & bit != 0 && *t < start_us)
        })
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

fn refusals(f: &FusionCounters) -> u32 {
    f.too_old + f.from_the_future + f.out_of_order + f.bad_input + f.dropped_waiting
}

/// The grid at one control rate: its table printed, the combinations that fail and why.
fn grid(grid: Grid) -> Vec<String> {
    let nu = 6.0 * SEEDS as f64;
    // Wilson–Hilferty χ²(ν) quantiles, z = ±1.96, of a SEEDS-run mean.
    let q = |z: f64| nu * (1.0 - 2.0 / (9.0 * nu) + z * (2.0 / (9.0 * nu)).sqrt()).powi(3) / SEEDS as f64;
    let band = (q(-1.96), q(1.96));
    let (arw, rrw) = {
        let e = acs_tests::scenario("estimation/mekf-hold.toml").estimation.unwrap();
        (e.gyro_arw_rad_sqrt_s, e.gyro_rrw_rad_s_sqrt_s)
    };
    let frames = (grid.duration_s * grid.control_hz) as usize;
    println!("control {} Hz, {} s, {SEEDS} seeds; NEES band {band:.2?}", grid.control_hz, grid.duration_s);
    println!(
        "| gyro s | tracker s | Sun/field s | tracker fused / delivered | CSS+mag fused / delivered | waited | late \
         | NEES | vs reference (σ: att, bias; frames) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut failures = Vec::new();
    let mut on_time_vectors = None;
    for &g in &LATENCIES_S {
        for &t in &LATENCIES_S {
            for &v in &LATENCIES_S {
                let why = cell(grid, (g, t, v), band, (arw, rrw), frames, &mut on_time_vectors);
                if !why.is_empty() {
                    failures.push(format!(
                        "{} Hz, gyro {g}, tracker {t}, Sun/field {v}: {}",
                        grid.control_hz,
                        why.join("; ")
                    ));
                }
            }
        }
    }
    failures
}

/// The tracker samples delivered after the filter's start (the start consumes one), and
/// how many of them the history fused; each fused one checked against the frame that
/// delivered it (same time, same attitude within 1e-6 rad).
fn tracker_samples(tr: &Traced, k0: usize, start_us: u64) -> (Vec<u64>, usize) {
    let trk: Vec<u64> = delivered(&tr.frames, k0, valid::ATTITUDE, |f| f.sampled_at.star_tracker_us)
        .into_iter()
        .filter(|&x| x > start_us)
        .collect();
    let tape_trk: Vec<(u64, Measurement)> = tr
        .tape
        .iter()
        .filter_map(|e| e.m.filter(|m| matches!(m, Measurement::Attitude { .. })).map(|m| (e.time_us, m)))
        .filter(|(x, _)| *x > start_us)
        .collect();
    // Each fused tracker sample is the frame's, at the frame's sample time.
    for (time, m) in &tape_trk {
        let fr = tr.frames.iter().find(|fr| fr.sampled_at.star_tracker_us == *time).unwrap();
        let Measurement::Attitude { q_meas, .. } = m else { unreachable!() };
        let qf = UnitQuaternion::from_quaternion(to_f64(q_meas));
        let [x, y, z, w] = fr.q_ib_xyzw.map(f64::from);
        assert!(qf.angle_to(&UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))) < 1e-6);
    }
    (trk, tape_trk.len())
}

/// One combination of the grid; what is wrong with it (empty: nothing).
fn cell(
    grid: Grid,
    (g, t, v): (f64, f64, f64),
    band: (f64, f64),
    (arw, rrw): (f64, f64),
    frames: usize,
    on_time_vectors: &mut Option<usize>,
) -> Vec<String> {
    let (tr, first) = traced(&grid_scenario(grid, (g, t, v), 1));
    let (mut sum, mut n) = nees_sum(&first);
    for seed in 2..=SEEDS {
        let (s, k) = nees_sum(&acs_tests::run_in_process(&grid_scenario(grid, (g, t, v), seed)));
        (sum, n) = (sum + s, n + k);
    }
    let nees = sum / n as f64;
    let f = tr.telemetry.last().unwrap().fusion;
    let k0 = tr.at_frame.iter().position(Option::is_some).unwrap();
    let start_us = tr.tape[0].time_us;
    let (trk, tape_trk) = tracker_samples(&tr, k0, start_us);
    let vectors = tr.tape.iter().filter(|e| matches!(e.m, Some(Measurement::Vector { .. }))).count();
    let vec_delivered = delivered(&tr.frames, k0, valid::CSS, |f| f.sampled_at.css_us).len()
        + delivered(&tr.frames, k0, valid::MAG, |f| f.sampled_at.magnetometer_us).len();
    let (att, bias, compared) = against_reference(&tr, arw, rrw);
    let on_time = *on_time_vectors.get_or_insert(vectors);
    println!(
        "| {g} | {t} | {v} | {} / {} | {vectors} / {vec_delivered} | {} | {} | {nees:.2} | {att:.4}, {bias:.4}; {compared} |",
        tape_trk,
        trk.len(),
        f.fused_after_wait,
        f.fused_late,
    );
    let mut why = Vec::new();
    // Samples taken before the filter started but delivered after (a start on the tracker
    // at the gyro's time; a late Sun sample) are older than the filter: refused as too old,
    // and nothing else ever is.
    let pre = pre_start(&tr.frames[k0..], start_us);
    let last_pre = tr.frames.iter().rposition(|fr| {
        [fr.sampled_at.star_tracker_us, fr.sampled_at.css_us, fr.sampled_at.magnetometer_us]
            .iter()
            .any(|&x| x < start_us)
    });
    let before = last_pre.map_or(FusionCounters::default(), |k| tr.telemetry[k].fusion);
    if refusals(&f) != f.too_old || f.too_old > pre.len() as u32 || refusals(&f) != refusals(&before) {
        why.push(format!("refusals {f:?}, {} samples delivered taken before the start", pre.len()));
    }
    // At most the samples still waiting or in flight at the end are not in the tape.
    if trk.len() < tape_trk || trk.len() > tape_trk + 2 {
        why.push(format!("tracker {tape_trk} fused of {} delivered", trk.len()));
    }
    if vectors.abs_diff(on_time) > 2 {
        why.push(format!("{vectors} vector samples fused, {on_time} on time"));
    }
    if !(band.0..=band.1).contains(&nees) {
        why.push(format!("NEES {nees} outside {band:?}"));
    }
    // Compared where every sample up to the filter's time has arrived: at least 40 % of
    // the frames (a tracker 0.2 s late is in flight at half of them at 4 Hz).
    if att > TOL_SIGMA || bias > TOL_SIGMA || compared < frames * 2 / 5 {
        why.push(format!("vs reference: {att} σ, {bias} σ over {compared} frames"));
    }
    if first.summary.run_status != sim_core::recorder::summary::RunStatus::Ok {
        why.push(format!("run_status {:?}", first.summary.run_status));
    }
    why
}

#[test]
fn every_latency_combination_at_4_hz_fuses_every_sample_consistently_as_the_time_ordered_reference() {
    let failures = grid(Grid { control_hz: 4.0, duration_s: 300.0 });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_latency_combination_at_20_hz_fuses_every_sample_consistently_as_the_time_ordered_reference() {
    let failures = grid(Grid { control_hz: 20.0, duration_s: 150.0 });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
