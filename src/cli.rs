//! The `sonarnet` command line (clap derive). `main` stays thin: it parses,
//! calls [`dispatch`], prints the error chain once, and maps it to an exit code.

use crate::prox::LocalSolver;
use crate::run::{self, Clock, EngineKind, RunError, RunOptions};
use crate::scenario::{Mode, Scenario};
use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;

/// Emulated distributed multistatic sonar network: asynchronous Douglas-Rachford
/// gossip with exact GTRS local steps.
#[derive(Debug, Parser)]
#[command(name = "sonarnet", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a scenario and write a results directory.
    Run(RunArgs),
    /// Check scenario files (and the trace, truth and schedule files they name).
    Validate {
        /// Scenario files.
        #[arg(required = true)]
        scenarios: Vec<PathBuf>,
    },
    /// Write the plots and a self-contained HTML report of a results
    /// directory (DIR/report.html), or compare two runs (DIR DIR2).
    Report(ReportArgs),
    /// Measure the multi-process engine: overhead over in-process, start-up,
    /// throughput and memory at scale, realtime throughput.
    Bench(BenchArgs),
}

/// `sonarnet report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Results directory (and a second one to compare against).
    #[arg(required = true, num_args = 1..=2, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Also write every plot as PNG.
    #[arg(long)]
    pub png: bool,
    /// Where to write the comparison page [default: DIR/compare-<DIR2 name>.html].
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// `sonarnet bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Directory holding mourya2017-spiral.toml.
    #[arg(long, default_value = "scenarios")]
    pub scenarios: PathBuf,
    /// Node counts of the scale runs (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "64,256")]
    pub nodes: Vec<usize>,
    /// Repeats of each overhead figure (the best is kept).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Where bench.json goes.
    #[arg(long, default_value = "results/bench")]
    pub out: PathBuf,
}

/// `sonarnet run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The scenario TOML file.
    pub scenario: PathBuf,
    /// Gossip mode (overrides algorithm.mode).
    #[arg(long, value_enum)]
    pub mode: Option<Mode>,
    /// Local prox (overrides algorithm.local_solver): gtrs (exact, on the cone),
    /// relaxed (no cone constraint) or gtrs_l0 (gtrs with up to algorithm.kappa
    /// outlier rows per node separated).
    #[arg(long, value_parser = parse_solver)]
    pub local_solver: Option<LocalSolver>,
    /// Run seed (overrides the scenario's seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Douglas-Rachford iterations per sample (overrides the scenario).
    #[arg(long)]
    pub iterations_per_sample: Option<usize>,
    /// Number of samples to run (at most the scenario's).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Results directory [default: results/<name>-<mode>-<engine>-seed<seed>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Which engine runs the nodes: one OS process per receiver over iceoryx2
    /// shared memory, or all nodes in this process (exact same numbers).
    #[arg(long, value_enum, default_value = "processes")]
    pub engine: EngineKind,
    /// Clock of async runs: `logical` (the coordinator draws every pair;
    /// exact, reproducible) or `realtime` (free-running nodes on Poisson
    /// clocks, [realtime] table of the scenario; needs --engine processes).
    #[arg(long, value_enum, default_value = "logical")]
    pub clock: Clock,
    /// Record every node's theta after every iteration into iterations.csv
    /// (used by consensus.svg).
    #[arg(long)]
    pub trace_iterations: bool,
    /// Log coordinator and node events (with node ids) to stderr.
    #[arg(long, short)]
    pub verbose: bool,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Also write report.html into the results directory.
    #[arg(long)]
    pub report: bool,
}

/// Parse a `--local-solver` value with the scenario file's spelling.
fn parse_solver(s: &str) -> Result<LocalSolver, String> {
    serde::Deserialize::deserialize(
        serde::de::value::StrDeserializer::<serde::de::value::Error>::new(s),
    )
    .map_err(|_| format!("unknown local solver `{s}` (expected gtrs, relaxed or gtrs_l0)"))
}

