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
        Ok(LinkInfo { board: 0, cost_counter_hz: 0, instructions_per_tick: None })
    }
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        self.fsw.configure(params).map_err(|e| anyhow!("flight code rejected the parameters: {e}"))
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        Ok(StepReport { cmd: self.fsw.step(frame), ..Default::default() })
    }
}
