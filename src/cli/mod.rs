//! The `sonarnet` command line (clap derive). `main` stays thin: it parses,
//! calls [`dispatch`], prints the error chain once, and maps it to an exit code.

use crate::estimators::gossip::ProxScaling;
use crate::pipeline::{self, Clock, EngineKind, RunOptions};
use crate::scenario::{AnyScenario, Scenario};
use std::path::PathBuf;

mod args;
mod errors;
mod net;
mod print;
mod replay;
mod scaffold;
mod sweep;

pub use args::{
    AgentArgs, BenchArgs, Cli, Command, NewArgs, ReplayArgs, ReportArgs, RunArgs, SweepArgs,
    parse_seed,
};
pub use errors::{CliError, error_report, one_line};
pub use print::eng;
use print::{print_mc_summary, print_summary, progress_bar};

/// Run a parsed command line.
pub fn dispatch(cli: Cli) -> Result<(), CliError> {
    if matches!(
        cli.command,
        Command::List { .. } | Command::Describe { .. } | Command::Validate { .. }
    ) {
        // Commands that only print end quietly when their reader goes away
        // (`sonarnet list | head`), as a Unix filter does, instead of
        // panicking on EPIPE. Runs keep SIGPIPE ignored: the coordinator
        // must never die in the middle of owning node processes.
        // SAFETY: resetting a signal's disposition to the default.
        unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    }
    match cli.command {
        Command::Validate { scenarios } => {
            for p in &scenarios {
                for sc in crate::scenario::AnyScenario::load_all(p)? {
                    match &sc {
                        crate::scenario::AnyScenario::Plane(sc) => validated(p, sc),
                        crate::scenario::AnyScenario::Space(sc) => validated(p, sc),
                    }
                }
            }
            Ok(())
        }
        Command::Run(args) => run_command(args),
        Command::Agent(args) => net::agent_command(&args),
        Command::FleetKey { file } => net::fleet_key_command(&file),
        Command::Replay(args) => replay::replay_command(&args),
        Command::Sweep(args) => sweep::sweep_command(&args),
        Command::New(args) => scaffold::new_command(&args),
        Command::List { dir } => scaffold::list_command(dir.as_deref()),
        Command::Describe {
            scenario,
            variant,
            set,
        } => scaffold::describe_command(&scenario, &variant, &set),
        Command::Bench(args) => {
            if let Some(n) = args.scale.iter().find(|n| !(2..=4096).contains(*n)) {
                return Err(crate::model::error::InputError::at(
                    std::path::Path::new("<command line>"),
                    "--scale",
                    format!("{n} nodes is outside [2, 4096]"),
                )
                .into());
            }
            crate::pipeline::bench::run_bench(
                &args.scenarios,
                &args.scale,
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

/// Load the scenario (every selected variant, 2-D or 3-D as the file is)
/// and apply the command-line overrides.
pub fn resolve_scenarios(args: &RunArgs) -> Result<Vec<AnyScenario>, CliError> {
    let overrides = args
        .set
        .iter()
        .map(|s| crate::scenario::Override::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let all = AnyScenario::load_all_with(&args.scenario, &overrides, &args.variant)?;
    let cli = std::path::Path::new("<command line>");
    for v in &args.variant {
        if !all.iter().any(|s| s.variant() == Some(v.as_str())) {
            let names: Vec<&str> = all.iter().filter_map(AnyScenario::variant).collect();
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
    for sc in all {
        if !args.variant.is_empty()
            && !args
                .variant
                .iter()
                .any(|v| sc.variant() == Some(v.as_str()))
        {
            continue;
        }
        out.push(match sc {
            AnyScenario::Plane(sc) => AnyScenario::Plane(with_flags(args, sc, &baselines)?),
            AnyScenario::Space(sc) => AnyScenario::Space(with_flags(args, sc, &baselines)?),
        });
    }
    Ok(out)
}

/// One scenario with the command line's flags applied.
fn with_flags<const D: usize>(
    args: &RunArgs,
    mut sc: Scenario<D>,
    baselines: &Option<Vec<crate::estimators::baselines::BaselineCfg>>,
) -> Result<Scenario<D>, CliError> {
    if let Some(s) = args.seed {
        sc = sc.with_seed(s);
    }
    if let Some(p) = args.prox_scaling {
        sc = sc.with_prox_scaling(p);
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
    if let Some(b) = baselines {
        sc = sc.with_baselines(b.clone())?;
    }
    sc = sc.with_trials(args.trials)?;
    for flag in &args.faults {
        sc = sc.with_fault_flag(flag)?;
    }
    if let Some(kinds) = &args.nemesis {
        sc = sc.with_nemesis(kinds, args.nemesis_interval_s)?;
    }
    let sc = sc.with_trace_iterations(args.trace_iterations);
    sc.check_size_cli()?;
    Ok(sc)
}

fn run_command(args: RunArgs) -> Result<(), CliError> {
    let scenarios = resolve_scenarios(&args)?;
    let many = scenarios.len() > 1;
    if let Some(first) = scenarios.first() {
        for w in first.warnings() {
            eprintln!("warning: {w}");
        }
    }
    let mut failed_checks = Vec::new();
    let mut failed_variants = Vec::new();
    for sc in scenarios {
        let label = sc.variant().map(str::to_owned);
        if many {
            println!("== variant {}", label.as_deref().unwrap_or("(base)"));
        }
        let res = match &sc {
            AnyScenario::Plane(sc) => run_one(&args, sc, many),
            AnyScenario::Space(sc) => run_one(&args, sc, many),
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
                // Input errors stop at once, and so do the only run and an
                // interrupt (Ctrl-C/SIGTERM); a
                // failed variant lets the other variants run: its error is
                // printed now, once, and the failures are listed at the end.
                if e.exit_code() == 2 || !many || crate::engine::interrupt::requested() {
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

/// One scenario (one variant): its Monte Carlo trials, or a single run.
fn run_one<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    many: bool,
) -> Result<(PathBuf, Vec<pipeline::ExpectResult>), CliError> {
    match sc.trials.unwrap_or(1) {
        trials if trials > 1 => run_monte_carlo_command(args, sc, trials, many),
        _ => run_single(args, sc, many),
    }
}

/// The results directory must be writable before the run starts (exit 2
/// otherwise, naming `--out`).
fn check_out(dir: &std::path::Path) -> Result<(), CliError> {
    pipeline::outdir::prepare_out_dir(dir).map_err(|e| {
        crate::model::error::InputError::at(
            std::path::Path::new("<command line>"),
            "--out",
            one_line(&e),
        )
        .into()
    })
}

fn default_dir<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    many: bool,
    tail: &str,
) -> PathBuf {
    match &args.out {
        Some(o) if many => o.join(sc.variant.as_deref().unwrap_or("base")),
        Some(o) => o.clone(),
        None => PathBuf::from("results").join(format!(
            "{}{}-{tail}-seed{}{}",
            sc.name,
            sc.variant
                .as_ref()
                .map_or(String::new(), |v| format!("-{v}")),
            sc.seed,
            override_suffix(args)
        )),
    }
}

/// The part of a default results directory's name that tells runs with
/// different overrides apart: every non-default override, in a fixed order
/// (`-gtrs_l0-kappa2-poll100-set-algorithm.gamma-1e-7`), or `-o<hash>` of
/// them when that would be longer than 48 characters.
pub fn override_suffix(args: &RunArgs) -> String {
    let mut parts: Vec<String> = Vec::new();
    if let Some(s) = args.local_solver {
        parts.push(s.as_str().into());
    }
    if let Some(k) = args.kappa {
        parts.push(format!("kappa{k}"));
    }
    if let Some(p) = args.prox_scaling {
        parts.push(match p {
            ProxScaling::None => "unscaled".into(),
            ProxScaling::InverseProbability => "invprob".into(),
        });
    }
    if args.transport == crate::protocol::TransportKind::Zenoh {
        parts.push("zenoh".into());
    }
    if args.poll_us > 0 {
        parts.push(format!("poll{}", args.poll_us));
    }
    if let Some(n) = args.iterations_per_sample {
        parts.push(format!("ips{n}"));
    }
    if let Some(n) = args.samples {
        parts.push(format!("samples{n}"));
    }
    if let Some(b) = &args.baselines {
        parts.push(format!("baselines-{}", b.join("-")));
    }
    for f in &args.faults {
        parts.push(format!("fault-{f}"));
    }
    if let Some(n) = &args.nemesis {
        parts.push(format!("nemesis-{n}-{}", args.nemesis_interval_s));
    }
    for s in &args.set {
        parts.push(format!("set-{s}"));
    }
    if parts.is_empty() {
        return String::new();
    }
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "._-".contains(c) {
                    c
                } else {
                    '-'
                }
            })
            .collect()
    };
    let long = format!("-{}", clean(&parts.join("-")));
    if long.len() <= 48 {
        long
    } else {
        // FNV-1a over the full text: stable across builds and platforms.
        let h = parts
            .join("\u{1f}")
            .bytes()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            });
        format!("-o{:08x}", h >> 32)
    }
}

fn run_monte_carlo_command<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    trials: usize,
    many: bool,
) -> Result<(PathBuf, Vec<pipeline::ExpectResult>), CliError> {
    // Trials run in-process: logical clocks directly, realtime clocks and the
    // acoustic channel in virtual time (the discrete-event engine); both are
    // exact and deterministic from each trial's seed.
    let (_, clock) = resolve(args, sc, trials)?;
    let out_dir = default_dir(
        args,
        sc,
        many,
        &format!("mc{trials}-{}", sc.algorithm.mode.as_str()),
    );
    let opts = RunOptions {
        engine: EngineKind::Inprocess,
        clock,
        out_dir,
        command_line: std::env::args().collect(),
        progress: !args.quiet,
        check_expect: false,
        poll_us: 0,
        verbose: false,
        stall_timeout: std::time::Duration::from_secs_f64(args.stall_timeout),
        write_checkpoints: false,
        net: Default::default(),
    };
    check_out(&opts.out_dir)?;
    let bar = print::Progress::new(
        opts.progress,
        trials as u64,
        "trials",
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} trials ({per_sec}, eta {eta})",
    );
    let tick = |done: usize| bar.set(done as u64, String::new);
    let mc = crate::pipeline::montecarlo::run_monte_carlo(sc, trials, &opts, &tick)?;
    bar.finish();
    let plots = if args.report {
        crate::report::write_report(&mc.out_dir, args.png).map(Some)
    } else {
        crate::plot::write_run_plots_as(&mc.out_dir, args.png).map(|_| None)
    };
    print_mc_summary(sc, &mc);
    if let Ok(Some(p)) = &plots {
        println!("  report             {}", p.display());
    }
    if mc.interrupted {
        if let Err(e) = plots {
            eprintln!("warning: plots were not written: {e}");
        }
        return Err(CliError::TrialsInterrupted {
            done: mc.trials.len(),
            requested: mc.requested,
            dir: mc.out_dir,
        });
    }
    plots.map_err(CliError::from)?;
    Ok((mc.out_dir, mc.expect))
}

/// The engine and clock of a run of `sc` with `trials` trials as `args`
/// ask ([`crate::protocol::RunConfig::resolve`]): a refusal names the flag
/// (on the command line) or the scenario key (in its file).
fn resolve<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    trials: usize,
) -> Result<(EngineKind, Clock), CliError> {
    let cfg = crate::protocol::RunConfig {
        engine: args.engine(),
        clock: args.clock,
        transport: args.transport,
        poll_us: args.poll_us,
        trials,
    };
    cfg.resolve(sc).map_err(|r| {
        let cli = std::path::Path::new("<command line>");
        let e = match r.key {
            crate::protocol::Key::Flag(flag) => {
                crate::model::error::InputError::at(cli, flag, r.reason)
            }
            crate::protocol::Key::Scenario(key) => {
                crate::model::error::InputError::at(&sc.path, key, r.reason)
            }
        };
        e.into()
    })
}

fn run_single<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    many: bool,
) -> Result<(PathBuf, Vec<pipeline::ExpectResult>), CliError> {
    let (engine, clock) = resolve(args, sc, 1)?;
    let wall_s = crate::protocol::config::realtime_wall_s(sc, clock);
    if engine == EngineKind::Processes && wall_s > crate::protocol::LONG_WALL_S && !args.quiet {
        eprintln!(
            "note: {} samples {} ms apart on the realtime clock take about {} of wall time \
             with node processes; --engine inprocess runs the same in virtual time, in seconds",
            sc.samples,
            sc.realtime.as_ref().map_or(0.0, |r| r.sample_period_ms),
            print::duration_words(wall_s)
        );
    }
    let net = net::net_options(args, sc, engine)?;
    let out_dir = default_dir(
        args,
        sc,
        many,
        &format!(
            "{}{}-{}",
            sc.algorithm.mode.as_str(),
            if clock == Clock::Realtime {
                "-realtime"
            } else {
                ""
            },
            engine.as_str()
        ),
    );
    let opts = RunOptions {
        engine,
        clock,
        out_dir,
        command_line: std::env::args().collect(),
        progress: !args.quiet,
        check_expect: true,
        poll_us: args.poll_us,
        verbose: args.verbose,
        stall_timeout: std::time::Duration::from_secs_f64(args.stall_timeout),
        write_checkpoints: true,
        net,
    };
    check_out(&opts.out_dir)?;
    pipeline::preflight(sc, &opts)?;
    let bar = progress_bar(&opts, sc.samples as u64);
    let mut tick = |k: usize, it: u64| {
        bar.set(k as u64, || {
            let secs = bar.elapsed_s().max(1e-9);
            format!("{it} iterations, {:.0} it/s", it as f64 / secs)
        });
    };
    let outcome = pipeline::run(sc, &opts, &mut tick);
    bar.finish();
    outcome.write(sc, &opts)?;
    let dir = opts.out_dir;
    let plots = if args.report {
        crate::report::write_report(&dir, args.png).map(Some)
    } else {
        crate::plot::write_run_plots_as(&dir, args.png).map(|_| None)
    };
    print_summary(&outcome, &dir);
    if let Ok(Some(p)) = &plots {
        println!("  report             {}", p.display());
    }
    match outcome.run.error {
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

/// `sonarnet validate`'s line for one checked scenario (and its warnings).
fn validated<const D: usize>(p: &std::path::Path, sc: &Scenario<D>) {
    for w in sc.warnings() {
        eprintln!("warning: {w}");
    }
    println!(
        "{}{}: ok ({}{} receivers, {} transmitters, {} edges, {} samples, {} {}{}{})",
        p.display(),
        sc.variant
            .as_ref()
            .map_or(String::new(), |v| format!(" [{v}]")),
        if D == 3 { "3-D, " } else { "" },
        sc.graph.len(),
        sc.geometry.transmitters.len(),
        sc.graph.edges().len(),
        sc.samples,
        sc.algorithm.mode.as_str(),
        sc.algorithm.local_solver.as_str(),
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
