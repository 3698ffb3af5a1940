//! The wheel FDIR wired into the flight step (issue 42; docs/fdir.md "Wiring"), against a
//! rigid body with four pyramid wheels integrated here in f64 (independent of the flight
//! code): the motors hold each step's command over the next control period; the body's
//! rate follows `J ω̇ = −Σ aᵢ τᵢ` (started at rest with the wheels at rest, the gyroscopic
//! term stays below 10⁻¹⁰ N m over the test and is left out), each rotor's relative speed
//! `ω̇_wᵢ = τᵢ / I_w − aᵢᵀ ω̇`. The frame carries a fixed 5° attitude error so the law asks
//! for a steady torque.
//! (a) healthy: no event over 200 steps; every residual below 10⁻⁹ N m (f32 rounding);
//! (b) a seized rotor (τ = 0) is declared after exactly k steps, isolated to its rotor, and
//!     from that step its command is 0 and its drive switched off while the realised torque
//!     still equals the demand (three wheels span the body);
//! (c) a frozen tachometer (rotor healthy) is declared after k steps and isolated to the
//!     tachometer;
//! (d) a repeated frame (same time) or a frame without wheel speeds is not judged;
//! (e) the ground clears the fault (the wheel commanded again) and an index beyond the
//!     wheels is refused with nothing changed.

use acs_flight::fsw::Fsw;
use acs_flight::link::{ActuatorCommand, FswMsg, HostMsg, LinkError, SensorFrame, valid};
use acs_flight::math::{EulerSeq, quat_from_euler, quat_to_xyzw};
use acs_flight::params::fdir::{FdirParams, KOfN, WheelFdirParams, WheelResidualNoise};
use acs_flight::params::{
    ActuatorParams, ControllerParams, FlightParams, QuaternionFeedbackParams, TargetFrame, WheelParams,
};
use acs_flight::session::Session;
use acs_flight::types::MAX_WHEELS;

const DT_S: f64 = 0.25;
const I_W: f64 = 1.6e-5;
const J: [f64; 3] = [0.18, 0.14, 0.06];
const K: u8 = 4;

fn pyramid_axes() -> [[f64; 3]; 4] {
    let (s, c) = (54.73f64.to_radians().sin(), 54.73f64.to_radians().cos());
    [[s, 0.0, c], [0.0, s, c], [-s, 0.0, c], [0.0, -s, c]]
}

