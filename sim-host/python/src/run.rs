//! One run in memory (`acs.run`): the scenario flown by `sim_core::runner::run_observed`
//! into a `TimeSeries`, with the interpreter's lock released while it flies. At least
//! every [`SIGNAL_POLL`] the run takes the lock back for a moment to check for Ctrl-C
//! (`KeyboardInterrupt` ends the run), and every [`CHECK_EVERY`] control steps to call the
//! progress callback; the `[margins]` phase and campaigns work on worker threads while
//! the calling thread looks for Ctrl-C ([`interruptible`]). The
//! columns are handed to numpy as they are (`PyArray1::from_vec` takes the `Vec<f64>`
//! over: no copy, no per-row conversion), the summary as `json.load` of `summary.json`
//! would read it. With `[margins]` the margins are measured after the run into
//! `summary["margins"]` (`sim_host::margins::summary`), as by `sim-host run`.

use crate::convert::json_to_py;
use crate::errors::{Kind, guard};
use crate::scenario::PyScenario;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use sim_core::link::cancel::Cancel;
use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::series::TimeSeries;
use sim_core::runner::{self, Summary};
use sim_core::scenario::Scenario;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Control steps between two calls of the progress callback.
pub const CHECK_EVERY: u64 = 256;
/// Most time between two looks for Ctrl-C while Rust code works without the lock: within
/// a run, checked every [`CLOCK_EVERY`] steps; in the phases on worker threads (margins,
/// campaigns), the calling thread wakes this often.
pub const SIGNAL_POLL: Duration = Duration::from_millis(50);
/// Control steps between two readings of the clock within a run (a reading costs tens of
/// nanoseconds; a step, microseconds).
const CLOCK_EVERY: u64 = 16;

/// The link a run uses: the caller's, else the scenario's `link.kind`, else in-process
/// (open-loop scenarios always in-process) — as `sim-host run` chooses.
pub fn link_kind(sc: &Scenario, link: Option<&str>) -> anyhow::Result<LinkKind> {
    Ok(match (link, &sc.link.kind) {
        _ if !sc.closed_loop() => LinkKind::InProcess,
        (Some(k), _) => k.parse()?,
        (None, Some(s)) => s.parse().map_err(|e: anyhow::Error| e.context("scenario link.kind"))?,
        (None, None) => LinkKind::InProcess,
    })
}

/// Runs `work` on a helper thread while this thread (which must not hold the interpreter's
/// lock) looks for Ctrl-C every [`SIGNAL_POLL`]. On a signal's exception, `cancel` is
/// cancelled, the work is waited for (it stops at its next control step: every link it
/// opens was opened with `cancel`) and the exception is returned instead of its result.
/// A panic in `work` is resumed here (the entry point's `guard` makes it
/// `acs.InternalError`).
pub fn interruptible<T: Send>(cancel: &Cancel, work: impl FnOnce() -> T + Send) -> Result<T, PyErr> {
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        s.spawn(move || {
            let _ = tx.send(catch_unwind(AssertUnwindSafe(work)));
        });
        let mut interrupt: Option<PyErr> = None;
        loop {
            match rx.recv_timeout(SIGNAL_POLL) {
                Ok(Ok(v)) => return interrupt.map_or(Ok(v), Err),
                Ok(Err(panic)) => resume_unwind(panic),
                Err(mpsc::RecvTimeoutError::Timeout) if interrupt.is_none() => {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        cancel.cancel();
                        interrupt = Some(e);
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(
                        interrupt.unwrap_or_else(|| Kind::Run.err("the worker thread stopped without a result"))
                    );
                }
            }
        }
    })
}

/// Why a run failed: a Rust error, or a Python exception to raise as it is (Ctrl-C, or an
/// exception in the progress callback).
enum Failed {
    Rust(anyhow::Error),
    Python(PyErr),
}

impl From<anyhow::Error> for Failed {
    fn from(e: anyhow::Error) -> Self {
        Failed::Rust(e)
    }
}

