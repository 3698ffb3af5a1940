//! Links between the simulator and the flight code. Every link speaks the same session
//! (hello → parameter upload → one step per sensor frame); only the transport differs:
//! - [`in_process::InProcess`]: calls `acs_flight::Fsw` directly (no serialisation);
//! - [`framed::Framed`]: the postcard/COBS/CRC protocol over any byte stream
//!   (TCP to a board bridge or to QEMU, a serial port);
//! - [`qemu`]: starts the real firmware under QEMU and connects a `Framed` link to it;
//! - [`tap::Tap`]: wraps any link and hands every step reply to a hook (the telemetry tap);
//! - [`cancel::Cancellable`]: wraps any link so that another thread can stop what flies on it.

pub mod cancel;
pub mod framed;
pub mod in_process;
pub mod qemu;
pub mod serve;
pub mod tap;

use acs_flight::link::{FswMsg, HostMsg, ResetCause, SensorFrame, StepReport};
use acs_flight::params::{EstimationParams, FlightParams};
use acs_flight::params::{Mode, ModeManagerParams};
use anyhow::{Result, anyhow, bail};
use std::path::PathBuf;

/// A mode table as uploaded: one parameter set per mode, then the thresholds.
#[derive(Clone, Debug)]
pub struct ModeTable {
    pub slots: Vec<(Mode, FlightParams)>,
    pub manager: ModeManagerParams,
}

/// What the host saw on the link beyond one reply per message (summary.json
/// `link_anomalies`, docs/protocol.md "Link anomalies"). Some leave the result exactly as
/// on a clean link, the others may have changed it (`result_affected`, exit code 3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkAnomalies {
    /// Step replies bit-identical to the reply already used for that frame: a copy made
    /// in transit (the flight side steps a frame once). Harmless.
    pub duplicate_replies: u32,
    /// Step replies for an already answered frame that differ from the reply used: the
    /// flight side stepped a frame twice or out of order. Invalidates the result.
    pub late_replies: u32,
    /// Replies the host did not ask for: a step for a frame not sent yet, or a message of
    /// another kind while waiting for a step. The flight side acted on a message the host
    /// did not send then. Invalidates the result.
    pub unexpected_replies: u32,
    /// `Error(StaleSequence)` refusals received for frames the host had already had
    /// answered: a repeated or late copy of a frame that the flight side did not step
    /// (one frame, one step). Harmless.
    pub refusals_received: u32,
    /// The flight side's own count of refused frames (`StepReport::seq_refused` of the
    /// last step; a refusal of the last frames of a run may only show here). Harmless.
    pub frames_refused_flight: u32,
    /// True when any anomaly that may have changed the result occurred.
    pub result_affected: bool,
}

impl LinkAnomalies {
    /// Why the result may be wrong, or `None` when the link anomalies (if any) left it as
    /// on a clean link.
    pub fn failure_reason(&self) -> Option<String> {
        self.result_affected.then(|| {
            format!(
                "link anomalies may have changed the result: {} late step replies (a frame stepped twice or out of \
                 order), {} unexpected replies",
                self.late_replies, self.unexpected_replies
            )
        })
    }
}

/// What the flight side said at hello.
#[derive(Clone, Debug, PartialEq)]
pub struct LinkInfo {
    pub board: u8,
    /// Frequency of the counter behind `StepReport::step_cost_ticks`, Hz (0: not measured).
    pub cost_counter_hz: u32,
    /// Instructions per cost tick when the counter runs in QEMU with `-icount shift=0`
    /// (1 instruction = 1 ns); `None` on real hardware (ticks are cycles there).
    pub instructions_per_tick: Option<f64>,
    /// Why the flight computer last started (`HelloAck::reset_cause`).
    pub reset_cause: ResetCause,
    /// The flight computer's measured stack high-water mark at this `Hello`, bytes
    /// (`HelloAck::stack_hwm_bytes`; 0 = not measured).
    pub stack_hwm_bytes: u32,
}

