//! The `sonarnet` command line (clap derive). `main` stays thin: it parses,
//! calls [`dispatch`], prints the error chain once, and maps it to an exit code.

use crate::estimators::prox::LocalSolver;
use crate::pipeline::{self, Clock, EngineKind, RunError, RunOptions};
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

// The field docs below are clap's `--help` text, not rustdoc prose: `[expect]`,
// `[[variants]]` and `<DIR2 name>` are the scenario-file and placeholder syntax
// a user types, and escaping them for rustdoc would show the backslashes in
// `--help`. So rustdoc is told they are not links or HTML.
/// `sonarnet report`.
#[derive(Debug, clap::Args)]
#[allow(rustdoc::invalid_html_tags)]
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

/// The command-line spelling of [`Mode`] (library types carry no clap derive;
/// the doc comments are the `--help` text of each value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    /// Every node updates every iteration; positions averaged over all nodes.
    Sync,
    /// One random edge `(v, w)` per iteration (seed 002 eq. 11).
    Async,
}

impl From<ModeArg> for Mode {
    fn from(m: ModeArg) -> Self {
        match m {
            ModeArg::Sync => Mode::Sync,
            ModeArg::Async => Mode::Async,
        }
    }
}

/// The command-line spelling of [`EngineKind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EngineArg {
    /// All nodes in one thread of this process.
    Inprocess,
    /// One `sonarnet-node` OS process per receiver, over iceoryx2.
    Processes,
    /// One thread per node in this process, over the in-memory transport.
    Threads,
}

impl From<EngineArg> for EngineKind {
    fn from(e: EngineArg) -> Self {
        match e {
            EngineArg::Inprocess => EngineKind::Inprocess,
            EngineArg::Processes => EngineKind::Processes,
            EngineArg::Threads => EngineKind::Threads,
        }
    }
}

/// The command-line spelling of [`Clock`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ClockArg {
    /// The coordinator sequences rounds/iterations; results are exact.
    Logical,
    /// Free-running nodes on Poisson clocks (multi-process async only).
    Realtime,
}

impl RunArgs {
    /// `--mode` as the library's type.
    pub fn mode(&self) -> Option<Mode> {
        self.mode.map(Mode::from)
    }
    /// `--engine` as the library's type.
    pub fn engine(&self) -> Option<EngineKind> {
        self.engine.map(EngineKind::from)
    }
    /// `--clock` as the library's type.
    pub fn clock(&self) -> Clock {
        self.clock.into()
    }
}

impl From<ClockArg> for Clock {
    fn from(c: ClockArg) -> Self {
        match c {
            ClockArg::Logical => Clock::Logical,
            ClockArg::Realtime => Clock::Realtime,
        }
    }
}

