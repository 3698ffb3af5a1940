//! One run in memory (`acs.run`): the scenario flown by `sim_core::runner::run_observed`
//! into a `TimeSeries`, with the interpreter's lock released while it flies. Every
//! [`CHECK_EVERY`] control steps the run takes the lock back for a moment to check for
//! Ctrl-C (`KeyboardInterrupt` ends the run) and to call the progress callback. The
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
use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::series::TimeSeries;
use sim_core::runner::{self, Summary};
use sim_core::scenario::Scenario;
use std::path::PathBuf;

/// Control steps between two looks at the interpreter (signals, progress callback).
pub const CHECK_EVERY: u64 = 256;

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

/// Why a run stopped early at the observer's request: Ctrl-C or an error in the progress
/// callback (the Python exception, raised again once the run has returned).
struct Interrupted(PyErr);

/// Flies `sc` on `kind` without the interpreter's lock; `observe` gets the lock.
fn fly(
    sc: &Scenario,
    kind: &LinkKind,
    firmware: Option<PathBuf>,
    callback: Option<&Py<PyAny>>,
) -> Result<(Summary, TimeSeries), (anyhow::Error, Option<PyErr>)> {
    let firmware_again = firmware.clone();
    let mut l = link::open(kind, &LinkOptions { firmware }).map_err(|e| (e, None))?;
    let mut series = TimeSeries::default();
    let mut stop: Option<Interrupted> = None;
    let mut observe = |done: u64, total: u64| -> anyhow::Result<()> {
        if !done.is_multiple_of(CHECK_EVERY) && done <= total {
            return Ok(());
        }
        Python::attach(|py| {
            py.check_signals()?;
            match callback {
                Some(cb) => cb.call1(py, (done.min(total + 1), total + 1)).map(drop),
                None => Ok(()),
            }
        })
        .map_err(|e| {
            stop = Some(Interrupted(e));
            anyhow::anyhow!("interrupted")
        })
    };
    let r = runner::run_observed(sc, l.as_mut(), &mut series, &mut observe);
    drop(l);
    match r {
        Ok(mut summary) => {
            // `[margins]`: measured after the run on the same link, as `sim-host run` does.
            let base = sim_host::margins::MarginOptions {
                link: kind.clone(),
                link_options: LinkOptions { firmware: firmware_again },
                threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
                ..Default::default()
            };
            summary.margins = sim_host::margins::summary::for_scenario(sc, &base).map_err(|e| (e, None))?.map(|m| m.0);
            Ok((summary, series))
        }
        Err(e) => Err((e, stop.map(|s| s.0))),
    }
}

/// Runs `scenario` in memory; returns `(summary, column names, columns)` for the Python
/// layer (`acs.run` wraps them in `acs.RunResult`).
#[pyfunction]
#[pyo3(signature = (scenario, link=None, progress=None, output_every=None, firmware=None))]
pub fn run<'py>(
    py: Python<'py>,
    scenario: PyRef<'_, PyScenario>,
    link: Option<&str>,
    progress: Option<Py<PyAny>>,
    output_every: Option<u32>,
    firmware: Option<PathBuf>,
) -> PyResult<Bound<'py, PyTuple>> {
    guard(|| {
        let mut sc = scenario.parsed.clone();
        if let Some(n) = output_every {
            sc.timing.output_every = n;
            sc.validate().map_err(|e| Kind::Scenario.chain(&e.context("output_every")))?;
        }
        let kind = link_kind(&sc, link).map_err(|e| Kind::Run.chain(&e))?;
        let flown = py.detach(|| fly(&sc, &kind, firmware, progress.as_ref()));
        let (summary, series) = match flown {
            Ok(x) => x,
            Err((_, Some(interrupt))) => return Err(interrupt),
            Err((e, None)) => return Err(Kind::Run.chain(&e)),
        };
        let columns = PyDict::new(py);
        let TimeSeries { names, cols } = series;
        for (name, col) in names.iter().zip(cols) {
            columns.set_item(name, PyArray1::from_vec(py, col))?;
        }
        let summary = json_to_py(py, &summary).map_err(|e| Kind::Run.chain(&e))?;
        PyTuple::new(py, [summary, PyList::new(py, &names)?.into_any(), columns.into_any()])
    })
}
