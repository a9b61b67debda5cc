//! `sonarnet sweep`: the cartesian product of `--grid` values times the
//! seeds, run in parallel into one directory: `runs/` (one results directory
//! per run), `sweep.csv` (one row per run), `sweep-summary.csv` (mean, std
//! and n per grid point), `sweep.svg` and `report.html`.

use crate::model::error::InputError;
use crate::pipeline::{self, RunError, RunOptions, RunStatus};
use crate::protocol::EngineKind;
use crate::scenario::{AnyScenario, Override, Scenario};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// At most this many runs in one sweep (grid points times seeds).
pub const MAX_RUNS: usize = 100_000;

fn cli_error(flag: &str, reason: impl Into<String>) -> InputError {
    InputError::at(Path::new("<command line>"), flag, reason)
}

/// One `--grid KEY=V1,V2,...` axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The dotted scenario key.
    pub key: String,
    /// Its values, as written (each a TOML value, see [`Override`]).
    pub values: Vec<String>,
}

impl Axis {
    /// Parse `KEY=V1,V2,...`; commas inside brackets, braces or quotes do not
    /// split (`geometry.receivers=[[0,0],[1,1]],[[0,0],[2,2]]` is two values).
    pub fn parse(flag: &str) -> Result<Axis, InputError> {
        let err = |r: String| cli_error(&format!("--grid {flag}"), r);
        let Some((key, rest)) = flag.split_once('=') else {
            return Err(err(
                "expected KEY=V1,V2,... e.g. algorithm.gamma=1e-8,1e-7".into()
            ));
        };
        let mut values = Vec::new();
        let (mut depth, mut quote, mut cur) = (0i32, None::<char>, String::new());
        for c in rest.chars() {
            match (quote, c) {
                (Some(q), c) if c == q => quote = None,
                (Some(_), _) => {}
                (None, '"' | '\'') => quote = Some(c),
                (None, '[' | '{') => depth += 1,
                (None, ']' | '}') => depth -= 1,
                (None, ',') if depth == 0 => {
                    values.push(std::mem::take(&mut cur).trim().to_string());
                    continue;
                }
                _ => {}
            }
            cur.push(c);
        }
        values.push(cur.trim().to_string());
        if values.iter().any(String::is_empty) {
            return Err(err("a value is empty (two commas in a row?)".into()));
        }
        let mut seen = BTreeSet::new();
        if let Some(v) = values.iter().find(|v| !seen.insert(v.as_str())) {
            return Err(err(format!("{v} is listed twice")));
        }
        // Each value must be a valid override on its own (syntax only here;
        // the scenario checks the values).
        for v in &values {
            Override::parse_for("--grid", &format!("{}={v}", key.trim()))?;
        }
        Ok(Axis {
            key: key.trim().to_string(),
            values,
        })
    }
}

/// Parse `--seeds`: `A..B` (A to B inclusive: `0..9` is ten seeds),
/// `A..=B` (the same), or a list `1,5,9`.
pub fn parse_seeds(s: &str) -> Result<Vec<u64>, InputError> {
    let err = |r: String| cli_error("--seeds", format!("`{s}`: {r}"));
    let num = |t: &str| {
        t.trim()
            .parse::<u64>()
            .map_err(|e| err(format!("{:?} is not a seed: {e}", t.trim())))
    };
    let seeds: Vec<u64> = if let Some((a, b)) = s.split_once("..") {
        let (a, b) = (num(a)?, num(b.trim_start_matches('='))?);
        if b < a {
            return Err(err("the range is empty".into()));
        }
        if b - a >= MAX_RUNS as u64 {
            return Err(err(format!("more than {MAX_RUNS} seeds")));
        }
        (a..=b).collect()
    } else {
        s.split(',').map(num).collect::<Result<_, _>>()?
    };
    let mut seen = BTreeSet::new();
    if let Some(d) = seeds.iter().find(|x| !seen.insert(**x)) {
        return Err(err(format!("seed {d} is listed twice")));
    }
    Ok(seeds)
}

/// One grid point: a value per axis, and the variant when the file has
/// several.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// `(key, value)` per axis, in axis order.
    pub values: Vec<(String, String)>,
    /// The scenario's variant, if it has variants.
    pub variant: Option<String>,
}

impl Point {
    /// `key=value, ...` (and `variant=NAME`).
    pub fn label(&self) -> String {
        let mut parts: Vec<String> = self
            .values
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        if let Some(v) = &self.variant {
            parts.push(format!("variant={v}"));
        }
        parts.join(", ")
    }
}

/// What a sweep runs: every grid point's scenario, validated, and the seeds.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// The grid axes.
    pub axes: Vec<Axis>,
    /// Every grid point with its scenario (before the seed is set).
    pub points: Vec<(Point, AnyScenario)>,
    /// The seeds, each run at every point.
    pub seeds: Vec<u64>,
    /// Whether the points carry a variant.
    pub has_variants: bool,
}

