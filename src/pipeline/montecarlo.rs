//! Monte Carlo: the same scenario over seeds `seed .. seed + trials`, in
//! parallel across cores, in-process.
//!
//! Trial `i` is exactly the single run `sonarnet run --seed (seed + i)`
//! (in-process engine): same measurements, schedule, baselines and bounds.
//! Outputs in the results directory:
//!
//! * `trials.csv`: `trial,seed,failed,<metric columns>`, one row per trial
//!   (`failed` is 1 for a trial whose engine stopped early);
//!   the columns are the flat metric names of [`crate::pipeline::RunMetrics::flat`]
//!   (`theta_bar.rmse`, `ogd.ctte`, `pocs.bounds.upp_maxdis.coverage`, ...);
//! * `summary.json`: `status` (`ok`, or `interrupted` when Ctrl-C/SIGTERM
//!   stopped the run: then `trials.csv` and the statistics cover the
//!   completed trials only, `trials` of `trials_requested`), `trials`, `seeds`, per-sample mean and 5th/95th
//!   percentile curves of every track's error, running CTTE and regret
//!   (format in [`crate::plot::data::MonteCarlo`]; at most
//!   [`MAX_CURVE_POINTS`] samples, evenly strided, are kept), the CRLB band,
//!   per-metric statistics (`n, mean, rms, std, min, p5, p10, p25, median,
//!   p75, p80, p90, p95, max`) and the `[expect]` checks;
//! * trial 0's full single-run outputs (`track.csv`, `nodes.csv`,
//!   `metrics.json`, ...), so the track plots have a representative trial.

use crate::model::metrics;
use crate::pipeline::{
    self, Band, ExpectResult, McSummary, RunError, RunOptions, RunStatus, TrackBands,
};
use crate::scenario::Scenario;
use std::collections::BTreeMap;
use std::time::Instant;

/// Most samples kept per curve in `summary.json`.
pub const MAX_CURVE_POINTS: usize = 1000;

/// Curves of one track in one trial, at the kept sample indices.
#[derive(Debug, Clone, Default)]
struct Curves {
    error: Vec<Option<f64>>,
    ctte: Option<Vec<f64>>,
    regret: Option<Vec<f64>>,
}

/// One trial's result.
#[derive(Debug, Clone)]
pub struct Trial {
    /// Trial index.
    pub trial: usize,
    /// Its seed.
    pub seed: u64,
    /// How the trial ended.
    pub status: RunStatus,
    /// Why it failed.
    pub error: Option<String>,
    /// Flat metrics.
    pub flat: BTreeMap<String, f64>,
    curves: Vec<(String, Curves)>,
    crlb: Vec<Option<f64>>,
}

/// What a Monte Carlo run produced.
#[derive(Debug, Clone)]
pub struct MonteCarloOutcome {
    /// Every trial, in trial order.
    pub trials: Vec<Trial>,
    /// Mean (and other statistics) of every metric: `name -> stats`.
    pub stats: BTreeMap<String, BTreeMap<&'static str, f64>>,
    /// The `[expect]` checks on the means.
    pub expect: Vec<ExpectResult>,
    /// Trials that failed.
    pub failed: usize,
    /// SIGINT/SIGTERM stopped the run: `trials` holds the completed trials
    /// only (a trial cut short is left out).
    pub interrupted: bool,
    /// Trials asked for.
    pub requested: usize,
    /// Wall time of all trials.
    pub wall_seconds: f64,
    /// Where the results are.
    pub out_dir: std::path::PathBuf,
}

fn kept_indices(samples: usize) -> Vec<usize> {
    let stride = samples.div_ceil(MAX_CURVE_POINTS).max(1);
    let mut idx: Vec<usize> = (0..samples).step_by(stride).collect();
    if samples > 0 && idx.last() != Some(&(samples - 1)) {
        idx.push(samples - 1);
    }
    idx
}