/// Flies `sc` on `kind` without the interpreter's lock; the observer takes it to look for
/// Ctrl-C (every [`SIGNAL_POLL`] at most) and to call the progress callback (every
/// [`CHECK_EVERY`] steps). `[margins]`: measured after the run on the same link, as
/// `sim-host run` does, on worker threads ([`interruptible`]).
fn fly(
    sc: &Scenario,
    kind: &LinkKind,
    firmware: Option<PathBuf>,
    callback: Option<&Py<PyAny>>,
) -> Result<(Summary, TimeSeries), Failed> {
    let cancel = Cancel::new();
    let link_options = LinkOptions { firmware, cancel: Some(cancel.clone()) };
    let mut l = link::open(kind, &link_options)?;
    let mut series = TimeSeries::default();
    let mut stop: Option<PyErr> = None;
    let mut last_look = Instant::now();
    // `done` counts flight steps, the initial frame's included (1..=total + 1); the callback
    // gets the control steps elapsed (done - 1) of the CLI's "N steps" (total), so the bar
    // ends once at total/total (issue 38: it counted to total + 1).
    let mut observe = |done: u64, total: u64| -> anyhow::Result<()> {
        let progress = done.is_multiple_of(CHECK_EVERY) || done > total;
        let look = progress || (done.is_multiple_of(CLOCK_EVERY) && last_look.elapsed() >= SIGNAL_POLL);
        if !look {
            return Ok(());
        }
        last_look = Instant::now();
        Python::attach(|py| {
            py.check_signals()?;
            match callback {
                Some(cb) if progress => cb.call1(py, (done.saturating_sub(1).min(total), total)).map(drop),
                _ => Ok(()),
            }
        })
        .map_err(|e| {
            stop = Some(e);
            anyhow::anyhow!("interrupted")
        })
    };
    let r = runner::run_observed(sc, l.as_mut(), &mut series, &mut observe);
    drop(l);
    let mut summary = match (r, stop) {
        (_, Some(e)) => return Err(Failed::Python(e)),
        (r, None) => r?,
    };
    let base = sim_host::margins::MarginOptions {
        link: kind.clone(),
        link_options,
        threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
        ..Default::default()
    };
    let measured =
        interruptible(&cancel, || sim_host::margins::summary::for_scenario(sc, &base)).map_err(Failed::Python)?;
    // As `sim-host run` and campaigns: a loop that is not stable and steady fails the run.
    if let Some((m, _)) = measured? {
        summary.record_margins(m);
    }
    Ok((summary, series))
}

/// Runs `scenario` in memory; returns `(summary, column names, columns)` for the Python
/// layer (`acs.run` wraps them in `acs.RunResult`).
#[pyfunction]
#[pyo3(signature = (scenario, link=None, progress=None, output_every=None, firmware=None))]
pub fn run<'py>(
    py: Python<'py>,
    scenario: &Bound<'_, PyScenario>,
    link: Option<&str>,
    progress: Option<Py<PyAny>>,
    output_every: Option<u32>,
    firmware: Option<PathBuf>,
) -> PyResult<Bound<'py, PyTuple>> {
    guard(|| {
        // The run flies a copy taken now: the scenario can be changed meanwhile (another
        // thread) without a borrow conflict and without changing this run.
        let mut sc = crate::scenario::snapshot(scenario)?;
        if let Some(n) = output_every {
            sc.timing.output_every = n;
            sc.validate().map_err(|e| Kind::Scenario.chain(&e.context("output_every")))?;
        }
        let kind = link_kind(&sc, link).map_err(|e| Kind::Run.chain(&e))?;
        let flown = py.detach(|| fly(&sc, &kind, firmware, progress.as_ref()));
        let (summary, series) = match flown {
            Ok(x) => x,
            Err(Failed::Python(e)) => return Err(e),
            Err(Failed::Rust(e)) => return Err(Kind::Run.chain(&e)),
        };
        // A Ctrl-C after the last look is raised now, before the results are converted
        // (Python code, such as numpy's first import, would otherwise receive it).
        py.check_signals()?;
        let columns = PyDict::new(py);
        let TimeSeries { names, cols } = series;
        for (name, col) in names.iter().zip(cols) {
            columns.set_item(name, PyArray1::from_vec(py, col))?;
        }
        let summary = json_to_py(py, &summary).map_err(|e| Kind::Run.chain(&e))?;
        PyTuple::new(py, [summary, PyList::new(py, &names)?.into_any(), columns.into_any()])
    })
}