impl SweepPlan {
    /// Build and validate every grid point of `file` before any work: `sets`
    /// apply first (`--set`), then the point's values; `variants` picks
    /// variants (empty: all). An error names the `--grid` value to blame.
    pub fn new(
        file: &Path,
        sets: &[Override],
        axes: Vec<Axis>,
        seeds: Vec<u64>,
        variants: &[String],
    ) -> Result<SweepPlan, InputError> {
        let text = crate::scenario::read_scenario_text(file)?;
        Self::of_text(file, &text, sets, axes, seeds, variants)
    }

    /// [`SweepPlan::new`] of scenario text already read (`file` names it
    /// in errors and anchors its relative file names).
    pub fn of_text(
        file: &Path,
        text: &str,
        sets: &[Override],
        axes: Vec<Axis>,
        seeds: Vec<u64>,
        variants: &[String],
    ) -> Result<SweepPlan, InputError> {
        if axes.is_empty() {
            return Err(cli_error(
                "--grid",
                "give at least one --grid KEY=V1,V2,...",
            ));
        }
        let mut keys = BTreeSet::new();
        if let Some(a) = axes.iter().find(|a| !keys.insert(a.key.as_str())) {
            return Err(cli_error(
                "--grid",
                format!("{} has two --grid axes", a.key),
            ));
        }
        let n_points = axes
            .iter()
            .try_fold(1usize, |n, a| n.checked_mul(a.values.len()))
            .filter(|n| n.saturating_mul(seeds.len().max(1)) <= MAX_RUNS)
            .ok_or_else(|| cli_error("--grid", format!("more than {MAX_RUNS} runs")))?;
        let mut points = Vec::new();
        for i in 0..n_points {
            // Mixed radix, the last axis fastest.
            let mut rem = i;
            let mut values = vec![(String::new(), String::new()); axes.len()];
            for (j, a) in axes.iter().enumerate().rev() {
                values[j] = (a.key.clone(), a.values[rem % a.values.len()].clone());
                rem /= a.values.len();
            }
            let mut ov = sets.to_vec();
            for (k, v) in &values {
                ov.push(Override::parse_for("--grid", &format!("{k}={v}"))?);
            }
            let all = AnyScenario::text_with(file, text, &ov, variants)?;
            for v in variants {
                if !all.iter().any(|s| s.variant() == Some(v.as_str())) {
                    return Err(cli_error(
                        "--variant",
                        format!("no variant {v:?} in {}", file.display()),
                    ));
                }
            }
            for sc in all {
                if !variants.is_empty()
                    && !variants.iter().any(|v| sc.variant() == Some(v.as_str()))
                {
                    continue;
                }
                // A sweep draws its own seeds: one run per seed.
                let texts = ov.iter().map(|o| o.text.clone()).collect();
                let sc = match sc {
                    AnyScenario::Plane(sc) => AnyScenario::Plane(for_sweep(sc, texts)),
                    AnyScenario::Space(sc) => AnyScenario::Space(for_sweep(sc, texts)),
                };
                let p = Point {
                    values: values.clone(),
                    variant: sc.variant().map(str::to_owned),
                };
                points.push((p, sc));
            }
        }
        let has_variants = points.iter().any(|(p, _)| p.variant.is_some());
        if points.len().saturating_mul(seeds.len()) > MAX_RUNS {
            return Err(cli_error("--grid", format!("more than {MAX_RUNS} runs")));
        }
        Ok(SweepPlan {
            axes,
            points,
            seeds,
            has_variants,
        })
    }

    /// Number of runs.
    pub fn runs(&self) -> usize {
        self.points.len() * self.seeds.len()
    }
}

/// One finished run of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRun {
    /// Index of its grid point in [`SweepPlan::points`].
    pub point: usize,
    /// Its seed.
    pub seed: u64,
    /// How the run ended.
    pub status: RunStatus,
    /// Every scalar metric ([`pipeline::RunMetrics::flat`]).
    pub metrics: BTreeMap<String, f64>,
    /// `[expect]` checks that held, and all of them.
    pub expect: (usize, usize),
    /// Its results directory.
    pub dir: PathBuf,
}

/// A sweep's results.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// The completed runs, in grid order then seed order.
    pub runs: Vec<SweepRun>,
    /// Whether Ctrl-C/SIGTERM stopped it early.
    pub interrupted: bool,
    /// Runs asked for.
    pub requested: usize,
}

