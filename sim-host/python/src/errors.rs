//! The exceptions of `acs` and the one mapping from Rust errors to them. Every entry point
//! runs its Rust code through [`guard`]: an error becomes the entry point's exception
//! class with the whole `anyhow` chain as its message (the chain names the key or the
//! file), and a Rust panic becomes `acs.InternalError` instead of unwinding into the
//! interpreter (PyO3 would raise `PanicException`, a `BaseException` that `except
//! Exception` does not catch).

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyError, PyTypeError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};
use std::panic::{AssertUnwindSafe, catch_unwind};

create_exception!(acs, AcsError, PyException, "Base class of every error the acs package raises.");
create_exception!(
    acs,
    ScenarioError,
    AcsError,
    "A scenario that cannot be read or is invalid: unknown key, wrong type, non-finite or out-of-range value. The message names the key."
);
create_exception!(
    acs,
    RunError,
    AcsError,
    "A run that could not be flown: the link could not be opened, the flight code refused the parameters, a link error."
);
create_exception!(
    acs,
    FrameError,
    AcsError,
    "A sensor frame or link message that does not decode, or that the flight code refused (Fsw.step, Fsw.request)."
);
create_exception!(acs, CampaignError, AcsError, "A campaign that cannot be planned, run or merged.");
create_exception!(acs, InternalError, AcsError, "A bug: the Rust code panicked (the interpreter keeps running).");

/// `acs.ScenarioKeyError(ScenarioError, KeyError)`: reading a key the scenario does not
/// have. Both an `acs` error and the `KeyError` a mapping raises.
static SCENARIO_KEY_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
/// `acs.ScenarioTypeError(ScenarioError, TypeError)`: an argument of the wrong Python type
/// where a scenario is built (`Scenario.from_dict` of a list).
static SCENARIO_TYPE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// A class deriving from `bases` (PyO3's `create_exception!` takes one base), made by
/// calling `type(name, bases, namespace)` as a `class` statement would.
fn subclass<'py>(py: Python<'py>, name: &str, bases: Bound<'py, PyTuple>, doc: &str) -> PyResult<Bound<'py, PyType>> {
    let ns = PyDict::new(py);
    ns.set_item("__module__", "acs")?;
    ns.set_item("__doc__", doc)?;
    py.get_type::<PyType>().call1((name, bases, ns))?.cast_into::<PyType>().map_err(PyErr::from)
}

fn class<'py>(py: Python<'py>, cell: &'static PyOnceLock<Py<PyType>>, name: &str) -> PyResult<Bound<'py, PyType>> {
    cell.get(py)
        .map(|t| t.bind(py).clone())
        .ok_or_else(|| InternalError::new_err(format!("acs.{name} used before the module was initialised")))
}

/// `acs.ScenarioKeyError` with `msg`.
pub fn scenario_key_error(py: Python<'_>, msg: String) -> PyErr {
    class(py, &SCENARIO_KEY_ERROR, "ScenarioKeyError").map_or_else(|e| e, |t| PyErr::from_type(t, msg))
}

/// `acs.ScenarioTypeError` with `msg`.
pub fn scenario_type_error(py: Python<'_>, msg: String) -> PyErr {
    class(py, &SCENARIO_TYPE_ERROR, "ScenarioTypeError").map_or_else(|e| e, |t| PyErr::from_type(t, msg))
}

/// Which exception class an entry point raises for its errors.
#[derive(Clone, Copy, Debug)]
pub enum Kind {
    Scenario,
    Run,
    Frame,
    Campaign,
}

impl Kind {
    pub fn err(self, e: impl std::fmt::Display) -> PyErr {
        let msg = e.to_string();
        match self {
            Kind::Scenario => ScenarioError::new_err(msg),
            Kind::Run => RunError::new_err(msg),
            Kind::Frame => FrameError::new_err(msg),
            Kind::Campaign => CampaignError::new_err(msg),
        }
    }

    /// An `anyhow` error with its whole chain of contexts (`a: b: c`).
    pub fn chain(self, e: &anyhow::Error) -> PyErr {
        self.err(format!("{e:#}"))
    }
}

/// Runs `f`, turning a panic into `acs.InternalError` (the payload's message kept).
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into());
        Err(InternalError::new_err(format!("internal error in the acs native module (please report): {what}")))
    })
}

pub fn register(py: Python<'_>, m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("AcsError", py.get_type::<AcsError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    m.add("FrameError", py.get_type::<FrameError>())?;
    m.add("CampaignError", py.get_type::<CampaignError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    let scenario = py.get_type::<ScenarioError>();
    let key = SCENARIO_KEY_ERROR.get_or_try_init(py, || {
        let bases = PyTuple::new(py, [scenario.clone(), py.get_type::<PyKeyError>()])?;
        let doc = "A key the scenario does not have (an acs.ScenarioError and a KeyError).";
        subclass(py, "ScenarioKeyError", bases, doc).map(Bound::unbind)
    })?;
    let ty = SCENARIO_TYPE_ERROR.get_or_try_init(py, || {
        let bases = PyTuple::new(py, [scenario.clone(), py.get_type::<PyTypeError>()])?;
        let doc = "An argument of the wrong type for a scenario (an acs.ScenarioError and a TypeError).";
        subclass(py, "ScenarioTypeError", bases, doc).map(Bound::unbind)
    })?;
    m.add("ScenarioKeyError", key.bind(py))?;
    m.add("ScenarioTypeError", ty.bind(py))?;
    Ok(())
}

/// Panics on purpose (tests check that a panic in the native module raises
/// `acs.InternalError` and leaves the interpreter running).
#[pyfunction]
#[pyo3(name = "_panic_for_test")]
pub fn panic_for_test(message: &str) -> PyResult<()> {
    guard(|| panic!("{message}"))
}
