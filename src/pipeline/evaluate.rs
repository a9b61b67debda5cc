//! Scoring one run: the baselines on the same realization, every track scored
//! ([`super::score`]), the metrics of `metrics.json`, and the `[expect]` checks.

use super::ChannelStats;
use super::Death;
use super::ExpectResult;
use super::FaultOutcome;
use super::LinkStats;
use super::NodeCounters;
use super::RealtimeStats;
use super::RunMetrics;
use super::RunStatus;
use crate::engine::RunOutcome;
use crate::estimators::gossip::Mode;
use crate::model::geometry::Point;
use crate::model::metrics;
use crate::pipeline::RunOptions;
use crate::pipeline::score;
use crate::pipeline::score::Scored;
use crate::protocol::Clock;
use crate::protocol::EngineError;
use crate::protocol::RunRecord;
use crate::scenario::Realization;
use crate::scenario::Scenario;
use crate::world::faults::FaultLog;
use crate::world::medium::ChannelLog;
use crate::world::medium::MessageRecord;
use std::collections::BTreeMap;

/// The `distributed` baseline: the DR engine again, in-process, on the same
/// realization, with the baseline's own local solver, mode and iteration
/// count (the scenario's where it gives none), and no fixed schedule.
fn distributed_run<const D: usize>(
    changes: crate::estimators::baselines::DistributedRun,
    sc: &Scenario<D>,
    real: &Realization<D>,
    samples: usize,
) -> (Vec<Option<Point<D>>>, Option<String>) {
    let crate::estimators::baselines::DistributedRun {
        local_solver,
        mode,
        iterations_per_sample,
    } = changes;
    let mut alt = sc.clone().with_trace_iterations(false);
    alt.algorithm.schedule = None;
    if let Some(s) = local_solver {
        alt = alt.with_local_solver(s);
    }
    if let Some(m) = mode {
        alt.algorithm.mode = m;
    }
    if let Some(n) = iterations_per_sample {
        alt.algorithm.iterations_per_sample = n;
    }
    alt.samples = samples;
    let run = match crate::protocol::RunPlan::new(&alt, Clock::Logical) {
        Ok(plan) => crate::engine::run_inprocess(&plan, real.feed(), &mut |_, _| {}),
        Err(e) => RunOutcome::refused(alt.graph.len(), e),
    };
    let est = (0..samples)
        .map(|k| run.record.thetas.get(k).map(|t| metrics::theta_bar::<D>(t)))
        .collect();
    (est, run.error.as_ref().map(EngineError::in_full))
}

/// Every baseline of `sc` on the first `done` samples of `real` (`ml`: the
/// centralised ML track and the seconds it took).
fn run_baselines<const D: usize>(
    sc: &Scenario<D>,
    real: &Realization<D>,
    done: usize,
    ml: (&[Point<D>], f64),
) -> Vec<crate::estimators::baselines::BaselineTrack<D>> {
    sc.baselines
        .iter()
        .map(|b| {
            let engine = |changes, samples: usize| distributed_run(changes, sc, real, samples);
            crate::estimators::baselines::run_baseline(b, &sc.geometry, real, done, ml, &engine)
        })
        .collect()
}

/// Why some metrics are missing: no truth, or no sample completed.
fn note<const D: usize>(real: &Realization<D>, done: usize) -> Option<String> {
    if real.truth.is_none() {
        Some(
            "no truth file was given: error metrics (rmse, ctte, regret, ml_rmse, crlb, bound coverage) are not computed"
                .to_string(),
        )
    } else if done == 0 {
        Some("no sample completed".to_string())
    } else {
        None
    }
}

/// Every node's counters, with its process's timing and peak RSS where
/// node processes ran.
fn node_counters(run: &RunOutcome) -> Vec<NodeCounters> {
    let procs = run.processes.as_ref();
    run.record
        .counters
        .iter()
        .enumerate()
        .map(|(node, c)| NodeCounters {
            node,
            counters: *c,
            busy_seconds: procs
                .and_then(|p| p.timing.get(node))
                .map(|t| t.busy_seconds),
            wait_seconds: procs
                .and_then(|p| p.timing.get(node))
                .map(|t| t.wait_seconds),
            peak_rss_kib: procs
                .and_then(|p| p.peak_rss_kib.get(node).copied())
                .flatten(),
            bad_frames_sent: procs
                .and_then(|p| p.bad_frames.get(node).copied())
                .unwrap_or(0),
        })
        .collect()
}

