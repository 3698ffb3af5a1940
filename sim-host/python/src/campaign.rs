//! Campaigns from Python (`acs.campaign.plan / run / merge`): the `sim_host::campaign`
//! functions the `sim-host campaign` commands call, so the directory holds the same files
//! and `campaign.json` the same result. The lock is released while they work; a campaign
//! run stops on Ctrl-C (`KeyboardInterrupt`) within a fraction of a second.

use crate::convert::json_to_py;
use crate::errors::{Kind, guard};
use crate::run::interruptible;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::link::cancel::Cancel;
use sim_host::campaign::{self, Campaign, Shard};
use std::path::PathBuf;

/// `sim-host campaign plan SPEC --out OUT [--runs N]`: the manifest as a dict.
#[pyfunction]
#[pyo3(signature = (spec, out, runs=None))]
pub fn campaign_plan(py: Python<'_>, spec: PathBuf, out: PathBuf, runs: Option<u32>) -> PyResult<Bound<'_, PyAny>> {
    guard(|| {
        let m = py
            .detach(|| Campaign::load(&spec).and_then(|c| campaign::plan(&c, &out, runs)))
            .map_err(|e| Kind::Campaign.chain(&e))?;
        json_to_py(py, &m).map_err(|e| Kind::Campaign.chain(&e))
    })
}

/// `sim-host campaign run DIR [--shard K/S] [--jobs N]`: what the shard did, as a dict.
#[pyfunction]
#[pyo3(signature = (dir, jobs=None, shard=None, progress=false))]
pub fn campaign_run<'py>(
    py: Python<'py>,
    dir: PathBuf,
    jobs: Option<usize>,
    shard: Option<&str>,
    progress: bool,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let shard: Shard = match shard {
            Some(s) => s.parse().map_err(|e| Kind::Campaign.chain(&e))?,
            None => Shard::ALL,
        };
        let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from)).max(1);
        // On worker threads while this one looks for Ctrl-C: the runs in flight then stop
        // and write nothing (the shard resumes with them), and KeyboardInterrupt is raised.
        let cancel = Cancel::new();
        let r = py
            .detach(|| interruptible(&cancel, || campaign::run_shard_until(&dir, shard, jobs, progress, &cancel)))?
            .map_err(|e| Kind::Campaign.chain(&e))?;
        let d = PyDict::new(py);
        for (k, v) in [
            ("assigned", r.assigned),
            ("skipped", r.skipped),
            ("ran", r.ran),
            ("ok", r.ok),
            ("requirement_failed", r.requirement_failed),
            ("errors", r.errors),
            ("diverged", r.diverged),
            ("all_refused", r.all_refused),
            ("margins_failed", r.margins_failed),
            ("no_control", r.no_control),
            ("control_lost", r.control_lost),
            ("recovery_failed", r.recovery_failed),
            ("pointing_degraded", r.pointing_degraded),
            ("propellant_exceeded", r.propellant_exceeded),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    })
}

/// `sim-host campaign merge DIR [--no-plots]`: `campaign.json` as a dict (plus `passed`,
/// the verdict behind the command's exit status). A failed campaign is returned, not
/// raised: read `passed`.
#[pyfunction]
#[pyo3(signature = (dir, plots=true))]
pub fn campaign_merge(py: Python<'_>, dir: PathBuf, plots: bool) -> PyResult<Bound<'_, PyAny>> {
    guard(|| {
        let m = py.detach(|| campaign::merge(&dir, plots)).map_err(|e| Kind::Campaign.chain(&e))?;
        let d = json_to_py(py, &m.result).map_err(|e| Kind::Campaign.chain(&e))?;
        if let Ok(dict) = d.cast::<PyDict>() {
            dict.set_item("passed", m.result.passed())?;
        }
        Ok(d)
    })
}
