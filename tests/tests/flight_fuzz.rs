//! The flight side of the link under random message sequences: real parameter sets (the
//! mode mission's four modes, a CMG set, a thruster LP set, a DMCS set), mode commands,
//! targets, adaptation freezes (protocol 14) and sensor frames, each with a chance of random byte corruption that still decodes (so
//! NaN, huge, negative or nonsensical fields reach validation and the step). Asserts: no
//! panic, one reply per message, every step answers its frame with finite commands, the
//! mode code is one of the five, and a safe command is all-idle. One frame, one step: a
//! frame (its `seq` possibly corrupted) is stepped exactly when its `seq` is above the last
//! stepped one since the last `Hello` or accepted configuration (a model kept here), and
//! refused with `StaleSequence` otherwise. Frames carry protocol 13's sample times
//! (late, beyond the history, from the future, absurd) and gyro increments. Pointing
//! timelines (protocol 19): random segments (times near the latest fix, in the past, far
//! ahead, out of order, NaN; fixed, Sun and ground pointings), armed with the checksum of
//! what was sent (corruption makes some differ), cleared; every arming gets `TimelineArmed`
//! or `TimelineRejected`, and every step report's timeline counters stay consistent.
//! FDIR (protocols 20, 21): `ClearWheelFault` (every index: the wheels, beyond them, beyond
//! `MAX_WHEELS`, `ALL_UNITS`), `ClearSensorFaults`, parameter sets with a wheel monitor
//! (`fdir.wheel`, on the 6U's wheel set and on the mission's mode slots, some of them
//! without wheels) and estimation sets with `tracker_fdir` and `gyro_fdir`, every field
//! drawn from a pool of sane and absurd values (NaN, ±inf, negative, 0, huge, k > n, k = 0,
//! n beyond the 32-sample window). Asserts, besides the above: `ClearWheelFault` is `Ack`
//! exactly for an index below `MAX_WHEELS` or `ALL_UNITS` and `Error(NoSuchUnit)` otherwise;
//! a set whose monitor parameters break their documented ranges (restated here) is refused
//! (`ParamsRejected`, naming `Fdir` when nothing else was corrupted); and every refused or
//! errored message leaves the flight side as it was: a copy of the session taken before it
//! and the session after it answer the next three frames identically.

use acs_flight::guidance::timeline::checksum;
use acs_flight::link::{
    ActuatorCommand, FswMsg, HostMsg, LinkError, PROTOCOL_VERSION, SampleTimes, SensorFrame, schema_hash, status, valid,
};
use acs_flight::params::fdir::{GyroFdirParams, KOfN, TrackerFdirParams, WheelFdirParams, WheelResidualNoise};
use acs_flight::params::{ActuatorParams, FlightParams, Mode, ModeRequest, ParamField};
use acs_flight::params::{AttitudeSource, Direction, EstimationParams, GuidanceParams, Pointing, TargetFrame};
use acs_flight::params::{MAX_TIMELINE_SEGMENTS, TimelineSegment};
use acs_flight::session::{Session, board};
use acs_tests::scenario;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn finite(c: &ActuatorCommand) -> bool {
    c.gimbal_rate_cmd_rad_s
        .iter()
        .chain(&c.wheel_torque_cmd_nm)
        .chain(&c.dipole_cmd_am2)
        .chain(&c.thruster_level)
        .chain(&c.torque_demand_nm)
        .chain(&c.torque_realised_nm)
        .chain(&c.law_telemetry)
        .chain(&[c.attitude_error_rad, c.singularity_measure, c.steering_alpha])
        .all(|x| x.is_finite())
}

fn frame(rng: &mut ChaCha8Rng, seq: u32) -> SensorFrame {
    let mut q: [f32; 4] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
    let n = q.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-3);
    q.iter_mut().for_each(|x| *x /= n);
    SensorFrame {
        q_ib_xyzw: q,
        rate_rad_s: std::array::from_fn(|_| rng.random_range(-0.2..0.2)),
        gimbal_angle_rad: std::array::from_fn(|_| rng.random_range(-3.0..3.0)),
        wheel_speed_rad_s: std::array::from_fn(|_| rng.random_range(-500.0..500.0)),
        mag_field_t: std::array::from_fn(|_| rng.random_range(-5e-5..5e-5)),
        // A LEO fix (LVLH targets need navigation): ~7,000 km, ~7.5 km/s.
        gnss_pos_m: std::array::from_fn(|_| rng.random_range(3.0e6..5.0e6)),
        gnss_vel_m_s: std::array::from_fn(|_| rng.random_range(-5.0e3..5.0e3)),
        gnss_j2000_days: rng.random_range(9000..10000),
        gnss_j2000_s: rng.random_range(0.0..86_400.0),
        css_output: std::array::from_fn(|_| rng.random_range(0.0..1.0)),
        // Protocol 13: the gyro increment (absurd intervals included) and each sensor's
        // sample time — current, late, beyond the history, from the future.
        gyro_angle_rad: std::array::from_fn(|_| rng.random_range(-0.2..0.2)),
        gyro_interval_us: [0, 1, 500_000, rng.random()][rng.random_range(0..4)],
        sampled_at: SampleTimes {
            gyro_us: sample_time(rng, seq),
            star_tracker_us: sample_time(rng, seq),
            sun_sensor_us: sample_time(rng, seq),
            css_us: sample_time(rng, seq),
            magnetometer_us: sample_time(rng, seq),
            gnss_us: sample_time(rng, seq),
        },
        valid: valid::ALL,
        ..SensorFrame::empty(seq, frame_time_us(seq))
    }
}

