//! The Python exceptions and the conversions of the library's errors.

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use sonarnet::model::error::InputError;

pyo3::create_exception!(
    sonarnet,
    ScenarioError,
    PyValueError,
    "A scenario, an override or an argument is invalid: the command line's \
     exit-2 errors. Attributes: file, key (None when the whole file is \
     meant) and reason; str() is the command line's message."
);
pyo3::create_exception!(
    sonarnet,
    RunError,
    PyRuntimeError,
    "A run could not complete (an engine error, a node that failed, a \
     results directory that cannot be written). Attribute run: the partial \
     Run when the engine stopped early (its status is 'failed'), else None."
);
pyo3::create_exception!(
    sonarnet,
    RunInterrupted,
    PyKeyboardInterrupt,
    "Ctrl-C stopped a run in order: a KeyboardInterrupt whose attribute run \
     holds what was completed (status 'interrupted'), as the command line \
     keeps the partial results of an interrupted run."
);

/// A [`ScenarioError`] from an input error, with its parts as attributes.
pub fn scenario_error(py: Python<'_>, e: &InputError) -> PyErr {
    let err = ScenarioError::new_err(e.to_string());
    let v = err.value(py);
    let _ = v.setattr("file", e.file.display().to_string());
    let _ = v.setattr("key", e.location.clone());
    let _ = v.setattr("reason", e.reason.clone());
    err
}

/// A [`ScenarioError`] about a Python argument (`engine=`, `grid=`).
pub fn argument_error(py: Python<'_>, arg: &str, reason: impl Into<String>) -> PyErr {
    scenario_error(
        py,
        &InputError::at(std::path::Path::new("<arguments>"), arg, reason),
    )
}

/// A [`RunError`] with `run` attached (None when there is nothing).
pub fn run_error(py: Python<'_>, message: String, run: Option<Py<PyAny>>) -> PyErr {
    let err = RunError::new_err(message);
    let _ = err.value(py).setattr("run", run);
    err
}

/// A [`RunInterrupted`] holding the partial run.
pub fn interrupted(py: Python<'_>, message: String, run: Option<Py<PyAny>>) -> PyErr {
    let err = RunInterrupted::new_err(message);
    let _ = err.value(py).setattr("run", run);
    err
}

/// The library's `RunError` (input, results directory, output).
pub fn from_pipeline(py: Python<'_>, e: sonarnet::pipeline::RunError) -> PyErr {
    match e {
        sonarnet::pipeline::RunError::Input(e) => scenario_error(py, &e),
        other => run_error(py, sonarnet::cli::one_line(&other), None),
    }
}
