//! Issue 23, simulator side: each sensor samples on its own clock at a dynamics-substep
//! boundary, time-tagged with the time the truth was sampled, delivered after its latency,
//! held between samples; the gyro's angle increment over the frames.
//!
//! The suite is driven as the simulation drives it (the truth offered at t = 0 and at every
//! substep boundary, a frame at every control step), on a truth given in closed form, and
//! checked against that truth.

use acs_flight::link::{SensorFrame, valid};
use nalgebra::{Matrix3, UnitQuaternion};
use sim_core::attitude::Vec3;
use sim_core::plant::{MAX_GIMBALS, Spacecraft, State};
use sim_core::scenario::{GyroSpec, SampleTimingSpec, Sensors, StarTrackerSpec};
use sim_core::sensors::SensorSuite;

fn craft() -> Spacecraft {
    Spacecraft::new(Matrix3::identity(), None).unwrap()
}

/// Yaw rate of the test attitude, rad/s: the attitude at t is a turn of `YAW_RATE · t`
/// about z, so a delivered attitude tells the time it was sampled.
const YAW_RATE: f64 = 0.1;

fn state_at(t: f64, w: Vec3) -> State {
    State {
        q: UnitQuaternion::from_axis_angle(&Vec3::z_axis(), YAW_RATE * t).into_inner(),
        w,
        gimbal_rad: [0.0; MAX_GIMBALS],
        gimbal_rate_rad_s: [0.0; MAX_GIMBALS],
        wheels: Default::default(),
        cmg_rotor_scale: sim_core::plant::NOMINAL_ROTORS,
    }
}

fn yaw(f: &SensorFrame) -> f64 {
    let q = f.q_ib_xyzw.map(f64::from);
    2.0 * q[2].atan2(q[3])
}

/// Whether the frame's attitude is the test attitude at `t_s` (to 1e-6 rad; the yaw moves
/// 1e-3 rad per 10 ms substep), angles compared modulo a turn.
fn attitude_at(f: &SensorFrame, t_s: f64) -> bool {
    let d = (yaw(f) - YAW_RATE * t_s).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d) < 1e-6
}

/// Runs `steps` control steps at `control_hz` with `substeps` RK4 substeps each, the
/// truth `truth(t)` offered at t = 0 and at each substep boundary (the last one at the
/// control step's own time, as the simulation does); `check(k, t_k, frame)` per frame.
fn drive(
    suite: &mut SensorSuite,
    control_hz: f64,
    substeps: u32,
    steps: u32,
    truth: impl Fn(f64) -> State,
    mut check: impl FnMut(u32, f64, &SensorFrame, &SensorSuite),
) {
    let c = craft();
    let (dt, h) = (1.0 / control_hz, 1.0 / control_hz / substeps as f64);
    suite.sample_due(0.0, &truth(0.0), &c, None, &[0.0; 3]);
    for k in 0..steps {
        let t = k as f64 * dt;
        let f = suite.frame(k, t, &truth(t), &c, None);
        check(k, t, &f, suite);
        for j in 0..substeps {
            let tb = if j + 1 == substeps { (k + 1) as f64 * dt } else { t + j as f64 * h + h };
            suite.sample_due(tb, &truth(tb), &c, None, &[0.0; 3]);
        }
    }
}

fn tracker(t: StarTrackerSpec) -> Sensors {
    Sensors { star_tracker: Some(t), ..Default::default() }
}

/// A 3 Hz tracker under a loop at `control_hz` with 50 substeps per step for `steps`
/// frames; (new samples, held frames). Independent truth: at frame t_k the newest grid
/// point is m = ⌊3 t_k⌋, sampled at the first boundary at or after m/3, i.e. within
/// [m/3, m/3 + h); its attitude is the yaw at that time; the frame shows a new sample
/// exactly when m changed since the previous frame.
fn tracker_3hz(control_hz: f64, steps: u32) -> (u32, u32) {
    let h = 1.0 / control_hz / 50.0;
    let mut s = SensorSuite::new(
        &tracker(StarTrackerSpec {
            timing: SampleTimingSpec { rate_hz: Some(3.0), ..Default::default() },
            ..Default::default()
        })
        .suite_spec(control_hz),
    );
    let (mut last, mut new, mut held) = (None::<(f64, u64)>, 0, 0);
    drive(
        &mut s,
        control_hz,
        50,
        steps,
        |t| state_at(t, Vec3::zeros()),
        |k, t, f, _| {
            assert!(f.valid & valid::ATTITUDE != 0, "frame {k}");
            let m = (3.0 * t + 1e-9).floor();
            let tag = f.sampled_at.star_tracker_us;
            let tag_s = tag as f64 * 1e-6;
            assert!(
                tag_s >= m / 3.0 - 1e-6 && tag_s < m / 3.0 + h + 1e-6,
                "frame {k} at {t}: tag {tag_s}, grid {}",
                m / 3.0
            );
            assert!(attitude_at(f, tag_s), "frame {k}: the truth at the tag");
            match last {
                Some((lm, ltag)) if lm == m => {
                    assert_eq!(tag, ltag, "frame {k}: no new grid point, the sample is held");
                    held += 1;
                }
                _ => {
                    assert!(last.is_none_or(|(_, ltag)| ltag < tag), "frame {k}: a new sample, never seen before");
                    new += 1;
                }
            }
            last = Some((m, tag));
        },
    );
    (new, held)
}

