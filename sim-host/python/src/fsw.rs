//! `acs.Fsw`: the flight software of a scenario, stepped from Python. It is the in-process
//! link's flight side (`sim_core::link::in_process::InProcess`: `acs_flight::session::
//! Session` around `acs_flight::Fsw`), opened exactly as a run opens it (hello, the
//! parameter set or mode table, the estimation parameters: `Simulation::new`), so a frame
//! stepped here gives the command the simulator would get for it.
//!
//! [`record_frames`] flies a scenario in-process and keeps every frame, the reply and the
//! ground commands sent before it, so a test can replay them into an `Fsw`.

use crate::convert::to_py;
use crate::errors::{Kind, guard};
use crate::scenario::PyScenario;
use acs_flight::link::{FswMsg, HostMsg, SensorFrame, StepReport};
use anyhow::{Context, Result, bail};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyList};
use sim_core::link::FlightLink;
use sim_core::link::in_process::InProcess;
use sim_core::link::tap::{Tap, Tapped};
use sim_core::recorder::series::Discard;
use sim_core::scenario::{Resolved, Scenario, Upload};

/// The flight software of one scenario, configured as a run configures it.
#[pyclass(name = "Fsw", module = "acs")]
pub struct PyFsw {
    link: InProcess,
}

/// Hello, then the parameter set (or mode table) and the estimation parameters, as
/// `Simulation::new` sends them.
fn configure(link: &mut dyn FlightLink, sc: &Scenario) -> Result<()> {
    let r = Resolved::try_from(sc)?;
    let Some(upload) = &r.upload else {
        bail!("{}: open loop (controller.type = \"none\"): there is no flight software to build", sc.name)
    };
    link.hello().context("hello")?;
    match upload {
        Upload::Modes(table) => link.upload_modes(table).context("mode table upload")?,
        Upload::Params(p) => link.upload(p).context("parameter upload")?,
    };
    if let Some(e) = &r.estimation {
        link.configure_estimation(e).context("estimation parameters")?;
    }
    Ok(())
}

/// A frame from a dict (the serde form of `SensorFrame`, read by [`crate::strict`]: every
/// field typed, no unknown key) or its postcard bytes, which must be one `SensorFrame` and
/// nothing else: the wire refuses a frame with bytes left over (`FrameError::Decode`).
fn frame_of(obj: &Bound<'_, PyAny>) -> Result<SensorFrame> {
    let bytes = match (obj.cast::<PyBytes>(), obj.cast::<PyByteArray>()) {
        (Ok(b), _) => Some(b.as_bytes().to_vec()),
        (_, Ok(b)) => Some(b.to_vec()),
        _ => None,
    };
    if let Some(b) = bytes {
        let (frame, rest) = postcard::take_from_bytes::<SensorFrame>(&b).context("postcard SensorFrame")?;
        if !rest.is_empty() {
            bail!(
                "postcard SensorFrame: {} bytes after the frame's {} (a frame carries one message and nothing \
                 else; the wire refuses it)",
                rest.len(),
                b.len() - rest.len()
            );
        }
        return Ok(frame);
    }
    crate::strict::from_py(obj).context("SensorFrame dict")
}

/// `PyFsw`'s one mutable borrow, taken after the Python arguments were read (reading them
/// may run Python code that uses this object): a failure is an `acs.FrameError`, never
/// PyO3's `RuntimeError("Already borrowed")`.
fn borrow<'py>(slf: &Bound<'py, PyFsw>) -> PyResult<PyRefMut<'py, PyFsw>> {
    slf.try_borrow_mut()
        .map_err(|e| Kind::Frame.err(format!("this acs.Fsw is in use (called from inside its own call): {e}")))
}

#[pymethods]
impl PyFsw {
    #[new]
    fn new(scenario: &Bound<'_, PyScenario>) -> PyResult<Self> {
        guard(|| {
            let sc = crate::scenario::snapshot(scenario)?;
            let mut link = InProcess::new();
            configure(&mut link, &sc).map_err(|e| Kind::Scenario.chain(&e))?;
            Ok(Self { link })
        })
    }

