//! One run of a scenario: realise the measurements, run an engine, score,
//! and write the results directory.
//!
//! Outputs (one directory per run; every file carries the seed):
//! * `run.json`: resolved scenario, seed, crate version, engine, mode, clock, command line, status;
//! * `track.csv`: `sample,true_x,true_y,est_x,est_y,error,ml_x,ml_y,crlb,ctte,seed`;
//! * `nodes.csv`: `sample,node,x,y,d,alive,seed`;
//! * `schedule.csv`: `iteration,v,w,seed` (async runs);
//! * `measurements.csv`: every measurement in the trace format (replayable);
//! * `iterations.csv`: `iteration,sample,node,x,y,d,seed` with `--trace-iterations`;
//! * `truth.csv`: `sample,x,y,seed` when the truth is known;
//! * `receivers.csv`: `sample,node,x,y,drifts` when receivers drift (`[[geometry.drift]]`);
//! * `metrics.json`: the metrics, see [`RunMetrics`].
//!
//! A 3-D run (`Scenario<3>`) goes through the same functions: its position
//! columns have a `z` after `x` and `y` (`true_z`, `est_z`, `ml_z`,
//! `NAME_z`; `x,y,z,d` in `nodes.csv` and `iterations.csv`).

pub mod bench;
pub mod montecarlo;
pub mod score;

mod evaluate;
pub mod outdir;
pub(crate) mod pool;
pub mod provenance;
pub mod replay;
mod results;
pub mod sweep;
mod write;

pub use evaluate::{check_expect, evaluate, expect_results, unknown_metric};
pub use results::{
    Band, ChannelStats, Death, ExpectResult, FaultOutcome, LinkStats, McSummary, NodeCounters,
    RealtimeStats, RunJson, RunMetrics, RunStatus, TrackBands,
};
pub use write::{
    CsvDir, TableSink, check_out_dir, write_csv, write_json, write_trace, write_track_csv,
};

use crate::engine::RunOutcome;
use crate::model::error::InputError;
use crate::pipeline::score::Scored;
use crate::protocol::EngineError;
use crate::scenario::{Realization, Scenario};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::protocol::{Clock, EngineKind};

/// Options of one run that are not part of the scenario.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Engine.
    pub engine: EngineKind,
    /// Clock.
    pub clock: Clock,
    /// Results directory.
    pub out_dir: PathBuf,
    /// The command line, recorded in `run.json`.
    pub command_line: Vec<String>,
    /// Show a progress bar (only when stderr is a terminal).
    pub progress: bool,
    /// Check the scenario's `[expect]` block and record it in
    /// `metrics.json` (off for the representative trial of a Monte Carlo
    /// run, whose expectations are checked on the trial means).
    pub check_expect: bool,
    /// Multi-process engine: node processes poll their inboxes for up to this many
    /// microseconds before blocking (0: block at once). Recorded in `run.json`.
    pub poll_us: u64,
    /// Multi-process engine: log protocol events of the coordinator and the
    /// nodes to stderr.
    pub verbose: bool,
    /// The liveness watchdog ([`RunPlan::stall_timeout`](crate::protocol::RunPlan::stall_timeout),
    /// `--stall-timeout`). Recorded in `run.json`.
    pub stall_timeout: std::time::Duration,
    /// Node processes that checkpoint (a `restart` fault with `state =
    /// "checkpoint"`) write their files to `out_dir/checkpoints/`, where
    /// they stay with the results. Off: a temporary directory, removed at
    /// the end (runs that are not written, Monte Carlo trials).
    pub write_checkpoints: bool,
    /// Multi-process engine: the transport, and nodes on other hosts.
    pub net: NetOptions,
}

/// How the node processes of a multi-process run reach each other
/// (`--transport`, `--listen`, `--place`, ...). The default is iceoryx2 with
/// every node on this host.
#[derive(Debug, Clone, Default)]
pub struct NetOptions {
    /// iceoryx2 or zenoh (with the coordinator's endpoints).
    pub transport: crate::transport::TransportChoice,
    /// Nodes on other hosts (`--place`, else the scenario's `[deploy]`).
    pub placement: Option<crate::scenario::deploy::Placement>,
    /// How long to wait for the agents of the placement (default 30 s).
    pub agent_wait: Option<std::time::Duration>,
    /// The run id (`--run-id`); default: a fresh one (with a random secret
    /// over zenoh, [`crate::transport::secret_run_id`]).
    pub run_id: Option<String>,
    /// The node program; default: [`crate::runtime::processes::default_node_program`]
    /// (a host such as the Python package names its own).
    pub node_program: Option<crate::runtime::processes::NodeProgram>,
    /// The fleet's key, which the agents of a placement log in with
    /// (`--fleet-key`).
    pub fleet_key: Option<crate::transport::credentials::Secret>,
}

