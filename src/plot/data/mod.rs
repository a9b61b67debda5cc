//! Reading a results directory into plain data structs ([`RunData`]).
//!
//! The loader is the only part of the plotting code that touches files; the
//! figure builders take these structs, so they are unit-testable.

mod json;
mod tables;
pub use json::{parse_run_json, parse_summary};
pub use tables::{Csv, MessageRow, parse_messages, parse_node_points, parse_track_csv, read_csv};

/// The distance between two positions of a `dim`-dimensional run.
pub fn distance(a: &Pos, b: &Pos, dim: usize) -> f64 {
    if dim == 3 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    } else {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }
}

use crate::model::error::InputError;
use crate::pipeline::{NodeCounters, RunJson, RunMetrics};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A position `[x, y, z]` in metres; `z` is 0 in a 2-D run
/// ([`RunInfo::dim`]).
pub type Pos = [f64; 3];

/// Name of the distributed estimate `theta_bar` in track lists and in
/// `summary.json` curves.
pub const THETA_BAR: &str = "theta_bar";
/// Name of the centralised ML reference in track lists and in `summary.json`.
pub const ML: &str = "ml";

/// What a track is, which decides its style and legend text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackKind {
    /// The distributed estimate `theta_bar = mean_i theta_i[0:2]` (Mourya 2017).
    Distributed,
    /// The centralised maximum-likelihood reference.
    Reference,
    /// A baseline tracker (`NAME_x,NAME_y,...` columns of `track.csv`).
    Baseline,
}

/// One estimated track of `track.csv`, with its per-sample error series.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// `theta_bar`, `ml` or the baseline's NAME.
    pub name: String,
    /// Kind of track.
    pub kind: TrackKind,
    /// Estimated position per row (`None` where the cell is empty).
    pub pos: Vec<Option<Pos>>,
    /// Error `||x_k - x_k*||` per row (m): the `error`/`NAME_error` column,
    /// else computed from the truth.
    pub error: Vec<Option<f64>>,
    /// Running CTTE per row (m, Pun-So 2022 Sec. II): the `ctte`/`NAME_ctte`
    /// column, else the running sum of `error`.
    pub ctte: Vec<Option<f64>>,
    /// Running dynamic regret (Pun-So 2020), when the column exists.
    pub regret: Option<Vec<Option<f64>>>,
}

impl Track {
    /// The legend text.
    pub fn label(&self) -> String {
        match self.kind {
            TrackKind::Distributed => "distributed estimate".to_string(),
            TrackKind::Reference => "centralised ML".to_string(),
            TrackKind::Baseline => self.name.clone(),
        }
    }
}

/// A per-sample bound on the error of the distributed estimate
/// (`bound_NAME` column of `track.csv`: a radius in m, empty when the set
/// was empty).
#[derive(Debug, Clone, PartialEq)]
pub struct BoundSeries {
    /// NAME of `bound_NAME`.
    pub name: String,
    /// Certified radius per row.
    pub radius: Vec<Option<f64>>,
}

/// `track.csv`, split into generic tracks.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrackTable {
    /// Sample index per row.
    pub sample: Vec<f64>,
    /// True position per row, when known.
    pub truth: Vec<Option<Pos>>,
    /// 3 when `track.csv` has `z` columns (`true_z`, `est_z`, ...), else 2.
    pub dim: usize,
    /// Every estimated track: `theta_bar` first, then `ml`, then baselines in
    /// column order.
    pub tracks: Vec<Track>,
    /// Per-sample CRLB `sqrt(trace(J^-1))` (m), when present.
    pub crlb: Vec<Option<f64>>,
    /// Bounds on the distributed estimate.
    pub bounds: Vec<BoundSeries>,
}

impl TrackTable {
    /// The track called `name`.
    pub fn track(&self, name: &str) -> Option<&Track> {
        self.tracks.iter().find(|t| t.name == name)
    }
}

/// One row of `nodes.csv` or `iterations.csv`: a node's `theta` at a sample
/// (and, for `iterations.csv`, after an iteration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodePoint {
    /// Sample index.
    pub sample: usize,
    /// Iteration index (`iterations.csv` only).
    pub iteration: Option<u64>,
    /// Node id.
    pub node: usize,
    /// The node's position estimate (`theta` without `d`).
    pub pos: Pos,
}

/// A run's `run.json` ([`RunJson`]) with the facts the plots and the report
/// derive from it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunInfo {
    /// `run.json` as written.
    pub run: RunJson,
    /// Scenario name (the directory's name when the scenario has none).
    pub name: String,
    /// Scenario description.
    pub description: Option<String>,
    /// 2 or 3: the dimension of the scenario's points.
    pub dim: usize,
    /// Transmitter positions (m).
    pub transmitters: Vec<Pos>,
    /// Receiver (node) positions (m).
    pub receivers: Vec<Pos>,
    /// Network edges.
    pub edges: Vec<(usize, usize)>,
    /// Samples excluded from `rmse_after_burn_in`.
    pub burn_in: Option<usize>,
}