fn frame_time_us(seq: u32) -> u64 {
    seq as u64 * 500_000
}

/// A sample time for the frame `seq`: mostly the frame's or up to 0.4 s before it, some
/// far behind (beyond the history), some after it (from the future), some absurd.
fn sample_time(rng: &mut ChaCha8Rng, seq: u32) -> u64 {
    let t = frame_time_us(seq);
    match rng.random_range(0..10) {
        0..=4 => t,
        5..=7 => t.saturating_sub(rng.random_range(0..400_000)),
        8 => t.saturating_sub(rng.random_range(0..60_000_000)),
        _ => [t + rng.random_range(1..2_000_000), 0, u64::MAX][rng.random_range(0..3)],
    }
}

/// A random segment `index`: mostly in order, 60 s apart from 60 s after the fix time
/// `(days, s)`; some anywhere in the next 2 h, in the past, beyond the 1-day horizon or
/// NaN; a fixed, Sun or ground pointing.
fn segment(rng: &mut ChaCha8Rng, index: u8, days: i32, s: f32) -> TimelineSegment {
    let start_s = match rng.random_range(0..10) {
        0 => s - rng.random_range(1.0..5_000.0),
        1 => s + rng.random_range(86_400.0..400_000.0),
        2 => f32::NAN,
        3 => s + rng.random_range(10.0..7_200.0),
        _ => s + 60.0 * f32::from(index + 1) + rng.random_range(0.0..30.0),
    };
    let align = |primary| Pointing::Align {
        primary_body: [0.0, 0.0, 1.0],
        primary,
        secondary_body: [1.0, 0.0, 0.0],
        secondary: Direction::OrbitNormal,
    };
    let pointing = match rng.random_range(0..3) {
        0 => Pointing::Fixed { q_xyzw: frame(rng, 0).q_ib_xyzw, frame: TargetFrame::Inertial },
        1 => align(Direction::Sun),
        _ => align(Direction::Ground {
            lat_rad: rng.random_range(-1.5..1.5),
            lon_rad: rng.random_range(-3.0..3.0),
            alt_m: 0.0,
        }),
    };
    let guidance = GuidanceParams { pointing, ..GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial) };
    TimelineSegment { start_j2000_days: days, start_j2000_s: start_s, guidance }
}

/// A value from a pool of sane and absurd ones around `sane`.
fn absurd_f32(rng: &mut ChaCha8Rng, sane: f32) -> f32 {
    let pool = [sane, sane, sane, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -sane, 0.0, -0.0, 1e30, f32::MAX, 1e-30];
    pool[rng.random_range(0..pool.len())]
}

/// k-of-n from a pool: valid windows, k = 0, k > n, n beyond the 32-sample window.
fn absurd_window(rng: &mut ChaCha8Rng) -> KOfN {
    let pool = [0u8, 1, 4, 6, 32, 33, 255];
    if rng.random_bool(0.5) {
        KOfN { k: 4, n: 6 }
    } else {
        KOfN { k: pool[rng.random_range(0..pool.len())], n: pool[rng.random_range(0..pool.len())] }
    }
}

fn absurd_repeats(rng: &mut ChaCha8Rng) -> u16 {
    [0u16, 1, 3, 4, u16::MAX][rng.random_range(0..5)]
}

fn wheel_fdir(rng: &mut ChaCha8Rng) -> WheelFdirParams {
    WheelFdirParams {
        noise: WheelResidualNoise {
            tach_sigma_rad_s: absurd_f32(rng, 1e-4),
            tach_lsb_rad_s: absurd_f32(rng, 6.1e-5),
            gyro_sigma_rad_s: absurd_f32(rng, 1e-5),
        },
        threshold_sigma: absurd_f32(rng, 6.0),
        floor_nm: absurd_f32(rng, 5e-8),
        window: absurd_window(rng),
        isolation_min_ratio: absurd_f32(rng, 3.0),
        body_torque_sigma_nm: absurd_f32(rng, 1e-6),
    }
}

/// The wheel monitor's documented ranges (docs/fdir.md; `params::fdir`), restated: noise
/// figures and the floor finite and ≥ 0, the threshold and the isolation ratio finite and
/// > 0, the body-torque noise finite and ≥ 0, 1 ≤ k ≤ n ≤ 32.
fn wheel_fdir_valid(w: &WheelFdirParams) -> bool {
    let nonneg = |x: f32| x.is_finite() && x >= 0.0;
    let positive = |x: f32| x.is_finite() && x > 0.0;
    let n = &w.noise;
    nonneg(n.tach_sigma_rad_s)
        && nonneg(n.tach_lsb_rad_s)
        && nonneg(n.gyro_sigma_rad_s)
        && positive(w.threshold_sigma)
        && nonneg(w.floor_nm)
        && window_valid(w.window)
        && positive(w.isolation_min_ratio)
        && nonneg(w.body_torque_sigma_nm)
}