fn params() -> FlightParams {
    let mut axes = [[0.0f32; 3]; MAX_WHEELS];
    for (a, p) in axes.iter_mut().zip(pyramid_axes()) {
        *a = p.map(|x| x as f32);
    }
    let wheels = WheelParams {
        count: 4,
        axes,
        max_torque_nm: 2e-3,
        max_speed_rad_s: 628.0,
        inertia_kgm2: I_W as f32,
        null_gain_per_s: 0.0,
        bias_speed_rad_s: [0.0; MAX_WHEELS],
        failed_mask: 0,
    };
    let diag = |v: [f64; 3], k: f64| {
        let mut m = [[0.0f32; 3]; 3];
        for (i, x) in v.iter().enumerate() {
            m[i][i] = (x * k) as f32;
        }
        m
    };
    let fdir = WheelFdirParams {
        noise: WheelResidualNoise { tach_sigma_rad_s: 0.0, tach_lsb_rad_s: 6.1e-5, gyro_sigma_rad_s: 1e-7 },
        threshold_sigma: 6.0,
        floor_nm: 5e-8,
        window: KOfN { k: K, n: 6 },
        isolation_min_ratio: 3.0,
        body_torque_sigma_nm: 0.0,
    };
    FlightParams {
        control_rate_hz: (1.0 / DT_S) as f32,
        inertia_kgm2: diag(J, 1.0),
        controller: ControllerParams::QuaternionFeedback(QuaternionFeedbackParams {
            k_att_nm: diag(J, 0.08),
            d_rate_nms: diag(J, 0.72),
            ki_att_nm_s: [[0.0; 3]; 3],
            integral_limit_s: 0.0,
            torque_limit_nm: [1.5e-3; 3],
            gyro_compensation: false,
            max_slew_rate_rad_s: 0.0,
        }),
        actuator: ActuatorParams::Wheels(wheels),
        guidance: acs_flight::params::GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial),
        fdir: FdirParams { wheel: Some(fdir) },
        ..FlightParams::default()
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Fault {
    None,
    Seized(usize),
    TachFrozen(usize),
}

/// The body and its wheels, f64.
struct Truth {
    rate: [f64; 3],
    speed: [f64; 4],
    tach_frozen_at: Option<f64>,
    time_us: u64,
    seq: u32,
}

impl Truth {
    fn new() -> Self {
        Self { rate: [0.0; 3], speed: [0.0; 4], tach_frozen_at: None, time_us: 1_000_000, seq: 1 }
    }

    fn frame(&self, fault: Fault) -> SensorFrame {
        let q = quat_from_euler([0.05, -0.04, 0.06], EulerSeq::Zyx321);
        let mut speeds = [0.0f32; MAX_WHEELS];
        for (s, w) in speeds.iter_mut().zip(self.speed) {
            *s = w as f32;
        }
        if let (Fault::TachFrozen(j), Some(v)) = (fault, self.tach_frozen_at) {
            speeds[j] = v as f32;
        }
        SensorFrame {
            q_ib_xyzw: quat_to_xyzw(&q),
            rate_rad_s: self.rate.map(|x| x as f32),
            wheel_speed_rad_s: speeds,
            valid: valid::ATTITUDE | valid::RATE | valid::WHEELS,
            ..SensorFrame::empty(self.seq, self.time_us)
        }
    }

    /// The motors hold `cmd` over one control period.
    fn advance(&mut self, cmd: &ActuatorCommand, fault: Fault) {
        let axes = pyramid_axes();
        let mut tau = [0.0f64; 4];
        for (i, t) in tau.iter_mut().enumerate() {
            *t = f64::from(cmd.wheel_torque_cmd_nm[i]);
        }
        if let Fault::Seized(j) = fault {
            tau[j] = 0.0;
        }
        let mut body = [0.0f64; 3];
        for (a, t) in axes.iter().zip(tau) {
            for k in 0..3 {
                body[k] -= a[k] * t;
            }
        }
        let dw: [f64; 3] = std::array::from_fn(|k| body[k] / J[k] * DT_S);
        for (i, (a, t)) in axes.iter().zip(tau).enumerate() {
            let axial: f64 = (0..3).map(|k| a[k] * dw[k]).sum();
            if !matches!(fault, Fault::Seized(j) if j == i) {
                self.speed[i] += t / I_W * DT_S - axial;
            } else {
                self.speed[i] -= axial; // seized: the rotor holds its absolute speed
            }
        }
        for (r, d) in self.rate.iter_mut().zip(dw) {
            *r += d;
        }
        self.time_us += (DT_S * 1e6) as u64;
        self.seq += 1;
    }
}

/// Flies `steps` steps with `fault` from step `onset`; returns every command.
fn fly(fsw: &mut Fsw, truth: &mut Truth, steps: usize, onset: usize, fault: Fault) -> Vec<ActuatorCommand> {
    (0..steps)
        .map(|k| {
            let f = if k >= onset { fault } else { Fault::None };
            if let Fault::TachFrozen(j) = f
                && truth.tach_frozen_at.is_none()
            {
                truth.tach_frozen_at = Some(truth.speed[j]);
            }
            let cmd = fsw.step(&truth.frame(f));
            truth.advance(&cmd, f);
            cmd
        })
        .collect()
}

fn configured() -> Fsw {
    let mut fsw = Fsw::new();
    fsw.configure(&params()).expect("valid parameters");
    fsw
}

#[test]
fn a_healthy_array_raises_nothing() {
    let mut fsw = configured();
    let cmds = fly(&mut fsw, &mut Truth::new(), 200, usize::MAX, Fault::None);
    assert!(cmds.iter().all(|c| c.fdir.events == 0 && c.fdir.failed_wheels == 0));
    let judged: Vec<_> = cmds.iter().filter(|c| c.fdir.wheel_judged).collect();
    assert_eq!(judged.len(), 199, "every step after the first is judged");
    let worst = judged.iter().flat_map(|c| c.fdir.wheel_residual_nm).fold(0.0f32, |a, r| a.max(r.abs()));
    // Commands ~1e-5 N m: the residual is f32 rounding of speeds ~1e2 rad/s times I_w/Δt.
    assert!(worst < 1e-9, "healthy residual {worst:e} N m");
    assert!(
        cmds[10].wheel_torque_cmd_nm.iter().take(4).all(|u| u.abs() > 1e-6),
        "the law commands every wheel: {:?}",
        cmds[10].wheel_torque_cmd_nm
    );
}

#[test]
fn a_seized_rotor_is_declared_after_k_steps_isolated_and_dropped() {
    let mut fsw = configured();
    let onset = 20;
    let cmds = fly(&mut fsw, &mut Truth::new(), 60, onset, Fault::Seized(2));
    // The first step that sees the seized period is onset + 1; declared k steps later.
    let first = cmds.iter().position(|c| c.fdir.failed_wheels != 0).expect("declared");
    assert_eq!(first, onset + usize::from(K), "declared at step {first}");
    let c = &cmds[first];
    assert_eq!((c.fdir.failed_wheels, c.fdir.events), (0b0100, 1));
    assert_eq!(c.fdir.tachometer_wheels, 0, "a seized rotor is not its tachometer");
    assert_eq!(c.fdir.ambiguous_wheels, 0, "|r| ~ 1e-5 N m is far above the body noise (σ_m ~ 1e-7 N m)");
    assert!(cmds[..first].iter().all(|c| c.wheel_power_off == 0));
    for c in &cmds[first..] {
        assert_eq!(c.wheel_torque_cmd_nm[2], 0.0, "the dropped wheel is not commanded");
        assert_eq!(c.wheel_power_off, 0b0100, "and its drive is switched off");
        let (d, r) = (c.torque_demand_nm, c.torque_realised_nm);
        let err = (0..3).map(|k| (d[k] - r[k]).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-9, "three wheels realise the demand: {d:?} vs {r:?}");
    }
    assert_eq!(cmds.last().map(|c| c.fdir.events), Some(1), "one event, not one per step");
}

#[test]
fn a_frozen_tachometer_is_isolated_to_the_tachometer() {
    let mut fsw = configured();
    let onset = 20;
    let cmds = fly(&mut fsw, &mut Truth::new(), 40, onset, Fault::TachFrozen(1));
    let first = cmds.iter().position(|c| c.fdir.failed_wheels != 0).expect("declared");
    // The tachometer freezes at step `onset`'s reading: the first differing sample is the
    // next step's, declared k steps after `onset` like the seized rotor.
    assert_eq!(first, onset + usize::from(K), "declared at step {first}");
    let c = &cmds[first];
    assert_eq!((c.fdir.failed_wheels, c.fdir.tachometer_wheels, c.fdir.ambiguous_wheels), (0b0010, 0b0010, 0));
}

#[test]
fn repeated_or_incomplete_frames_are_not_judged() {
    let mut fsw = configured();
    let mut truth = Truth::new();
    let _ = fly(&mut fsw, &mut truth, 5, usize::MAX, Fault::None);
    let mut again = truth.frame(Fault::None);
    let c = fsw.step(&again);
    assert!(c.fdir.wheel_judged, "a fresh frame is judged");
    again.seq += 1; // same time: a repeated frame
    assert!(!fsw.step(&again).fdir.wheel_judged);
    again.seq += 1;
    again.time_us += 250_000;
    again.valid = valid::ATTITUDE | valid::RATE;
    assert!(!fsw.step(&again).fdir.wheel_judged, "no wheel speeds");
}

#[test]
fn the_ground_clears_a_fault_and_a_bad_index_is_refused() {
    let mut s = Session::new(0, 0);
    assert!(matches!(s.handle(&HostMsg::UploadParams(params()), 0, &mut || 0), Some(FswMsg::ParamsAccepted { .. })));
    // Seize wheel 0 through the session's own Fsw: fly on a copy of the session's steps.
    let mut truth = Truth::new();
    let mut last = ActuatorCommand::default();
    for k in 0..30 {
        let fault = if k >= 10 { Fault::Seized(0) } else { Fault::None };
        let Some(FswMsg::Step(r)) = s.handle(&HostMsg::Sensor(truth.frame(fault)), 0, &mut || 0) else {
            panic!("step {k}")
        };
        truth.advance(&r.cmd, fault);
        last = r.cmd;
    }
    assert_eq!(last.fdir.failed_wheels, 0b0001);
    let bad = s.handle(&HostMsg::ClearWheelFault { wheel: MAX_WHEELS as u8 }, 0, &mut || 0);
    assert_eq!(bad, Some(FswMsg::Error(LinkError::NoSuchUnit)));
    assert_eq!(s.handle(&HostMsg::ClearWheelFault { wheel: 0 }, 0, &mut || 0), Some(FswMsg::Ack));
    let Some(FswMsg::Step(r)) = s.handle(&HostMsg::Sensor(truth.frame(Fault::None)), 0, &mut || 0) else {
        panic!("step after the clear")
    };
    assert_eq!(r.cmd.fdir.failed_wheels, 0, "re-enabled");
    assert_ne!(r.cmd.wheel_torque_cmd_nm[0], 0.0, "commanded again");
    assert_eq!(r.cmd.fdir.events, 1, "the event stays counted");
}