    /// One flight step: the reply (`StepReport`: `cmd`, the command and telemetry, and the
    /// link counters) as a dict. `frame`: a dict like `acs.empty_frame()` or the postcard
    /// bytes of a `SensorFrame`. Frames must come in increasing `seq` (one frame, one step,
    /// as on the wire); a refused frame raises `acs.FrameError`.
    fn step<'py>(slf: &Bound<'py, Self>, frame: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            let py = slf.py();
            let f = frame_of(frame).map_err(|e| Kind::Frame.chain(&e))?;
            // Through the session with no cost counter: the reply does not depend on the
            // host's clock (step_cost_ticks = 0).
            let reply = borrow(slf)?.link.request(&HostMsg::Sensor(f)).map_err(|e| Kind::Frame.chain(&e))?;
            match reply {
                FswMsg::Step(r) => to_py(py, &r).map_err(|e| Kind::Frame.chain(&e)),
                FswMsg::Error(e) => Err(Kind::Frame.err(format!("the flight code refused frame {}: {e:?}", f.seq))),
                other => Err(Kind::Frame.err(format!("unexpected answer to frame {}: {other:?}", f.seq))),
            }
        })
    }

    /// Any other link message (`HostMsg` as a dict, e.g. `{"CommandMode": {"Enter": "Hold"}}`, a ground
    /// command recorded by `acs.record_frames`): the flight side's reply as a dict. Read as
    /// strictly as a frame ([`crate::strict`]).
    fn request<'py>(slf: &Bound<'py, Self>, msg: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            let m: HostMsg = crate::strict::from_py(msg).map_err(|e| Kind::Frame.err(format!("HostMsg {e}")))?;
            let reply = borrow(slf)?.link.request(&m).map_err(|e| Kind::Frame.chain(&e))?;
            to_py(slf.py(), &reply).map_err(|e| Kind::Frame.chain(&e))
        })
    }
}

/// A frame with nothing valid in it (identity attitude, zeros), as a dict to fill in.
/// `seq` and `time_us` are read as the frame's fields are ([`crate::strict`]).
#[pyfunction]
#[pyo3(signature = (seq, time_us=None))]
pub fn empty_frame<'py>(
    py: Python<'py>,
    seq: &Bound<'py, PyAny>,
    time_us: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    guard(|| {
        let field = |name: &str, e: crate::strict::StrictError| Kind::Frame.err(format!("empty_frame `{name}`: {e}"));
        let seq: u32 = crate::strict::from_py(seq).map_err(|e| field("seq", e))?;
        let time_us: u64 = time_us.map_or(Ok(0), crate::strict::from_py).map_err(|e| field("time_us", e))?;
        to_py(py, &SensorFrame::empty(seq, time_us)).map_err(|e| Kind::Frame.chain(&e))
    })
}

/// The postcard bytes of a frame (what `Fsw.step` also accepts; the payload of a wire
/// frame before CRC and COBS).
#[pyfunction]
pub fn frame_to_bytes<'py>(py: Python<'py>, frame: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyBytes>> {
    guard(|| {
        let f = frame_of(frame).map_err(|e| Kind::Frame.chain(&e))?;
        let b = postcard::to_stdvec(&f).map_err(|e| Kind::Frame.err(e))?;
        Ok(PyBytes::new(py, &b))
    })
}

/// One control step as the in-process link saw it.
struct Recorded {
    /// Ground commands sent since the previous frame.
    requests: Vec<HostMsg>,
    frame: SensorFrame,
    reply: StepReport,
}

/// Flies `scenario` in-process for `steps` control steps (all: `None`) and returns one dict
/// per step: `frame` (the `SensorFrame` sent), `reply` (the `StepReport` received) and
/// `requests` (ground commands sent just before that frame).
#[pyfunction]
#[pyo3(signature = (scenario, steps=None))]
pub fn record_frames<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyScenario>,
    steps: Option<u64>,
) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let sc = crate::scenario::snapshot(scenario)?;
        if !sc.closed_loop() {
            return Err(Kind::Scenario.err(format!("{}: open loop: no frames reach the flight code", sc.name)));
        }
        let recorded = py.detach(|| {
            // Every frame, reply and ground command (the set-up messages — hello, uploads —
            // are not requests: `acs.Fsw` sends those itself).
            let (mut kept, mut pending) = (Vec::new(), Vec::new());
            let limit = steps.unwrap_or(u64::MAX);
            let r = {
                let mut link = Tap::new(InProcess::new(), |t: Tapped<'_>| match t {
                    Tapped::Request(m) => pending.push(m.clone()),
                    Tapped::Step(frame, reply) => {
                        kept.push(Recorded { requests: std::mem::take(&mut pending), frame: *frame, reply: *reply })
                    }
                });
                let mut enough = |done: u64, _: u64| if done >= limit { bail!("enough") } else { Ok(()) };
                sim_core::runner::run_observed(&sc, &mut link, &mut Discard, &mut enough)
            };
            match r {
                Err(e) if kept.len() as u64 != limit || e.to_string() != "enough" => Err(e),
                _ => Ok(kept),
            }
        });
        let recorded = recorded.map_err(|e| Kind::Run.chain(&e))?;
        let out = PyList::empty(py);
        for r in &recorded {
            let d = PyDict::new(py);
            let conv = |e: anyhow::Error| Kind::Run.chain(&e);
            d.set_item("requests", to_py(py, &r.requests).map_err(conv)?)?;
            d.set_item("frame", to_py(py, &r.frame).map_err(conv)?)?;
            d.set_item("reply", to_py(py, &r.reply).map_err(conv)?)?;
            out.append(d)?;
        }
        Ok(out)
    })
}