pub use crate::protocol::config::default_clock;

impl RunOptions {
    /// The engine and clock of these options, as [`crate::protocol::RunPlan::new`]
    /// takes them.
    pub fn run_config(&self) -> crate::protocol::RunConfig {
        crate::protocol::RunConfig {
            engine: Some(self.engine),
            clock: Some(self.clock),
            transport: match self.net.transport {
                crate::transport::TransportChoice::Zenoh(_) => {
                    crate::protocol::TransportKind::Zenoh
                }
                _ => crate::protocol::TransportKind::Iceoryx2,
            },
            poll_us: self.poll_us,
            trials: 1,
        }
    }

    /// A run in this process with logical clocks, no progress bar, `[expect]`
    /// checked; nothing is written unless [`Scenario::run_and_write`] is used
    /// (then into `out_dir`, here `results/library-run`).
    pub fn inprocess() -> Self {
        RunOptions {
            engine: EngineKind::Inprocess,
            clock: Clock::Logical,
            out_dir: PathBuf::from("results/library-run"),
            command_line: vec![],
            progress: false,
            check_expect: true,
            poll_us: 0,
            verbose: false,
            stall_timeout: crate::protocol::plan::DEFAULT_STALL_TIMEOUT,
            write_checkpoints: false,
            net: NetOptions::default(),
        }
    }

    /// The same options with clock `clock`.
    pub fn with_clock(mut self, clock: Clock) -> Self {
        self.clock = clock;
        self
    }

    /// The same options with engine `engine`.
    pub fn with_engine(mut self, engine: EngineKind) -> Self {
        self.engine = engine;
        self
    }

    /// The same options writing into `dir` (used by [`Scenario::run_and_write`]).
    pub fn with_out_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.out_dir = dir.into();
        self
    }
}

/// What [`Scenario::run`] returns: every result of the run in memory.
#[derive(Debug)]
pub struct Outcome<const D: usize = 2> {
    /// The run's metrics (those of `metrics.json`), `[expect]` included.
    pub metrics: RunMetrics,
    /// What the engine returned: every node's `theta` per sample, the
    /// schedule, the engine that ran, why the run stopped early if it did
    /// (the results above are then those of the completed samples), and the
    /// processes', channel's and faults' logs where they apply.
    pub run: RunOutcome,
    /// Every track (the distributed `theta_bar`, `ml`, the baselines), scored.
    pub scored: Scored<D>,
    /// The truth and measurements the run was given.
    pub real: Realization<D>,
    /// When the run started (wall clock; recorded in `run.json`).
    pub started: std::time::SystemTime,
}

impl<const D: usize> Outcome<D> {
    /// Every scalar metric by the names `[expect]` uses (`theta_bar.rmse`,
    /// `ml.rmse`, `ogd.ctte`, ...).
    pub fn flat(&self) -> BTreeMap<String, f64> {
        self.metrics.flat()
    }
}

impl Scenario {
    /// Load a 2-D scenario file (the first of its variants when it has
    /// `[[variants]]`; see [`Scenario::load_all`] for all of them, and
    /// [`crate::scenario::AnyScenario`] for a file of either dimension).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Scenario, InputError> {
        Scenario::load(path.as_ref())
    }
}

impl<const D: usize> Scenario<D> {
    /// Run this scenario with its seed and score it, writing nothing: the
    /// library's entry point for scenario-driven tests. The engine comes
    /// from `opts` (`[monte_carlo]` trials are not run here). An engine
    /// failure is not an `Err`: it is `Outcome::run.error` ([`RunOutcome::error`]), with the results
    /// of the samples completed before it.
    ///
    /// ```
    /// use sonarnet::pipeline::RunOptions;
    /// use sonarnet::scenario::Scenario;
    ///
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/mourya2017-spiral.toml");
    /// let out = Scenario::from_file(path)?.with_seed(3).with_samples(30)?.run(&RunOptions::inprocess());
    /// assert!(out.run.error.is_none());
    /// assert!(out.metrics.rmse_after_burn_in.is_some_and(|r| r < 50.0));
    /// assert!(out.metrics.expect.iter().all(|c| c.holds));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run(&self, opts: &RunOptions) -> Outcome<D> {
        run(self, opts, &mut |_, _| {})
    }

    /// [`Scenario::run`], then write the results directory `opts.out_dir`
    /// exactly as `sonarnet run` does (CSVs and JSON; no plots).
    pub fn run_and_write(&self, opts: &RunOptions) -> Result<Outcome<D>, RunError> {
        // The directory must be writable before any work is done.
        check_out_dir(&opts.out_dir)?;
        let opts = &RunOptions {
            write_checkpoints: true,
            ..opts.clone()
        };
        let out = self.run(opts);
        out.write(self, opts)?;
        Ok(out)
    }
}

