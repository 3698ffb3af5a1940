//! The flight protocol over a byte stream (see `acs_flight::link`).

use super::{FlightLink, LinkAnomalies, LinkInfo};
use acs_flight::link::{
    FrameAccumulator, FswMsg, HostMsg, LinkError, MAX_FRAME, PROTOCOL_VERSION, SensorFrame, StepReport, encode_frame,
    schema_hash,
};
use anyhow::{Context, Result, anyhow, bail};
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// How long to wait for any reply before declaring the flight side dead.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(10);

pub struct Framed<S: Read + Write> {
    stream: S,
    name: String,
    acc: FrameAccumulator<MAX_FRAME>,
    rx: Box<[u8; 4096]>,
    rx_pos: usize,
    rx_len: usize,
    tx: Box<[u8; MAX_FRAME]>,
    pub info: Option<LinkInfo>,
    /// The step reply last used (a bit-identical copy of it is a harmless duplicate).
    last_step: Option<StepReport>,
    anomalies: LinkAnomalies,
}

impl Framed<TcpStream> {
    pub fn tcp(addr: &str) -> Result<Self> {
        let s = TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
        Self::from_tcp(s, format!("tcp:{addr}"))
    }

    pub fn from_tcp(s: TcpStream, name: String) -> Result<Self> {
        s.set_nodelay(true)?;
        s.set_read_timeout(Some(Duration::from_millis(200)))?;
        Ok(Self::new(s, name))
    }
}

impl Framed<Box<dyn serialport::SerialPort>> {
    pub fn serial(device: &str, baud: u32) -> Result<Self> {
        let p = serialport::new(device, baud)
            .timeout(Duration::from_millis(200))
            .open()
            .with_context(|| format!("opening serial port {device}"))?;
        Ok(Self::new(p, format!("serial:{device}@{baud}")))
    }
}

impl<S: Read + Write> Framed<S> {
    pub fn new(stream: S, name: String) -> Self {
        Self {
            stream,
            name,
            acc: FrameAccumulator::new(),
            rx: Box::new([0; 4096]),
            rx_pos: 0,
            rx_len: 0,
            tx: Box::new([0; MAX_FRAME]),
            info: None,
            last_step: None,
            anomalies: LinkAnomalies::default(),
        }
    }

    pub fn send(&mut self, msg: &HostMsg) -> Result<()> {
        let frame = encode_frame(msg, &mut self.tx[..]).map_err(|e| anyhow!("encoding {msg:?}: {e:?}"))?;
        self.stream.write_all(frame)?;
        self.stream.flush()?;
        Ok(())
    }

    /// Send raw bytes (tests use this to inject corrupt frames).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<()> {
        self.stream.write_all(bytes)?;
        self.stream.flush()?;
        Ok(())
    }

    /// A reply that is not the one awaited (`waiting_for`: the frame a step waits for;
    /// `None` while waiting for the reply to another request): counted by kind. Errors
    /// other than a refusal of an earlier frame end a step as before.
    fn stray(&mut self, msg: FswMsg, waiting_for: Option<u32>) -> Result<()> {
        let a = &mut self.anomalies;
        let older = |seq: u32| waiting_for.is_none_or(|w| seq < w);
        match msg {
            FswMsg::Step(r) if self.last_step == Some(r) => a.duplicate_replies += 1,
            FswMsg::Step(r) if older(r.cmd.seq) => {
                a.late_replies += 1;
                a.result_affected = true;
            }
            FswMsg::Error(LinkError::StaleSequence { seq, .. }) if older(seq) => a.refusals_received += 1,
            FswMsg::Error(e) if waiting_for.is_some() && !matches!(e, LinkError::StaleSequence { .. }) => {
                bail!("{}: flight error {e:?}", self.name)
            }
            _ => {
                a.unexpected_replies += 1;
                a.result_affected = true;
            }
        }
        Ok(())
    }

    /// Next good message; bad frames are counted and skipped.
    pub fn recv(&mut self) -> Result<FswMsg> {
        match self.recv_timeout(REPLY_TIMEOUT)? {
            Some(m) => Ok(m),
            None => bail!("{}: no reply within {:?}", self.name, REPLY_TIMEOUT),
        }
    }

    /// Next good message, or `None` if none came within `timeout` (the stream's read
    /// timeout, 200 ms for TCP and serial, is the granularity).
    pub fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<FswMsg>> {
        let deadline = Instant::now() + timeout;
        loop {
            while self.rx_pos < self.rx_len {
                let b = self.rx[self.rx_pos];
                self.rx_pos += 1;
                if let Some(Ok(m)) = self.acc.push::<FswMsg>(b) {
                    return Ok(Some(m));
                }
            }
            match self.stream.read(&mut self.rx[..]) {
                Ok(0) => bail!("{}: the flight side closed the link", self.name),
                Ok(n) => {
                    self.rx_pos = 0;
                    self.rx_len = n;
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted) => {
                    if Instant::now() > deadline {
                        return Ok(None);
                    }
                }
                Err(e) => return Err(e).context(format!("{}: reading", self.name)),
            }
        }
    }
}

