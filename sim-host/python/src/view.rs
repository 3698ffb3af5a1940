//! The 3D replay page from Python (`acs.view`, `RunResult.view`; docs/viewer.md): the same
//! page `sim-host view` writes, from a run directory or from a run in memory.

use crate::convert::from_py;
use crate::errors::{Kind, guard};
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::recorder::series::TimeSeries;
use sim_core::scenario::Scenario;
use sim_host::view::{RunData, ViewOptions, write_page, write_replay};
use std::path::{Path, PathBuf};

/// `acs.view(run_dir, out=None)`: writes the page of a run directory (`sim-host view`)
/// and returns its path.
#[pyfunction]
#[pyo3(signature = (run_dir, out=None))]
pub fn view_run_dir(py: Python<'_>, run_dir: PathBuf, out: Option<PathBuf>) -> PyResult<String> {
    guard(|| {
        let o = ViewOptions { out, ..Default::default() };
        let r = py.detach(|| write_replay(&run_dir, &o)).map_err(|e| Kind::Run.chain(&e))?;
        Ok(r.page.display().to_string())
    })
}

/// `RunResult.view(path)`: writes the page of a run in memory (its summary, its columns in
/// order, and the TOML of the scenario it flew) to `out` and returns the path.
#[pyfunction]
pub fn view_result(
    py: Python<'_>,
    summary: &Bound<'_, PyAny>,
    names: Vec<String>,
    columns: &Bound<'_, PyDict>,
    scenario_toml: &str,
    out: PathBuf,
) -> PyResult<String> {
    guard(|| {
        let summary: serde_json::Value = from_py(summary).map_err(|e| Kind::Run.chain(&e.context("summary")))?;
        let mut cols = Vec::with_capacity(names.len());
        for name in &names {
            let item = columns.get_item(name)?.ok_or_else(|| Kind::Run.err(format!("no column {name:?}")))?;
            let array: PyReadonlyArray1<'_, f64> = item.extract()?;
            cols.push(array.as_array().to_vec());
        }
        if let Some(bad) = cols.iter().position(|c| c.len() != cols[0].len()) {
            return Err(Kind::Run.err(format!(
                "column {:?} has {} rows, {:?} has {}",
                names[bad],
                cols[bad].len(),
                names[0],
                cols[0].len()
            )));
        }
        let scenario = Scenario::from_toml(scenario_toml).map_err(|e| Kind::Scenario.chain(&e))?;
        let series = TimeSeries { names, cols };
        let data = RunData { series, metadata: Default::default(), summary: Some(summary), scenario: Some(scenario) };
        let o = ViewOptions::default();
        let r = py
            .detach(|| write_page(&data, Path::new("(Python RunResult)"), &out, &o))
            .map_err(|e| Kind::Run.chain(&e))?;
        Ok(r.page.display().to_string())
    })
}