/// Run the baselines and score every track of a record (no I/O).
pub fn evaluate<const D: usize>(
    sc: &Scenario<D>,
    real: &Realization<D>,
    run: &RunOutcome,
    opts: &RunOptions,
) -> (RunMetrics, Scored<D>) {
    let record = &run.record;
    let error = run.error.as_ref();
    let procs = run.processes.as_ref();
    let done = record.thetas.len();
    // theta_bar is the mean of the nodes alive at each sample: a dead node's
    // frozen estimate is left out from the sample its death was noticed.
    let est: Vec<Point<D>> = (0..done)
        .map(|k| metrics::theta_bar::<D>(&record.alive_thetas(k)))
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
    let baselines = run_baselines(sc, real, done, (&ml, ml_seconds));
    let scored = score::score(sc, real, &est, ml, baselines, done);
    let tb = &scored.tracks[0].metrics;
    let ml = &scored.tracks[1].metrics;
    let crlbs: Vec<f64> = scored.crlb.iter().flatten().copied().collect();
    let max_dis = (0..done)
        .map(|k| metrics::disagreement::<D>(&record.alive_thetas(k)))
        .fold(0.0, f64::max);
    let status = match error {
        None => RunStatus::Ok,
        Some(EngineError::Interrupted { .. }) => RunStatus::Interrupted,
        Some(_) => RunStatus::Failed,
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
        clock: opts.clock.as_str().into(),
        seed: sc.seed,
        variant: sc.variant.clone(),
        samples_completed: done,
        samples: sc.samples,
        status,
        error: error.map(EngineError::in_full),
        note: note(real, done),
        startup_seconds: procs.and_then(|p| p.startup_seconds),
        realtime: realtime_stats(record, opts),
        channel: run
            .channel
            .as_ref()
            .map(|c| channel_stats(record, c, opts.clock, sc.algorithm.mode)),
        faults: fault_outcomes(
            run.faults.as_ref(),
            scored.tracks[0].error.as_deref(),
            sc.realtime
                .as_ref()
                .map_or(1.0, |rt| rt.sample_period_ms / 1000.0),
        ),
        deaths: record
            .deaths
            .iter()
            .map(|(node, sample, how)| Death {
                node: *node,
                sample: *sample,
                how: how.clone(),
            })
            .collect(),
        nodes: node_counters(run),
        bounds: tb.bounds.clone(),
        theta_bar: tb.clone(),
        ml: ml.clone(),
        baselines: scored.tracks[2..]
            .iter()
            .map(|t| (t.name.clone(), t.metrics.clone()))
            .collect(),
        x_hat_not_converged: scored.x_hat_not_converged,
        expect: Vec::new(),
    };
    (m, scored)
}

/// Check the scenario's `[expect]` block against one run's metrics.
pub fn check_expect<const D: usize>(
    sc: &Scenario<D>,
    flat: &BTreeMap<String, f64>,
) -> Vec<ExpectResult> {
    expect_results(crate::scenario::expect::check(&sc.expect, &|name: &str| {
        flat.get(name)
            .copied()
            .ok_or_else(|| unknown_metric(name, flat.keys()))
    }))
}