/// A mean curve with its 5th-95th percentile band across Monte Carlo trials.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BandCurve {
    /// Mean across trials per sample.
    pub mean: Vec<Option<f64>>,
    /// 5th percentile per sample.
    pub p5: Vec<Option<f64>>,
    /// 95th percentile per sample.
    pub p95: Vec<Option<f64>>,
}

/// The curves of one track in `summary.json`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrackCurves {
    /// Track name (`theta_bar`, `ml` or a baseline NAME).
    pub name: String,
    /// Error per sample.
    pub error: Option<BandCurve>,
    /// Running CTTE per sample.
    pub ctte: Option<BandCurve>,
    /// Running dynamic regret per sample.
    pub regret: Option<BandCurve>,
}

/// A Monte Carlo run: `trials.csv` and `summary.json`.
///
/// `summary.json` is specified as follows (the report reads exactly this;
/// unknown keys are ignored):
///
/// ```json
/// {
///   "trials": 200,
///   "sample": [0, 1, 2],
///   "curves": {
///     "theta_bar": {
///       "error":  {"mean": [..], "p5": [..], "p95": [..]},
///       "ctte":   {"mean": [..], "p5": [..], "p95": [..]},
///       "regret": {"mean": [..], "p5": [..], "p95": [..]}
///     },
///     "ml":   {"error": {..}, "ctte": {..}},
///     "NAME": {"error": {..}, "ctte": {..}}
///   },
///   "crlb": {"mean": [..], "p5": [..], "p95": [..]}
/// }
/// ```
///
/// * `trials`: number of trials (integer).
/// * `sample`: the sample indices `k` of the curves, increasing.
/// * `curves`: one object per track, keyed `theta_bar` (the distributed
///   estimate), `ml` (the centralised ML reference) or a baseline's NAME as in
///   `track.csv`. Each of `error` (`||x_k - x_k*||`, m), `ctte` (running
///   `sum_{j<=k} ||x_j - x_j*||`, m, Pun-So 2022) and `regret` (running dynamic
///   regret, Pun-So 2020) is optional.
/// * Every curve is `{"mean", "p5", "p95"}`: the mean and the 5th and 95th
///   percentiles across trials at each sample (percentiles with linear
///   interpolation, as `metrics::quantile`). Every array has the length of
///   `sample`; an entry is a number or `null` (undefined at that sample).
/// * `crlb` (optional): the per-sample CRLB `sqrt(trace(J^-1))` across trials.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MonteCarlo {
    /// Number of trials (`summary.json` `trials`).
    pub trials: Option<u64>,
    /// Sample indices of the curves.
    pub sample: Vec<f64>,
    /// Curves per track: `theta_bar`, `ml`, then the others by name.
    pub curves: Vec<TrackCurves>,
    /// CRLB across trials.
    pub crlb: Option<BandCurve>,
    /// `trials.csv` header (`trial,seed,<metric columns>`).
    pub trial_columns: Vec<String>,
    /// `trials.csv` rows (empty cells are `None`).
    pub trial_rows: Vec<Vec<Option<f64>>>,
}

/// Everything the plots and the report read from a results directory.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunData {
    /// The results directory.
    pub dir: PathBuf,
    /// `run.json`.
    pub info: RunInfo,
    /// `metrics.json` (absent in a Monte Carlo directory without one).
    pub metrics: Option<RunMetrics>,
    /// `track.csv` (empty when absent in a Monte Carlo directory).
    pub track: TrackTable,
    /// `nodes.csv`: every node's `theta` after every sample.
    pub nodes: Vec<NodePoint>,
    /// `iterations.csv` (written by `--trace-iterations`), when present.
    pub iterations: Option<Vec<NodePoint>>,
    /// Monte Carlo outputs, when present.
    pub monte_carlo: Option<MonteCarlo>,
    /// `messages.csv` (the acoustic channel), when present.
    pub messages: Option<Vec<MessageRow>>,
    /// `receivers.csv` (receivers that drift), when present: every
    /// receiver's position at every sample.
    pub receivers: Option<Vec<NodePoint>>,
}

impl RunData {
    /// 3 for a 3-D run (its scenario's points or `track.csv` have a `z`),
    /// else 2.
    pub fn dim(&self) -> usize {
        if self.info.dim == 3 || self.track.dim == 3 {
            3
        } else {
            2
        }
    }

    /// The path of every receiver that moves during the run
    /// (`receivers.csv`), in sample order: `(receiver, positions)`.
    pub fn drift_paths(&self) -> Vec<(usize, Vec<Pos>)> {
        let Some(rows) = &self.receivers else {
            return Vec::new();
        };
        let mut by_node: std::collections::BTreeMap<usize, Vec<(usize, Pos)>> =
            std::collections::BTreeMap::new();
        for r in rows {
            by_node.entry(r.node).or_default().push((r.sample, r.pos));
        }
        by_node
            .into_iter()
            .filter_map(|(n, mut pts)| {
                pts.sort_by_key(|p| p.0);
                let path: Vec<Pos> = pts.into_iter().map(|p| p.1).collect();
                let moves = path.windows(2).any(|w| distance(&w[0], &w[1], 3) > 0.0);
                moves.then_some((n, path))
            })
            .collect()
    }