/// How a command failed; decides the exit code.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input (exit 2).
    #[error(transparent)]
    Input(#[from] crate::error::InputError),
    /// The run failed (exit 1); partial results were written to `dir`.
    #[error("{error}\npartial results were written to {}", dir.display())]
    RunFailed {
        /// The reason.
        error: crate::engine::EngineError,
        /// Where the partial results are.
        dir: PathBuf,
    },
    /// Anything else that stops a run (exit 1).
    #[error(transparent)]
    Run(RunError),
    /// Plots or report could not be written (exit 1).
    #[error(transparent)]
    Plot(crate::plot::PlotError),
}

impl From<crate::plot::PlotError> for CliError {
    fn from(e: crate::plot::PlotError) -> Self {
        match e {
            crate::plot::PlotError::Input(i) => CliError::Input(i),
            other => CliError::Plot(other),
        }
    }
}

impl CliError {
    /// The process exit code: 2 for bad input, 1 for a failed run.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Input(_) | CliError::Run(RunError::Input(_)) => 2,
            _ => 1,
        }
    }
}

impl From<RunError> for CliError {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Input(i) => CliError::Input(i),
            other => CliError::Run(other),
        }
    }
}

/// Run a parsed command line.
pub fn dispatch(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Validate { scenarios } => {
            for p in &scenarios {
                let sc = Scenario::load(p)?;
                println!(
                    "{}: ok ({} receivers, {} transmitters, {} edges, {} samples, {} {})",
                    p.display(),
                    sc.graph.len(),
                    sc.geometry.transmitters.len(),
                    sc.graph.edges().len(),
                    sc.samples,
                    sc.algorithm.mode.as_str(),
                    serde_json::to_value(sc.algorithm.local_solver)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_owned))
                        .unwrap_or_default()
                );
            }
            Ok(())
        }
        Command::Run(args) => run_command(args),
        Command::Bench(args) => {
            crate::bench::run_bench(&args.scenarios, &args.nodes, args.repeats, &args.out)?;
            Ok(())
        }
        Command::Report(args) => {
            let path = match args.dirs.as_slice() {
                [a, b] => crate::report::write_comparison(a, b, args.out.as_deref(), args.png)?,
                [a] if args.out.is_none() => crate::report::write_report(a, args.png)?,
                [_] => {
                    return Err(crate::error::InputError::at(
                        std::path::Path::new("<command line>"),
                        "--out",
                        "only applies when comparing two results directories",
                    )
                    .into());
                }
                _ => unreachable!("clap enforces 1..=2 directories"),
            };
            println!("report written to {}", path.display());
            Ok(())
        }
    }
}

/// Load the scenario and apply the command-line overrides.
pub fn resolve_scenario(args: &RunArgs) -> Result<Scenario, CliError> {
    let mut sc = Scenario::load(&args.scenario)?;
    if let Some(s) = args.seed {
        sc = sc.with_seed(s);
    }
    if let Some(m) = args.mode {
        sc = sc.with_mode(m)?;
    }
    if let Some(s) = args.local_solver {
        sc = sc.with_local_solver(s);
        sc.check_kappa()?;
    }
    if let Some(n) = args.iterations_per_sample {
        sc = sc.with_iterations_per_sample(n)?;
    }
    if let Some(n) = args.samples {
        sc = sc.with_samples(n)?;
    }
    Ok(sc.with_trace_iterations(args.trace_iterations))
}