/// The pipeline of every run (single runs, every Monte Carlo trial, the
/// library's [`Scenario::run`]): [`execute`] it, run the baselines and score
/// every track ([`evaluate`]), and check `[expect]` when `opts` asks for it
/// and the run completed. Writes nothing ([`Outcome::write`] does).
pub fn run<const D: usize>(
    sc: &Scenario<D>,
    opts: &RunOptions,
    progress: crate::engine::Progress<'_>,
) -> Outcome<D> {
    let started = std::time::SystemTime::now();
    let Executed { real, mut run } = execute(sc, opts, progress);
    let (mut metrics, scored) = evaluate(sc, &real, &run, opts);
    // Ctrl-C/SIGTERM while scoring a complete run: scoring is pure
    // computation and finishes (a second signal ends the process at once),
    // then the run is written as interrupted.
    if run.error.is_none() && crate::engine::interrupt::requested() {
        let e = EngineError::Interrupted {
            sample: run.record.thetas.len() as u32,
        };
        metrics.status = RunStatus::Interrupted;
        metrics.error = Some(format!(
            "{} (while scoring: every sample had been run)",
            e.in_full()
        ));
        run.error = Some(e);
    }
    if run.error.is_none() && opts.check_expect {
        metrics.expect = check_expect(sc, &metrics.flat());
    }
    Outcome {
        metrics,
        run,
        scored,
        real,
        started,
    }
}

/// Check, before any work, that this machine can hold the run on `opts`'s
/// engine ([`crate::runtime::preflight`]: node processes need shared memory,
/// open files, process slots and memory in proportion to the receivers and
/// the inbox size). An error names the scenario key most to blame.
pub fn preflight<const D: usize>(sc: &Scenario<D>, opts: &RunOptions) -> Result<(), InputError> {
    if opts.engine != EngineKind::Processes {
        return Ok(());
    }
    // A plan that cannot be built is reported by the run itself.
    let Ok(plan) = crate::protocol::RunPlan::new(sc, opts.run_config()) else {
        return Ok(());
    };
    let needs = crate::runtime::preflight::needs(&plan);
    crate::runtime::preflight::check(&needs, &crate::runtime::preflight::machine())
        .map_err(|e| e.in_file(&sc.path))
}

/// What the engine side of one run produced.
#[derive(Debug)]
pub struct Executed<const D: usize = 2> {
    /// The truth and measurements of the run's seed.
    pub real: Realization<D>,
    /// What the engine returned.
    pub run: RunOutcome,
}

/// The engine side of every run (single runs, Monte Carlo trials, the
/// distributed baseline's engine run excepted, `sonarnet bench`): realize `sc`
/// with its seed, build its [`RunPlan`](crate::protocol::RunPlan) once and run it
/// on the engine and clock of `opts`. `progress` hears of every completed
/// sample.
pub fn execute<const D: usize>(
    sc: &Scenario<D>,
    opts: &RunOptions,
    progress: crate::engine::Progress<'_>,
) -> Executed<D> {
    let real = sc.realize();
    let zenoh = matches!(
        opts.net.transport,
        crate::transport::TransportChoice::Zenoh(_)
    );
    let popts = crate::runtime::processes::ProcessOptions {
        transport: opts.net.transport.clone(),
        // A placement applies over zenoh only: the scenario's [deploy] is
        // ignored on iceoryx2 (every node is then on this host).
        placement: opts
            .net
            .placement
            .clone()
            .or_else(|| sc.deploy.clone())
            .filter(|_| zenoh),
        agent_wait: opts
            .net
            .agent_wait
            .unwrap_or(std::time::Duration::from_secs(30)),
        run_id: opts.net.run_id.clone(),
        fleet_key: opts.net.fleet_key.clone(),
        poll_us: opts.poll_us,
        verbose: opts.verbose,
        checkpoint_dir: opts
            .write_checkpoints
            .then(|| opts.out_dir.join("checkpoints")),
        node_program: opts
            .net
            .node_program
            .clone()
            .unwrap_or_else(crate::runtime::processes::default_node_program),
        ..Default::default()
    };
    let plan = crate::protocol::RunPlan::new(sc, opts.run_config())
        .and_then(|p| p.with_stall_timeout(opts.stall_timeout));
    let run = match plan {
        Ok(plan) => crate::runtime::run(&plan, real.feed(), &popts, progress),
        Err(e) => RunOutcome::refused(sc.graph.len(), e),
    };
    Executed { real, run }
}

/// Errors of a run that prevent writing results at all.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Bad input.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The results directory cannot be used.
    #[error(transparent)]
    OutDir(#[from] outdir::OutDirError),
    /// Could not write the results directory.
    #[error("cannot write results to {}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}
