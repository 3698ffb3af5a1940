//! The Python package `acs`: its native module `acs._core`, bindings of the simulator
//! core library (`sim_core`: scenarios, runs, the in-process flight code) and of the tools
//! library (`sim_host`: campaigns). The user-facing API (`acs.run`, `acs.RunResult`,
//! `acs.campaign`) is the thin Python layer in `python/acs/`; `docs/python.md` is the
//! guide.
//!
//! - [`errors`]: the exception classes and the one mapping from Rust errors (and panics);
//! - [`convert`]: values between serde (TOML, JSON, the flight messages) and Python;
//! - [`scenario`]: `acs.Scenario`, keys addressed by the campaigns' key paths;
//! - [`run`]: one run in memory, columns handed to numpy without a copy per row;
//! - [`fsw`]: `acs.Fsw`, the flight step called from Python, and recorded frames;
//! - [`strict`]: Python values read into the flight messages as strictly as the wire reads them;
//! - [`campaign`]: plan, run and merge of a Monte Carlo campaign.

use pyo3::prelude::*;

pub mod campaign;
pub mod convert;
pub mod errors;
pub mod fsw;
pub mod run;
pub mod scenario;
pub mod strict;
pub mod view;

#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("PROTOCOL_VERSION", acs_flight::link::PROTOCOL_VERSION)?;
    errors::register(py, m)?;
    // numpy's C API is loaded now, not at the first array a run returns: loading it runs
    // Python code, which a pending Ctrl-C would interrupt (rust-numpy then panics).
    errors::guard(|| {
        drop(numpy::PyArray1::<f64>::from_vec(py, Vec::new()));
        Ok(())
    })?;
    m.add_class::<scenario::PyScenario>()?;
    m.add_class::<fsw::PyFsw>()?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(fsw::record_frames, m)?)?;
    m.add_function(wrap_pyfunction!(fsw::empty_frame, m)?)?;
    m.add_function(wrap_pyfunction!(fsw::frame_to_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::campaign_plan, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::campaign_run, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::campaign_merge, m)?)?;
    m.add_function(wrap_pyfunction!(view::view_run_dir, m)?)?;
    m.add_function(wrap_pyfunction!(view::view_result, m)?)?;
    m.add_function(wrap_pyfunction!(errors::panic_for_test, m)?)?;
    Ok(())
}