fn run_command(args: RunArgs) -> Result<(), CliError> {
    let sc = resolve_scenario(&args)?;
    if args.clock == Clock::Realtime {
        let cli = std::path::Path::new("<command line>");
        if args.engine != EngineKind::Processes || sc.algorithm.mode != Mode::Async {
            return Err(crate::error::InputError::at(
                cli,
                "--clock",
                "realtime clocks need --engine processes and async mode",
            )
            .into());
        }
        if sc.realtime.is_none() {
            return Err(crate::error::InputError::at(
                &sc.path,
                "realtime",
                "--clock realtime needs a [realtime] table (sample_period_ms, wake_rate_hz)",
            )
            .into());
        }
    }
    let out_dir = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("results").join(format!(
            "{}-{}{}-{}-seed{}",
            sc.name,
            sc.algorithm.mode.as_str(),
            if args.clock == Clock::Realtime {
                "-realtime"
            } else {
                ""
            },
            args.engine.as_str(),
            sc.seed
        ))
    });
    let opts = RunOptions {
        engine: args.engine,
        clock: args.clock,
        out_dir,
        command_line: std::env::args().collect(),
        progress: !args.quiet && std::io::stdout().is_terminal(),
    };
    let real = sc.realize(sc.seed);
    let bar = progress_bar(&opts, sc.samples as u64);
    let mut tick = |k: usize, it: u64| {
        if let Some(b) = &bar {
            b.set_position(k as u64);
            let secs = b.elapsed().as_secs_f64().max(1e-9);
            b.set_message(format!("{it} iterations, {:.0} it/s", it as f64 / secs));
        }
    };
    let (record, result) = match args.engine {
        EngineKind::Inprocess => run::run_inprocess(&sc, &real, &mut tick),
        EngineKind::Processes => {
            let popts = crate::engine::processes::ProcessOptions {
                verbose: args.verbose,
                ..Default::default()
            };
            let (rec, res, _) = match args.clock {
                Clock::Logical => {
                    crate::engine::processes::run_logical(&sc, &real, &popts, &mut tick)
                }
                Clock::Realtime => {
                    crate::engine::processes::run_realtime(&sc, &real, &popts, &mut tick)
                }
            };
            (rec, res)
        }
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let outcome = run::finish(&sc, &real, record, result.err(), &opts)?;
    let plots = if args.report {
        crate::report::write_report(&outcome.out_dir, false).map(drop)
    } else {
        crate::plot::write_run_plots(&outcome.out_dir).map(drop)
    };
    print_summary(&outcome);
    match outcome.error {
        Some(error) => {
            if let Err(e) = plots {
                eprintln!("warning: plots were not written: {e}");
            }
            Err(CliError::RunFailed {
                error,
                dir: outcome.out_dir,
            })
        }
        None => plots.map_err(CliError::from),
    }
}

fn progress_bar(opts: &RunOptions, samples: u64) -> Option<indicatif::ProgressBar> {
    if !opts.progress {
        return None;
    }
    let b = indicatif::ProgressBar::new(samples);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} samples, {msg}",
    ) {
        b.set_style(style);
    }
    Some(b)
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map_or("-".into(), |v| format!("{v:.3}"))
}

fn print_summary(o: &run::RunOutcome) {
    let m = &o.metrics;
    println!(
        "sonarnet run: {} / {} / {} clock, seed {}",
        m.engine, m.mode, m.clock, m.seed
    );
    println!("  samples            {}/{}", m.samples_completed, m.samples);
    println!("  rmse               {} m", fmt_opt(m.rmse));
    println!("  rmse_after_burn_in {} m", fmt_opt(m.rmse_after_burn_in));
    println!("  median_error       {} m", fmt_opt(m.median_error));
    println!("  final_error        {} m", fmt_opt(m.final_error));
    println!("  ctte               {} m", fmt_opt(m.ctte));
    println!("  max_disagreement   {:.3} m", m.max_disagreement);
    println!("  ml_rmse            {} m", fmt_opt(m.ml_rmse));
    println!("  crlb_rms           {} m", fmt_opt(m.crlb_rms));
    println!("  iterations         {}", m.iterations);
    println!("  prox_solves        {}", m.prox_solves);
    println!("  wall_seconds       {:.4}", m.wall_seconds);
    if let Some(n) = &m.note {
        println!("  note: {n}");
    }
    println!("  results in {}", o.out_dir.display());
}
