use super::{FlightLink, LinkInfo};
use acs_flight::Fsw;
use acs_flight::params::FlightParams;
use acs_flight::protocol::{SensorFrame, StepReport};
use anyhow::{Result, anyhow};

/// The flight code called directly, in this process.
pub struct InProcess {
    fsw: Fsw,
}

impl InProcess {
    pub fn new() -> Self {
        Self { fsw: Fsw::new() }
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
        // The step is timed with the host's monotonic clock, in nanoseconds.
        Ok(LinkInfo { board: 0, cost_counter_hz: 1_000_000_000, instructions_per_tick: None })
    }
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        self.fsw.configure(params).map_err(|e| anyhow!("flight code rejected the parameters: {e}"))
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        // Reading the clock costs as much as a fifth of a step here: time one step in
        // eight (0 = not measured; the statistics skip those).
        if !frame.seq.is_multiple_of(8) {
            return Ok(StepReport { cmd: self.fsw.step(frame), ..Default::default() });
        }
        let t0 = std::time::Instant::now();
        let cmd = self.fsw.step(frame);
        let ns = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        Ok(StepReport { cmd, step_cost_ticks: ns.max(1), ..Default::default() })
    }
}
