//! One run of a scenario: realise the measurements, run an engine, score,
//! and write the results directory.
//!
//! Outputs (one directory per run; every file carries the seed):
//! * `run.json`: resolved scenario, seed, crate version, engine, mode, clock, command line, status;
//! * `track.csv`: `sample,true_x,true_y,est_x,est_y,error,ml_x,ml_y,crlb,ctte,seed`;
//! * `nodes.csv`: `sample,node,x,y,d,seed`;
//! * `schedule.csv`: `iteration,v,w,seed` (async runs);
//! * `measurements.csv`: every measurement in the trace format (replayable);
//! * `iterations.csv`: `iteration,sample,node,x,y,d,seed` with `--trace-iterations`;
//! * `truth.csv`: `sample,x,y,seed` when the truth is known;
//! * `metrics.json`: the metrics, see [`RunMetrics`].

pub mod bench;
pub mod montecarlo;
pub mod score;

use crate::engine::{EngineError, RunRecord};
use crate::model::error::InputError;
use crate::model::geometry::Vec2;
use crate::model::metrics;
use crate::pipeline::score::{BoundMetrics, Scored, TrackMetrics};
use crate::protocol::Counters;
use crate::scenario::{Realization, Scenario};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

pub use crate::engine::{Clock, EngineKind};

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
}

impl RunOptions {
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
pub struct Outcome {
    /// The run's metrics (those of `metrics.json`), `[expect]` included.
    pub metrics: RunMetrics,
    /// What the engine recorded: every node's `theta` per sample, the schedule.
    pub record: RunRecord,
    /// Every track (the distributed `theta_bar`, `ml`, the baselines), scored.
    pub scored: Scored,
    /// The truth and measurements the run was given.
    pub real: Realization,
    /// Why the run stopped early, if it did (the results above are then
    /// those of the completed samples).
    pub error: Option<EngineError>,
}

impl Outcome {
    /// Every scalar metric by the names `[expect]` uses (`theta_bar.rmse`,
    /// `ml.rmse`, `ogd.ctte`, ...).
    pub fn flat(&self) -> BTreeMap<String, f64> {
        flat_metrics(&self.metrics, &self.scored)
    }
}

impl Scenario {
    /// Load a scenario file (the first of its variants when it has
    /// `[[variants]]`; see [`Scenario::load_all`] for all of them).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Scenario, InputError> {
        Scenario::load(path.as_ref())
    }

    /// Run this scenario with its seed and score it, writing nothing: the
    /// library's entry point for scenario-driven tests. The engine comes
    /// from `opts` (`[monte_carlo]` trials are not run here). An engine
    /// failure is not an `Err`: it is [`Outcome::error`], with the results
    /// of the samples completed before it.
    ///
    /// ```
    /// use sonarnet::pipeline::RunOptions;
    /// use sonarnet::scenario::Scenario;
    ///
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/mourya2017-spiral.toml");
    /// let out = Scenario::from_file(path)?.with_seed(3).with_samples(30)?.run(&RunOptions::inprocess());
    /// assert!(out.error.is_none());
    /// assert!(out.metrics.rmse_after_burn_in.is_some_and(|r| r < 50.0));
    /// assert!(out.metrics.expect.iter().all(|c| c.holds));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run(&self, opts: &RunOptions) -> Outcome {
        run(self, opts, &mut |_, _| {})
    }

    /// [`Scenario::run`], then write the results directory `opts.out_dir`
    /// exactly as `sonarnet run` does (CSVs and JSON; no plots).
    pub fn run_and_write(&self, opts: &RunOptions) -> Result<Outcome, RunError> {
        let out = self.run(opts);
        out.write(self, opts)?;
        Ok(out)
    }
}