/// Checks as recorded in `metrics.json` / `summary.json`; one that could not
/// be evaluated fails with its reason.
pub fn expect_results(
    checks: Vec<Result<crate::scenario::expect::Check, crate::scenario::expect::ExpectError>>,
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
                expect: e.to_string(),
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

/// How much worse than before a fault the error may be and still count as
/// recovered.
pub const RECOVERY_FACTOR: f64 = 1.5;

/// Each applied fault's outcome on the error of `theta_bar` (`errors`, per
/// sample), with samples `period_s` emulated seconds long: the mean error of
/// the five samples before it, the peak from its start to its end, and the
/// samples from its end until the error is back within [`RECOVERY_FACTOR`]
/// of that mean.
pub fn fault_outcomes(
    log: Option<&FaultLog>,
    errors: Option<&[Option<f64>]>,
    period_s: f64,
) -> Vec<FaultOutcome> {
    let errs = errors.unwrap_or(&[]);
    log.map_or(&[][..], |l| &l.applied[..])
        .iter()
        .map(|f| {
            let s0 = f.sample as usize;
            let end = match f.fault.until_s {
                Some(u) => ((u / period_s).ceil() as usize).max(s0),
                None => s0,
            };
            let before: Vec<f64> = errs[s0.saturating_sub(5).min(errs.len())..s0.min(errs.len())]
                .iter()
                .flatten()
                .copied()
                .collect();
            let error_before =
                (!before.is_empty()).then(|| before.iter().sum::<f64>() / before.len() as f64);
            let during = errs
                .get(s0.min(errs.len())..(end + 1).min(errs.len()))
                .unwrap_or(&[]);
            let peak_error = during.iter().flatten().copied().reduce(f64::max);
            let back = error_before.and_then(|lvl| {
                (end..errs.len()).find(|&k| errs[k].is_some_and(|e| e <= RECOVERY_FACTOR * lvl))
            });
            FaultOutcome {
                kind: f.fault.kind.name().into(),
                nodes: f.fault.kind.nodes(),
                detail: f.fault.kind.detail(),
                t_s: f.t_s,
                until_s: f.fault.until_s,
                until_sample: end as u32,
                sample: f.sample,
                detected_s: f.detected_s,
                error_before,
                peak_error,
                recovery_samples: back.map(|k| (k - end) as u32),
                recovered_s: back.map(|k| (k + 1) as f64 * period_s),
            }
        })
        .collect()
}

/// The acoustic channel's statistics from the run's messages.
pub fn channel_stats(rec: &RunRecord, log: &ChannelLog, clock: Clock, mode: Mode) -> ChannelStats {
    let emulated = log.emulated_seconds;
    let timeouts = rec.counters.iter().map(|c| c.timeouts).sum();
    // Frames still in flight at the end were never judged: they are
    // counted apart, not as delivered or lost.
    let in_flight = log.messages.iter().filter(|m| m.in_flight).count() as u64;
    let judged: Vec<&MessageRecord> = log.messages.iter().filter(|m| !m.in_flight).collect();
    let msgs = &judged;
    let frames = msgs.len() as u64;
    let delivered = msgs.iter().filter(|m| m.lost.is_none()).count() as u64;
    let ratio = |d: u64, n: u64| if n == 0 { 0.0 } else { d as f64 / n as f64 };
    let mut lost = BTreeMap::new();
    let mut links: BTreeMap<(u32, u32), (u64, u64)> = BTreeMap::new();
    for m in msgs {
        if let Some(r) = m.lost {
            *lost.entry(r.as_str().to_string()).or_insert(0) += 1;
        }
        let e = links.entry((m.from, m.to)).or_insert((0, 0));
        e.0 += 1;
        e.1 += u64::from(m.lost.is_none());
    }
    let delays: Vec<f64> = msgs
        .iter()
        .filter_map(|m| m.t_recv.map(|t| t - m.t_send))
        .collect();
    let count = |k: &str, delivered_only: bool| {
        msgs.iter()
            .filter(|m| m.kind == k && (!delivered_only || m.lost.is_none()))
            .count() as u64
    };
    ChannelStats {
        frames,
        in_flight,
        delivered,
        delivery_ratio: ratio(delivered, frames),
        lost,
        links: links
            .into_iter()
            .map(|((from, to), (n, d))| LinkStats {
                from,
                to,
                frames: n,
                delivery_ratio: ratio(d, n),
            })
            .collect(),
        delay_mean_s: (!delays.is_empty())
            .then(|| delays.iter().sum::<f64>() / delays.len() as f64),
        delay_p99_s: metrics::quantile(&delays, 0.99),
        exchanges_attempted: count("request", false),
        exchanges_completed: count("accept", true),
        exchanges_timed_out: if clock == Clock::Realtime {
            timeouts
        } else {
            0
        },
        rounds_timed_out: if clock == Clock::Logical && mode == Mode::Sync {
            timeouts
        } else {
            0
        },
        points_missing: rec.counters.iter().map(|c| c.missing).sum(),
        steps_timed_out: if clock == Clock::Logical && mode == Mode::Async {
            timeouts
        } else {
            0
        },
        delivery_error_p50_ms: metrics::quantile(&log.delivery_errors_ms, 0.5),
        delivery_error_p99_ms: metrics::quantile(&log.delivery_errors_ms, 0.99),
        bits_sent: msgs.iter().map(|m| m.bits).sum(),
        emulated_seconds: emulated,
        realtime_factor: emulated / rec.wall_seconds.max(1e-9),
        events: log.events.unwrap_or(0),
        events_per_second: log.events.unwrap_or(0) as f64 / rec.wall_seconds.max(1e-9),
    }
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
