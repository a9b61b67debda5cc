//! One run from Python: the scenario's flags applied as `sonarnet run`
//! applies them, the engine and clock resolved by the library's one rule,
//! the run driven with the GIL released, and its results kept in memory.

use crate::drive::{Tick, drive};
use crate::errors::{argument_error, from_pipeline, interrupted, run_error, scenario_error};
use crate::scenario::PyScenario;
use crate::tables::Columns;
use pyo3::prelude::*;
use sonarnet::pipeline::{self, Clock, EngineKind, NetOptions, Outcome, RunOptions};
use sonarnet::protocol::{Key, RunConfig, TransportKind};
use sonarnet::scenario::{AnyScenario, Mode, Scenario};
use std::path::PathBuf;

/// The arguments of `Scenario.run` and `Scenario.monte_carlo`.
pub struct RunArgs {
    pub engine: Option<String>,
    pub clock: Option<String>,
    pub seed: Option<u64>,
    pub mode: Option<String>,
    pub baselines: Option<Vec<String>>,
    pub transport: Option<String>,
    pub poll_us: u64,
    pub stall_timeout_s: f64,
    pub out: Option<PathBuf>,
    pub trials: Option<usize>,
}

/// A named value of `arg=` (an engine, a clock, a mode), or the error
/// listing the names there are.
fn named<T: std::str::FromStr<Err = sonarnet::model::names::UnknownName>>(
    py: Python<'_>,
    arg: &str,
    v: &Option<String>,
) -> PyResult<Option<T>> {
    v.as_deref()
        .map(|s| s.parse::<T>())
        .transpose()
        .map_err(|e| argument_error(py, arg, e.to_string()))
}