fn trial_of<const D: usize>(
    i: usize,
    seed: u64,
    out: &pipeline::Outcome<D>,
    idx: &[usize],
) -> Trial {
    let (m, scored) = (&out.metrics, &out.scored);
    let mut flat = m.flat();
    // One snapshot per trial: each track's error vector (estimate - truth,
    // m), for the scatter of the estimates around the truth.
    if m.samples == 1 {
        let truth = out.real.truth.as_ref().and_then(|t| t.first());
        for t in &scored.tracks {
            if let (Some(Some(e)), Some(x)) = (t.est.first(), truth) {
                for (i, axis) in ["x", "y", "z"].iter().enumerate().take(D) {
                    flat.insert(format!("{}.error_{axis}", t.name), e[i] - x[i]);
                }
            }
        }
    }
    let curves = scored
        .tracks
        .iter()
        .map(|t| {
            // A trial that stopped early has fewer samples: its curves end
            // there (a missing point is left out of the bands).
            let pick = |v: &Vec<f64>| {
                idx.iter()
                    .map_while(|&k| v.get(k).copied())
                    .collect::<Vec<_>>()
            };
            (
                t.name.clone(),
                Curves {
                    error: t
                        .error
                        .as_ref()
                        .map(|e| idx.iter().map(|&k| e.get(k).copied().flatten()).collect())
                        .unwrap_or_default(),
                    ctte: t.ctte.as_ref().map(pick),
                    regret: t.regret.as_ref().map(pick),
                },
            )
        })
        .collect();
    Trial {
        trial: i,
        seed,
        status: m.status,
        error: m.error.clone(),
        flat,
        curves,
        crlb: idx
            .iter()
            .map(|&k| scored.crlb.get(k).copied().flatten())
            .collect(),
    }
}

/// Statistics of a metric across trials.
pub fn stats(values: &[f64]) -> BTreeMap<&'static str, f64> {
    let mut out = BTreeMap::new();
    if values.is_empty() {
        return out;
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0).max(1.0);
    out.insert("n", n);
    out.insert("mean", mean);
    // Root mean square across trials: for one-sample trials `NAME.rmse.rms`
    // is the RMSE over trials that Shi 2024 and Gholami 2015 report.
    out.insert(
        "rms",
        (values.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
    );
    out.insert("std", var.sqrt());
    for (k, q) in [
        ("min", 0.0),
        ("p5", 0.05),
        ("p10", 0.1),
        ("p25", 0.25),
        ("median", 0.5),
        ("p75", 0.75),
        ("p80", 0.8),
        ("p90", 0.9),
        ("p95", 0.95),
        ("max", 1.0),
    ] {
        if let Some(v) = metrics::quantile(values, q) {
            out.insert(k, v);
        }
    }
    out
}

/// Resolve a metric name of an `[expect]` relation against the trial
/// statistics: `NAME` is the mean, `NAME.median` (`.p5`, `.p95`, `.min`,
/// `.max`, `.std`, ...) another statistic.
pub fn lookup(
    stats: &BTreeMap<String, BTreeMap<&'static str, f64>>,
    name: &str,
) -> Result<f64, String> {
    if let Some(s) = stats.get(name) {
        return s
            .get("mean")
            .copied()
            .ok_or_else(|| format!("{name:?} has no value in any trial"));
    }
    if let Some((base, stat)) = name.rsplit_once('.')
        && let Some(s) = stats.get(base)
    {
        return s.get(stat).copied().ok_or_else(|| {
            format!("no statistic {stat:?} of {base:?} (mean, rms, std, min, p5, p10, p25, median, p75, p80, p90, p95, max)")
        });
    }
    Err(pipeline::unknown_metric(name, stats.keys()))
}

fn band(columns: Vec<Vec<f64>>) -> Band {
    Band {
        mean: columns
            .iter()
            .map(|c| (!c.is_empty()).then(|| c.iter().sum::<f64>() / c.len() as f64))
            .collect(),
        p5: columns.iter().map(|c| metrics::quantile(c, 0.05)).collect(),
        p95: columns.iter().map(|c| metrics::quantile(c, 0.95)).collect(),
    }
}