fn window_valid(w: KOfN) -> bool {
    w.k >= 1 && w.k <= w.n && w.n <= 32
}

/// Whether a set's wheel monitor is out of its ranges, or on a family without wheels (or
/// wheels of no valid inertia) — a set the flight side must refuse.
fn wheel_fdir_refusable(p: &FlightParams) -> bool {
    match (&p.fdir.wheel, &p.actuator) {
        (None, _) => false,
        (Some(w), ActuatorParams::Wheels(wh)) => {
            !(wheel_fdir_valid(w) && wh.inertia_kgm2.is_finite() && wh.inertia_kgm2 > 0.0)
        }
        (Some(_), _) => true,
    }
}

/// The estimation stage's monitors (protocols 21, 22), each off, sane or absurd.
fn sensor_fdir(rng: &mut ChaCha8Rng) -> (Option<TrackerFdirParams>, Option<GyroFdirParams>) {
    let tracker = rng.random_bool(0.7).then(|| TrackerFdirParams {
        witness_max_rad: [0.35, 0.35, f32::NAN, f32::INFINITY, -0.35, 0.0, std::f32::consts::PI, 4.0, 1e-30, 1e30]
            [rng.random_range(0..10)],
        window: absurd_window(rng),
        max_repeats: absurd_repeats(rng),
    });
    let gyro = rng.random_bool(0.7).then(|| GyroFdirParams {
        max_repeats: absurd_repeats(rng),
        bias_step: rng.random_bool(0.6).then(|| absurd_window(rng)),
    });
    (tracker, gyro)
}

/// The monitors' documented ranges, restated: the witness angle finite in (0, π), 1 ≤ k ≤ n
/// ≤ 32, every repeat count ≥ 1; the gyro's bias-step window 2 ≤ k ≤ n ≤ 32 and only with
/// the star-tracker monitor (protocol 22).
fn sensor_fdir_valid(e: &EstimationParams) -> bool {
    let tracker_ok = e.tracker_fdir.is_none_or(|t| {
        t.witness_max_rad.is_finite()
            && t.witness_max_rad > 0.0
            && t.witness_max_rad < std::f32::consts::PI
            && window_valid(t.window)
            && t.max_repeats >= 1
    });
    let bias_ok = |w: Option<KOfN>| w.is_none_or(|w| window_valid(w) && w.k >= 2 && e.tracker_fdir.is_some());
    tracker_ok && e.gyro_fdir.is_none_or(|g| g.max_repeats >= 1 && bias_ok(g.bias_step))
}

/// Whether a refused or errored message left the flight side as it was: `before` (a copy
/// taken before the message) and `after` answer the same three frames (from `probe`, with
/// sequence numbers far above any the fuzz sends) identically.
fn unchanged_by_refusal(before: &Session, after: &Session, probe: &mut ChaCha8Rng, k: u32) -> bool {
    let (mut a, mut b) = (before.clone(), after.clone());
    let mut counter = || 0u32;
    (0..3).all(|i| {
        let f = HostMsg::Sensor(frame(probe, 1_000_000 + 3 * k + i));
        a.handle(&f, 0, &mut counter) == b.handle(&f, 0, &mut counter)
    })
}

