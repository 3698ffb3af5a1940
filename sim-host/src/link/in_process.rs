use super::{FlightLink, LinkInfo};
use acs_flight::link::session::{Session, board};
use acs_flight::link::{FswMsg, HostMsg, LinkError, SensorFrame, StepReport};
use anyhow::Result;

/// The flight code called directly, in this process, through the same `Session` as the
/// firmware (no serialisation).
pub struct InProcess {
    session: Session,
}

impl InProcess {
    pub fn new() -> Self {
        // The step is timed with the host's monotonic clock, in nanoseconds.
        Self { session: Session::new(board::HOST, 1_000_000_000) }
    }
}

impl Default for InProcess {
    fn default() -> Self {
        Self::new()
    }
}

impl FlightLink for InProcess {
    fn name(&self) -> String {
        "in-process".into()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        Ok(LinkInfo {
            board: board::HOST,
            cost_counter_hz: 1_000_000_000,
            instructions_per_tick: None,
            reset_cause: acs_flight::link::ResetCause::PowerOn,
            stack_hwm_bytes: 0,
        })
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        let mut no_counter = || 0u32;
        Ok(self.session.handle(msg, 0, &mut no_counter).unwrap_or(FswMsg::Error(LinkError::UnexpectedMessage)))
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        // Reading the clock costs as much as a fifth of a step here: time one step in
        // eight (0 = not measured; the statistics skip those).
        if !frame.seq.is_multiple_of(8) {
            return Ok(StepReport { cmd: self.session.fsw.step(frame), ..Default::default() });
        }
        let t0 = std::time::Instant::now();
        let cmd = self.session.fsw.step(frame);
        let ns = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        Ok(StepReport { cmd, step_cost_ticks: ns.max(1), ..Default::default() })
    }
}
