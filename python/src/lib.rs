//! `sonarnet._sonarnet`: the native half of the Python package `sonarnet`.
//!
//! Everything here drives the library as the command line does (the same
//! [`sonarnet::scenario::Scenario::run`], the same table producers as the
//! CSV files, the same sweep), so a run from Python gives the command line's
//! numbers bit for bit. The Python half (`python/sonarnet/`) turns the
//! columns into pandas DataFrames and draws the progress bar.
//!
//! A run holds no GIL: it runs on a worker thread while the calling thread
//! waits with the GIL released, waking every 100 ms to let Python look at
//! its signals. Ctrl-C then asks the engine to stop (as SIGINT does on the
//! command line), the run ends in order with what it completed, and the
//! caller gets `sonarnet.RunInterrupted`, a `KeyboardInterrupt` that holds
//! the partial run.
#![deny(clippy::float_cmp)]

use pyo3::prelude::*;

mod drive;
mod errors;
mod run;
mod scenario;
mod sweep;
mod tables;

/// The node program compiled into the extension: `python -m
/// sonarnet._node --launch JSON` (and the `sonarnet-node` command the
/// package installs) run it, one process per receiver.
#[path = "../../nodes/main.rs"]
#[allow(dead_code)]
mod node_program;

/// Run the node program with `argv` (program name first); returns its exit
/// status.
#[pyfunction]
fn _node_main(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| node_program::node_status(argv))
}

/// The names of the scenarios built into sonarnet (`sonarnet list`), each
/// loadable with `Scenario.builtin(name)`.
#[pyfunction]
fn list_scenarios() -> Vec<&'static str> {
    sonarnet::scenario::shipped::names()
}

/// The native module.
#[pymodule]
fn _sonarnet(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Python owns SIGINT (KeyboardInterrupt): the engines' stop flag is set
    // by the run driver, never by a signal handler of the library's.
    sonarnet::engine::interrupt::embedded();
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("ScenarioError", py.get_type::<errors::ScenarioError>())?;
    m.add("RunError", py.get_type::<errors::RunError>())?;
    m.add("RunInterrupted", py.get_type::<errors::RunInterrupted>())?;
    m.add_class::<scenario::PyScenario>()?;
    m.add_class::<run::PyRun>()?;
    m.add_function(wrap_pyfunction!(list_scenarios, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(run::_bench_native, m)?)?;
    m.add_function(wrap_pyfunction!(_node_main, m)?)?;
    Ok(())
}