/// Run `trials` trials of `sc` (seeds `sc.seed + i`) on all cores, write the
/// Monte Carlo outputs into `opts.out_dir`, and check `[expect]` on the means.
/// `on_trial(done)` is called after every finished trial (progress).
pub fn run_monte_carlo<const D: usize>(
    sc: &Scenario<D>,
    trials: usize,
    opts: &RunOptions,
    on_trial: &(dyn Fn(usize) + Sync),
) -> Result<MonteCarloOutcome, RunError> {
    let start = Instant::now();
    let idx = kept_indices(sc.samples);
    // Trial 0 writes the representative single-run outputs.
    let rep_opts = RunOptions {
        check_expect: false,
        ..opts.clone()
    };
    let out0 = sc.run_and_write(&rep_opts)?;
    let first = trial_of(0, sc.seed, &out0, &idx);
    on_trial(1);

    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rest = super::pool::run_indexed(
        1..trials,
        threads,
        |i| {
            let seed = sc.seed.wrapping_add(i as u64);
            let out = sc.clone().with_seed(seed).run(&rep_opts);
            trial_of(i, seed, &out, &idx)
        },
        on_trial,
    );
    // A trial cut short by Ctrl-C/SIGTERM is not a completed trial: it is
    // left out, and the run is marked interrupted.
    let all: Vec<Trial> = std::iter::once(first)
        .chain(rest.into_iter().flatten())
        .collect();
    let interrupted = crate::engine::interrupt::requested()
        || all.iter().any(|t| t.status == RunStatus::Interrupted);
    let trials_out: Vec<Trial> = all
        .into_iter()
        .filter(|t| t.status != RunStatus::Interrupted)
        .collect();
    let run = McRun {
        requested: trials,
        interrupted,
        wall_seconds: start.elapsed().as_secs_f64(),
    };
    write_outputs(sc, &trials_out, &idx, opts, &run)
}

/// How the trials went, for the summary.
struct McRun {
    requested: usize,
    interrupted: bool,
    wall_seconds: f64,
}

/// Write `trials.csv` (a row per trial: its seed, whether it failed, and
/// every metric); the metric columns.
fn write_trials_csv(path: &std::path::Path, trials: &[Trial]) -> Result<Vec<String>, RunError> {
    let mut cols: Vec<String> = trials
        .iter()
        .flat_map(|t| t.flat.keys().cloned())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    cols.retain(|c| !c.is_empty());
    let mut header: Vec<&str> = vec!["trial", "seed", "failed"];
    header.extend(cols.iter().map(String::as_str));
    pipeline::write_csv(
        path,
        &header,
        trials.iter().map(|t| {
            let mut row = vec![
                t.trial.to_string(),
                t.seed.to_string(),
                u8::from(t.status != RunStatus::Ok).to_string(),
            ];
            row.extend(
                cols.iter()
                    .map(|c| t.flat.get(c).map(|v| format!("{v:?}")).unwrap_or_default()),
            );
            row
        }),
    )?;
    Ok(cols)
}

/// Every track's bands across trials (error, CTTE, regret) at each of the
/// `samples` recorded samples, in the track order of trial 0, and the
/// CRLB's band.
fn curve_bands(trials: &[Trial], samples: usize) -> (BTreeMap<String, TrackBands>, Option<Band>) {
    // Curves: track order of trial 0.
    let names: Vec<String> = trials
        .first()
        .map(|t| t.curves.iter().map(|(n, _)| n.clone()).collect())
        .unwrap_or_default();
    let mut curves = BTreeMap::new();
    for (ti, name) in names.iter().enumerate() {
        let per = |f: &dyn Fn(&Curves, usize) -> Option<f64>| -> Option<Band> {
            let cols: Vec<Vec<f64>> = (0..samples)
                .map(|j| {
                    trials
                        .iter()
                        .filter_map(|t| t.curves.get(ti).and_then(|(_, c)| f(c, j)))
                        .collect()
                })
                .collect();
            cols.iter().any(|c| !c.is_empty()).then(|| band(cols))
        };
        let bands = TrackBands {
            error: per(&|c, j| c.error.get(j).copied().flatten()),
            ctte: per(&|c, j| c.ctte.as_ref().and_then(|v| v.get(j).copied())),
            regret: per(&|c, j| c.regret.as_ref().and_then(|v| v.get(j).copied())),
        };
        curves.insert(name.clone(), bands);
    }
    let crlb_cols: Vec<Vec<f64>> = (0..samples)
        .map(|j| {
            trials
                .iter()
                .filter_map(|t| t.crlb.get(j).copied().flatten())
                .collect()
        })
        .collect();
    let crlb = crlb_cols
        .iter()
        .any(|c| !c.is_empty())
        .then(|| band(crlb_cols));
    (curves, crlb)
}