#[test]
fn random_message_sequences_never_break_the_flight_side() {
    // More seeds for a longer local campaign: ACS_FUZZ_SEEDS=1000 cargo test ...
    let seeds: u64 = std::env::var("ACS_FUZZ_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(8);
    for seed in 0..seeds {
        fuzz(seed);
    }
}

fn fuzz(seed: u64) {
    let mission = scenario("modes/cubesat-mission.toml").mode_table().unwrap().unwrap();
    let cmg = scenario("paper002/lqg.toml").flight_params().unwrap();
    let thr = scenario("paper004/dp-nominal.toml").flight_params().unwrap();
    let dmcs = scenario("paper001/dmcs-m1.toml").flight_params().unwrap();
    let six = scenario("fdir/wheel-seized-6u.toml").flight_params().unwrap();
    assert!(six.fdir.wheel.is_some(), "the 6U flies a wheel monitor");
    let mut rng = ChaCha8Rng::seed_from_u64(0xF100 + seed);
    // Frames for the refusal check, apart from `rng` so the fuzz's sequence stays its own.
    let mut probe = ChaCha8Rng::seed_from_u64(0xF1D0 + seed);
    let mut fdir = FdirFuzz::default();
    let mut s = Session::new(board::HOST, 1);
    let mut counter = || 0u32;
    let (mut steps, mut corrupted, mut rejected, mut armed, mut mode_seen) =
        (0u32, 0u32, 0u32, 0u32, [0u32; 1 + Mode::ALL.len()]);
    let (mut model_last, mut seq_refused, mut refused_total) = (None::<u32>, 0u32, 0u32);
    // Timeline: what was sent per index (the arming's checksum), the latest fix's time.
    let mut staged: Vec<Option<TimelineSegment>> = vec![None; MAX_TIMELINE_SEGMENTS];
    let (mut fix_days, mut fix_s) = (9_500i32, 1_000.0f32);
    let (mut tl_armed, mut tl_rejected, mut tl_msgs) = (0u32, 0u32, 0u32);
    let mut tl_faults = std::collections::BTreeMap::new();
    for k in 0..30_000u32 {
        let msg = match rng.random_range(0..100) {
            0 => HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() },
            1..=10 => {
                let (mode, params) = mission.slots[rng.random_range(0..mission.slots.len())];
                HostMsg::UploadModeParams { mode, params }
            }
            11..=16 => HostMsg::ArmModes(mission.manager),
            17 => HostMsg::UploadParams([cmg, thr, dmcs][rng.random_range(0..3)]),
            26 => HostMsg::FreezeAdaptation { frozen: rng.random_bool(0.5) },
            18..=21 => {
                let m = Mode::ALL[rng.random_range(0..Mode::ALL.len())];
                HostMsg::CommandMode(match rng.random_range(0..3) {
                    0 => ModeRequest::Enter(m),
                    1 => ModeRequest::Lock(m),
                    _ => ModeRequest::Auto,
                })
            }
            22..=23 => HostMsg::SetTarget { target_q_xyzw: frame(&mut rng, 0).q_ib_xyzw },
            // The attitude source flips between the sensor and the MEKF (with every
            // vector update on); corruption below makes some sets absurd.
            24..=25 => HostMsg::ConfigureEstimation(EstimationParams {
                source: if rng.random_bool(0.5) { AttitudeSource::Mekf } else { AttitudeSource::Sensor },
                sun_sensor_sigma_rad: 0.01,
                css_count: 6,
                css_sigma_rad: 0.1,
                magnetometer_sigma_rad: 0.05,
                ..EstimationParams::default()
            }),
            27..=29 => {
                let index = rng.random_range(0..MAX_TIMELINE_SEGMENTS as u8 + 2);
                HostMsg::UploadTimelineSegment { index, segment: segment(&mut rng, index, fix_days, fix_s) }
            }
            30 => {
                // Mostly the staged prefix; sometimes any count (missing segments, too many).
                let prefix = staged.iter().take_while(|s| s.is_some()).count() as u8;
                let count =
                    if rng.random_bool(0.7) { prefix } else { rng.random_range(0..MAX_TIMELINE_SEGMENTS as u8 + 2) };
                let sent: Option<Vec<_>> = staged.iter().take(usize::from(count)).copied().collect();
                let crc32 = sent.and_then(|v| checksum(&v)).unwrap_or_else(|| rng.random());
                HostMsg::ArmTimeline { count, crc32 }
            }
            31 => HostMsg::ClearTimeline,
            // FDIR (protocols 20, 21): ground clears, monitors' parameters.
            32..=33 => {
                HostMsg::ClearWheelFault { wheel: [0u8, 2, 3, 4, 5, 6, 7, 200, 254, 255][rng.random_range(0..10)] }
            }
            34 => HostMsg::ClearSensorFaults,
            35..=36 => HostMsg::UploadParams(FlightParams {
                fdir: acs_flight::params::fdir::FdirParams { wheel: Some(wheel_fdir(&mut rng)) },
                ..six
            }),
            37 => {
                let (mode, params) = mission.slots[rng.random_range(0..mission.slots.len())];
                let wheel = Some(wheel_fdir(&mut rng));
                HostMsg::UploadModeParams {
                    mode,
                    params: FlightParams { fdir: acs_flight::params::fdir::FdirParams { wheel }, ..params },
                }
            }
            38..=39 => {
                let (tracker_fdir, gyro_fdir) = sensor_fdir(&mut rng);
                HostMsg::ConfigureEstimation(EstimationParams {
                    source: AttitudeSource::Mekf,
                    sun_sensor_sigma_rad: 0.01,
                    css_count: 6,
                    css_sigma_rad: 0.1,
                    magnetometer_sigma_rad: 0.05,
                    tracker_fdir,
                    gyro_fdir,
                    ..EstimationParams::default()
                })
            }
            _ => {
                let f = frame(&mut rng, k);
                (fix_days, fix_s) = (f.gnss_j2000_days, f.gnss_j2000_s);
                HostMsg::Sensor(f)
            }
        };
        let mut bytes = postcard::to_allocvec(&msg).unwrap();
        if rng.random_bool(0.3) {
            for _ in 0..rng.random_range(1..4) {
                let i = rng.random_range(0..bytes.len());
                bytes[i] = rng.random();
            }
        }
        let Ok(decoded) = postcard::from_bytes::<HostMsg>(&bytes) else {
            continue;
        };
        let intact = decoded == msg;
        corrupted += u32::from(!intact);
        let msg = decoded;
        let before = (!matches!(msg, HostMsg::Sensor(_))).then(|| s.clone());
        let reply = s.handle(&msg, 0, &mut counter);
        fdir.check(&msg, reply.as_ref(), intact);
        if let (Some(b), Some(FswMsg::ParamsRejected(_) | FswMsg::Error(_))) = (&before, &reply) {
            assert!(
                unchanged_by_refusal(b, &s, &mut probe, k),
                "seed {seed}: {msg:?} refused ({reply:?}) but changed the flight side"
            );
            fdir.refusals_unchanged += 1;
        }
        match (&msg, &reply) {
            (HostMsg::ArmTimeline { .. }, Some(FswMsg::TimelineArmed { .. })) => tl_armed += 1,
            (HostMsg::ArmTimeline { .. }, Some(FswMsg::TimelineRejected(e))) => {
                tl_rejected += 1;
                *tl_faults.entry(format!("{:?}", e.fault)).or_insert(0u32) += 1;
            }
            (HostMsg::ArmTimeline { .. }, other) => panic!("ArmTimeline got {other:?}"),
            // The model stages what the flight side accepted (after any corruption).
            (HostMsg::UploadTimelineSegment { index, segment }, Some(FswMsg::Ack)) => {
                tl_msgs += 1;
                staged[usize::from(*index)] = Some(*segment);
            }
            (HostMsg::UploadTimelineSegment { .. }, Some(FswMsg::ParamsRejected(_))) => tl_msgs += 1,
            (HostMsg::ClearTimeline, Some(FswMsg::Ack)) => {
                tl_msgs += 1;
                staged.iter_mut().for_each(|s| *s = None);
            }
            (HostMsg::UploadTimelineSegment { .. } | HostMsg::ClearTimeline, other) => panic!("{msg:?} got {other:?}"),
            _ => {}
        }
        // The sequence model: Hello and accepted configurations start a new sequence.
        match (&msg, &reply) {
            (_, Some(FswMsg::HelloAck { .. })) => (model_last, seq_refused) = (None, 0),
            (HostMsg::UploadParams(_) | HostMsg::ConfigureEstimation(_), Some(FswMsg::ParamsAccepted { .. }))
            | (_, Some(FswMsg::ModesArmed { .. })) => model_last = None,
            _ => {}
        }
        match (&msg, reply) {
            (HostMsg::Sensor(f), Some(FswMsg::Error(LinkError::StaleSequence { seq, last_seq }))) => {
                assert_eq!((seq, Some(last_seq)), (f.seq, model_last), "refused against the model");
                assert!(seq <= last_seq);
                seq_refused += 1;
                refused_total += 1;
            }
            (HostMsg::Sensor(f), Some(FswMsg::Step(r))) => {
                assert!(model_last.is_none_or(|l| f.seq > l), "frame {} stepped after {model_last:?}", f.seq);
                model_last = Some(f.seq);
                assert_eq!(r.seq_refused, seq_refused);
                steps += 1;
                let tl = r.timeline;
                assert!(usize::from(tl.segments) <= MAX_TIMELINE_SEGMENTS && tl.in_force <= tl.segments, "{tl:?}");
                let c = r.cmd;
                assert_eq!(c.seq, f.seq);
                assert!(finite(&c), "non-finite command for {f:?}: {c:?}");
                assert!(usize::from(c.mode) <= Mode::ALL.len(), "{}", c.mode);
                mode_seen[c.mode as usize] += 1;
                assert!(c.estimate.covariance_upper.iter().chain(&c.estimate.q_est_xyzw).all(|x| x.is_finite()));
                if c.status & (status::NOT_CONFIGURED | status::BAD_INPUT | status::NO_ESTIMATE) != 0 {
                    // All idle; the mode and estimation telemetry still report (the FDIR's
                    // too), and the drives of exactly the wheels FDIR declared failed stay
                    // off.
                    let idle = ActuatorCommand {
                        estimate: c.estimate,
                        fdir: c.fdir,
                        wheel_power_off: c.fdir.failed_wheels,
                        mode: c.mode,
                        mode_reason: c.mode_reason,
                        mode_transitions: c.mode_transitions,
                        momentum_events: c.momentum_events,
                        momentum_keepup_events: c.momentum_keepup_events,
                        gimbal_events: c.gimbal_events,
                        ..acs_flight::Fsw::safe_command(c.seq, c.status)
                    };
                    assert_eq!(c, idle, "safe command not idle");
                }
            }
            (HostMsg::Sensor(_), other) => panic!("a sensor frame got {other:?}"),
            (HostMsg::StartRealTime, _) => {}
            (_, Some(FswMsg::ParamsRejected(_) | FswMsg::Error(_))) => rejected += 1,
            (_, Some(FswMsg::ModesArmed { .. })) => armed += 1,
            (_, Some(_)) => {}
            (m, None) => panic!("no reply to {m:?}"),
        }
    }
    eprintln!(
        "seed {seed}: {steps} steps, {corrupted} corrupted messages decoded, {rejected} rejected, armed {armed} times, modes seen {mode_seen:?}, {refused_total} frames refused (seq); timeline armed {tl_armed}, refused {tl_rejected} {tl_faults:?}, {tl_msgs} uploads/clears"
    );
    assert!(tl_rejected > 50 && tl_msgs > 500, "timeline messages exercised");
    assert!(steps > 15_000 && corrupted > 3_000 && rejected > 100 && armed > 100 && refused_total > 10);
    assert!(mode_seen.iter().all(|n| *n > 0), "every mode (and none) was exercised: {mode_seen:?}");
    eprintln!("seed {seed}: FDIR {fdir:?}");
    fdir.assert_exercised();
}