/// The pipeline of every run (single runs, every Monte Carlo trial, the
/// library's [`Scenario::run`]): [`execute`] it, run the baselines and score
/// every track ([`evaluate`]), and check `[expect]` when `opts` asks for it
/// and the run completed. Writes nothing ([`Outcome::write`] does).
pub fn run(sc: &Scenario, opts: &RunOptions, progress: crate::engine::Progress<'_>) -> Outcome {
    let Executed {
        real,
        record,
        error,
    } = execute(sc, opts, progress);
    let (mut metrics, scored) = evaluate(sc, &real, &record, error.as_ref(), opts);
    if error.is_none() && opts.check_expect {
        metrics.expect = check_expect(sc, &flat_metrics(&metrics, &scored));
    }
    Outcome {
        metrics,
        record,
        scored,
        real,
        error,
    }
}

/// What the engine side of one run produced.
#[derive(Debug)]
pub struct Executed {
    /// The truth and measurements of the run's seed.
    pub real: Realization,
    /// What the engine recorded.
    pub record: RunRecord,
    /// Why the run stopped early, if it did.
    pub error: Option<EngineError>,
}

/// The engine side of every run (single runs, Monte Carlo trials, the
/// distributed baseline's engine run excepted, `sonarnet bench`): realize `sc`
/// with its seed, build its [`RunPlan`](crate::engine::RunPlan) once and run it
/// on the engine and clock of `opts`. `progress` hears of every completed
/// sample.
pub fn execute(
    sc: &Scenario,
    opts: &RunOptions,
    progress: crate::engine::Progress<'_>,
) -> Executed {
    let real = sc.realize();
    let popts = crate::engine::processes::ProcessOptions {
        poll_us: opts.poll_us,
        verbose: opts.verbose,
        ..Default::default()
    };
    let (record, res) = match crate::engine::RunPlan::new(sc, opts.clock) {
        Ok(plan) => crate::engine::run(&plan, &real, opts.engine, &popts, progress),
        Err(e) => (RunRecord::empty(sc.graph.len()), Err(e)),
    };
    Executed {
        real,
        record,
        error: res.err(),
    }
}

/// Per-node counters as written to `metrics.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeCounters {
    /// Node id.
    pub node: usize,
    /// Counters.
    #[serde(flatten)]
    pub counters: Counters,
    /// Multi-process: seconds spent computing.
    pub busy_seconds: Option<f64>,
    /// Multi-process: seconds spent blocked waiting for messages.
    pub wait_seconds: Option<f64>,
    /// Multi-process: peak resident set size of the node process (KiB).
    pub peak_rss_kib: Option<u64>,
}

/// Free-running (realtime) statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RealtimeStats {
    /// Fewest exchanges completed in one sample period.
    pub iterations_per_sample_min: u64,
    /// Median exchanges per sample period.
    pub iterations_per_sample_median: f64,
    /// Most exchanges in one sample period.
    pub iterations_per_sample_max: u64,
    /// Declined exchange requests, all nodes.
    pub declines: u64,
    /// Network exchange rate (exchanges per second of run time).
    pub iterations_per_second: f64,
}

/// A node that died during the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Death {
    /// Node id.
    pub node: u32,
    /// Sample at which the coordinator noticed.
    pub sample: u32,
    /// Exit status or signal.
    pub how: String,
}

