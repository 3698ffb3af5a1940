//! The telemetry tap: a [`FlightLink`] that wraps another and hands every request and
//! every step (the frame sent and the `StepReport` answered: the command, with the `seq`
//! of the frame it answers, step cost, link counters) to a hook before the simulation sees
//! the reply. Tools and the Python package read every step's telemetry (commands, step
//! cost, link counters) through it; tests also use it to alter a reply (fault injection)
//! and check what the host makes of it.

use super::{FlightLink, LinkAnomalies, LinkInfo, ModeTable};
use acs_flight::link::{FswMsg, HostMsg, SensorFrame, StepReport};
use acs_flight::params::{EstimationParams, FlightParams};
use anyhow::Result;

/// What the hook of a [`Tap`] sees.
pub enum Tapped<'a> {
    /// A request (ground command, mode command, ...) about to be sent after the set-up.
    Request(&'a HostMsg),
    /// A step: the frame sent and the reply, which the hook may alter.
    Step(&'a SensorFrame, &'a mut StepReport),
}

impl<'a> Tapped<'a> {
    /// The step reply, for hooks that only look at those.
    pub fn reply(self) -> Option<&'a mut StepReport> {
        match self {
            Tapped::Step(_, r) => Some(r),
            Tapped::Request(_) => None,
        }
    }
}

/// A link that calls `hook` on every request and every step of `inner` (see [`Tapped`]);
/// hello, uploads and link counters pass through untouched.
pub struct Tap<L, F> {
    inner: L,
    hook: F,
}

impl<L: FlightLink, F: FnMut(Tapped<'_>)> Tap<L, F> {
    pub fn new(inner: L, hook: F) -> Self {
        Self { inner, hook }
    }

    /// The wrapped link, back.
    pub fn into_inner(self) -> L {
        self.inner
    }
}

impl<L: FlightLink, F: FnMut(Tapped<'_>)> FlightLink for Tap<L, F> {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        self.inner.hello()
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        (self.hook)(Tapped::Request(msg));
        self.inner.request(msg)
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        let mut reply = self.inner.step(frame)?;
        (self.hook)(Tapped::Step(frame, &mut reply));
        Ok(reply)
    }
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        self.inner.upload(params)
    }
    fn upload_modes(&mut self, table: &ModeTable) -> Result<u32> {
        self.inner.upload_modes(table)
    }
    fn configure_estimation(&mut self, p: &EstimationParams) -> Result<u32> {
        self.inner.configure_estimation(p)
    }
    fn frames_dropped_host(&self) -> u32 {
        self.inner.frames_dropped_host()
    }
    fn anomalies(&self) -> LinkAnomalies {
        self.inner.anomalies()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stand-in flight side: answers each frame with its `seq` and counts requests.
    struct Echo {
        requests: u32,
    }

    impl FlightLink for Echo {
        fn name(&self) -> String {
            "echo".into()
        }
        fn hello(&mut self) -> Result<LinkInfo> {
            anyhow::bail!("not used")
        }
        fn request(&mut self, _msg: &HostMsg) -> Result<FswMsg> {
            self.requests += 1;
            Ok(FswMsg::ParamsAccepted { checksum: 7 })
        }
        fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
            let mut r = StepReport::default();
            r.cmd.seq = frame.seq;
            Ok(r)
        }
        fn frames_dropped_host(&self) -> u32 {
            5
        }
    }

    /// The hook sees every step reply, in order; what it changes is what the caller gets;
    /// everything else passes through.
    #[test]
    fn the_hook_sees_and_may_alter_every_step_reply() {
        let (mut seen, mut requests) = (Vec::new(), 0);
        let mut tap = Tap::new(Echo { requests: 0 }, |t: Tapped<'_>| match t {
            Tapped::Step(frame, reply) => {
                assert_eq!(frame.seq, reply.cmd.seq);
                seen.push(reply.cmd.seq);
                reply.deadline_misses = 10 * reply.cmd.seq;
            }
            Tapped::Request(_) => requests += 1,
        });
        assert_eq!(tap.name(), "echo");
        assert_eq!(tap.frames_dropped_host(), 5);
        assert!(matches!(tap.request(&HostMsg::StartRealTime), Ok(FswMsg::ParamsAccepted { checksum: 7 })));
        for seq in 1..=3 {
            let frame = SensorFrame::empty(seq, 0);
            let reply = tap.step(&frame).unwrap();
            assert_eq!((reply.cmd.seq, reply.deadline_misses), (seq, 10 * seq));
        }
        assert_eq!(tap.into_inner().requests, 1);
        assert_eq!((seen, requests), (vec![1, 2, 3], 1));
    }
}
