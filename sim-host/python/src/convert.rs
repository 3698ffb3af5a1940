//! Values between serde and Python. Numbers keep their bits: an f64 is a Python float, an
//! f32 of the flight messages is widened to f64 (exact), and a Python float read into an
//! f32 field is rounded to the nearest f32 (exact for values that came out of one).
//! JSON-shaped outputs (`summary.json`, `campaign.json`, manifests) go through
//! `serde_json::Value`, so that Python sees exactly what `json.load` of the file gives
//! (a non-finite number as `None`, as the file writes it).

use pyo3::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// A serde value as a Python object (dicts, lists, floats, ints, strings).
pub fn to_py<'py, T: Serialize + ?Sized>(py: Python<'py>, v: &T) -> anyhow::Result<Bound<'py, PyAny>> {
    pythonize::pythonize(py, v).map_err(|e| anyhow::anyhow!("{e}"))
}

/// What the JSON file of `v` would read back as in Python (`json.load`).
pub fn json_to_py<'py, T: Serialize + ?Sized>(py: Python<'py>, v: &T) -> anyhow::Result<Bound<'py, PyAny>> {
    to_py(py, &serde_json::to_value(v)?)
}

/// A Python object as a serde value.
pub fn from_py<T: DeserializeOwned>(obj: &Bound<'_, PyAny>) -> anyhow::Result<T> {
    pythonize::depythonize(obj).map_err(|e| anyhow::anyhow!("{e}"))
}