/// Run every point of `plan` at every seed on `engine` with `jobs` runs at
/// once, each into `out/runs/p<point>-seed<seed>`; `on_done(n)` after each.
/// Ctrl-C/SIGTERM stops taking runs; those cut short are left out.
pub fn run_sweep(
    plan: &SweepPlan,
    engine: EngineKind,
    jobs: usize,
    out: &Path,
    on_done: &(dyn Fn(usize) + Sync),
) -> SweepOutcome {
    let tasks: Vec<(usize, u64)> = (0..plan.points.len())
        .flat_map(|p| plan.seeds.iter().map(move |&s| (p, s)))
        .collect();
    let results = super::pool::run_indexed(
        0..tasks.len(),
        jobs,
        |i| {
            let (p, seed) = tasks[i];
            run_one(plan, p, seed, engine, out)
        },
        on_done,
    );
    let runs: Vec<SweepRun> = results
        .into_iter()
        .flatten()
        .filter(|r| r.status != RunStatus::Interrupted)
        .collect();
    SweepOutcome {
        interrupted: crate::engine::interrupt::requested() || runs.len() < tasks.len(),
        requested: tasks.len(),
        runs,
    }
}

/// A grid point's scenario: no Monte Carlo trials (a sweep draws its own
/// seeds), and the overrides that made it.
fn for_sweep<const D: usize>(mut sc: Scenario<D>, overrides: Vec<String>) -> Scenario<D> {
    sc.trials = None;
    sc.overrides = overrides;
    sc
}

fn run_one(plan: &SweepPlan, p: usize, seed: u64, engine: EngineKind, out: &Path) -> SweepRun {
    match &plan.points[p].1 {
        AnyScenario::Plane(sc) => run_point(sc.clone().with_seed(seed), p, engine, out),
        AnyScenario::Space(sc) => run_point(sc.clone().with_seed(seed), p, engine, out),
    }
}

fn run_point<const D: usize>(
    sc: Scenario<D>,
    p: usize,
    engine: EngineKind,
    out: &Path,
) -> SweepRun {
    let seed = sc.seed;
    let dir = out.join("runs").join(format!("p{p:03}-seed{seed}"));
    let opts = RunOptions {
        command_line: std::env::args().collect(),
        ..RunOptions::inprocess()
            .with_engine(engine)
            .with_clock(pipeline::default_clock(&sc))
            .with_out_dir(&dir)
    };
    let failed = |e: String| {
        eprintln!("sweep run p{p:03} seed {seed} failed: {e}");
        SweepRun {
            point: p,
            seed,
            status: RunStatus::Failed,
            metrics: BTreeMap::new(),
            expect: (0, 0),
            dir: dir.clone(),
        }
    };
    if let Err(e) = pipeline::preflight(&sc, &opts) {
        return failed(e.to_string());
    }
    match sc.run_and_write(&opts) {
        Ok(o) => SweepRun {
            point: p,
            seed,
            status: o.metrics.status,
            metrics: o.metrics.flat(),
            expect: (
                o.metrics.expect.iter().filter(|c| c.holds).count(),
                o.metrics.expect.len(),
            ),
            dir,
        },
        Err(e) => failed(e.to_string()),
    }
}

/// The full metric name of `m`: itself if some run has it, else
/// `theta_bar.m` (`rmse_after_burn_in` is `theta_bar.rmse_after_burn_in`).
pub fn metric_key(runs: &[SweepRun], m: &str) -> Option<String> {
    let has = |k: &str| runs.iter().any(|r| r.metrics.contains_key(k));
    if has(m) {
        Some(m.to_string())
    } else if has(&format!("theta_bar.{m}")) {
        Some(format!("theta_bar.{m}"))
    } else {
        None
    }
}