/// `sonarnet run`.
#[derive(Debug, clap::Args)]
// `[expect]`, `[[variants]]`, `<name>`: see the note above `ReportArgs`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]
pub struct RunArgs {
    /// The scenario TOML file.
    pub scenario: PathBuf,
    /// Gossip mode (overrides algorithm.mode).
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    /// Local prox (overrides algorithm.local_solver): gtrs (exact, on the cone),
    /// relaxed (no cone constraint) or gtrs_l0 (gtrs with up to algorithm.kappa
    /// outlier rows per node separated).
    #[arg(long, value_parser = parse_solver)]
    pub local_solver: Option<LocalSolver>,
    /// Outlier budget of gtrs_l0: rows of each node's local cost that may be
    /// separated as outliers (overrides algorithm.kappa; must be below every
    /// node's row count; ignored by gtrs and relaxed).
    #[arg(long, value_name = "K")]
    pub kappa: Option<usize>,
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
    /// shared memory, all nodes in this process, or one thread per node over
    /// the in-memory transport (exact same numbers) [default: processes;
    /// inprocess for Monte Carlo runs].
    #[arg(long, value_enum)]
    pub engine: Option<EngineArg>,
    /// Run only this variant of a scenario with [[variants]] (repeatable;
    /// default: every variant, one results directory each).
    #[arg(long, value_name = "NAME")]
    pub variant: Vec<String>,
    /// Monte Carlo: repeat the run with seeds seed..seed+N in parallel
    /// (in-process); overrides [monte_carlo] trials. 1 = a single run.
    #[arg(long, value_name = "N")]
    pub trials: Option<usize>,
    /// Centralised baselines to score next to the distributed track, with
    /// default parameters, replacing the scenario's [[baselines]]
    /// (comma separated: ogd, onm, ml, ls, l0os, lq_irls, lad, pocs, lls,
    /// distributed; l0os needs p or kappa, so give it in the file).
    #[arg(long, value_delimiter = ',', value_name = "KINDS")]
    pub baselines: Option<Vec<String>>,
    /// Exit with code 1 when an [expect] check of the scenario fails.
    #[arg(long)]
    pub check: bool,
    /// Clock of async runs: `logical` (the coordinator draws every pair;
    /// exact, reproducible) or `realtime` (free-running nodes on Poisson
    /// clocks, [realtime] table of the scenario; needs --engine processes).
    #[arg(long, value_enum, default_value = "logical")]
    pub clock: ClockArg,
    /// Record every node's theta after every iteration into iterations.csv
    /// (used by consensus.svg).
    #[arg(long)]
    pub trace_iterations: bool,
    /// Multi-process engine: let each node process poll its inbox for up to N
    /// microseconds (yielding the CPU between checks) before it blocks. Trades CPU
    /// for latency while gossip messages are due within microseconds; 0, the
    /// default, blocks at once (idle nodes use ~0 % CPU either way, after N us).
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub poll_us: u64,
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
    Input(#[from] crate::model::error::InputError),
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
    /// `--check`: an `[expect]` check failed (exit 1).
    #[error("{failed} [expect] check(s) failed:\n{list}")]
    ExpectFailed {
        /// How many.
        failed: usize,
        /// One line per failed check, with the results directory.
        list: String,
    },
    /// Plots or report could not be written (exit 1).
    #[error(transparent)]
    Plot(crate::plot::PlotError),
    /// Some variants of a scenario failed; each error was printed as it
    /// happened (exit 1).
    #[error("{failed} variant(s) failed (their errors are above):\n{list}")]
    VariantsFailed {
        /// How many.
        failed: usize,
        /// One line per failed variant.
        list: String,
    },
}

/// An error and its causes as the command line prints them, once:
/// `error: ...` and one `  caused by: ...` line per cause.
pub fn error_report(e: &dyn std::error::Error) -> String {
    let mut out = format!("error: {e}\n");
    let mut src = e.source();
    while let Some(s) = src {
        out.push_str(&format!("  caused by: {s}\n"));
        src = s.source();
    }
    out
}

impl From<crate::pipeline::bench::BenchError> for CliError {
    fn from(e: crate::pipeline::bench::BenchError) -> Self {
        match e {
            crate::pipeline::bench::BenchError::Input(i) => CliError::Input(i),
            crate::pipeline::bench::BenchError::RunFailed { error, dir } => {
                CliError::RunFailed { error, dir }
            }
            crate::pipeline::bench::BenchError::Run(r) => r.into(),
        }
    }
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
                for sc in Scenario::load_all(p)? {
                    println!(
                        "{}{}: ok ({} receivers, {} transmitters, {} edges, {} samples, {} {}{}{})",
                        p.display(),
                        sc.variant
                            .as_ref()
                            .map_or(String::new(), |v| format!(" [{v}]")),
                        sc.graph.len(),
                        sc.geometry.transmitters.len(),
                        sc.graph.edges().len(),
                        sc.samples,
                        sc.algorithm.mode.as_str(),
                        crate::estimators::baselines::solver_name(sc.algorithm.local_solver),
                        if sc.baselines.is_empty() {
                            String::new()
                        } else {
                            format!(
                                ", baselines {}",
                                sc.baselines
                                    .iter()
                                    .map(|b| b.name())
                                    .collect::<Vec<_>>()
                                    .join(" ")
                            )
                        },
                        sc.trials.map_or(String::new(), |n| format!(", {n} trials"))
                    );
                }
            }
            Ok(())
        }
        Command::Run(args) => run_command(args),
        Command::Bench(args) => {
            crate::pipeline::bench::run_bench(
                &args.scenarios,
                &args.nodes,
                args.repeats,
                &args.out,
            )?;
            Ok(())
        }
        Command::Report(args) => {
            let path = match args.dirs.as_slice() {
                [a, b] => crate::report::write_comparison(a, b, args.out.as_deref(), args.png)?,
                [a] if args.out.is_none() => crate::report::write_report(a, args.png)?,
                [_] => {
                    return Err(crate::model::error::InputError::at(
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

/// Load the scenario (every selected variant) and apply the command-line overrides.
pub fn resolve_scenarios(args: &RunArgs) -> Result<Vec<Scenario>, CliError> {
    let all = Scenario::load_all(&args.scenario)?;
    let cli = std::path::Path::new("<command line>");
    for v in &args.variant {
        if !all.iter().any(|s| s.variant.as_deref() == Some(v.as_str())) {
            let names: Vec<&str> = all.iter().filter_map(|s| s.variant.as_deref()).collect();
            return Err(crate::model::error::InputError::at(
                cli,
                "--variant",
                if names.is_empty() {
                    format!("{} has no [[variants]]", args.scenario.display())
                } else {
                    format!("no variant {v:?} (the file has: {})", names.join(", "))
                },
            )
            .into());
        }
    }
    let baselines = match &args.baselines {
        None => None,
        Some(kinds) => Some(
            kinds
                .iter()
                .filter(|k| !k.trim().is_empty())
                .map(|k| {
                    crate::estimators::baselines::BaselineCfg::default_of(k.trim()).ok_or_else(
                        || {
                            crate::model::error::InputError::at(
                                cli,
                                "--baselines",
                                format!(
                                    "unknown baseline {k:?} (expected one of {})",
                                    crate::estimators::baselines::KINDS.join(", ")
                                ),
                            )
                        },
                    )
                })
                .collect::<Result<Vec<_>, _>>()?,
        ),
    };
    let mut out = Vec::new();
    for mut sc in all {
        if !args.variant.is_empty()
            && !args
                .variant
                .iter()
                .any(|v| sc.variant.as_deref() == Some(v.as_str()))
        {
            continue;
        }
        if let Some(s) = args.seed {
            sc = sc.with_seed(s);
        }
        if let Some(m) = args.mode() {
            sc = sc.with_mode(m)?;
        }
        if let Some(s) = args.local_solver {
            sc = sc.with_local_solver(s);
        }
        if let Some(k) = args.kappa {
            sc = sc.with_kappa(k);
        }
        if args.local_solver.is_some() || args.kappa.is_some() {
            sc.check_kappa().map_err(|e| match args.kappa {
                // The value came from the command line: say so.
                Some(_) => crate::model::error::InputError::at(
                    std::path::Path::new("<command line>"),
                    "--kappa",
                    e.reason,
                ),
                None => e,
            })?;
        }
        if let Some(n) = args.iterations_per_sample {
            sc = sc.with_iterations_per_sample(n)?;
        }
        if let Some(n) = args.samples {
            sc = sc.with_samples(n)?;
        }
        if let Some(b) = &baselines {
            sc = sc.with_baselines(b.clone())?;
        }
        sc = sc.with_trials(args.trials)?;
        out.push(sc.with_trace_iterations(args.trace_iterations));
    }
    Ok(out)
}

/// Load the scenario and apply the command-line overrides; a file with
/// several variants needs `--variant`.
pub fn resolve_scenario(args: &RunArgs) -> Result<Scenario, CliError> {
    let mut all = resolve_scenarios(args)?;
    if all.len() != 1 {
        let names: Vec<String> = all.iter().filter_map(|s| s.variant.clone()).collect();
        return Err(crate::model::error::InputError::at(
            std::path::Path::new("<command line>"),
            "--variant",
            format!("pick one variant of {}", names.join(", ")),
        )
        .into());
    }
    Ok(all.remove(0))
}

fn run_command(args: RunArgs) -> Result<(), CliError> {
    let scenarios = resolve_scenarios(&args)?;
    let many = scenarios.len() > 1;
    let mut failed_checks = Vec::new();
    let mut failed_variants = Vec::new();
    for sc in scenarios {
        let label = sc.variant.clone();
        if many {
            println!("== variant {}", label.as_deref().unwrap_or("(base)"));
        }
        let trials = sc.trials.unwrap_or(1);
        let res = if trials > 1 {
            run_monte_carlo_command(&args, &sc, trials, many)
        } else {
            run_single(&args, &sc, many)
        };
        match res {
            Ok((dir, checks)) => {
                for c in checks.iter().filter(|c| !c.holds) {
                    failed_checks.push(format!(
                        "  {}{}  ({})",
                        label.as_ref().map_or(String::new(), |v| format!("[{v}] ")),
                        c.expect,
                        dir.display()
                    ));
                }
            }
            Err(e) => {
                // Input errors stop at once, and so does the only run; a
                // failed variant lets the other variants run: its error is
                // printed now, once, and the failures are listed at the end.
                if e.exit_code() == 2 || !many {
                    return Err(e);
                }
                eprint!(
                    "[variant {}] {}",
                    label.as_deref().unwrap_or("(base)"),
                    error_report(&e)
                );
                failed_variants.push(format!("  {}", label.as_deref().unwrap_or("(base)")));
            }
        }
    }
    if !failed_variants.is_empty() {
        return Err(CliError::VariantsFailed {
            failed: failed_variants.len(),
            list: failed_variants.join("\n"),
        });
    }
    if args.check && !failed_checks.is_empty() {
        return Err(CliError::ExpectFailed {
            failed: failed_checks.len(),
            list: failed_checks.join("\n"),
        });
    }
    Ok(())
}

fn default_dir(args: &RunArgs, sc: &Scenario, many: bool, tail: &str) -> PathBuf {
    match &args.out {
        Some(o) if many => o.join(sc.variant.as_deref().unwrap_or("base")),
        Some(o) => o.clone(),
        None => PathBuf::from("results").join(format!(
            "{}{}-{tail}-seed{}",
            sc.name,
            sc.variant
                .as_ref()
                .map_or(String::new(), |v| format!("-{v}")),
            sc.seed
        )),
    }
}

fn run_monte_carlo_command(
    args: &RunArgs,
    sc: &Scenario,
    trials: usize,
    many: bool,
) -> Result<(PathBuf, Vec<pipeline::ExpectResult>), CliError> {
    let cli = std::path::Path::new("<command line>");
    if args.engine().is_some_and(|e| e != EngineKind::Inprocess)
        || args.clock() == Clock::Realtime
        || args.poll_us > 0
    {
        return Err(crate::model::error::InputError::at(
            cli,
            if args.clock() == Clock::Realtime {
                "--clock"
            } else if args.poll_us > 0 {
                "--poll-us"
            } else {
                "--engine"
            },
            "Monte Carlo trials run in-process with logical clocks (the engines give \
             identical numbers); drop --engine processes|threads / --clock realtime or use --trials 1",
        )
        .into());
    }
    let out_dir = default_dir(
        args,
        sc,
        many,
        &format!("mc{trials}-{}", sc.algorithm.mode.as_str()),
    );
    let opts = RunOptions {
        engine: EngineKind::Inprocess,
        clock: Clock::Logical,
        out_dir,
        command_line: std::env::args().collect(),
        progress: !args.quiet && std::io::stdout().is_terminal(),
        check_expect: false,
        poll_us: 0,
        verbose: false,
    };
    std::fs::create_dir_all(&opts.out_dir).map_err(|e| RunError::Output {
        path: opts.out_dir.clone(),
        source: e,
    })?;
    let bar = opts.progress.then(|| {
        let b = indicatif::ProgressBar::new(trials as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} trials ({per_sec}, eta {eta})",
        ) {
            b.set_style(style);
        }
        b
    });
    let tick = |done: usize| {
        if let Some(b) = &bar {
            b.set_position(done as u64);
        }
    };
    let mc = crate::pipeline::montecarlo::run_monte_carlo(sc, trials, &opts, &tick)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let plots = if args.report {
        crate::report::write_report(&mc.out_dir, false).map(drop)
    } else {
        crate::plot::write_run_plots(&mc.out_dir).map(drop)
    };
    print_mc_summary(sc, &mc);
    plots.map_err(CliError::from)?;
    Ok((mc.out_dir, mc.expect))
}

fn run_single(
    args: &RunArgs,
    sc: &Scenario,
    many: bool,
) -> Result<(PathBuf, Vec<pipeline::ExpectResult>), CliError> {
    let engine = args.engine().unwrap_or(EngineKind::Processes);
    if args.poll_us > 0 && engine != EngineKind::Processes {
        return Err(crate::model::error::InputError::at(
            std::path::Path::new("<command line>"),
            "--poll-us",
            "polling applies to node processes: it needs --engine processes",
        )
        .into());
    }
    if args.clock() == Clock::Realtime {
        let cli = std::path::Path::new("<command line>");
        if engine != EngineKind::Processes || sc.algorithm.mode != Mode::Async {
            return Err(crate::model::error::InputError::at(
                cli,
                "--clock",
                "realtime clocks need --engine processes and async mode",
            )
            .into());
        }
        if sc.realtime.is_none() {
            return Err(crate::model::error::InputError::at(
                &sc.path,
                "realtime",
                "--clock realtime needs a [realtime] table (sample_period_ms, wake_rate_hz)",
            )
            .into());
        }
    }
    let out_dir = default_dir(
        args,
        sc,
        many,
        &format!(
            "{}{}-{}",
            sc.algorithm.mode.as_str(),
            if args.clock() == Clock::Realtime {
                "-realtime"
            } else {
                ""
            },
            engine.as_str()
        ),
    );
    let opts = RunOptions {
        engine,
        clock: args.clock(),
        out_dir,
        command_line: std::env::args().collect(),
        progress: !args.quiet && std::io::stdout().is_terminal(),
        check_expect: true,
        poll_us: args.poll_us,
        verbose: args.verbose,
    };
    let bar = progress_bar(&opts, sc.samples as u64);
    let mut tick = |k: usize, it: u64| {
        if let Some(b) = &bar {
            b.set_position(k as u64);
            let secs = b.elapsed().as_secs_f64().max(1e-9);
            b.set_message(format!("{it} iterations, {:.0} it/s", it as f64 / secs));
        }
    };
    let outcome = pipeline::run(sc, &opts, &mut tick);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    outcome.write(sc, &opts)?;
    let dir = opts.out_dir;
    let plots = if args.report {
        crate::report::write_report(&dir, false).map(drop)
    } else {
        crate::plot::write_run_plots(&dir).map(drop)
    };
    print_summary(&outcome, &dir);
    match outcome.error {
        Some(error) => {
            if let Err(e) = plots {
                eprintln!("warning: plots were not written: {e}");
            }
            Err(CliError::RunFailed { error, dir })
        }
        None => {
            plots.map_err(CliError::from)?;
            Ok((dir, outcome.metrics.expect))
        }
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

fn print_summary(o: &pipeline::Outcome, dir: &std::path::Path) {
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
    print_tracks(&o.scored);
    print_expect(&m.expect);
    println!("  results in {}", dir.display());
}

fn print_tracks(s: &crate::pipeline::score::Scored) {
    if s.tracks.len() <= 2 && s.tracks.iter().all(|t| t.bounds.is_empty()) {
        return;
    }
    println!(
        "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>10}",
        "track", "rmse", "median", "ctte", "regret", "failures"
    );
    for t in &s.tracks {
        let m = &t.metrics;
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>10}",
            t.name,
            fmt_opt(m.rmse),
            fmt_opt(m.median_error),
            fmt_opt(m.ctte),
            fmt_opt(m.regret),
            m.failures
        );
        for (b, bm) in &m.bounds {
            println!(
                "    bound {b:<12} coverage {:.3}, empty {:.3}, mean tightness {} m",
                bm.coverage,
                bm.empty_fraction,
                fmt_opt(bm.mean_tightness)
            );
        }
    }
}

fn print_expect(checks: &[pipeline::ExpectResult]) {
    if checks.is_empty() {
        return;
    }
    let ok = checks.iter().filter(|c| c.holds).count();
    println!("  expect             {ok}/{} hold", checks.len());
    for c in checks.iter().filter(|c| !c.holds) {
        println!(
            "    FAILS: {} ({} vs {})",
            c.expect,
            fmt_opt(c.lhs),
            fmt_opt(c.rhs)
        );
    }
}

fn print_mc_summary(sc: &Scenario, mc: &crate::pipeline::montecarlo::MonteCarloOutcome) {
    println!(
        "sonarnet run: Monte Carlo, {} trials (seeds {}..{}), in-process / {}{}, {:.2} s",
        mc.trials.len(),
        sc.seed,
        sc.seed.wrapping_add(mc.trials.len() as u64),
        sc.algorithm.mode.as_str(),
        sc.variant
            .as_ref()
            .map_or(String::new(), |v| format!(", variant {v}")),
        mc.wall_seconds
    );
    if mc.failed > 0 {
        println!("  failed trials      {}", mc.failed);
    }
    let mean = |k: &str| mc.stats.get(k).and_then(|s| s.get("mean").copied());
    let mut names: Vec<String> = vec!["theta_bar".into(), "ml".into()];
    names.extend(sc.baselines.iter().map(|b| b.name()));
    println!(
        "  {:<14} {:>12} {:>12} {:>12} {:>12}   (means over trials)",
        "track", "rmse", "median", "ctte", "regret"
    );
    for n in &names {
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12}",
            n,
            fmt_opt(mean(&format!("{n}.rmse"))),
            fmt_opt(mean(&format!("{n}.median_error"))),
            fmt_opt(mean(&format!("{n}.ctte"))),
            fmt_opt(mean(&format!("{n}.regret")))
        );
        if let Some(b) = &sc.bounds {
            for k in &b.all_kinds() {
                let p = format!("{n}.bounds.{}", k.as_str());
                if let Some(c) = mean(&format!("{p}.coverage")) {
                    println!(
                        "    bound {:<12} coverage {:.3}, empty {:.3}, rel. tightness median {}",
                        k.as_str(),
                        c,
                        mean(&format!("{p}.empty_fraction")).unwrap_or(0.0),
                        fmt_opt(
                            mc.stats
                                .get(&format!("{p}.rel_tightness_median"))
                                .and_then(|s| s.get("median").copied())
                        )
                    );
                }
            }
        }
    }
    print_expect(&mc.expect);
    println!("  results in {}", mc.out_dir.display());
}
