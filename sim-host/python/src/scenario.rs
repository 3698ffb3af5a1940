//! `acs.Scenario`: a scenario file in memory, every key explicit (defaults materialised,
//! as `sim-host campaign plan` writes its runs), read and set by the key paths campaigns
//! use (`controller.wn_rad_s`, `initial.euler_deg[2]`: `sim_host::campaign::path`).
//!
//! Every change is checked the way `sim-host run` reads a file ([`Scenario::from_toml`]:
//! unknown keys, types, array lengths, finite numbers, then every value's range) before it
//! is kept, so an object always holds a valid scenario; [`PyScenario::check`] resolves it
//! as a run does (`Scenario` → `Resolved`, the flight parameters it uploads).

use crate::convert::{from_py, to_py};
use crate::errors::{Kind, guard, scenario_key_error, scenario_type_error};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::scenario::{Resolved, Scenario};
use sim_host::campaign::path::KeyPath;
use std::path::PathBuf;

/// A valid scenario: the typed value a run flies and its TOML tree (every key explicit).
#[pyclass(name = "Scenario", module = "acs", skip_from_py_object)]
#[derive(Clone)]
pub struct PyScenario {
    pub parsed: Scenario,
    value: toml::Value,
}

impl PyScenario {
    pub fn new(parsed: Scenario) -> anyhow::Result<Self> {
        let value = toml::Value::try_from(&parsed)?;
        Ok(Self { parsed, value })
    }

    /// Reads `value` as a scenario file (all of `sim-host run`'s checks).
    fn from_value(value: &toml::Value) -> anyhow::Result<Self> {
        if !value.is_table() {
            anyhow::bail!("a scenario is a table of keys (a dict), not a {}", value.type_str());
        }
        Self::new(Scenario::from_toml(&toml::to_string(value)?)?)
    }

    /// The value at `key`, or an `acs.ScenarioKeyError` (a `KeyError`) naming what is missing.
    fn get(&self, py: Python<'_>, key: &str) -> PyResult<toml::Value> {
        let path = KeyPath::parse(key).map_err(|e| Kind::Scenario.chain(&e))?;
        let mut v = self.value.clone();
        path.get_mut(&mut v, false).map(|x| x.clone()).map_err(|e| scenario_key_error(py, format!("{e:#}")))
    }

    /// The scenario `value` with every `(key, value)` set, checked once at the end. Reading
    /// the Python values may run Python code, so no borrow of the object is held meanwhile.
    fn with(value: &toml::Value, changes: &[(String, Bound<'_, PyAny>)]) -> PyResult<Self> {
        let mut v = value.clone();
        for (key, obj) in changes {
            let path = KeyPath::parse(key).map_err(|e| Kind::Scenario.chain(&e))?;
            let new: toml::Value = from_py(obj).map_err(|e| {
                Kind::Scenario.err(format!(
                    "key `{key}`: {e} (a scenario value is a float, int, bool, str, list or dict; TOML has no None)"
                ))
            })?;
            *path.get_mut(&mut v, true).map_err(|e| Kind::Scenario.chain(&e))? = new;
        }
        let keys: Vec<&str> = changes.iter().map(|(k, _)| k.as_str()).collect();
        Self::from_value(&v).map_err(|e| Kind::Scenario.err(format!("setting `{}`: {e:#}", keys.join("`, `"))))
    }
}

/// The scenario a run or a flight software is built from: a copy taken now, so that the
/// object can be changed meanwhile (from another thread, while a run flies without the
/// interpreter's lock) without a borrow conflict and without changing what flies.
pub fn snapshot(obj: &Bound<'_, PyScenario>) -> PyResult<Scenario> {
    Ok(obj.try_borrow().map_err(|e| busy(&e))?.parsed.clone())
}

/// Sets `changes` on `slf`: computed from a copy (no borrow held while Python values are
/// read), then swapped in whole.
fn replace(slf: &Bound<'_, PyScenario>, changes: &[(String, Bound<'_, PyAny>)]) -> PyResult<()> {
    let value = slf.try_borrow().map_err(|e| busy(&e))?.value.clone();
    let new = PyScenario::with(&value, changes)?;
    *slf.try_borrow_mut().map_err(|e| busy(&e))? = new;
    Ok(())
}