fn write_outputs<const D: usize>(
    sc: &Scenario<D>,
    trials: &[Trial],
    idx: &[usize],
    opts: &RunOptions,
    run: &McRun,
) -> Result<MonteCarloOutcome, RunError> {
    let wall_seconds = run.wall_seconds;
    let dir = &opts.out_dir;
    let cols = write_trials_csv(&dir.join("trials.csv"), trials)?;
    // Statistics.
    let stats_map: BTreeMap<String, BTreeMap<&'static str, f64>> = cols
        .iter()
        .map(|c| {
            let v: Vec<f64> = trials
                .iter()
                .filter_map(|t| t.flat.get(c).copied())
                .collect();
            (c.clone(), stats(&v))
        })
        .collect();
    let failed = trials.iter().filter(|t| t.status != RunStatus::Ok).count();
    let expect =
        pipeline::expect_results(crate::scenario::expect::check(&sc.expect, &|n: &str| {
            lookup(&stats_map, n)
        }));
    let (curves, crlb) = curve_bands(trials, idx.len());
    let summary = McSummary {
        status: Some(if run.interrupted {
            RunStatus::Interrupted
        } else {
            RunStatus::Ok
        }),
        trials_requested: Some(run.requested as u64),
        trials: Some(trials.len() as u64),
        failed_trials: Some(failed),
        first_failure: trials.iter().find_map(|t| t.error.clone()),
        seeds: Some([
            sc.seed,
            sc.seed.wrapping_add(trials.len().saturating_sub(1) as u64),
        ]),
        seed: Some(sc.seed),
        scenario: Some(sc.name.clone()),
        variant: sc.variant.clone(),
        engine: Some("inprocess".into()),
        mode: Some(sc.algorithm.mode.as_str().into()),
        samples: Some(sc.samples),
        wall_seconds: Some(wall_seconds),
        command_line: opts.command_line.clone(),
        sample: idx.to_vec(),
        curves,
        crlb,
        metrics: stats_map
            .iter()
            .map(|(k, s)| {
                let s = s.iter().map(|(stat, v)| (stat.to_string(), Some(*v)));
                (k.clone(), s.collect())
            })
            .collect(),
        expect: expect.clone(),
    };
    pipeline::write_json(&dir.join("summary.json"), &summary)?;
    Ok(MonteCarloOutcome {
        trials: trials.to_vec(),
        stats: stats_map,
        expect,
        failed,
        interrupted: run.interrupted,
        requested: run.requested,
        wall_seconds,
        out_dir: dir.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn long_runs_keep_at_most_max_curve_points_including_the_last_sample() {
        let idx = kept_indices(10_000);
        assert!(idx.len() <= MAX_CURVE_POINTS + 1);
        assert_eq!(idx[0], 0);
        assert_eq!(*idx.last().unwrap(), 9_999);
        assert_eq!(kept_indices(7), vec![0, 1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn statistics_and_lookup_give_means_by_default_and_named_quantiles() {
        let s = stats(&[1.0, 2.0, 3.0, 4.0, 10.0]);
        assert_relative_eq!(s["mean"], 4.0);
        assert_relative_eq!(s["median"], 3.0);
        assert_relative_eq!(s["max"], 10.0);
        let mut m = BTreeMap::new();
        m.insert("ogd.ctte".to_string(), s);
        assert_relative_eq!(lookup(&m, "ogd.ctte").unwrap(), 4.0);
        assert_relative_eq!(lookup(&m, "ogd.ctte.median").unwrap(), 3.0);
        assert!(lookup(&m, "ogd.ctte.p42").is_err());
        assert!(lookup(&m, "onm.ctte").unwrap_err().contains("onm"));
    }
}