/// The FDIR messages of one seed of [`fuzz`]: what was sent and answered.
#[derive(Debug, Default)]
struct FdirFuzz {
    clears_acked: u32,
    clears_no_unit: u32,
    sensor_clears: u32,
    /// Sets with a wheel monitor (UploadParams, UploadModeParams) accepted / refused, and
    /// those refused because of the monitor (by the restated ranges).
    wheel_sets_accepted: u32,
    wheel_sets_refused: u32,
    wheel_sets_out_of_range: u32,
    /// Estimation sets with a sensor monitor accepted / refused / out of range.
    sensor_sets_accepted: u32,
    sensor_sets_refused: u32,
    sensor_sets_out_of_range: u32,
    /// Refused or errored messages checked to leave the flight side unchanged.
    refusals_unchanged: u32,
}

impl FdirFuzz {
    /// Checks one FDIR message's reply (`intact`: not corrupted on the way).
    fn check(&mut self, msg: &HostMsg, reply: Option<&FswMsg>, intact: bool) {
        let refused = |r: Option<&FswMsg>| matches!(r, Some(FswMsg::ParamsRejected(_)));
        let accepted = |r: Option<&FswMsg>| matches!(r, Some(FswMsg::ParamsAccepted { .. } | FswMsg::Ack));
        match msg {
            HostMsg::ClearWheelFault { wheel } => {
                let exists =
                    usize::from(*wheel) < acs_flight::types::MAX_WHEELS || *wheel == acs_flight::link::ALL_UNITS;
                match reply {
                    Some(FswMsg::Ack) if exists => self.clears_acked += 1,
                    Some(FswMsg::Error(LinkError::NoSuchUnit)) if !exists => self.clears_no_unit += 1,
                    other => panic!("ClearWheelFault {{ wheel: {wheel} }} got {other:?}"),
                }
            }
            HostMsg::ClearSensorFaults => {
                assert_eq!(reply, Some(&FswMsg::Ack), "ClearSensorFaults");
                self.sensor_clears += 1;
            }
            HostMsg::UploadParams(p) | HostMsg::UploadModeParams { params: p, .. } if p.fdir.wheel.is_some() => {
                if wheel_fdir_refusable(p) {
                    self.wheel_sets_out_of_range += 1;
                    assert!(refused(reply), "a wheel monitor out of range accepted: {:?} -> {reply:?}", p.fdir.wheel);
                    if intact {
                        assert!(
                            matches!(reply, Some(FswMsg::ParamsRejected(e)) if e.field == ParamField::Fdir),
                            "{reply:?} for {:?}",
                            p.fdir.wheel
                        );
                    }
                }
                match reply {
                    r if refused(r) => self.wheel_sets_refused += 1,
                    r if accepted(r) => self.wheel_sets_accepted += 1,
                    other => panic!("a parameter set got {other:?}"),
                }
            }
            HostMsg::ConfigureEstimation(e) if e.tracker_fdir.is_some() || e.gyro_fdir.is_some() => {
                if !sensor_fdir_valid(e) {
                    self.sensor_sets_out_of_range += 1;
                    assert!(refused(reply), "a sensor monitor out of range accepted: {e:?} -> {reply:?}");
                }
                match reply {
                    r if refused(r) => self.sensor_sets_refused += 1,
                    r if accepted(r) => self.sensor_sets_accepted += 1,
                    other => panic!("an estimation set got {other:?}"),
                }
            }
            _ => {}
        }
    }

