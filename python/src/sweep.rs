//! `sonarnet.sweep`'s native half: the command line's sweep of a grid of
//! overrides over seeds, from a scenario's text and overrides.

use crate::drive::drive;
use crate::errors::{argument_error, from_pipeline, interrupted, scenario_error};
use crate::scenario::PyScenario;
use pyo3::prelude::*;
use sonarnet::pipeline::sweep::{Axis, SweepPlan, run_sweep, write_tables};
use sonarnet::pipeline::{EngineKind, RunOptions};
use sonarnet::scenario::AnyScenario;
use std::path::PathBuf;

/// Run the grid `axes` (key, values as `--grid` takes them) at every seed
/// with `jobs` runs at once, into `out` (its `sweep.csv` and
/// `sweep-summary.csv`, and a directory per run).
#[pyfunction]
#[pyo3(signature = (scenario, axes, seeds, jobs, engine, out, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn _sweep(
    py: Python<'_>,
    scenario: &PyScenario,
    axes: Vec<(String, Vec<String>)>,
    seeds: Vec<u64>,
    jobs: usize,
    engine: &str,
    out: PathBuf,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<usize> {
    let engine: EngineKind = engine
        .parse()
        .map_err(|e: sonarnet::model::names::UnknownName| {
            argument_error(py, "engine", e.to_string())
        })?;
    if !(1..=1024).contains(&jobs) {
        return Err(argument_error(
            py,
            "jobs",
            format!("{jobs} is outside [1, 1024]"),
        ));
    }
    if seeds.is_empty() {
        return Err(argument_error(py, "seeds", "no seed"));
    }
    let mut unique = seeds.clone();
    unique.sort_unstable();
    unique.dedup();
    if unique.len() != seeds.len() {
        return Err(argument_error(py, "seeds", "a seed is given twice"));
    }
    let axes = axes
        .into_iter()
        .map(|(key, values)| Axis { key, values })
        .collect();
    let variants: Vec<String> = scenario.variant.iter().cloned().collect();
    let plan = SweepPlan::of_text(
        &scenario.path,
        &scenario.text,
        &scenario.overrides,
        axes,
        seeds,
        &variants,
    )
    .map_err(|e| scenario_error(py, &e))?;
    sonarnet::pipeline::outdir::prepare_out_dir(&out)
        .map_err(|e| argument_error(py, "out", sonarnet::cli::one_line(&e)))?;
    for (_, sc) in &plan.points {
        let r = match sc {
            AnyScenario::Plane(sc) => preflight(sc, engine, &out),
            AnyScenario::Space(sc) => preflight(sc, engine, &out),
        };
        r.map_err(|e| scenario_error(py, &e))?;
    }
    let runs = plan.runs();
    let d = drive(py, progress.as_ref(), move |tick| {
        let t = |n: usize| tick(n as u64, String::new());
        let o = run_sweep(&plan, engine, jobs, &out, &t);
        (o, plan, out)
    })?;
    let (outcome, plan, out) = d.value;
    write_tables(&plan, &outcome, &out).map_err(|e| from_pipeline(py, e))?;
    if d.interrupted.is_some() {
        return Err(interrupted(
            py,
            format!(
                "interrupted after {} of {runs} runs; the completed runs were written to {}",
                outcome.runs.len(),
                out.display()
            ),
            None,
        ));
    }
    Ok(outcome.runs.len())
}

fn preflight<const D: usize>(
    sc: &sonarnet::scenario::Scenario<D>,
    engine: EngineKind,
    out: &std::path::Path,
) -> Result<(), sonarnet::model::error::InputError> {
    let opts = RunOptions::inprocess()
        .with_engine(engine)
        .with_clock(sonarnet::pipeline::default_clock(sc))
        .with_out_dir(out);
    sonarnet::pipeline::preflight(sc, &opts)
}