pub trait FlightLink {
    fn name(&self) -> String;
    fn hello(&mut self) -> Result<LinkInfo>;
    /// Send a message that is not a sensor frame and return the flight side's one reply.
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg>;
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport>;
    /// Upload and have the flight side validate the parameters; returns the checksum it
    /// computed (checked against the host's).
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        let reply = self.request(&HostMsg::UploadParams(*params))?;
        accepted(&self.name(), params, reply)
    }
    /// Upload a mode table (one message per mode) and arm it.
    fn upload_modes(&mut self, table: &ModeTable) -> Result<u32> {
        for (mode, params) in &table.slots {
            let reply = self.request(&HostMsg::UploadModeParams { mode: *mode, params: *params })?;
            accepted(&self.name(), params, reply).map_err(|e| anyhow!("mode {}: {e}", mode.name()))?;
        }
        match self.request(&HostMsg::ArmModes(table.manager))? {
            FswMsg::ModesArmed { checksum } => {
                let mine = table.manager.checksum().map_err(|e| anyhow!("{e}"))?;
                if checksum != mine {
                    bail!("{}: mode table checksum mismatch: flight {checksum:#010x}, host {mine:#010x}", self.name());
                }
                Ok(checksum)
            }
            FswMsg::ParamsRejected(e) => bail!("{}: flight code rejected the mode table: {e}", self.name()),
            other => bail!("{}: unexpected reply to ArmModes: {other:?}", self.name()),
        }
    }
    /// Send the attitude-determination parameters; returns the flight side's checksum
    /// (checked against the host's).
    fn configure_estimation(&mut self, p: &EstimationParams) -> Result<u32> {
        match self.request(&HostMsg::ConfigureEstimation(*p))? {
            FswMsg::ParamsAccepted { checksum } => {
                let mine = p.checksum().map_err(|e| anyhow!("{e}"))?;
                if checksum != mine {
                    bail!("{}: estimation checksum mismatch: flight {checksum:#010x}, host {mine:#010x}", self.name());
                }
                Ok(checksum)
            }
            FswMsg::ParamsRejected(e) => bail!("{}: flight code rejected the estimation parameters: {e}", self.name()),
            other => bail!("{}: unexpected reply to ConfigureEstimation: {other:?}", self.name()),
        }
    }
    /// Frames the host side dropped (CRC, COBS, ...).
    fn frames_dropped_host(&self) -> u32 {
        0
    }
    /// Duplicate, late and unexpected replies and reported refusals so far.
    fn anomalies(&self) -> LinkAnomalies {
        LinkAnomalies::default()
    }
    /// A copy of this link whose flight side is in the same state, when the link can make
    /// one: only in-process (a flight computer on the far side of a wire cannot be copied).
    /// It lets a run be forked at an operating point ([`crate::simulation::probe::Probe::fork`],
    /// `sim-host margins`); `None` (the default) means "re-fly from t = 0 instead".
    fn fork(&self) -> Option<Box<dyn FlightLink>> {
        None
    }
}

/// A boxed link (what [`open`] returns) is a link: every call goes to the box's content,
/// so a `Box<dyn FlightLink>` can be wrapped (e.g. by [`tap::Tap`]).
impl<T: FlightLink + ?Sized> FlightLink for Box<T> {
    fn name(&self) -> String {
        (**self).name()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        (**self).hello()
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        (**self).request(msg)
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        (**self).step(frame)
    }
    fn upload(&mut self, params: &FlightParams) -> Result<u32> {
        (**self).upload(params)
    }
    fn upload_modes(&mut self, table: &ModeTable) -> Result<u32> {
        (**self).upload_modes(table)
    }
    fn configure_estimation(&mut self, p: &EstimationParams) -> Result<u32> {
        (**self).configure_estimation(p)
    }
    fn frames_dropped_host(&self) -> u32 {
        (**self).frames_dropped_host()
    }
    fn anomalies(&self) -> LinkAnomalies {
        (**self).anomalies()
    }
    fn fork(&self) -> Option<Box<dyn FlightLink>> {
        (**self).fork()
    }
}

fn accepted(name: &str, params: &FlightParams, reply: FswMsg) -> Result<u32> {
    match reply {
        FswMsg::ParamsAccepted { checksum } => {
            let mine = params.checksum().map_err(|e| anyhow!("{e}"))?;
            if checksum != mine {
                bail!("{name}: parameter checksum mismatch: flight {checksum:#010x}, host {mine:#010x}");
            }
            Ok(checksum)
        }
        FswMsg::ParamsRejected(e) => bail!("{name}: flight code rejected the parameters: {e}"),
        other => bail!("{name}: unexpected reply to the parameter upload: {other:?}"),
    }
}

/// Parsed `--link` value.
#[derive(Clone, Debug, PartialEq)]
pub enum LinkKind {
    InProcess,
    Qemu,
    Tcp(String),
    Serial { device: String, baud: u32 },
}

impl std::str::FromStr for LinkKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        Ok(match s {
            "in-process" => LinkKind::InProcess,
            "qemu" => LinkKind::Qemu,
            _ if s.starts_with("tcp:") => LinkKind::Tcp(s[4..].to_string()),
            _ if s.starts_with("serial:") => {
                let rest = &s[7..];
                let (device, baud) = match rest.split_once('@') {
                    Some((d, b)) => (d.to_string(), b.parse()?),
                    None => (rest.to_string(), 115_200),
                };
                LinkKind::Serial { device, baud }
            }
            _ => bail!("unknown link {s:?}: use in-process, qemu, tcp:HOST:PORT or serial:DEV[@BAUD]"),
        })
    }
}

/// Options for links that start something.
#[derive(Clone, Debug, Default)]
pub struct LinkOptions {
    /// Firmware ELF for `qemu`; default: the release build under `firmware/target`.
    pub firmware: Option<PathBuf>,
    /// Stops every link opened with these options, and their forks, once cancelled
    /// ([`cancel`]: Ctrl-C in the Python package); `None`: not cancellable.
    pub cancel: Option<cancel::Cancel>,
}

pub fn open(kind: &LinkKind, opts: &LinkOptions) -> Result<Box<dyn FlightLink>> {
    if let Some(c) = &opts.cancel {
        c.check()?;
    }
    let link: Box<dyn FlightLink> = match kind {
        LinkKind::InProcess => Box::new(in_process::InProcess::new()),
        LinkKind::Qemu => Box::new(qemu::QemuLink::start(opts.firmware.as_deref())?),
        LinkKind::Tcp(addr) => Box::new(framed::Framed::tcp(addr)?),
        LinkKind::Serial { device, baud } => Box::new(framed::Framed::serial(device, *baud)?),
    };
    Ok(match &opts.cancel {
        Some(c) => Box::new(cancel::Cancellable::new(link, c.clone())),
        None => link,
    })
}