#[test]
fn a_3hz_tracker_delivers_its_newest_sample_once_at_its_true_time() {
    // 2 Hz loop, 300 s: ⌊3 k / 2⌋ = 0, 1, 3, 4, 6, … changes at every frame (the samples
    // 2, 5, 8, … are superseded before a frame takes them): 600 new, none held.
    assert_eq!(tracker_3hz(2.0, 600), (600, 0));
    // 5 Hz loop, 200 s: every one of the 600 grid points is new in exactly one frame and
    // held in the other 400.
    assert_eq!(tracker_3hz(5.0, 1000), (600, 400));
}

#[test]
fn latency_delivers_the_newest_sample_at_least_that_old_with_its_exact_tag() {
    // Tracker and loop at 10 Hz, substep 10 ms, latency 0.13 s: frame t_k carries the
    // newest sample with tag ≤ t_k − 0.13 s, i.e. grid point ⌊10 (t_k − 0.13)⌋ / 10 exactly
    // (the grid falls on boundaries); nothing before t = 0.13 s.
    let spec = tracker(StarTrackerSpec {
        timing: SampleTimingSpec { latency_s: 0.13, ..Default::default() },
        ..Default::default()
    });
    let mut s = SensorSuite::new(&spec.suite_spec(10.0));
    drive(
        &mut s,
        10.0,
        10,
        300,
        |t| state_at(t, Vec3::zeros()),
        |k, t, f, _| {
            if t < 0.13 - 1e-9 {
                assert_eq!(f.valid & valid::ATTITUDE, 0, "frame {k}: nothing has arrived yet");
                return;
            }
            let m = (10.0 * (t - 0.13) + 1e-9).floor() as u64;
            assert_eq!(f.sampled_at.star_tracker_us, m * 100_000, "frame {k} at {t}");
            assert!(f.valid & valid::ATTITUDE != 0);
            assert!(attitude_at(f, m as f64 / 10.0), "frame {k}");
        },
    );
    // The suite latency adds to the tracker's: 0.05 + 0.08 s is the same 0.13 s.
    let spec = Sensors {
        latency_s: 0.05,
        star_tracker: Some(StarTrackerSpec {
            timing: SampleTimingSpec { latency_s: 0.08, ..Default::default() },
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut s = SensorSuite::new(&spec.suite_spec(10.0));
    drive(
        &mut s,
        10.0,
        10,
        50,
        |t| state_at(t, Vec3::zeros()),
        |k, t, f, _| {
            if t > 0.13 {
                let m = (10.0 * (t - 0.13) + 1e-9).floor() as u64;
                assert_eq!(f.sampled_at.star_tracker_us, m * 100_000, "frame {k}");
                // The rate is behind the suite latency only: 0.05 s.
                let g = (10.0 * (t - 0.05) + 1e-9).floor() as u64;
                assert_eq!(f.sampled_at.gyro_us, g * 100_000, "frame {k}");
            }
        },
    );
}

fn gyro(g: GyroSpec) -> Sensors {
    Sensors { seed: 11, gyro: Some(g), ..Default::default() }
}

/// ∫ (ω0 + α t) dt over [t1, t2] about `axis`, per axis.
fn ramp_angle(w0: f64, alpha: f64, t1: f64, t2: f64, axis: &Vec3) -> Vec3 {
    axis * (w0 * (t2 - t1) + 0.5 * alpha * (t2 * t2 - t1 * t1))
}

#[test]
fn the_gyro_increment_integrates_a_constant_angular_acceleration_and_adds_the_bias() {
    // ω(t) = (ω0 + α t) a about a fixed axis a: ∫ω dt = ω0 T + ½ α (t2² − t1²). The
    // trapezoid rule on the substep boundaries is exact for a rate linear in time, so the
    // tolerance is the f32 of the link: 2e-6 relative plus 1e-9 rad. The gyro samples at
    // 50 Hz under a 10 Hz loop: each frame sums five samples' increments.
    let axis = Vec3::new(1.0, -2.0, 0.5).normalize();
    let (w0, alpha) = (0.02, 1e-3);
    let truth = |t: f64| state_at(t, axis * (w0 + alpha * t));
    let bias = [1e-4, -2e-4, 3e-4];
    for b in [[0.0; 3], bias] {
        let mut s = SensorSuite::new(
            &gyro(GyroSpec {
                timing: SampleTimingSpec { rate_hz: Some(50.0), ..Default::default() },
                bias_rad_s: b,
                ..Default::default()
            })
            .suite_spec(10.0),
        );
        let mut prev_tag: Option<u64> = None;
        drive(&mut s, 10.0, 20, 500, truth, |k, t, f, _| {
            assert_eq!(f.sampled_at.gyro_us, (t * 1e6).round() as u64, "frame {k}: the newest 50 Hz sample is now");
            let Some(p) = prev_tag else {
                assert_eq!(f.gyro_interval_us, 0, "no increment before the second sample");
                prev_tag = Some(f.sampled_at.gyro_us);
                return;
            };
            let (t1, t2) = (p as f64 * 1e-6, f.sampled_at.gyro_us as f64 * 1e-6);
            assert_eq!(u64::from(f.gyro_interval_us), f.sampled_at.gyro_us - p, "frame {k}");
            let want = ramp_angle(w0, alpha, t1, t2, &axis) + Vec3::from(b) * (t2 - t1);
            for i in 0..3 {
                let got = f.gyro_angle_rad[i] as f64;
                assert!(
                    (got - want[i]).abs() < 2e-6 * want[i].abs() + 1e-9,
                    "frame {k} axis {i}: {got} vs {}",
                    want[i]
                );
            }
            prev_tag = Some(f.sampled_at.gyro_us);
        });
    }
}

#[test]
fn the_gyro_increment_angle_random_walk_has_variance_arw_squared_times_the_interval() {
    // ARW N = 1e-3 rad/√s at 10 Hz (interval T = 0.1 s) over 20 000 frames, three axes:
    // the increments' errors are N(0, N² T). With n = 60 000 samples, s²/σ² has standard
    // deviation √(2/n) = 0.0058 (χ²): accept within 5 of those (a 5σ bound), and a mean
    // within 5 σ/√n of zero. The rate samples keep the white noise they had before the
    // increments existed (their own stream): checked against a suite built without them.
    let n_arw = 1e-3;
    let spec = gyro(GyroSpec { arw_rad_sqrt_s: n_arw, ..Default::default() });
    let w = Vec3::new(0.01, 0.0, -0.02);
    let mut s = SensorSuite::new(&spec.suite_spec(10.0));
    let (mut sum, mut sum2, mut n) = (0.0, 0.0, 0usize);
    let mut rates = Vec::new();
    drive(
        &mut s,
        10.0,
        10,
        20_001,
        |t| state_at(t, w),
        |_, _, f, _| {
            rates.push(f.rate_rad_s);
            if f.gyro_interval_us == 0 {
                return;
            }
            let t = f.gyro_interval_us as f64 * 1e-6;
            for i in 0..3 {
                let e = f.gyro_angle_rad[i] as f64 - w[i] * t;
                sum += e;
                sum2 += e * e;
                n += 1;
            }
        },
    );
    let var = n_arw * n_arw * 0.1;
    let mean = sum / n as f64;
    let ratio = (sum2 / n as f64 - mean * mean) / var;
    println!("ARW increments: n = {n}, variance / (N² T) = {ratio:.4}, mean {mean:.3e} rad");
    assert!((ratio - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(), "{ratio}");
    assert!(mean.abs() < 5.0 * var.sqrt() / (n as f64).sqrt(), "{mean}");
    // The rate samples: one per frame, at the frame, noise σ = N √rate; the same bits as
    // the model's own rate sequence (the gyro driven alone at the frame times).
    let mut alone = sim_core::sensors::gyro::Gyro::new(spec.gyro_model(10.0), 11, 1);
    for (k, r) in rates.iter().enumerate() {
        let want = alone.update(k as f64 / 10.0, &w.into()).rate_rad_s.map(|x| x as f32);
        assert_eq!(*r, want, "frame {k}");
    }
}

#[test]
fn same_seed_same_bits_with_jitter_latency_and_noise() {
    let spec = Sensors {
        seed: 3,
        latency_s: 0.02,
        gyro: Some(GyroSpec {
            timing: SampleTimingSpec { rate_hz: Some(40.0), jitter_s: 0.004, phase_s: 0.01, latency_s: 0.0 },
            arw_rad_sqrt_s: 1e-3,
            rrw_rad_s_sqrt_s: 1e-5,
            ..Default::default()
        }),
        star_tracker: Some(StarTrackerSpec {
            timing: SampleTimingSpec { rate_hz: Some(3.0), jitter_s: 0.05, latency_s: 0.13, phase_s: 0.0 },
            noise_deg: 0.01,
            ..Default::default()
        }),
        ..Default::default()
    };
    let run = |spec: &Sensors| {
        let mut s = SensorSuite::new(&spec.suite_spec(10.0));
        let mut frames = Vec::new();
        drive(&mut s, 10.0, 10, 2000, |t| state_at(t, Vec3::new(0.0, 0.0, YAW_RATE)), |_, _, f, _| frames.push(*f));
        frames
    };
    let (a, b) = (run(&spec), run(&spec));
    assert!(a == b, "same seed, same bits");
    let c = run(&Sensors { seed: 4, ..spec.clone() });
    assert!(a != c, "another seed, other noise and other jitter");
    // The jitter moves the tracker's tags out of [m/3, m/3 + h) (where the plain grid
    // would put them), within ±0.05 s of m/3 (+ h).
    let offsets: Vec<f64> = a
        .iter()
        .filter(|f| f.valid & valid::ATTITUDE != 0)
        .map(|f| {
            let t = f.sampled_at.star_tracker_us as f64 * 1e-6;
            t - (3.0 * t).round() / 3.0
        })
        .collect();
    assert!(offsets.iter().all(|o| (-0.05 - 1e-6..=0.05 + 0.01 + 1e-6).contains(o)), "{offsets:?}");
    assert!(offsets.iter().any(|o| *o < -1e-6 || *o > 0.01 + 1e-6), "{offsets:?}");
}

#[test]
fn the_queues_stay_within_their_cap_over_a_long_run() {
    // 100 000 frames (10 Hz loop, 1 ms substeps): a 47 Hz gyro behind 0.3 s and a jittered
    // 9 Hz tracker behind 0.55 s. Cap ⌈latency × rate⌉ + 2; nothing dropped.
    let spec = Sensors {
        latency_s: 0.3,
        gyro: Some(GyroSpec {
            timing: SampleTimingSpec { rate_hz: Some(47.0), jitter_s: 0.01, ..Default::default() },
            ..Default::default()
        }),
        star_tracker: Some(StarTrackerSpec {
            timing: SampleTimingSpec { rate_hz: Some(9.0), jitter_s: 0.05, latency_s: 0.25, phase_s: 0.0 },
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut s = SensorSuite::new(&spec.suite_spec(10.0));
    assert_eq!((s.gyro_channel.queue.cap(), s.attitude_channel.queue.cap()), (17, 7));
    drive(&mut s, 10.0, 100, 100_000, |t| state_at(t, Vec3::zeros()), |_, _, _, _| {});
    let (max_g, max_a) = (s.gyro_channel.queue.max_len, s.attitude_channel.queue.max_len);
    println!("queues over 10^4 s: gyro at most {max_g} of 17, tracker {max_a} of 7");
    assert!(max_g <= 17 && max_a <= 7);
    assert_eq!((s.gyro_channel.queue.dropped, s.attitude_channel.queue.dropped), (0, 0));
}

/// The shipped `mekf-hold` scenario with `extra` appended to its `[sensors.<table>]`
/// table; the validation's error, if any.
fn validate_with(table: &str, extra: &str) -> Option<String> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/estimation/mekf-hold.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let head = format!("[sensors.{table}]\n");
    assert!(text.contains(&head), "{table}");
    let text = text.replacen(&head, &format!("{head}{extra}\n"), 1);
    sim_core::scenario::Scenario::from_toml(&text).and_then(|s| s.validate()).err().map(|e| format!("{e:#}"))
}

#[test]
fn bad_timing_keys_are_refused_naming_the_key() {
    // mekf-hold: control 4 Hz; tracker 2 Hz (period 0.5 s), GNSS 1 Hz, others at 4 Hz.
    for (table, extra, key) in [
        ("star_tracker", "latency_s = -1", "sensors.star_tracker.latency_s"),
        ("star_tracker", "latency_s = 11", "sensors.star_tracker.latency_s"),
        ("star_tracker", "latency_s = nan", "sensors.star_tracker.latency_s"),
        ("gyro", "latency_s = inf", "sensors.gyro.latency_s"),
        ("star_tracker", "phase_s = 0.5", "sensors.star_tracker.phase_s"),
        ("star_tracker", "phase_s = -0.1", "sensors.star_tracker.phase_s"),
        ("gyro", "phase_s = 0.25", "sensors.gyro.phase_s"),
        ("star_tracker", "jitter_s = 0.25", "sensors.star_tracker.jitter_s"),
        ("magnetometer", "jitter_s = 0.125", "sensors.magnetometer.jitter_s"),
        ("css", "jitter_s = -0.01", "sensors.css.jitter_s"),
        ("gnss", "phase_s = 1.0", "sensors.gnss.phase_s"),
        ("gnss", "latency_s = -0.5", "sensors.gnss.latency_s"),
        ("magnetometer", "rate_hz = 0", "sensors.magnetometer.rate_hz"),
        ("css", "rate_hz = -1", "sensors.css.rate_hz"),
    ] {
        let err = validate_with(table, extra).unwrap_or_else(|| panic!("{table}: {extra} accepted"));
        assert!(err.contains(&format!("`{key}`")), "{extra}: {err}");
    }
    // The largest values inside the ranges are accepted: 10 s of latency on the GNSS (the
    // MEKF does not fuse it); the tracker, which it fuses, up to its horizon
    // (`max_sample_latency_s`, 0.5 s: beyond it the loader refuses, issue 37).
    for (table, extra) in [
        ("star_tracker", "latency_s = 0.5\nphase_s = 0.499\njitter_s = 0.249"),
        ("gnss", "latency_s = 10\nphase_s = 0.999\njitter_s = 0.499"),
        ("gyro", "latency_s = 0.01\nphase_s = 0.2\njitter_s = 0.1"),
    ] {
        assert_eq!(validate_with(table, extra), None, "{table}: {extra}");
    }
}

#[test]
fn a_sensor_sample_lost_by_its_queue_fails_the_run() {
    // The latency queues are sized so that nothing is ever dropped; should a queue
    // overflow anyway (injected here: a burst of samples beyond its cap mid-run), the
    // summary counts it and the run fails with `samples_dropped`, never `ok`.
    use sim_core::link::in_process::InProcess;
    use sim_core::recorder::series::Discard;
    use sim_core::recorder::summary::{Failure, RunStatus};
    use sim_core::runner::Simulation;
    use sim_core::scenario::{Resolved, Scenario};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/estimation/mekf-hold.toml");
    let mut sc = Scenario::load(&path).unwrap();
    sc.duration_s = 5.0;
    let clean = sim_core::runner::run(&sc, &mut InProcess::new(), false).unwrap().summary;
    assert_eq!((clean.run_status, clean.sensor_samples_dropped), (RunStatus::Ok, 0));
    let mut link = InProcess::new();
    let mut sim = Simulation::new(Resolved::try_from(&sc).unwrap(), &mut link).unwrap();
    let mut rec = Discard;
    let mut injected = false;
    while !sim.finished() {
        sim.step(&mut rec).unwrap();
        if !injected && sim.steps_done() == 10 {
            let q = &mut sim.sensors_mut().mag_channel.queue;
            let cap = q.cap() as u64;
            for k in 0..=cap + 2 {
                q.push(u64::MAX / 2 + k, [0.0; 3]);
            }
            injected = true;
        }
    }
    let s = sim.summary(1.0);
    assert_eq!(s.run_status, RunStatus::SamplesDropped);
    assert!(s.sensor_samples_dropped >= 3, "{}", s.sensor_samples_dropped);
    match s.failure {
        Some(Failure::Sensors { reason }) => assert!(reason.contains("magnetometer"), "{reason}"),
        other => panic!("{other:?}"),
    }
}