    /// Every branch was reached (else the pools are too tame or too wild).
    fn assert_exercised(&self) {
        assert!(self.clears_acked > 20 && self.clears_no_unit > 20 && self.sensor_clears > 20, "{self:?}");
        assert!(self.wheel_sets_accepted > 5 && self.wheel_sets_out_of_range > 50, "{self:?}");
        assert!(self.sensor_sets_accepted > 5 && self.sensor_sets_out_of_range > 20, "{self:?}");
        assert!(self.refusals_unchanged > 100, "{self:?}");
    }
}

/// Records every message the simulator sends on its way to an in-process flight side:
/// the set-up (parameters, mode table, estimation), the timeline's uploads and arming, and
/// every sensor frame, so a fuzz can start from a flight that really is configured,
/// navigating and armed.
struct Recording {
    inner: sim_core::link::in_process::InProcess,
    sent: Vec<HostMsg>,
}

impl sim_core::link::FlightLink for Recording {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn hello(&mut self) -> anyhow::Result<sim_core::link::LinkInfo> {
        self.inner.hello()
    }
    fn request(&mut self, msg: &HostMsg) -> anyhow::Result<FswMsg> {
        self.sent.push(msg.clone());
        self.inner.request(msg)
    }
    fn step(&mut self, frame: &SensorFrame) -> anyhow::Result<acs_flight::link::StepReport> {
        self.sent.push(HostMsg::Sensor(*frame));
        self.inner.step(frame)
    }
}