impl<S: Read + Write> FlightLink for Framed<S> {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn hello(&mut self) -> Result<LinkInfo> {
        // A lone delimiter first: the other side drops whatever partial frame it holds.
        self.send_raw(&[0])?;
        self.send(&HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() })?;
        match self.recv()? {
            FswMsg::HelloAck {
                protocol_version,
                schema_hash: h,
                cost_counter_hz,
                board,
                reset_cause,
                stack_hwm_bytes,
                ..
            } => {
                if protocol_version != PROTOCOL_VERSION || h != schema_hash() {
                    bail!(
                        "{}: flight protocol {protocol_version}/{h:#x}, host {PROTOCOL_VERSION}/{:#x}",
                        self.name,
                        schema_hash()
                    );
                }
                // QEMU (board 1) runs with -icount shift=0: 1 instruction per ns.
                let ipt = (board == 1 && cost_counter_hz > 0).then(|| 1e9 / cost_counter_hz as f64);
                let info =
                    LinkInfo { board, cost_counter_hz, instructions_per_tick: ipt, reset_cause, stack_hwm_bytes };
                self.info = Some(info.clone());
                Ok(info)
            }
            FswMsg::Error(LinkError::Busy) => {
                bail!("{}: flight computer busy (it is serving another host; try again later)", self.name)
            }
            FswMsg::Error(e) => bail!("{}: flight side refused hello: {e:?}", self.name),
            other => bail!("{}: unexpected reply to hello: {other:?}", self.name),
        }
    }

    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        self.send(msg)?;
        loop {
            match self.recv()? {
                // Answers to sensor frames: copies, late steps or refusals (counted).
                m @ (FswMsg::Step(_) | FswMsg::Error(LinkError::StaleSequence { .. })) => self.stray(m, None)?,
                reply => return Ok(reply),
            }
        }
    }

    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        self.send(&HostMsg::Sensor(*frame))?;
        loop {
            match self.recv()? {
                FswMsg::Step(r) if r.cmd.seq == frame.seq => {
                    self.anomalies.frames_refused_flight = r.seq_refused;
                    self.last_step = Some(r);
                    return Ok(r);
                }
                FswMsg::Error(LinkError::StaleSequence { seq, last_seq }) if seq == frame.seq => bail!(
                    "{}: the flight side refused frame {seq} (it has stepped frame {last_seq} of this sequence)",
                    self.name
                ),
                other => self.stray(other, Some(frame.seq))?,
            }
        }
    }

    fn frames_dropped_host(&self) -> u32 {
        self.acc.stats.dropped()
    }

    fn anomalies(&self) -> LinkAnomalies {
        self.anomalies
    }
}