/// The contents of `metrics.json`. Error metrics are `null` without truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// RMSE of `theta_bar` over all samples.
    pub rmse: Option<f64>,
    /// RMSE after `burn_in` samples.
    pub rmse_after_burn_in: Option<f64>,
    /// Median error.
    pub median_error: Option<f64>,
    /// Error at the last sample.
    pub final_error: Option<f64>,
    /// Cumulative target tracking error.
    pub ctte: Option<f64>,
    /// Dynamic regret of `theta_bar` (seed 001), see [`crate::pipeline::score`].
    pub regret: Option<f64>,
    /// Largest consensus disagreement over all samples.
    pub max_disagreement: f64,
    /// RMSE of the centralised ML estimate.
    pub ml_rmse: Option<f64>,
    /// RMS of the per-sample CRLB.
    pub crlb_rms: Option<f64>,
    /// DR iterations (sync: rounds) completed.
    pub iterations: u64,
    /// Prox solves over all nodes.
    pub prox_solves: u64,
    /// Engine wall time (seconds).
    pub wall_seconds: f64,
    /// `inprocess` or `processes`.
    pub engine: String,
    /// `sync` or `async`.
    pub mode: String,
    /// `logical` or `realtime`.
    pub clock: String,
    /// Run seed.
    pub seed: u64,
    /// The scenario variant, if the file has `[[variants]]`.
    pub variant: Option<String>,
    /// Samples completed.
    pub samples_completed: usize,
    /// Samples asked for.
    pub samples: usize,
    /// `ok`, `failed` or `interrupted`.
    pub status: String,
    /// Why the run stopped early.
    pub error: Option<String>,
    /// Why some metrics are missing.
    pub note: Option<String>,
    /// Multi-process: seconds from spawning the nodes to all of them ready.
    pub startup_seconds: Option<f64>,
    /// Realtime clock statistics.
    pub realtime: Option<RealtimeStats>,
    /// Nodes that died (the gap: they are left out of `theta_bar` from then on).
    pub deaths: Vec<Death>,
    /// Per-node counters.
    pub nodes: Vec<NodeCounters>,
    /// Certified bounds on `theta_bar` (`[bounds]`), by bound name.
    pub bounds: BTreeMap<String, BoundMetrics>,
    /// Every baseline's metrics, by track name.
    pub baselines: BTreeMap<String, TrackMetrics>,
    /// `x_hat_t` solves (regret) that stopped at 5000 iterations.
    pub x_hat_not_converged: usize,
    /// The scenario's `[expect]` checks on this run.
    pub expect: Vec<ExpectResult>,
}

/// One `[expect]` check as recorded in `metrics.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectResult {
    /// The relation (thresholds as `theta_bar.rmse <= 5.0`), or why it
    /// could not be evaluated.
    pub expect: String,
    /// Left value (`None` when it could not be evaluated).
    pub lhs: Option<f64>,
    /// Right value.
    pub rhs: Option<f64>,
    /// Whether it holds.
    pub holds: bool,
}

/// Errors of a run that prevent writing results at all.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Bad input.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Could not write the results directory.
    #[error("cannot write results to {}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

pub use crate::engine::run_inprocess;

/// The `distributed` baseline: the DR engine again, in-process, on the same
/// realization, with the baseline's own local solver, mode and iteration
/// count (the scenario's where it gives none), and no fixed schedule.
fn distributed_run(
    cfg: &crate::estimators::baselines::BaselineCfg,
    sc: &Scenario,
    real: &Realization,
    samples: usize,
) -> (Vec<Option<Vec2>>, Option<String>) {
    let crate::estimators::baselines::BaselineCfg::Distributed {
        local_solver,
        mode,
        iterations_per_sample,
        ..
    } = cfg
    else {
        return (
            vec![None; samples],
            Some(format!("{} is not the distributed baseline", cfg.kind())),
        );
    };
    let mut alt = sc.clone().with_trace_iterations(false);
    alt.algorithm.schedule = None;
    if let Some(s) = local_solver {
        alt = alt.with_local_solver(*s);
    }
    if let Some(m) = mode {
        alt.algorithm.mode = *m;
    }
    if let Some(n) = iterations_per_sample {
        alt.algorithm.iterations_per_sample = *n;
    }
    alt.samples = samples;
    let (rec, res) = match crate::engine::RunPlan::new(&alt, Clock::Logical) {
        Ok(plan) => run_inprocess(&plan, real, &mut |_, _| {}),
        Err(e) => (RunRecord::empty(alt.graph.len()), Err(e)),
    };
    let est = (0..samples)
        .map(|k| rec.thetas.get(k).map(|t| metrics::theta_bar(t)))
        .collect();
    (est, res.err().map(|e| e.to_string()))
}