/// A borrow refused: only possible when a scenario is changed from inside the reading of
/// its own new value (Python code called back); never PyO3's bare `RuntimeError`.
fn busy(e: &dyn std::fmt::Display) -> PyErr {
    Kind::Scenario.err(format!("the scenario is being changed by another call ({e})"))
}

#[pymethods]
impl PyScenario {
    /// Reads and validates a scenario file (as `sim-host run` does).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        guard(|| Scenario::load(&path).and_then(Self::new).map_err(|e| Kind::Scenario.chain(&e)))
    }

    /// A scenario from the text of a TOML file.
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        guard(|| Scenario::from_toml(text).and_then(Self::new).map_err(|e| Kind::Scenario.chain(&e)))
    }

    /// A scenario from a dict shaped like the TOML file (tables as dicts).
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyAny>) -> PyResult<Self> {
        guard(|| {
            if !d.is_instance_of::<PyDict>() {
                return Err(scenario_type_error(d.py(), "Scenario.from_dict needs a dict".into()));
            }
            let v: toml::Value = from_py(d).map_err(|e| Kind::Scenario.err(format!("scenario dict: {e}")))?;
            Self::from_value(&v).map_err(|e| Kind::Scenario.chain(&e))
        })
    }

    #[getter]
    fn name(&self) -> String {
        self.parsed.name.clone()
    }

    /// Control steps after t = 0 (a run flies steps 0..=steps).
    #[getter]
    fn steps(&self) -> u64 {
        self.parsed.steps()
    }

    fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        guard(|| to_py(py, &self.get(py, key)?).map_err(|e| Kind::Scenario.chain(&e)))
    }

    fn __setitem__(slf: &Bound<'_, Self>, key: String, value: Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| replace(slf, &[(key, value)]))
    }

    fn __contains__(&self, py: Python<'_>, key: &str) -> bool {
        self.get(py, key).is_ok()
    }

    /// Sets several keys at once, checked together (a change that needs two keys, such as
    /// a new controller type and its gains).
    fn update(slf: &Bound<'_, Self>, changes: &Bound<'_, PyDict>) -> PyResult<()> {
        guard(|| {
            let pairs: Vec<(String, Bound<'_, PyAny>)> = changes
                .iter()
                .map(|(k, v)| match k.extract::<String>() {
                    Ok(k) => Ok((k, v)),
                    Err(_) => Err(Kind::Scenario.err(format!("update: a key is {k:?}, not a key path (a string)"))),
                })
                .collect::<PyResult<_>>()?;
            replace(slf, &pairs)
        })
    }

    fn copy(&self) -> Self {
        self.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    /// The scenario as nested dicts (every key explicit).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| to_py(py, &self.value).map_err(|e| Kind::Scenario.chain(&e)))
    }

    /// The scenario as TOML text (a file `sim-host run` reads back to the same scenario).
    fn to_toml(&self) -> PyResult<String> {
        guard(|| toml::to_string(&self.value).map_err(|e| Kind::Scenario.err(e)))
    }

    /// Resolves the scenario as a run does (`sim-host check` / `run`): clock, plant,
    /// sensors, the flight parameters or mode table and their validation by the flight
    /// code's own rules. Returns what `sim-host check` prints first.
    fn check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let sc = &self.parsed;
            Resolved::try_from(sc).map_err(|e| Kind::Scenario.chain(&e))?;
            let d = PyDict::new(py);
            d.set_item("name", &sc.name)?;
            d.set_item("steps", sc.steps())?;
            d.set_item("closed_loop", sc.closed_loop())?;
            let sum =
                |p: &acs_flight::params::FlightParams| p.checksum().map_err(|e| Kind::Scenario.err(format!("{e:?}")));
            if let Some(t) = sc.mode_table().map_err(|e| Kind::Scenario.chain(&e))? {
                let modes = PyDict::new(py);
                for (mode, p) in &t.slots {
                    modes.set_item(mode.name(), sum(p)?)?;
                }
                d.set_item("mode_checksums", modes)?;
            } else if sc.closed_loop() {
                let p = sc.flight_params().map_err(|e| Kind::Scenario.chain(&e))?;
                d.set_item("checksum", sum(&p)?)?;
            }
            Ok(d)
        })
    }

    fn __repr__(&self) -> String {
        format!("Scenario({:?}, {} steps)", self.parsed.name, self.parsed.steps())
    }

    fn __eq__(&self, other: PyRef<'_, Self>) -> bool {
        self.value == other.value
    }
}