/// Mean, sample standard deviation and count of the finite values.
pub fn mean_std(v: &[f64]) -> (Option<f64>, Option<f64>, usize) {
    let x: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let n = x.len();
    if n == 0 {
        return (None, None, 0);
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let std = (n > 1)
        .then(|| (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt());
    (Some(mean), std, n)
}

/// Per grid point: the point, runs ok, runs failed, and per metric
/// `(mean, std, n)`.
pub type Summary = Vec<(
    usize,
    usize,
    usize,
    BTreeMap<String, (Option<f64>, Option<f64>, usize)>,
)>;

/// Summarise `runs` per grid point of `plan`.
pub fn summarise(plan: &SweepPlan, runs: &[SweepRun]) -> Summary {
    let names: BTreeSet<&String> = runs.iter().flat_map(|r| r.metrics.keys()).collect();
    (0..plan.points.len())
        .map(|p| {
            let here: Vec<&SweepRun> = runs.iter().filter(|r| r.point == p).collect();
            let ok = here.iter().filter(|r| r.status == RunStatus::Ok).count();
            let stats = names
                .iter()
                .map(|m| {
                    let v: Vec<f64> = here
                        .iter()
                        .filter(|r| r.status == RunStatus::Ok)
                        .filter_map(|r| r.metrics.get(*m).copied())
                        .collect();
                    ((*m).clone(), mean_std(&v))
                })
                .collect();
            (p, ok, here.len() - ok, stats)
        })
        .collect()
}

fn num(x: Option<f64>) -> String {
    x.map(|v| format!("{v:?}")).unwrap_or_default()
}

/// Write `sweep.csv` and `sweep-summary.csv` into `out`.
pub fn write_tables(plan: &SweepPlan, o: &SweepOutcome, out: &Path) -> Result<(), RunError> {
    let metrics: Vec<String> = o
        .runs
        .iter()
        .flat_map(|r| r.metrics.keys().cloned())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let mut head: Vec<String> = vec!["point".into()];
    head.extend(plan.axes.iter().map(|a| a.key.clone()));
    if plan.has_variants {
        head.push("variant".into());
    }
    let mut runs_head = head.clone();
    runs_head.extend(["seed", "status", "expect_held", "expect_total"].map(String::from));
    runs_head.extend(metrics.iter().cloned());
    runs_head.push("dir".into());
    let point_cells = |p: usize| {
        let (pt, _) = &plan.points[p];
        let mut row = vec![p.to_string()];
        row.extend(pt.values.iter().map(|(_, v)| v.clone()));
        if plan.has_variants {
            row.push(pt.variant.clone().unwrap_or_default());
        }
        row
    };
    let rh = &runs_head;
    pipeline::write_csv(
        &out.join("sweep.csv"),
        &rh.iter().map(String::as_str).collect::<Vec<_>>(),
        o.runs.iter().map(|r| {
            let mut row = point_cells(r.point);
            row.extend([
                r.seed.to_string(),
                r.status.to_string(),
                r.expect.0.to_string(),
                r.expect.1.to_string(),
            ]);
            row.extend(metrics.iter().map(|m| num(r.metrics.get(m).copied())));
            let rel = r.dir.strip_prefix(out).unwrap_or(&r.dir);
            row.push(rel.display().to_string());
            row
        }),
    )?;
    let summary = summarise(plan, &o.runs);
    let mut sum_head = head;
    sum_head.extend(["n", "failed"].map(String::from));
    for m in &metrics {
        sum_head.push(format!("{m}.mean"));
        sum_head.push(format!("{m}.std"));
    }
    pipeline::write_csv(
        &out.join("sweep-summary.csv"),
        &sum_head.iter().map(String::as_str).collect::<Vec<_>>(),
        summary.iter().map(|(p, ok, failed, stats)| {
            let mut row = point_cells(*p);
            row.extend([ok.to_string(), failed.to_string()]);
            for m in &metrics {
                let (mean, std, _) = stats.get(m).copied().unwrap_or((None, None, 0));
                row.push(num(mean));
                row.push(num(std));
            }
            row
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_values_split_at_top_level_commas_only() {
        let a = Axis::parse("geometry.receivers=[[0,0],[1,1]], [[0,0],[2,2]]").unwrap();
        assert_eq!(a.values, vec!["[[0,0],[1,1]]", "[[0,0],[2,2]]"]);
        let a = Axis::parse("algorithm.gamma=1e-9,1e-8,1e-7").unwrap();
        assert_eq!(a.values.len(), 3);
        let a = Axis::parse("name='a,b',c").unwrap();
        assert_eq!(a.values, vec!["'a,b'", "c"]);
        for bad in ["algorithm.gamma", "algorithm.gamma=1,,2", "x=1,1", "x=[1"] {
            let e = Axis::parse(bad).unwrap_err().to_string();
            assert!(e.contains("--grid"), "{bad}: {e}");
        }
    }

    #[test]
    fn seed_ranges_are_inclusive_and_lists_are_kept_in_order() {
        assert_eq!(parse_seeds("0..9").unwrap(), (0..10).collect::<Vec<_>>());
        assert_eq!(parse_seeds("3..=5").unwrap(), vec![3, 4, 5]);
        assert_eq!(parse_seeds("9,1,5").unwrap(), vec![9, 1, 5]);
        for bad in ["5..1", "a..b", "1,1", "0..1000000", "-1"] {
            assert!(parse_seeds(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn mean_and_std_match_the_textbook_values() {
        let (m, s, n) = mean_std(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        approx::assert_relative_eq!(m.unwrap(), 5.0);
        // Sample std (n - 1): sqrt(32 / 7).
        approx::assert_relative_eq!(s.unwrap(), (32.0f64 / 7.0).sqrt(), max_relative = 1e-15);
        assert_eq!(n, 8);
        assert_eq!(mean_std(&[f64::NAN, 1.0]), (Some(1.0), None, 1));
        assert_eq!(mean_std(&[]), (None, None, 0));
    }
}