/// The messages of the shipped day in the life's first 2000 s (its segments at 900 s
/// Sun, 1250 s nadir, 1520 s Cape Schmidt and 1900 s nadir), flown in-process.
fn day_in_the_life_messages() -> Vec<HostMsg> {
    use toml::{Table, Value};
    const CUT_S: f64 = 2000.0;
    let path = acs_tests::repo().join("scenarios/guidance/eo-day-in-the-life.toml");
    let mut sc: Table = std::fs::read_to_string(path).unwrap().parse().unwrap();
    sc.insert("duration_s".into(), Value::Float(CUT_S));
    let kept: Vec<Value> = sc["timeline"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["start_s"].as_float().unwrap() < CUT_S)
        .cloned()
        .collect();
    assert_eq!(kept.len(), 4);
    sc.insert("timeline".into(), Value::Array(kept));
    let sc = sim_core::scenario::Scenario::from_toml(&toml::to_string(&sc).unwrap()).unwrap();
    let mut link = Recording { inner: sim_core::link::in_process::InProcess::new(), sent: Vec::new() };
    let run = sim_core::runner::run(&sc, &mut link, false).unwrap();
    assert_eq!(run.summary.timeline.map(|t| (t.met, t.missed)), Some((4, 0)), "the recorded run meets its segments");
    link.sent
}

