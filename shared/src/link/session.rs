//! The flight side of a link session, independent of the transport: the firmware's link
//! task and the host's virtual flight computer (`sim-host serve`) both feed it decoded
//! [`HostMsg`]s and send back what it returns.

use crate::fsw::Fsw;
use crate::link::{FswMsg, HostMsg, LinkError, PROTOCOL_VERSION, StepReport, schema_hash};
use crate::params::PARAMS_VERSION;

/// Board identifiers reported in `HelloAck`.
pub mod board {
    pub const HOST: u8 = 0;
    pub const QEMU_MPS2_AN386: u8 = 1;
    pub const STM32F405: u8 = 2;
}

pub struct Session {
    pub fsw: Fsw,
    board: u8,
    cost_counter_hz: u32,
    real_time: bool,
    pub deadline_misses: u32,
    /// Reported in `HelloAck`: the firmware stores its measured stack high-water mark
    /// here before handing a `Hello` over (0 = not measured).
    pub stack_hwm_bytes: u32,
}

impl Session {
    pub const fn new(board: u8, cost_counter_hz: u32) -> Self {
        Self { fsw: Fsw::new(), board, cost_counter_hz, real_time: false, deadline_misses: 0, stack_hwm_bytes: 0 }
    }

    /// True once the host asked for real-time mode (`StartRealTime`).
    pub fn real_time(&self) -> bool {
        self.real_time
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
                FswMsg::HelloAck {
                    protocol_version: PROTOCOL_VERSION,
                    schema_hash: schema_hash(),
                    params_version: PARAMS_VERSION,
                    cost_counter_hz: self.cost_counter_hz,
                    board: self.board,
                    stack_hwm_bytes: self.stack_hwm_bytes,
                }
            }),
            HostMsg::UploadParams(p) => Some(match self.fsw.configure(p) {
                Ok(checksum) => FswMsg::ParamsAccepted { checksum },
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::Sensor(f) => {
                let t0 = counter();
                let cmd = self.fsw.step(f);
                let t1 = counter();
                Some(FswMsg::Step(self.report(cmd, t1.wrapping_sub(t0), frames_dropped)))
            }
            HostMsg::SetTarget { target_q_xyzw } => Some(match self.fsw.set_target(*target_q_xyzw) {
                Ok(()) => FswMsg::Ack,
                Err(_) => FswMsg::Error(LinkError::BadTarget),
            }),
            HostMsg::UploadModeParams { mode, params } => Some(match self.fsw.configure_mode(*mode, params) {
                Ok(checksum) => FswMsg::ParamsAccepted { checksum },
                Err(e) => FswMsg::ParamsRejected(e),
            }),
            HostMsg::ArmModes(p) => Some(match self.fsw.arm_modes(p) {
                Ok(checksum) => FswMsg::ModesArmed { checksum },
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
        }
    }

    pub fn report(&self, cmd: crate::link::ActuatorCommand, ticks: u32, frames_dropped: u32) -> StepReport {
        StepReport { cmd, step_cost_ticks: ticks, deadline_misses: self.deadline_misses, frames_dropped }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{SensorFrame, status, valid};
    use crate::params::FlightParams;

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
}