/// Run the baselines and score every track of a record (no I/O).
pub fn evaluate(
    sc: &Scenario,
    real: &Realization,
    record: &RunRecord,
    error: Option<&EngineError>,
    opts: &RunOptions,
) -> (RunMetrics, Scored) {
    let done = record.thetas.len();
    let est: Vec<Vec2> = record
        .thetas
        .iter()
        .map(|t| metrics::theta_bar(t))
        .collect();
    // The centralised ML reference, solved once for the `ml` track and any
    // `ml` baseline.
    let ml_start = std::time::Instant::now();
    let ml = crate::estimators::central::ml_track(
        &sc.geometry,
        &real.measurements[..done],
        &real.sigmas[..done],
    );
    let ml_seconds = ml_start.elapsed().as_secs_f64();
    let baselines: Vec<_> = sc
        .baselines
        .iter()
        .map(|b| {
            let engine = |samples: usize| distributed_run(b, sc, real, samples);
            crate::estimators::baselines::run_baseline(
                b,
                &sc.geometry,
                real,
                done,
                (&ml, ml_seconds),
                &engine,
            )
        })
        .collect();
    let scored = score::score(sc, real, &est, ml, baselines, done);
    let tb = &scored.tracks[0].metrics;
    let ml = &scored.tracks[1].metrics;
    let crlbs: Vec<f64> = scored.crlb.iter().flatten().copied().collect();
    let max_dis = (0..done)
        .map(|k| metrics::disagreement(&record.alive_thetas(k)))
        .fold(0.0, f64::max);
    let status = match error {
        None => "ok",
        Some(EngineError::Interrupted { .. }) => "interrupted",
        Some(_) => "failed",
    };
    let note = if real.truth.is_none() {
        Some(
            "no truth file was given: error metrics (rmse, ctte, regret, ml_rmse, crlb, bound coverage) are not computed"
                .to_string(),
        )
    } else if done == 0 {
        Some("no sample completed".to_string())
    } else {
        None
    };
    let m = RunMetrics {
        rmse: tb.rmse,
        rmse_after_burn_in: tb.rmse_after_burn_in,
        median_error: tb.median_error,
        final_error: tb.final_error,
        ctte: tb.ctte,
        regret: tb.regret,
        max_disagreement: max_dis,
        ml_rmse: ml.rmse,
        crlb_rms: metrics::rms(&crlbs),
        iterations: record.iterations,
        prox_solves: record.prox_solves(),
        wall_seconds: record.wall_seconds,
        engine: opts.engine.as_str().into(),
        mode: sc.algorithm.mode.as_str().into(),
        clock: match opts.clock {
            Clock::Logical => "logical".into(),
            Clock::Realtime => "realtime".into(),
        },
        seed: sc.seed,
        variant: sc.variant.clone(),
        samples_completed: done,
        samples: sc.samples,
        status: status.into(),
        error: error.map(|e| e.to_string()),
        note,
        startup_seconds: record.startup_seconds,
        realtime: realtime_stats(record, opts),
        deaths: record
            .deaths
            .iter()
            .map(|(node, sample, how)| Death {
                node: *node,
                sample: *sample,
                how: how.clone(),
            })
            .collect(),
        nodes: record
            .counters
            .iter()
            .enumerate()
            .map(|(node, c)| NodeCounters {
                node,
                counters: *c,
                busy_seconds: record.timing.get(node).map(|t| t.busy_seconds),
                wait_seconds: record.timing.get(node).map(|t| t.wait_seconds),
                peak_rss_kib: record.peak_rss_kib.get(node).copied().flatten(),
            })
            .collect(),
        bounds: tb.bounds.clone(),
        baselines: scored.tracks[2..]
            .iter()
            .map(|t| (t.name.clone(), t.metrics.clone()))
            .collect(),
        x_hat_not_converged: scored.x_hat_not_converged,
        expect: Vec::new(),
    };
    (m, scored)
}

/// The flat metric namespace of a run (`theta_bar.rmse`, `ogd.ctte`,
/// `pocs.bounds.upp_maxdis.coverage`, ...): what `[expect] holds` and
/// `trials.csv` use.
pub fn flat_metrics(m: &RunMetrics, scored: &Scored) -> std::collections::BTreeMap<String, f64> {
    let mut f = scored.flat();
    f.insert("theta_bar.max_disagreement".into(), m.max_disagreement);
    f.insert("theta_bar.iterations".into(), m.iterations as f64);
    f.insert("theta_bar.prox_solves".into(), m.prox_solves as f64);
    if let Some(c) = m.crlb_rms {
        f.insert("crlb_rms".into(), c);
    }
    f
}