    /// Per-node counters of `metrics.json` (`nodes` array).
    pub fn node_counters(&self) -> &[NodeCounters] {
        self.metrics.as_ref().map_or(&[], |m| &m.nodes)
    }

    /// A short name of the run for titles: `<name> (<mode>, <engine>, seed <seed>)`.
    pub fn title(&self) -> String {
        let mut parts = Vec::new();
        if let Some(m) = &self.info.run.mode {
            parts.push(m.clone());
        }
        if let Some(e) = &self.info.run.engine {
            parts.push(e.clone());
        }
        match (&self.monte_carlo, self.info.run.seed) {
            // A Monte Carlo run has many seeds: name the first.
            (Some(mc), Some(s)) => parts.push(match mc.trials {
                Some(n) if n > 1 => format!("seeds {s}..{}", s.wrapping_add(n - 1)),
                _ => format!("seed {s}"),
            }),
            (None, Some(s)) => parts.push(format!("seed {s}")),
            _ => {}
        }
        if parts.is_empty() {
            self.info.name.clone()
        } else {
            format!("{} ({})", self.info.name, parts.join(", "))
        }
    }
}

/// Read a results directory. A directory without `run.json` is not a run; a
/// single run also needs `metrics.json`, `track.csv` and `nodes.csv`; a Monte
/// Carlo directory (`summary.json` present) needs `trials.csv`, and its
/// `track.csv`/`nodes.csv`/`metrics.json`, if present, are read as those of a
/// representative trial. `iterations.csv` is read when present.
pub fn load_run(dir: &Path) -> Result<RunData, InputError> {
    if !dir.exists() {
        return Err(InputError::file(dir, "no such directory"));
    }
    if !dir.is_dir() {
        return Err(InputError::file(
            dir,
            "not a directory (expected a sonarnet results directory)",
        ));
    }
    let run_json = dir.join("run.json");
    if !run_json.is_file() {
        return Err(InputError::file(
            dir,
            "not a sonarnet results directory: it has no run.json",
        ));
    }
    let info = parse_run_json(&run_json, &read_json(&run_json)?)?;
    let summary = dir.join("summary.json");
    let is_mc = summary.is_file();
    let need = |name: &str| -> Result<Option<PathBuf>, InputError> {
        let p = dir.join(name);
        if p.is_file() {
            Ok(Some(p))
        } else if is_mc {
            Ok(None)
        } else {
            Err(InputError::file(
                &p,
                "missing file: a sonarnet results directory has run.json, metrics.json, track.csv and nodes.csv",
            ))
        }
    };
    let metrics = match need("metrics.json")? {
        Some(p) => match read_json(&p)? {
            v @ Value::Object(_) => Some(RunMetrics::from_json(v).map_err(|e| {
                InputError::file(&p, format!("not the metrics of a sonarnet run: {e}"))
            })?),
            _ => return Err(InputError::file(&p, "expected a JSON object")),
        },
        None => None,
    };
    let track = match need("track.csv")? {
        Some(p) => parse_track_csv(&p, &read_csv(&p)?)?,
        None => TrackTable::default(),
    };
    let nodes = match need("nodes.csv")? {
        Some(p) => parse_node_points(&p, &read_csv(&p)?, false)?,
        None => Vec::new(),
    };
    let it = dir.join("iterations.csv");
    let iterations = if it.is_file() {
        Some(parse_node_points(&it, &read_csv(&it)?, true)?)
    } else {
        None
    };
    let rx = dir.join("receivers.csv");
    let receivers = if rx.is_file() {
        Some(parse_node_points(&rx, &read_csv(&rx)?, false)?)
    } else {
        None
    };
    let msgs = dir.join("messages.csv");
    let messages = if msgs.is_file() {
        Some(parse_messages(&msgs, &read_csv(&msgs)?)?)
    } else {
        None
    };
    let monte_carlo = if is_mc {
        let trials = dir.join("trials.csv");
        if !trials.is_file() {
            return Err(InputError::file(
                &trials,
                "missing file: a Monte Carlo results directory (with summary.json) has trials.csv",
            ));
        }
        let mut mc = parse_summary(&summary, &read_json(&summary)?)?;
        let t = read_csv(&trials)?;
        mc.trial_columns = t.header.clone();
        mc.trial_rows = t
            .rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                r.iter()
                    .enumerate()
                    .map(|(j, c)| t.cell(&trials, i, j, c))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<_, _>>()?;
        Some(mc)
    } else {
        None
    };
    Ok(RunData {
        dir: dir.to_path_buf(),
        info,
        metrics,
        track,
        nodes,
        iterations,
        monte_carlo,
        messages,
        receivers,
    })
}

fn read_json(p: &Path) -> Result<Value, InputError> {
    let text = crate::model::error::read_text_at_most(p, 16 << 20, "results JSON")?;
    serde_json::from_str(&text).map_err(|e| {
        InputError::at(
            p,
            format!("line {}", e.line()),
            format!("invalid JSON: {e}"),
        )
    })
}