/// An armed timeline under random input. Each seed replays the recorded set-up of the
/// day in the life (mission modes, MEKF, GNSS navigation) up to its arming, which must
/// answer `TimelineArmed` with the checksum of the 4 segments sent; then the recorded
/// frames go on (one in 500 with a corrupted byte, its `seq` kept), with random timeline
/// messages among them (about one batch in 300 frames): random segment uploads (the
/// generator above, times near the latest fix), armings (mostly the staged prefix with its
/// checksum), clears, recorded segments, and the recorded pointings re-planned from the
/// latest fix and armed. Every other message is corrupted one time in twenty. Asserts: no
/// panic, one reply each (a frame: a step with finite commands, or a sequence refusal),
/// every arming armed or refused, the counters consistent; and that armed timelines do
/// step: segments switched (the segment in force moving on within one arming) and
/// segments met or missed are counted, each > 0 over the seeds, and some random armings
/// succeed.
#[test]
fn an_armed_timeline_steps_under_random_input() {
    let recorded = day_in_the_life_messages();
    let arm_at = recorded.iter().position(|m| matches!(m, HostMsg::ArmTimeline { .. })).expect("the run arms");
    let timeline: Vec<HostMsg> =
        recorded.iter().filter(|m| matches!(m, HostMsg::UploadTimelineSegment { .. })).cloned().collect();
    let seeds: u64 = std::env::var("ACS_FUZZ_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(8);
    let (mut switched, mut judged, mut armings) = (0u32, 0u32, 0u32);
    for seed in 0..seeds {
        let r = fuzz_armed(seed, &recorded[..=arm_at], &recorded[arm_at + 1..], &timeline);
        eprintln!(
            "seed {seed}: {} steps, {} refused frames, armed {} / refused {} {:?}, {} segments switched, {} met, {} missed",
            r.steps, r.stale, r.armed, r.rejected, r.faults, r.switched, r.met, r.missed
        );
        switched += r.switched;
        judged += r.met + r.missed;
        armings += r.armed;
    }
    eprintln!("over {seeds} seeds: {armings} armings, {switched} segments switched, {judged} met or missed");
    assert!(switched > 0 && judged > 0, "armed timelines must step: {switched} switched, {judged} judged");
    assert!(armings > 0, "some random armings succeed");
}

/// What one seed of [`an_armed_timeline_steps_under_random_input`] saw.
#[derive(Default)]
struct ArmedFuzz {
    steps: u32,
    stale: u32,
    armed: u32,
    rejected: u32,
    faults: std::collections::BTreeMap<String, u32>,
    switched: u32,
    met: u32,
    missed: u32,
}

fn fuzz_armed(seed: u64, setup: &[HostMsg], frames: &[HostMsg], timeline: &[HostMsg]) -> ArmedFuzz {
    let mut rng = ChaCha8Rng::seed_from_u64(0xA4E0 + seed);
    let mut s = Session::new(board::HOST, 1);
    let mut counter = || 0u32;
    let mut out = ArmedFuzz::default();
    for m in setup {
        let reply = s.handle(m, 0, &mut counter);
        if let HostMsg::ArmTimeline { crc32, .. } = m {
            assert_eq!(reply, Some(FswMsg::TimelineArmed { checksum: *crc32 }), "seed {seed}: the set-up arms");
        }
    }
    let (mut staged, mut fix) = (vec![None::<TimelineSegment>; MAX_TIMELINE_SEGMENTS], (9_500i32, 0.0f32));
    let mut last = acs_flight::link::TimelineTelemetry::default();
    for m in frames {
        if let HostMsg::Sensor(f) = m {
            fix = (f.gnss_j2000_days, f.gnss_j2000_s);
        }
        let mut batch = vec![m.clone()];
        if rng.random_range(0..300) == 0 {
            batch.splice(0..0, random_timeline_messages(&mut rng, &staged, fix, timeline));
        }
        for msg in batch {
            // Frames rarely: a corrupted GNSS time moves the on-board clock, and the
            // segments it passes are (rightly) counted missed, ending the timeline early.
            let msg = corrupt_sometimes(&mut rng, msg, if matches!(m, HostMsg::Sensor(_)) { 0.002 } else { 0.05 });
            let reply = s.handle(&msg, 0, &mut counter);
            match (&msg, reply) {
                (HostMsg::Sensor(f), Some(FswMsg::Step(r))) => {
                    out.steps += 1;
                    assert!(finite(&r.cmd), "seed {seed}: non-finite command for {f:?}");
                    let tl = r.timeline;
                    assert!(usize::from(tl.segments) <= MAX_TIMELINE_SEGMENTS && tl.in_force <= tl.segments, "{tl:?}");
                    // Within one arming (counters not reset), count the hand-overs and judgements.
                    if tl.segments == last.segments && tl.met >= last.met && tl.missed >= last.missed {
                        out.switched += u32::from(tl.in_force > last.in_force && last.in_force > 0);
                        out.met += u32::from(tl.met - last.met);
                        out.missed += u32::from(tl.missed - last.missed);
                    }
                    last = tl;
                }
                (HostMsg::Sensor(_), Some(FswMsg::Error(LinkError::StaleSequence { .. }))) => out.stale += 1,
                (HostMsg::Sensor(_), other) => panic!("seed {seed}: a sensor frame got {other:?}"),
                (HostMsg::ArmTimeline { .. }, Some(FswMsg::TimelineArmed { .. })) => {
                    out.armed += 1;
                    last = acs_flight::link::TimelineTelemetry::default();
                }
                (HostMsg::ArmTimeline { .. }, Some(FswMsg::TimelineRejected(e))) => {
                    out.rejected += 1;
                    *out.faults.entry(format!("{:?}", e.fault)).or_insert(0) += 1;
                }
                (HostMsg::UploadTimelineSegment { index, segment }, Some(FswMsg::Ack)) => {
                    staged[usize::from(*index)] = Some(*segment)
                }
                (HostMsg::ClearTimeline, Some(FswMsg::Ack)) => staged.iter_mut().for_each(|s| *s = None),
                (HostMsg::UploadTimelineSegment { .. }, Some(FswMsg::ParamsRejected(_))) => {}
                (m, other) => panic!("seed {seed}: {m:?} got {other:?}"),
            }
        }
    }
    out
}

/// Random timeline messages: a random segment (12 in 30), an arming (8 in 30; mostly of
/// the staged prefix with its checksum), a clear (1 in 30), one segment of the recorded
/// timeline (6 in 30), or the recorded timeline's pointings re-planned 300 s apart from
/// the latest fix, uploaded and armed with their checksum (3 in 30).
fn random_timeline_messages(
    rng: &mut ChaCha8Rng,
    staged: &[Option<TimelineSegment>],
    (days, s): (i32, f32),
    timeline: &[HostMsg],
) -> Vec<HostMsg> {
    let one = match rng.random_range(0..30) {
        0..=11 => {
            let index = rng.random_range(0..MAX_TIMELINE_SEGMENTS as u8 + 2);
            HostMsg::UploadTimelineSegment { index, segment: segment(rng, index, days, s) }
        }
        12..=19 => {
            let prefix = staged.iter().take_while(|s| s.is_some()).count() as u8;
            let count =
                if rng.random_bool(0.8) { prefix } else { rng.random_range(0..MAX_TIMELINE_SEGMENTS as u8 + 2) };
            let sent: Option<Vec<_>> = staged.iter().take(usize::from(count)).copied().collect();
            HostMsg::ArmTimeline { count, crc32: sent.and_then(|v| checksum(&v)).unwrap_or_else(|| rng.random()) }
        }
        // Rare: a clear ends the executing timeline, and this fuzz is of armed ones.
        20 => HostMsg::ClearTimeline,
        21..=26 => timeline[rng.random_range(0..timeline.len())].clone(),
        _ => return replanned(timeline, days, s),
    };
    vec![one]
}

/// The recorded timeline's segments moved to 300 s apart from `s` (the latest fix),
/// uploaded, then armed with their checksum.
fn replanned(timeline: &[HostMsg], days: i32, s: f32) -> Vec<HostMsg> {
    let segments: Vec<TimelineSegment> = timeline
        .iter()
        .enumerate()
        .filter_map(|(k, m)| match m {
            HostMsg::UploadTimelineSegment { segment, .. } => {
                Some(TimelineSegment { start_j2000_days: days, start_j2000_s: s + 300.0 * (k + 1) as f32, ..*segment })
            }
            _ => None,
        })
        .collect();
    let mut out: Vec<HostMsg> = segments
        .iter()
        .enumerate()
        .map(|(i, segment)| HostMsg::UploadTimelineSegment { index: i as u8, segment: *segment })
        .collect();
    out.push(HostMsg::ArmTimeline { count: segments.len() as u8, crc32: checksum(&segments).unwrap() });
    out
}

/// `msg`, with probability `p` with a random byte that still decodes (a frame's `seq`
/// kept).
fn corrupt_sometimes(rng: &mut ChaCha8Rng, msg: HostMsg, p: f64) -> HostMsg {
    if !rng.random_bool(p) {
        return msg;
    }
    let mut bytes = postcard::to_allocvec(&msg).unwrap();
    let i = rng.random_range(0..bytes.len());
    bytes[i] = rng.random();
    match (postcard::from_bytes::<HostMsg>(&bytes), &msg) {
        // A frame keeps its sequence number: one corrupted upwards would have every later
        // frame refused as stale (the main fuzz covers that).
        (Ok(HostMsg::Sensor(mut f)), HostMsg::Sensor(original)) => {
            f.seq = original.seq;
            HostMsg::Sensor(f)
        }
        (Ok(decoded), _) => decoded,
        (Err(_), _) => msg,
    }
}
