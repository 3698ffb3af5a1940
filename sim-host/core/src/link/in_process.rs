//! The in-process link (SIL): the flight code called directly, through the same `Session`
//! as the firmware, with no serialisation.

use super::{FlightLink, LinkInfo};
use acs_flight::link::{FswMsg, HostMsg, LinkError, SensorFrame, StepReport};
use acs_flight::session::{Session, board};
use anyhow::{Result, bail};

/// The flight code called directly, in this process, through the same `Session` as the
/// firmware (no serialisation).
#[derive(Clone)]
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
        // Through `Session::handle` like every other link (one frame, one step: the same
        // sequence check as the firmware). Reading the clock costs as much as a fifth of a
        // step here: time one step in eight (0 = not measured; the statistics skip those).
        let timed = frame.seq.is_multiple_of(8);
        let t0 = timed.then(std::time::Instant::now);
        let mut clock = || t0.map_or(0, |t| t.elapsed().as_nanos().min(u128::from(u32::MAX)) as u32);
        match self.session.handle(&HostMsg::Sensor(*frame), 0, &mut clock) {
            Some(FswMsg::Step(mut r)) => {
                if timed {
                    r.step_cost_ticks = r.step_cost_ticks.max(1);
                }
                Ok(r)
            }
            Some(FswMsg::Error(e)) => bail!("in-process: the flight code refused frame {}: {e:?}", frame.seq),
            other => bail!("in-process: unexpected answer to frame {}: {other:?}", frame.seq),
        }
    }
    fn fork(&self) -> Option<Box<dyn FlightLink>> {
        Some(Box::new(self.clone()))
    }
}
