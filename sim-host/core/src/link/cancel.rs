//! Cancelling work that flies through links from another thread (Ctrl-C in the Python
//! package while `[margins]` experiments or campaign runs fly on worker threads): a
//! [`Cancel`] token in [`super::LinkOptions`] makes [`super::open`] wrap every link it
//! opens — and every fork of one, so margin experiments forked at an operating point too —
//! in a [`Cancellable`] link that refuses its next message once the token is cancelled.
//! The run or experiment then ends with a [`Cancelled`] error at its next control step.
//! A token never cancelled changes nothing: the same messages, the same bits.

use super::{FlightLink, LinkAnomalies, LinkInfo, ModeTable};
use acs_flight::link::{FswMsg, HostMsg, SensorFrame, StepReport};
use acs_flight::params::{EstimationParams, FlightParams};
use anyhow::Result;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared flag: clones see the same state; cancelled once, cancelled for good.
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once cancelled (for run observers: `runner::run_observed`).
    pub fn check(&self) -> Result<()> {
        if self.is_cancelled() { Err(Cancelled.into()) } else { Ok(()) }
    }
}

/// The error a cancelled link (or [`Cancel::check`]) ends its run with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cancelled;

impl std::fmt::Display for Cancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "cancelled")
    }
}

impl std::error::Error for Cancelled {}

/// `inner`, refusing every message once `cancel` is cancelled.
pub struct Cancellable {
    inner: Box<dyn FlightLink>,
    cancel: Cancel,
}

impl Cancellable {
    pub fn new(inner: Box<dyn FlightLink>, cancel: Cancel) -> Self {
        Self { inner, cancel }
    }
}

impl FlightLink for Cancellable {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        self.cancel.check()?;
        self.inner.hello()
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        self.cancel.check()?;
        self.inner.request(msg)
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        self.cancel.check()?;
        self.inner.step(frame)
    }
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        self.cancel.check()?;
        self.inner.upload(params)
    }
    fn upload_modes(&mut self, table: &ModeTable) -> Result<u32> {
        self.cancel.check()?;
        self.inner.upload_modes(table)
    }
    fn configure_estimation(&mut self, p: &EstimationParams) -> Result<u32> {
        self.cancel.check()?;
        self.inner.configure_estimation(p)
    }
    fn frames_dropped_host(&self) -> u32 {
        self.inner.frames_dropped_host()
    }
    fn anomalies(&self) -> LinkAnomalies {
        self.inner.anomalies()
    }
    /// No fork once cancelled (a fork copies the flight side's state: work for nothing).
    fn fork(&self) -> Option<Box<dyn FlightLink>> {
        if self.cancel.is_cancelled() {
            return None;
        }
        let inner = self.inner.fork()?;
        Some(Box::new(Cancellable::new(inner, self.cancel.clone())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{LinkKind, LinkOptions, open};
    use acs_flight::link::PROTOCOL_VERSION;

    /// Until cancelled the wrapped link answers as the bare one; afterwards it and its
    /// forks refuse every message with `Cancelled` and make no more forks, and a link opened without a token is
    /// not affected.
    #[test]
    fn a_cancelled_link_and_its_forks_refuse_every_message() {
        let cancel = Cancel::new();
        let opts = LinkOptions { cancel: Some(cancel.clone()), ..Default::default() };
        let mut l = open(&LinkKind::InProcess, &opts).unwrap();
        let mut bare = open(&LinkKind::InProcess, &LinkOptions::default()).unwrap();
        let hello = HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: acs_flight::link::schema_hash() };
        assert_eq!(l.request(&hello).unwrap(), bare.request(&hello).unwrap());
        let mut fork = l.fork().expect("in-process links fork");
        cancel.cancel();
        assert!(l.fork().is_none() && fork.fork().is_none());
        for link in [&mut l, &mut fork] {
            let e = link.step(&SensorFrame::empty(1, 0)).unwrap_err();
            assert!(e.downcast_ref::<Cancelled>().is_some(), "{e:#}");
            assert!(link.request(&hello).unwrap_err().downcast_ref::<Cancelled>().is_some());
        }
        assert!(bare.request(&hello).is_ok());
    }
}
