//! The flight side of a link session, independent of the transport, above [`crate::fsw`]:
//! the firmware's link task and the host's virtual flight computer (`sim-host serve`) both
//! feed it decoded [`HostMsg`]s and send back what it returns.

use crate::fsw::{FreezeError, Fsw};
use crate::link::{FswMsg, HostMsg, LinkError, PROTOCOL_VERSION, ResetCause, SensorFrame, StepReport, schema_hash};
use crate::params::PARAMS_VERSION;

/// Board identifiers reported in `HelloAck`.
pub mod board {
    pub const HOST: u8 = 0;
    pub const QEMU_MPS2_AN386: u8 = 1;
    pub const STM32F405: u8 = 2;
}

/// `Clone`: a copy of the whole flight computer's state (the simulator forks an in-process
/// run at an operating point, `sim-host margins`).
#[derive(Clone)]
pub struct Session {
    pub fsw: Fsw,
    board: u8,
    cost_counter_hz: u32,
    real_time: bool,
    /// Real-time mode: the control loop currently sends the safe command (`HOLD`) because
    /// no fresh sensor frame came (set by the loop; `true` until its first fresh frame).
    holding: bool,
    reset_cause: ResetCause,
    pub deadline_misses: u32,
    /// Reported in `HelloAck`: the firmware stores its measured stack high-water mark
    /// here before handing a `Hello` over (0 = not measured).
    pub stack_hwm_bytes: u32,
    /// Lockstep: `seq` of the last stepped frame of the current sequence (`None` at the
    /// start of one: after `Hello` or an accepted configuration).
    last_seq: Option<u32>,
    /// Lockstep frames refused since the last `Hello` (repeated or out-of-order `seq`).
    seq_refused: u32,
}

impl Session {
    pub const fn new(board: u8, cost_counter_hz: u32) -> Self {
        Self {
            fsw: Fsw::new(),
            board,
            cost_counter_hz,
            real_time: false,
            holding: true,
            reset_cause: ResetCause::PowerOn,
            deadline_misses: 0,
            stack_hwm_bytes: 0,
            last_seq: None,
            seq_refused: 0,
        }
    }

    /// The frequency of the cost counter, Hz (a board that measures its clock at start-up
    /// sets it after building the session in place).
    pub fn set_cost_counter_hz(&mut self, hz: u32) {
        self.cost_counter_hz = hz;
    }

    /// Record why the flight computer started (reported in every `HelloAck`).
    pub fn set_reset_cause(&mut self, cause: ResetCause) {
        self.reset_cause = cause;
    }

    /// True once the host asked for real-time mode (`StartRealTime`).
    pub fn real_time(&self) -> bool {
        self.real_time
    }

    /// The real-time loop tells the session whether it is in the safe hold; parameters
    /// are only accepted in real-time mode while it is.
    pub fn set_holding(&mut self, holding: bool) {
        self.holding = holding;
    }

    /// Parameter changes are refused while the real-time loop is stepping: a new set may
    /// change the control rate, the law or the actuator family mid-flight.
    fn params_locked(&self) -> bool {
        self.real_time && !self.holding
    }

