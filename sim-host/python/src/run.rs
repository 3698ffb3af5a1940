//! One run in memory (`acs.run`): the scenario flown by `sim_host::fly` (as `sim-host run`)
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
use sim_core::link::{LinkKind, LinkOptions};
use sim_core::recorder::series::TimeSeries;
use sim_core::runner::Summary;
use sim_core::scenario::Scenario;
use sim_host::fly::{FlyOptions, Watch};
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

/// Flies `sc` as `sim-host run` does ([`sim_host::fly`]) without the interpreter's lock;
/// the observer takes it to look for Ctrl-C (every [`SIGNAL_POLL`] at most) and to call
/// the progress callback (every [`CHECK_EVERY`] steps). `[margins]`: measured after the
/// run on the same link on worker threads ([`interruptible`]).
fn fly(
    sc: &Scenario,
    opts: &FlyOptions,
    cancel: &Cancel,
    callback: Option<&Py<PyAny>>,
) -> Result<(Summary, TimeSeries), Failed> {
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
    let r = sim_host::fly::run(sc, opts, &mut series, Watch::Observer(&mut observe));
    let ran = match (r, stop) {
        (_, Some(e)) => return Err(Failed::Python(e)),
        (r, None) => r?,
    };
    let flown = interruptible(cancel, || ran.with_margins()).map_err(Failed::Python)??;
    Ok((flown.summary, series))
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
        // The token every link of the run and of its margins measurement is opened with.
        let cancel = Cancel::new();
        let link = link.map(str::parse::<LinkKind>).transpose().map_err(|e| Kind::Run.chain(&e))?;
        let opts = FlyOptions {
            link,
            link_options: LinkOptions { firmware, cancel: Some(cancel.clone()) },
            margin_threads: FlyOptions::machine_threads(),
        };
        let flown = py.detach(|| fly(&sc, &opts, &cancel, progress.as_ref()));
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
