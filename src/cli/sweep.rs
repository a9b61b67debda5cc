//! `sonarnet sweep`: parse and validate the whole grid, run it with a
//! progress bar, write the tables, the plot and the page, print a summary.

use super::SweepArgs;
use crate::cli::check_out;
use crate::cli::errors::CliError;
use crate::cli::print;
use crate::pipeline;
use crate::pipeline::EngineKind;
use crate::pipeline::RunOptions;
use crate::pipeline::sweep::{Axis, SweepPlan, metric_key, parse_seeds, run_sweep, summarise};
use crate::scenario::Override;
use crate::scenario::{AnyScenario, Scenario};
use std::path::PathBuf;

pub(super) fn sweep_command(args: &SweepArgs) -> Result<(), CliError> {
    let plan = sweep_plan(args)?;
    let Some((_, first)) = plan.points.first() else {
        return Err(crate::model::error::InputError::at(
            std::path::Path::new("<command line>"),
            "--grid",
            "the grid has no point",
        )
        .into());
    };
    let engine: EngineKind = args.engine;
    let out = args.out.clone().unwrap_or_else(|| {
        let keys: Vec<&str> = plan
            .axes
            .iter()
            .map(|a| a.key.rsplit('.').next().unwrap_or(&a.key))
            .collect();
        PathBuf::from("results").join(format!("{}-sweep-{}", first.name(), keys.join("-")))
    });
    check_out(&out)?;
    // Every run's machine check before any work (node processes).
    for (_, sc) in &plan.points {
        match sc {
            AnyScenario::Plane(sc) => preflight(sc, engine, &out)?,
            AnyScenario::Space(sc) => preflight(sc, engine, &out)?,
        }
    }
    let jobs = args.jobs.map_or_else(
        || {
            if engine == EngineKind::Processes {
                1
            } else {
                std::thread::available_parallelism().map_or(1, |n| n.get())
            }
        },
        |j| j as usize,
    );
    println!(
        "sonarnet sweep: {} grid points x {} seeds = {} runs on {} ({} at once), into {}",
        plan.points.len(),
        plan.seeds.len(),
        plan.runs(),
        engine.as_str(),
        jobs,
        out.display()
    );
    let bar = super::print::Progress::new(
        !args.quiet,
        plan.runs() as u64,
        "runs",
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs ({per_sec}, eta {eta})",
    );
    let tick = |n: usize| bar.set(n as u64, String::new);
    let outcome = run_sweep(&plan, engine, jobs, &out, &tick);
    bar.finish();
    if args.plots {
        println!("drawing the plots of {} runs", outcome.runs.len());
        draw_run_plots(&outcome.runs, jobs);
    }
    pipeline::sweep::write_tables(&plan, &outcome, &out)?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let report = crate::report::write_sweep_report(&plan, &outcome, &out, &args.metric, &command);
    print_summary(&plan, &outcome.runs, &args.metric);
    println!("  results in {}", out.display());
    match &report {
        Ok(p) => println!("  report     {}", p.display()),
        Err(e) => eprintln!("warning: the sweep's report was not written: {e}"),
    }
    if outcome.interrupted {
        return Err(CliError::SweepInterrupted {
            done: outcome.runs.len(),
            requested: outcome.requested,
            dir: out,
        });
    }
    report.map(drop).map_err(CliError::from)
}

/// The machine check of one grid point's runs on `engine`.
fn preflight<const D: usize>(
    sc: &Scenario<D>,
    engine: EngineKind,
    out: &std::path::Path,
) -> Result<(), CliError> {
    let opts = RunOptions::inprocess()
        .with_engine(engine)
        .with_clock(pipeline::default_clock(sc))
        .with_out_dir(out);
    Ok(pipeline::preflight(sc, &opts)?)
}

/// The sweep's plan from its flags: every `--set`, `--grid` axis and
/// seed checked before any work; notes what it ignores.
fn sweep_plan(args: &SweepArgs) -> Result<SweepPlan, CliError> {
    let sets = args
        .set
        .iter()
        .map(|s| Override::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let axes = args
        .grid
        .iter()
        .map(|g| Axis::parse(g))
        .collect::<Result<Vec<_>, _>>()?;
    let seeds = match &args.seeds {
        Some(s) => parse_seeds(s)?,
        None => {
            let base = AnyScenario::load_all_with(&args.scenario, &sets, &args.variant)?;
            vec![base.first().map_or(0, AnyScenario::seed)]
        }
    };
    let plan = SweepPlan::new(&args.scenario, &sets, axes, seeds, &args.variant)?;
    if plan
        .points
        .iter()
        .any(|(_, sc)| sc.file().monte_carlo.is_some())
    {
        eprintln!(
            "note: [monte_carlo] is ignored: a sweep runs each grid point once per --seeds seed"
        );
    }
    Ok(plan)
}

/// The terminal summary: `metric`'s mean ± std over the seeds at every grid
/// point (a warning naming the metrics there are, if no run has it).
fn print_summary(plan: &SweepPlan, runs: &[crate::pipeline::sweep::SweepRun], metric: &str) {
    let key = metric_key(runs, metric);
    match &key {
        Some(k) => println!("{k} (mean ± std over the seeds):"),
        None => {
            let names: std::collections::BTreeSet<&String> =
                runs.iter().flat_map(|r| r.metrics.keys()).collect();
            eprintln!(
                "warning: no run has a metric {:?}; the runs have: {}",
                metric,
                names.into_iter().cloned().collect::<Vec<_>>().join(", ")
            );
        }
    }
    for (p, ok, failed, stats) in summarise(plan, runs) {
        let cell = key.as_ref().and_then(|k| stats.get(k).copied()).map_or(
            "–".to_string(),
            |(m, s, _)| match (m, s) {
                (Some(m), Some(s)) => format!("{} ± {}", print::eng(m), print::eng(s)),
                (Some(m), None) => print::eng(m),
                _ => "–".into(),
            },
        );
        println!(
            "  {:<48} {cell:>24}  n={ok}{}",
            plan.points[p].0.label(),
            if failed > 0 {
                format!(" failed={failed}")
            } else {
                String::new()
            }
        );
    }
}

/// `--plots`: every completed run's plots, `jobs` runs at a time. A run whose
/// plots cannot be drawn keeps its results; the warning names it.
fn draw_run_plots(runs: &[crate::pipeline::sweep::SweepRun], jobs: usize) {
    // A run stopped before it wrote anything (a failed preflight) has
    // nothing to draw.
    let drawn = crate::pipeline::pool::run_indexed(
        0..runs.len(),
        jobs,
        |i| {
            let dir = &runs[i].dir;
            dir.join("metrics.json")
                .exists()
                .then(|| crate::plot::write_run_plots(dir))
        },
        &|_| {},
    );
    for (run, r) in runs.iter().zip(drawn) {
        if let Some(Some(Err(e))) = r {
            eprintln!("warning: plots of {} not drawn: {e}", run.dir.display());
        }
    }
}