    /// Handle one message. `frames_dropped`: the receiver's count, reported in steps;
    /// `counter`: reads the cost counter (wrapping), called right before and after the step.
    pub fn handle(&mut self, msg: &HostMsg, frames_dropped: u32, counter: &mut dyn FnMut() -> u32) -> Option<FswMsg> {
        match msg {
            HostMsg::Hello { protocol_version, schema_hash: h } => Some(if *protocol_version != PROTOCOL_VERSION {
                FswMsg::Error(LinkError::ProtocolVersion { flight: PROTOCOL_VERSION })
            } else if *h != schema_hash() {
                FswMsg::Error(LinkError::SchemaHash { flight: schema_hash() })
            } else {
                self.last_seq = None;
                self.seq_refused = 0;
                FswMsg::HelloAck {
                    protocol_version: PROTOCOL_VERSION,
                    schema_hash: schema_hash(),
                    params_version: PARAMS_VERSION,
                    cost_counter_hz: self.cost_counter_hz,
                    board: self.board,
                    reset_cause: self.reset_cause,
                    stack_hwm_bytes: self.stack_hwm_bytes,
                }
            }),
            HostMsg::UploadParams(_)
            | HostMsg::UploadModeParams { .. }
            | HostMsg::ArmModes(_)
            | HostMsg::ConfigureEstimation(_)
                if self.params_locked() =>
            {
                Some(FswMsg::Error(LinkError::RealTimeNotInHold))
            }
            HostMsg::UploadParams(p) => Some(match self.fsw.configure(p) {
                Ok(checksum) => self.restart_sequence(FswMsg::ParamsAccepted { checksum }),
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::Sensor(f) => Some(self.lockstep_step(f, frames_dropped, counter)),
            HostMsg::SetTarget { target_q_xyzw } => Some(match self.fsw.set_target(*target_q_xyzw) {
                Ok(()) => FswMsg::Ack,
                Err(_) => FswMsg::Error(LinkError::BadTarget),
            }),
            HostMsg::SetPointing(g) => Some(match self.fsw.set_pointing(g) {
                Ok(()) => FswMsg::Ack,
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::UploadModeParams { mode, params } => Some(match self.fsw.configure_mode(*mode, params) {
                Ok(checksum) => FswMsg::ParamsAccepted { checksum },
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::ConfigureEstimation(p) => Some(match self.fsw.configure_estimation(p) {
                Ok(checksum) => self.restart_sequence(FswMsg::ParamsAccepted { checksum }),
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::ArmModes(p) => Some(match self.fsw.arm_modes(p) {
                Ok(checksum) => self.restart_sequence(FswMsg::ModesArmed { checksum }),
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::CommandMode(r) => Some(match self.fsw.command_mode(*r) {
                Ok(mode) => FswMsg::ModeAccepted { mode },
                Err(_) => FswMsg::Error(LinkError::NoSuchMode),
            }),
            HostMsg::StartRealTime => {
                if self.fsw.is_configured() {
                    self.real_time = true;
                    None
                } else {
                    Some(FswMsg::Error(LinkError::NotConfigured))
                }
            }
            HostMsg::FreezeAdaptation { frozen } => Some(match self.fsw.freeze_adaptation(*frozen) {
                Ok(()) => FswMsg::Ack,
                Err(FreezeError::NotConfigured) => FswMsg::Error(LinkError::NotConfigured),
                Err(FreezeError::NotAdaptive) => FswMsg::Error(LinkError::NotAdaptive),
            }),
            // The hang itself is the firmware's (feature `debug-hang`); shared code never hangs.
            HostMsg::DebugHang => Some(FswMsg::Error(LinkError::DebugDisabled)),
            HostMsg::UploadTimelineSegment { .. } | HostMsg::ArmTimeline { .. } | HostMsg::ClearTimeline => {
                Some(self.timeline_message(msg))
            }
            HostMsg::ClearWheelFault { wheel } => Some(match self.fsw.clear_wheel_fault(*wheel) {
                Ok(()) => FswMsg::Ack,
                Err(_) => FswMsg::Error(LinkError::NoSuchUnit),
            }),
            HostMsg::ClearSensorFaults => {
                self.fsw.clear_sensor_faults();
                Some(FswMsg::Ack)
            }
        }
    }

    /// One frame, one step (lockstep): a frame whose `seq` is not above the last stepped
    /// one in this sequence is a repeat or arrived out of order (a duplicating link, a
    /// replay); stepping it would advance the flight state twice on one measurement and
    /// silently change every later command. It is refused without stepping, counted
    /// (`StepReport::seq_refused`) and answered `Error(StaleSequence)` so the host sees it.
    /// `seq` does not wrap within a sequence (u32 frames: 497 days at 100 Hz); a new
    /// sequence starts at `Hello` and at every accepted configuration, where the flight
    /// state restarts anyway (the timing search restarts its numbering there).
    fn lockstep_step(&mut self, f: &SensorFrame, frames_dropped: u32, counter: &mut dyn FnMut() -> u32) -> FswMsg {
        if let Some(last_seq) = self.last_seq
            && f.seq <= last_seq
        {
            self.seq_refused = self.seq_refused.saturating_add(1);
            return FswMsg::Error(LinkError::StaleSequence { seq: f.seq, last_seq });
        }
        self.last_seq = Some(f.seq);
        let t0 = counter();
        let cmd = self.fsw.step(f);
        let t1 = counter();
        FswMsg::Step(self.report(cmd, t1.wrapping_sub(t0), frames_dropped))
    }

    /// A configuration was accepted: the flight state restarted, so does the numbering.
    fn restart_sequence(&mut self, reply: FswMsg) -> FswMsg {
        self.last_seq = None;
        reply
    }

    pub fn report(&self, cmd: crate::link::ActuatorCommand, ticks: u32, frames_dropped: u32) -> StepReport {
        StepReport {
            cmd,
            step_cost_ticks: ticks,
            deadline_misses: self.deadline_misses,
            frames_dropped,
            seq_refused: self.seq_refused,
            timeline: self.timeline_telemetry(),
        }
    }

    /// The reply to a pointing-timeline message (protocol 19).
    fn timeline_message(&mut self, msg: &HostMsg) -> FswMsg {
        match msg {
            HostMsg::UploadTimelineSegment { index, segment } => {
                match self.fsw.stage_timeline_segment(*index, segment) {
                    Ok(()) => FswMsg::Ack,
                    Err(e) => FswMsg::ParamsRejected(e),
                }
            }
            HostMsg::ArmTimeline { count, crc32 } => match self.fsw.arm_timeline(*count, *crc32) {
                Ok(checksum) => FswMsg::TimelineArmed { checksum },
                Err(e) => FswMsg::TimelineRejected(e),
            },
            HostMsg::ClearTimeline => {
                self.fsw.clear_timeline();
                FswMsg::Ack
            }
            _ => FswMsg::Error(LinkError::UnexpectedMessage),
        }
    }

    /// The timeline counters of a step report.
    fn timeline_telemetry(&self) -> crate::link::TimelineTelemetry {
        let c = self.fsw.timeline_counters();
        crate::link::TimelineTelemetry {
            segments: u8::try_from(self.fsw.timeline().count()).unwrap_or(u8::MAX),
            in_force: c.in_force,
            met: c.met,
            missed: c.missed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{SensorFrame, status, valid};
    use crate::params::FlightParams;

    /// Timeline messages get one reply each: a segment beyond the table is refused naming
    /// the pointing, arming without a mission set says so, clearing is acknowledged.
    #[test]
    fn timeline_messages_are_answered() {
        use crate::params::{GuidanceParams, MAX_TIMELINE_SEGMENTS, TargetFrame, TimelineFault, TimelineSegment};
        let mut s = Session::new(board::HOST, 0);
        let mut c = || 0u32;
        let segment = TimelineSegment {
            start_j2000_days: 9_600,
            start_j2000_s: 100.0,
            guidance: GuidanceParams::fixed([0.0, 0.0, 0.0, 1.0], TargetFrame::Inertial),
        };
        let up = |index| HostMsg::UploadTimelineSegment { index, segment };
        assert_eq!(s.handle(&up(0), 0, &mut c), Some(FswMsg::Ack));
        let over = s.handle(&up(MAX_TIMELINE_SEGMENTS as u8), 0, &mut c);
        assert!(matches!(over, Some(FswMsg::ParamsRejected(_))), "{over:?}");
        let arm = s.handle(&HostMsg::ArmTimeline { count: 1, crc32: 0 }, 0, &mut c);
        assert!(
            matches!(arm, Some(FswMsg::TimelineRejected(e)) if e.fault == TimelineFault::NoMissionMode && e.index == 0),
            "{arm:?}"
        );
        assert_eq!(s.handle(&HostMsg::ClearTimeline, 0, &mut c), Some(FswMsg::Ack));
    }

    #[test]
    fn hello_checks_version_and_schema() {
        let mut s = Session::new(board::HOST, 0);
        let mut c = || 0u32;
        let ok =
            s.handle(&HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() }, 0, &mut c);
        assert!(matches!(ok, Some(FswMsg::HelloAck { board: 0, .. })));
        let bad =
            s.handle(&HostMsg::Hello { protocol_version: PROTOCOL_VERSION + 1, schema_hash: schema_hash() }, 0, &mut c);
        assert!(matches!(bad, Some(FswMsg::Error(LinkError::ProtocolVersion { .. }))));
        let bad =
            s.handle(&HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: !schema_hash() }, 0, &mut c);
        assert!(matches!(bad, Some(FswMsg::Error(LinkError::SchemaHash { .. }))));
    }

    #[test]
    fn step_reports_cost_and_answers_every_frame() {
        let mut s = Session::new(board::HOST, 1000);
        let mut t = 10u32;
        let mut c = || {
            t = t.wrapping_add(7);
            t
        };
        let f = SensorFrame { valid: valid::ALL, ..SensorFrame::empty(9, 0) };
        match s.handle(&HostMsg::Sensor(f), 3, &mut c) {
            Some(FswMsg::Step(r)) => {
                assert_eq!((r.cmd.seq, r.step_cost_ticks, r.frames_dropped), (9, 7, 3));
                assert_eq!(r.cmd.status, status::NOT_CONFIGURED);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(s.handle(&HostMsg::StartRealTime, 0, &mut c), Some(FswMsg::Error(LinkError::NotConfigured))));
        let mut p = FlightParams::default();
        assert!(matches!(s.handle(&HostMsg::UploadParams(p), 0, &mut c), Some(FswMsg::ParamsAccepted { .. })));
        p.control_rate_hz = -1.0;
        assert!(matches!(s.handle(&HostMsg::UploadParams(p), 0, &mut c), Some(FswMsg::ParamsRejected(_))));
    }

    /// Real-time mode: parameters are refused with a typed reason while the loop steps,
    /// leave the set in force untouched, and are accepted again in the safe hold.
    #[test]
    fn params_are_refused_in_real_time_unless_holding() {
        let mut s = Session::new(board::HOST, 1000);
        let mut c = || 0u32;
        let p = FlightParams::default();
        let Some(FswMsg::ParamsAccepted { checksum }) = s.handle(&HostMsg::UploadParams(p), 0, &mut c) else {
            panic!("default parameters refused")
        };
        assert_eq!(s.handle(&HostMsg::StartRealTime, 0, &mut c), None);
        assert!(s.real_time());
        // The loop starts in the hold (no frame yet): accepted.
        assert!(matches!(s.handle(&HostMsg::UploadParams(p), 0, &mut c), Some(FswMsg::ParamsAccepted { .. })));
        // Stepping: every configuration message is refused, the rate stays.
        s.set_holding(false);
        let mut faster = p;
        faster.control_rate_hz = p.control_rate_hz * 2.0;
        for msg in [
            HostMsg::UploadParams(faster),
            HostMsg::UploadModeParams { mode: crate::params::Mode::Hold, params: faster },
            HostMsg::ArmModes(crate::params::ModeManagerParams {
                slots: 0b1000,
                initial: crate::params::Mode::Hold,
                detumble_enter_rate_rad_s: 0.1,
                detumble_exit_rate_rad_s: 0.05,
                stabilise_exit_error_rad: 0.1,
                stabilise_exit_rate_rad_s: 0.01,
                hold_enter_error_rad: 0.01,
                hold_enter_rate_rad_s: 0.01,
                hold_exit_error_rad: 0.05,
                dwell_s: 1.0,
                trigger_persistence_s: 1.0,
                momentum_trip_fraction: 0.0,
                momentum_recover_fraction: 0.0,
                momentum_keepup_fraction: 0.0,
                gimbal_singularity_min: 0.0,
                slow_fdir_persistence_s: 0.0,
            }),
        ] {
            assert_eq!(s.handle(&msg, 0, &mut c), Some(FswMsg::Error(LinkError::RealTimeNotInHold)), "{msg:?}");
        }
        assert_eq!(s.fsw.params().map(|q| q.control_rate_hz), Some(p.control_rate_hz));
        assert_eq!(s.fsw.params().map(|q| q.checksum().ok()), Some(Some(checksum)));
        // Other messages still work while stepping.
        assert!(matches!(
            s.handle(&HostMsg::SetTarget { target_q_xyzw: [0.0, 0.0, 0.0, 1.0] }, 0, &mut c),
            Some(FswMsg::Ack)
        ));
        // Back in the hold: accepted, the new rate is in force.
        s.set_holding(true);
        assert!(matches!(s.handle(&HostMsg::UploadParams(faster), 0, &mut c), Some(FswMsg::ParamsAccepted { .. })));
        assert_eq!(s.fsw.params().map(|q| q.control_rate_hz), Some(faster.control_rate_hz));
        // Lockstep sessions are never locked, whatever the flag says.
        let mut l = Session::new(board::HOST, 1000);
        l.set_holding(false);
        assert!(matches!(l.handle(&HostMsg::UploadParams(faster), 0, &mut c), Some(FswMsg::ParamsAccepted { .. })));
    }

    fn frame(seq: u32) -> SensorFrame {
        SensorFrame {
            valid: valid::ALL,
            q_ib_xyzw: [0.1, -0.2, 0.3, 0.927],
            rate_rad_s: [0.01, 0.002 * seq as f32, -0.02],
            ..SensorFrame::empty(seq, 10_000 * u64::from(seq))
        }
    }

    fn step(s: &mut Session, seq: u32) -> Option<FswMsg> {
        s.handle(&HostMsg::Sensor(frame(seq)), 0, &mut || 0u32)
    }

    /// `FreezeAdaptation`: refused with a typed reason without a law or with one that does
    /// not adapt; with DMCS, acknowledged without resetting the law (the gains stay, the
    /// sequence goes on), Δk_p constant in telemetry while frozen and adapting again after.
    #[test]
    fn freeze_adaptation_keeps_the_dmcs_state() {
        use crate::params::{ControllerParams, DmcsParams};
        let mut s = Session::new(board::HOST, 0);
        let freeze = |s: &mut Session, frozen| s.handle(&HostMsg::FreezeAdaptation { frozen }, 0, &mut || 0);
        assert_eq!(freeze(&mut s, true), Some(FswMsg::Error(LinkError::NotConfigured)));
        let up = |s: &mut Session, p| s.handle(&HostMsg::UploadParams(p), 0, &mut || 0);
        assert!(matches!(up(&mut s, FlightParams::default()), Some(FswMsg::ParamsAccepted { .. })));
        assert_eq!(freeze(&mut s, true), Some(FswMsg::Error(LinkError::NotAdaptive)));
        let dmcs = DmcsParams {
            wn_rad_s: 0.05,
            zeta: 0.95,
            model_inertia_kgm2: [400.0; 3],
            alpha: 55.0,
            beta: 220.0,
            q_weights: [0.1, 1.0],
            gain_limit: 1e7,
            torque_limit_nm: [1e3; 3],
        };
        let p = FlightParams { controller: ControllerParams::Dmcs(dmcs), ..FlightParams::default() };
        assert!(matches!(up(&mut s, p), Some(FswMsg::ParamsAccepted { .. })));
        let gains = |r: Option<FswMsg>| match r {
            Some(FswMsg::Step(r)) => crate::link::law_slots::dmcs_proportional_gain(&r.cmd.law_telemetry),
            other => panic!("{other:?}"),
        };
        let mut last = [[0.0; 2]; 3];
        for seq in 1..10 {
            last = gains(step(&mut s, seq));
        }
        assert!(last.iter().flatten().any(|k| *k != 0.0), "adapted: {last:?}");
        assert_eq!(freeze(&mut s, true), Some(FswMsg::Ack));
        let frozen = gains(step(&mut s, 10));
        for seq in 11..20 {
            assert_eq!(gains(step(&mut s, seq)), frozen, "frozen at step {seq}");
        }
        assert_eq!(freeze(&mut s, false), Some(FswMsg::Ack));
        assert_ne!(gains(step(&mut s, 20)), frozen, "adapting again");
    }

    /// One frame, one step: repeats and older frames are refused with their `seq` and the
    /// last stepped one, counted, and leave the flight state alone — the commands after
    /// them are bit-identical to a session that never saw them (the reference). Gaps are
    /// allowed; `Hello` and an accepted configuration start a new sequence.
    #[test]
    fn repeated_or_old_frames_are_refused_without_stepping() {
        let (mut s, mut reference) = (Session::new(board::HOST, 0), Session::new(board::HOST, 0));
        for x in [&mut s, &mut reference] {
            assert!(matches!(
                x.handle(&HostMsg::UploadParams(FlightParams::default()), 0, &mut || 0),
                Some(FswMsg::ParamsAccepted { .. })
            ));
        }
        let (mut refused, mut model_last) = (0, None::<u32>);
        for seq in [1u32, 2, 2, 3, 1, 5, 5, 4, 6] {
            // The model: stepped iff above every frame stepped before.
            let expect_step = model_last.is_none_or(|l| seq > l);
            match step(&mut s, seq) {
                Some(FswMsg::Step(r)) => {
                    assert!(expect_step, "frame {seq} stepped after {model_last:?}");
                    model_last = Some(seq);
                    let Some(FswMsg::Step(want)) = step(&mut reference, seq) else { panic!("reference refused {seq}") };
                    assert_eq!(r.cmd, want.cmd, "frame {seq}: state changed by a refused frame");
                    assert_eq!((r.cmd.seq, r.seq_refused), (seq, refused));
                }
                Some(FswMsg::Error(LinkError::StaleSequence { seq: q, last_seq })) => {
                    assert!(!expect_step, "frame {seq} refused after {model_last:?}");
                    refused += 1;
                    assert_eq!((q, Some(last_seq)), (seq, model_last));
                }
                other => panic!("frame {seq}: {other:?}"),
            }
        }
        // Refused: the second 2, the 1, the second 5 and the 4.
        assert_eq!(refused, 4);
        // A new configuration restarts the numbering (frame 1 accepted again), the count stays.
        assert!(matches!(
            s.handle(&HostMsg::UploadParams(FlightParams::default()), 0, &mut || 0),
            Some(FswMsg::ParamsAccepted { .. })
        ));
        assert!(matches!(step(&mut s, 1), Some(FswMsg::Step(r)) if r.seq_refused == 4));
        assert!(matches!(step(&mut s, 1), Some(FswMsg::Error(LinkError::StaleSequence { seq: 1, last_seq: 1 }))));
        // A rejected configuration does not.
        let bad = FlightParams { control_rate_hz: -1.0, ..FlightParams::default() };
        assert!(matches!(s.handle(&HostMsg::UploadParams(bad), 0, &mut || 0), Some(FswMsg::ParamsRejected(_))));
        assert!(matches!(step(&mut s, 1), Some(FswMsg::Error(LinkError::StaleSequence { .. }))));
        // Hello: new sequence and a zero count.
        let hello = HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() };
        assert!(matches!(s.handle(&hello, 0, &mut || 0), Some(FswMsg::HelloAck { .. })));
        assert!(matches!(step(&mut s, 0), Some(FswMsg::Step(r)) if r.seq_refused == 0 && r.cmd.seq == 0));
    }

    #[test]
    fn hello_reports_the_reset_cause_and_debug_hang_is_refused() {
        let mut s = Session::new(board::HOST, 0);
        let mut c = || 0u32;
        let hello = HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() };
        assert!(matches!(s.handle(&hello, 0, &mut c), Some(FswMsg::HelloAck { reset_cause: ResetCause::PowerOn, .. })));
        s.set_reset_cause(ResetCause::Watchdog);
        assert!(matches!(
            s.handle(&hello, 0, &mut c),
            Some(FswMsg::HelloAck { reset_cause: ResetCause::Watchdog, .. })
        ));
        assert_eq!(s.handle(&HostMsg::DebugHang, 0, &mut c), Some(FswMsg::Error(LinkError::DebugDisabled)));
    }
}