/// The scenario with the run's arguments applied, as the command line's
/// flags are (`--seed`, `--mode`, `--baselines`).
fn with_args<const D: usize>(
    py: Python<'_>,
    mut sc: Scenario<D>,
    a: &RunArgs,
) -> PyResult<Scenario<D>> {
    let input = |e: sonarnet::model::error::InputError| scenario_error(py, &e);
    if let Some(s) = a.seed {
        sc = sc.with_seed(s);
    }
    if let Some(m) = named::<Mode>(py, "mode", &a.mode)? {
        sc = sc.with_mode(m).map_err(input)?;
    }
    if let Some(kinds) = &a.baselines {
        let cfgs = kinds
            .iter()
            .map(|k| {
                sonarnet::estimators::baselines::BaselineCfg::default_of(k.trim()).ok_or_else(
                    || {
                        argument_error(
                            py,
                            "baselines",
                            format!(
                                "unknown baseline {k:?} (expected one of {})",
                                sonarnet::estimators::baselines::KINDS.join(", ")
                            ),
                        )
                    },
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        sc = sc.with_baselines(cfgs).map_err(input)?;
    }
    sc = sc.with_trials(a.trials).map_err(input)?;
    sc.check_size_cli().map_err(input)?;
    Ok(sc)
}

/// The engine and clock of the run, by [`RunConfig::resolve`]; a refusal
/// names the argument (`engine=`) or the scenario key.
fn resolve<const D: usize>(
    py: Python<'_>,
    sc: &Scenario<D>,
    a: &RunArgs,
) -> PyResult<(EngineKind, Clock)> {
    let transport = named::<TransportKind>(py, "transport", &a.transport)?.unwrap_or_default();
    if transport == TransportKind::Zenoh {
        return Err(argument_error(
            py,
            "transport",
            "the Python package is built without zenoh: run across hosts with the \
             command line built with --features zenoh",
        ));
    }
    let cfg = RunConfig {
        engine: named::<EngineKind>(py, "engine", &a.engine)?,
        clock: named::<Clock>(py, "clock", &a.clock)?,
        transport,
        poll_us: a.poll_us,
        trials: a.trials.unwrap_or(1),
    };
    cfg.resolve(sc).map_err(|r| match r.key {
        Key::Flag(flag) => argument_error(
            py,
            &flag.trim_start_matches("--").replace('-', "_"),
            r.reason,
        ),
        Key::Scenario(key) => scenario_error(
            py,
            &sonarnet::model::error::InputError::at(&sc.path, key, r.reason),
        ),
    })
}

/// The node program of runs from Python: this interpreter running
/// `sonarnet._node` (the node program compiled into the extension), unless
/// `$SONARNET_NODE_BIN` names a `sonarnet-node` binary.
fn node_program(py: Python<'_>) -> PyResult<sonarnet::runtime::processes::NodeProgram> {
    if std::env::var_os("SONARNET_NODE_BIN").is_some() {
        return Ok(sonarnet::runtime::processes::default_node_program());
    }
    let exe: PathBuf = py.import("sys")?.getattr("executable")?.extract()?;
    if exe.as_os_str().is_empty() {
        return Err(run_error(
            py,
            "cannot start node processes: sys.executable is empty (an embedded \
             interpreter); set SONARNET_NODE_BIN to a sonarnet-node binary"
                .into(),
            None,
        ));
    }
    Ok(sonarnet::runtime::processes::NodeProgram {
        program: exe,
        args: vec!["-m".into(), "sonarnet._node".into()],
    })
}

/// The options of the run, as `sonarnet run` builds them.
fn options<const D: usize>(py: Python<'_>, sc: &Scenario<D>, a: &RunArgs) -> PyResult<RunOptions> {
    let (engine, clock) = resolve(py, sc, a)?;
    if !(0.1..=3600.0).contains(&a.stall_timeout_s) {
        return Err(argument_error(
            py,
            "stall_timeout_s",
            format!("{} is outside [0.1, 3600]", a.stall_timeout_s),
        ));
    }
    if a.poll_us > 1_000_000 {
        return Err(argument_error(
            py,
            "poll_us",
            format!("{} is outside [0, 1000000]", a.poll_us),
        ));
    }
    let mut command_line = vec!["python: sonarnet.Scenario.run".to_string()];
    command_line.extend(sc.overrides.iter().map(|o| format!("--set {o}")));
    let opts = RunOptions {
        engine,
        clock,
        out_dir: a
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results/python-run")),
        command_line,
        progress: false,
        check_expect: true,
        poll_us: a.poll_us,
        verbose: false,
        stall_timeout: std::time::Duration::from_secs_f64(a.stall_timeout_s),
        write_checkpoints: a.out.is_some(),
        net: NetOptions {
            node_program: Some(node_program(py)?),
            ..NetOptions::default()
        },
    };
    if let Some(dir) = &a.out {
        pipeline::outdir::prepare_out_dir(dir)
            .map_err(|e| argument_error(py, "out", sonarnet::cli::one_line(&e)))?;
    }
    pipeline::preflight(sc, &opts).map_err(|e| scenario_error(py, &e))?;
    Ok(opts)
}

/// A finished run in memory (either dimension).
pub enum AnyOutcome {
    Plane(Box<Outcome<2>>, Box<Scenario<2>>),
    Space(Box<Outcome<3>>, Box<Scenario<3>>),
}

/// `Scenario.run`.
pub fn run(
    py: Python<'_>,
    s: &PyScenario,
    a: &RunArgs,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    match &s.chosen {
        AnyScenario::Plane(sc) => run_in(py, sc, a, progress, AnyOutcome::Plane),
        AnyScenario::Space(sc) => run_in(py, sc, a, progress, AnyOutcome::Space),
    }
}

/// [`run`] in `D` dimensions; `wrap` keeps the outcome with its scenario.
fn run_in<const D: usize>(
    py: Python<'_>,
    sc: &Scenario<D>,
    a: &RunArgs,
    progress: Option<&Bound<'_, PyAny>>,
    wrap: fn(Box<Outcome<D>>, Box<Scenario<D>>) -> AnyOutcome,
) -> PyResult<Py<PyAny>> {
    let sc = with_args(py, sc.clone(), a)?;
    let opts = options(py, &sc, a)?;
    let d = drive(py, progress, move |tick| {
        let o = run_one(&sc, &opts, tick);
        (o, sc, opts)
    })?;
    let (o, sc, opts) = d.value;
    finish(py, wrap(Box::new(o), Box::new(sc)), opts, d.interrupted)
}

fn run_one<const D: usize>(sc: &Scenario<D>, opts: &RunOptions, tick: Tick<'_>) -> Outcome<D> {
    let start = std::time::Instant::now();
    let mut progress = |k: usize, it: u64| {
        let secs = start.elapsed().as_secs_f64().max(1e-9);
        tick(
            k as u64,
            format!("{it} iterations, {:.0} it/s", it as f64 / secs),
        );
    };
    pipeline::run(sc, opts, &mut progress)
}

/// Write the results directory when asked, then hand the run to Python,
/// or raise what stopped it (with the partial run attached).
fn finish(
    py: Python<'_>,
    outcome: AnyOutcome,
    opts: RunOptions,
    stop: Option<PyErr>,
) -> PyResult<Py<PyAny>> {
    let run = PyRun {
        outcome,
        opts,
        dir: None,
    };
    let written = match run.opts.out_dir.clone() {
        dir if run.opts.write_checkpoints => {
            Some(run.write_dir(py, &dir, true, false).map(|_| dir))
        }
        _ => None,
    };
    let error = run.engine_error();
    let status = run.run_status();
    let run = PyRun {
        dir: written.as_ref().and_then(|w| w.as_ref().ok().cloned()),
        ..run
    };
    let obj: Py<PyAny> = Py::new(py, run)?.into_any();
    if let Some(Err(e)) = written {
        return Err(e);
    }
    if let Some(e) = stop {
        if status == pipeline::RunStatus::Interrupted || error.is_none() {
            // Ctrl-C came while the run ran: it stopped in order.
            return Err(interrupted(
                py,
                format!(
                    "interrupted: {}; the completed samples are in the exception's .run",
                    error.unwrap_or_else(|| "the run had completed".into())
                ),
                Some(obj),
            ));
        }
        // Another exception from a signal handler: raise it as it is.
        return Err(e);
    }
    if let Some(error) = error {
        return Err(run_error(
            py,
            format!("{error}\nthe completed samples are in the exception's .run"),
            Some(obj),
        ));
    }
    Ok(obj)
}

/// `Scenario.monte_carlo`: the command line's Monte Carlo into `out`.
pub fn monte_carlo(
    py: Python<'_>,
    s: &PyScenario,
    a: &RunArgs,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<bool> {
    fn go<const D: usize>(
        py: Python<'_>,
        sc: &Scenario<D>,
        a: &RunArgs,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        let sc = with_args(py, sc.clone(), a)?;
        let trials = sc.trials.unwrap_or(1);
        let mut opts = options(py, &sc, a)?;
        opts.engine = EngineKind::Inprocess;
        opts.check_expect = false;
        opts.write_checkpoints = false;
        let d = drive(py, progress, move |tick| {
            let t = |n: usize| tick(n as u64, String::new());
            pipeline::montecarlo::run_monte_carlo(&sc, trials, &opts, &t)
        })?;
        let mc = d.value.map_err(|e| from_pipeline(py, e))?;
        if let Err(e) = sonarnet::plot::write_run_plots(&mc.out_dir) {
            eprintln!("warning: plots were not written: {e}");
        }
        if d.interrupted.is_some() {
            return Err(interrupted(
                py,
                format!(
                    "interrupted after {} of {} trials; the completed trials were written to {}",
                    mc.trials.len(),
                    mc.requested,
                    mc.out_dir.display()
                ),
                None,
            ));
        }
        Ok(mc.interrupted)
    }
    match &s.chosen {
        AnyScenario::Plane(sc) => go(py, sc, a, progress),
        AnyScenario::Space(sc) => go(py, sc, a, progress),
    }
}

/// A finished run: its metrics and tables in memory.
#[pyclass(name = "_Run", module = "sonarnet._sonarnet", frozen)]
pub struct PyRun {
    outcome: AnyOutcome,
    opts: RunOptions,
    dir: Option<PathBuf>,
}

impl PyRun {
    fn metrics(&self) -> &pipeline::RunMetrics {
        match &self.outcome {
            AnyOutcome::Plane(o, _) => &o.metrics,
            AnyOutcome::Space(o, _) => &o.metrics,
        }
    }

    fn run_status(&self) -> pipeline::RunStatus {
        self.metrics().status
    }

    fn engine_error(&self) -> Option<String> {
        let e = match &self.outcome {
            AnyOutcome::Plane(o, _) => &o.run.error,
            AnyOutcome::Space(o, _) => &o.run.error,
        };
        e.as_ref().map(sonarnet::protocol::EngineError::in_full)
    }

    /// Hand the run's tables to `sink`.
    fn fill(&self, py: Python<'_>, sink: &mut Columns) -> PyResult<()> {
        let r = match &self.outcome {
            AnyOutcome::Plane(o, sc) => o.tables(sc, sink),
            AnyOutcome::Space(o, sc) => o.tables(sc, sink),
        };
        r.map_err(|e| from_pipeline(py, e))
    }

    /// Write the results directory `dir` as `sonarnet run` does.
    fn write_dir(
        &self,
        py: Python<'_>,
        dir: &std::path::Path,
        plots: bool,
        png: bool,
    ) -> PyResult<()> {
        let opts = RunOptions {
            out_dir: dir.to_path_buf(),
            ..self.opts.clone()
        };
        let r = match &self.outcome {
            AnyOutcome::Plane(o, sc) => o.write(sc, &opts),
            AnyOutcome::Space(o, sc) => o.write(sc, &opts),
        };
        r.map_err(|e| from_pipeline(py, e))?;
        if plots {
            sonarnet::plot::write_run_plots_as(dir, png)
                .map_err(|e| run_error(py, format!("plots of {}: {e}", dir.display()), None))?;
        }
        Ok(())
    }
}

#[pymethods]
impl PyRun {
    /// metrics.json's content, as JSON text.
    fn metrics_json(&self, py: Python<'_>) -> PyResult<String> {
        serde_json::to_string(self.metrics())
            .map_err(|e| run_error(py, format!("metrics: {e}"), None))
    }

    /// The names of the tables this run has, in the order the results
    /// directory lists them.
    fn table_names(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        let mut sink = Columns::only("");
        self.fill(py, &mut sink)?;
        Ok(sink.names)
    }

    /// Table `name` as columns, `(name, column names, {column: numpy
    /// array or list})`; None when the run has no such table.
    fn table<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Option<crate::tables::PyTable<'py>>> {
        let mut sink = Columns::only(name);
        self.fill(py, &mut sink)?;
        Ok(sink.into_python(py)?.into_iter().next())
    }

    /// `ok`, `interrupted` or `failed`.
    #[getter]
    fn status(&self) -> String {
        self.metrics().status.to_string()
    }

    /// Why the engine stopped early (None when every sample ran).
    #[getter]
    fn error(&self) -> Option<String> {
        self.engine_error()
    }

    /// The run seed.
    #[getter]
    fn seed(&self) -> u64 {
        match &self.outcome {
            AnyOutcome::Plane(_, sc) => sc.seed,
            AnyOutcome::Space(_, sc) => sc.seed,
        }
    }

    /// The engine that ran it.
    #[getter]
    fn engine(&self) -> &'static str {
        self.opts.engine.as_str()
    }

    /// The clock.
    #[getter]
    fn clock(&self) -> &'static str {
        self.opts.clock.as_str()
    }

    /// The results directory written with the run (`out=`), else None.
    #[getter]
    fn dir(&self) -> Option<PathBuf> {
        self.dir.clone()
    }

    /// Write the results directory `sonarnet run` writes (CSVs, JSON and,
    /// with `plots`, the SVG plots; PNG too with `png`).
    #[pyo3(signature = (dir, plots=true, png=false))]
    fn write(&self, py: Python<'_>, dir: PathBuf, plots: bool, png: bool) -> PyResult<()> {
        pipeline::outdir::prepare_out_dir(&dir)
            .map_err(|e| argument_error(py, "dir", sonarnet::cli::one_line(&e)))?;
        self.write_dir(py, &dir, plots, png)
    }
}

/// Time `runs` in-process runs of the scenario from Rust alone (no Python
/// between them): the reference of the Python overhead benchmark.
#[pyfunction]
pub fn _bench_native(py: Python<'_>, s: &PyScenario, runs: usize) -> PyResult<f64> {
    fn go<const D: usize>(sc: &Scenario<D>, runs: usize) -> f64 {
        let opts = RunOptions::inprocess();
        let t = std::time::Instant::now();
        for _ in 0..runs {
            std::hint::black_box(sc.run(&opts));
        }
        t.elapsed().as_secs_f64()
    }
    Ok(py.detach(|| match &s.chosen {
        AnyScenario::Plane(sc) => go(sc, runs),
        AnyScenario::Space(sc) => go(sc, runs),
    }))
}