/// Check the scenario's `[expect]` block against one run's metrics.
pub fn check_expect(sc: &Scenario, flat: &BTreeMap<String, f64>) -> Vec<ExpectResult> {
    expect_results(crate::scenario::expect::check(&sc.expect, &|name: &str| {
        flat.get(name)
            .copied()
            .ok_or_else(|| unknown_metric(name, flat.keys()))
    }))
}

/// Checks as recorded in `metrics.json` / `summary.json`; one that could not
/// be evaluated fails with its reason.
pub fn expect_results(
    checks: Vec<Result<crate::scenario::expect::Check, String>>,
) -> Vec<ExpectResult> {
    checks
        .into_iter()
        .map(|c| match c {
            Ok(c) => ExpectResult {
                expect: c.text,
                lhs: Some(c.lhs),
                rhs: Some(c.rhs),
                holds: c.holds,
            },
            Err(e) => ExpectResult {
                expect: e,
                lhs: None,
                rhs: None,
                holds: false,
            },
        })
        .collect()
}

/// "no metric X" with the closest names, for expectation errors.
pub fn unknown_metric<'a>(name: &str, keys: impl Iterator<Item = &'a String>) -> String {
    let prefix = name.split('.').next().unwrap_or("");
    let near: Vec<&String> = keys
        .filter(|k| k.split('.').next() == Some(prefix))
        .take(12)
        .collect();
    if near.is_empty() {
        format!("no metric {name:?} (no track {prefix:?})")
    } else {
        format!(
            "no metric {name:?} (metrics of {prefix}: {})",
            near.iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

impl Outcome {
    /// Write the results directory `opts.out_dir` of this run of `sc`. Always
    /// writes what there is, even for a run that stopped early.
    pub fn write(&self, sc: &Scenario, opts: &RunOptions) -> Result<(), RunError> {
        let Outcome {
            metrics: m,
            record,
            scored,
            real,
            error,
        } = self;
        let done = record.thetas.len();
        let status = m.status.as_str();
        let dir = &opts.out_dir;
        std::fs::create_dir_all(dir).map_err(|e| RunError::Output {
            path: dir.clone(),
            source: e,
        })?;
        write_run_json(
            dir,
            sc,
            opts,
            status,
            error.as_ref(),
            record.run_id.as_deref(),
        )?;
        write_track_csv(&dir.join("track.csv"), sc, real, scored, done)?;
        write_csv(
            &dir.join("nodes.csv"),
            &["sample", "node", "x", "y", "d", "seed"],
            record.thetas.iter().enumerate().flat_map(|(k, ts)| {
                ts.iter().enumerate().map(move |(i, t)| {
                    vec![
                        k.to_string(),
                        i.to_string(),
                        num(t[0]),
                        num(t[1]),
                        num(t[2]),
                        sc.seed.to_string(),
                    ]
                })
            }),
        )?;
        if !record.schedule.is_empty() {
            write_csv(
                &dir.join("schedule.csv"),
                &["iteration", "v", "w", "seed"],
                record.schedule.iter().enumerate().map(|(it, (v, w))| {
                    vec![
                        it.to_string(),
                        v.to_string(),
                        w.to_string(),
                        sc.seed.to_string(),
                    ]
                }),
            )?;
        }
        if !record.iteration_trace.is_empty() {
            write_csv(
                &dir.join("iterations.csv"),
                &["iteration", "sample", "node", "x", "y", "d", "seed"],
                record.iteration_trace.iter().map(|(it, k, i, t)| {
                    vec![
                        it.to_string(),
                        k.to_string(),
                        i.to_string(),
                        num(t[0]),
                        num(t[1]),
                        num(t[2]),
                        sc.seed.to_string(),
                    ]
                }),
            )?;
        }
        write_trace(
            &dir.join("measurements.csv"),
            &real.measurements[..done],
            sc.seed,
        )?;
        if let Some(t) = real.truth.as_ref().map(|t| &t[..done]) {
            write_csv(
                &dir.join("truth.csv"),
                &["sample", "x", "y", "seed"],
                t.iter()
                    .enumerate()
                    .map(|(k, p)| vec![k.to_string(), num(p.x), num(p.y), sc.seed.to_string()]),
            )?;
        }
        write_json(&dir.join("metrics.json"), m)?;
        Ok(())
    }
}

/// Write `track.csv`: the distributed track's columns, then per baseline
/// `NAME_x,NAME_y,NAME_error,NAME_ctte,NAME_regret` (+ `NAME_regret_pred` for
/// online trackers) and bound radii (`bound_B` on `theta_bar`, `NAME_bound_B`
/// on a baseline; empty when the set was empty).
pub fn write_track_csv(
    path: &Path,
    sc: &Scenario,
    real: &Realization,
    scored: &Scored,
    done: usize,
) -> Result<(), RunError> {
    let truth = real.truth.as_ref().map(|t| &t[..done]);
    let mut header: Vec<String> = [
        "sample", "true_x", "true_y", "est_x", "est_y", "error", "ml_x", "ml_y", "crlb", "ctte",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let tb = &scored.tracks[0];
    let ml = &scored.tracks[1];
    if tb.regret.is_some() {
        header.push("regret".into());
    }
    for (b, _) in &tb.bounds {
        header.push(format!("bound_{b}"));
    }
    for t in &scored.tracks[2..] {
        for suffix in ["x", "y", "error", "ctte"] {
            header.push(format!("{}_{suffix}", t.name));
        }
        if t.regret.is_some() {
            header.push(format!("{}_regret", t.name));
        }
        if t.regret_pred.is_some() {
            header.push(format!("{}_regret_pred", t.name));
        }
        for (b, _) in &t.bounds {
            header.push(format!("{}_bound_{b}", t.name));
        }
    }
    header.push("seed".into());
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let rows = (0..done).map(|k| {
        let t = truth.map(|t| t[k]);
        let e = |tr: &score::ScoredTrack| tr.error.as_ref().and_then(|e| e[k]);
        let c = |tr: &score::ScoredTrack| tr.ctte.as_ref().map(|c| c[k]);
        let est = tb.est[k].unwrap_or_else(Vec2::zeros);
        let mlx = ml.est[k];
        let mut row = vec![
            k.to_string(),
            opt(t.map(|p| p.x)),
            opt(t.map(|p| p.y)),
            num(est.x),
            num(est.y),
            opt(e(tb)),
            opt(mlx.map(|p| p.x)),
            opt(mlx.map(|p| p.y)),
            opt(scored.crlb[k]),
            opt(c(tb)),
        ];
        if let Some(r) = &tb.regret {
            row.push(num(r[k]));
        }
        for (_, radii) in &tb.bounds {
            row.push(opt(radii[k]));
        }
        for tr in &scored.tracks[2..] {
            row.push(opt(tr.est[k].map(|p| p.x)));
            row.push(opt(tr.est[k].map(|p| p.y)));
            row.push(opt(e(tr)));
            row.push(opt(c(tr)));
            if let Some(r) = &tr.regret {
                row.push(num(r[k]));
            }
            if let Some(r) = &tr.regret_pred {
                row.push(num(r[k]));
            }
            for (_, radii) in &tr.bounds {
                row.push(opt(radii[k]));
            }
        }
        row.push(sc.seed.to_string());
        row
    });
    write_csv(path, &header_refs, rows)
}

fn realtime_stats(rec: &RunRecord, opts: &RunOptions) -> Option<RealtimeStats> {
    if opts.clock != Clock::Realtime || rec.iterations_per_sample.is_empty() {
        return None;
    }
    let ips: Vec<f64> = rec
        .iterations_per_sample
        .iter()
        .map(|&x| x as f64)
        .collect();
    Some(RealtimeStats {
        iterations_per_sample_min: rec.iterations_per_sample.iter().copied().min().unwrap_or(0),
        iterations_per_sample_median: metrics::median(&ips).unwrap_or(0.0),
        iterations_per_sample_max: rec.iterations_per_sample.iter().copied().max().unwrap_or(0),
        declines: rec.counters.iter().map(|c| c.declines).sum(),
        iterations_per_second: rec.iterations as f64 / rec.wall_seconds.max(1e-9),
    })
}

/// Write measurements in the trace format
/// (`sample,receiver,transmitter,kind,value,seed`), so a run can be replayed.
pub fn write_trace(
    path: &Path,
    samples: &[crate::model::measure::SampleMeasurements],
    seed: u64,
) -> Result<(), RunError> {
    let rows = samples.iter().enumerate().flat_map(|(k, s)| {
        s.nodes.iter().enumerate().flat_map(move |(n, nm)| {
            let mut rows = Vec::new();
            for &(m, v) in &nm.bistatic {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    m.to_string(),
                    "bistatic_range".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            if let Some(v) = nm.doa {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    String::new(),
                    "doa".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            if let Some(v) = nm.range {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    String::new(),
                    "range".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            rows
        })
    });
    write_csv(
        path,
        &["sample", "receiver", "transmitter", "kind", "value", "seed"],
        rows,
    )
}

/// Shortest round-trip decimal form of a float (exact replay from CSV).
fn num(x: f64) -> String {
    format!("{x:?}")
}

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> RunError + '_ {
    move |e| RunError::Output {
        path: path.to_path_buf(),
        source: e,
    }
}

/// Write a CSV file with a header and string rows.
pub fn write_csv(
    path: &Path,
    header: &[&str],
    rows: impl Iterator<Item = Vec<String>>,
) -> Result<(), RunError> {
    let f = std::fs::File::create(path).map_err(io_err(path))?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(f));
    let to_io = |e: csv::Error| RunError::Output {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    w.write_record(header).map_err(to_io)?;
    for r in rows {
        w.write_record(&r).map_err(to_io)?;
    }
    w.flush().map_err(io_err(path))
}

/// Write pretty JSON.
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<(), RunError> {
    let mut f = std::fs::File::create(path).map_err(io_err(path))?;
    let s = serde_json::to_string_pretty(v).map_err(|e| RunError::Output {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    f.write_all(s.as_bytes()).map_err(io_err(path))?;
    f.write_all(b"\n").map_err(io_err(path))
}

fn write_run_json(
    dir: &Path,
    sc: &Scenario,
    opts: &RunOptions,
    status: &str,
    error: Option<&EngineError>,
    run_id: Option<&str>,
) -> Result<(), RunError> {
    let mut resolved = sc.file.clone();
    resolved.seed = sc.seed;
    resolved.algorithm.mode = sc.algorithm.mode;
    resolved.algorithm.local_solver = sc.algorithm.local_solver;
    resolved.algorithm.kappa = sc.algorithm.kappa;
    resolved.algorithm.iterations_per_sample = sc.algorithm.iterations_per_sample;
    if let Some(t) = &mut resolved.target {
        t.samples = sc.samples;
    }
    resolved.geometry.receivers = sc.geometry.receivers.iter().map(|r| [r.x, r.y]).collect();
    let v = serde_json::json!({
        "scenario_file": sc.path.display().to_string(),
        "scenario": resolved,
        "edges": sc.graph.edges(),
        "seed": sc.seed,
        "crate_version": env!("CARGO_PKG_VERSION"),
        "engine": opts.engine.as_str(),
        "mode": sc.algorithm.mode.as_str(),
        "clock": match opts.clock { Clock::Logical => "logical", Clock::Realtime => "realtime" },
        "local_solver": sc.algorithm.local_solver,
        "poll_us": opts.poll_us,
        "command_line": opts.command_line,
        "status": status,
        "error": error.map(|e| e.to_string()),
        "run_id": run_id,
    });
    write_json(&dir.join("run.json"), &v)
}
