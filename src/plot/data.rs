//! Reading a results directory into plain data structs ([`RunData`]).
//!
//! The loader is the only part of the plotting code that touches files; the
//! figure builders take these structs, so they are unit-testable.

use crate::model::error::InputError;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Name of the distributed estimate `theta_bar` in track lists and in
/// `summary.json` curves.
pub const THETA_BAR: &str = "theta_bar";
/// Name of the centralised ML reference in track lists and in `summary.json`.
pub const ML: &str = "ml";

/// What a track is, which decides its style and legend text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackKind {
    /// The distributed estimate `theta_bar = mean_i theta_i[0:2]` (seed 002).
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
    pub pos: Vec<Option<[f64; 2]>>,
    /// Error `||x_k - x_k*||` per row (m): the `error`/`NAME_error` column,
    /// else computed from the truth.
    pub error: Vec<Option<f64>>,
    /// Running CTTE per row (m, seed 000 Sec. II): the `ctte`/`NAME_ctte`
    /// column, else the running sum of `error`.
    pub ctte: Vec<Option<f64>>,
    /// Running dynamic regret (seed 001), when the column exists.
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
    pub truth: Vec<Option<[f64; 2]>>,
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
    /// `theta[0:2]`.
    pub pos: [f64; 2],
}

/// Facts from `run.json` used by the plots and the report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunInfo {
    /// Scenario name.
    pub name: String,
    /// Scenario description.
    pub description: Option<String>,
    /// The scenario file.
    pub scenario_file: Option<String>,
    /// Run seed.
    pub seed: Option<u64>,
    /// `inprocess` or `processes`.
    pub engine: Option<String>,
    /// `sync` or `async`.
    pub mode: Option<String>,
    /// `logical` or `realtime`.
    pub clock: Option<String>,
    /// `gtrs`, `relaxed` or `gtrs_l0`.
    pub local_solver: Option<String>,
    /// Node polling before blocking (µs; `run.json` `poll_us`, absent in older runs).
    pub poll_us: Option<u64>,
    /// `ok`, `failed` or `interrupted`.
    pub status: Option<String>,
    /// Why the run stopped early.
    pub error: Option<String>,
    /// Crate version that wrote the run.
    pub crate_version: Option<String>,
    /// The command line.
    pub command_line: Vec<String>,
    /// Transmitter positions (m).
    pub transmitters: Vec<[f64; 2]>,
    /// Receiver (node) positions (m).
    pub receivers: Vec<[f64; 2]>,
    /// Network edges.
    pub edges: Vec<(usize, usize)>,
    /// Samples excluded from `rmse_after_burn_in`.
    pub burn_in: Option<usize>,
    /// The resolved scenario object, as written.
    pub scenario: Value,
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
///   `sum_{j<=k} ||x_j - x_j*||`, m, seed 000) and `regret` (running dynamic
///   regret, seed 001) is optional.
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
    /// `metrics.json` (empty when absent in a Monte Carlo directory).
    pub metrics: Map<String, Value>,
    /// `track.csv` (empty when absent in a Monte Carlo directory).
    pub track: TrackTable,
    /// `nodes.csv`: every node's `theta` after every sample.
    pub nodes: Vec<NodePoint>,
    /// `iterations.csv` (written by `--trace-iterations`), when present.
    pub iterations: Option<Vec<NodePoint>>,
    /// Monte Carlo outputs, when present.
    pub monte_carlo: Option<MonteCarlo>,
}

impl RunData {
    /// Per-node counters of `metrics.json` (`nodes` array).
    pub fn node_counters(&self) -> Vec<Map<String, Value>> {
        self.metrics
            .get("nodes")
            .and_then(Value::as_array)
            .map(|a| a.iter().filter_map(|v| v.as_object().cloned()).collect())
            .unwrap_or_default()
    }

    /// A short name of the run for titles: `<name> (<mode>, <engine>, seed <seed>)`.
    pub fn title(&self) -> String {
        let mut parts = Vec::new();
        if let Some(m) = &self.info.mode {
            parts.push(m.clone());
        }
        if let Some(e) = &self.info.engine {
            parts.push(e.clone());
        }
        if let Some(s) = self.info.seed {
            parts.push(format!("seed {s}"));
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
            Value::Object(m) => m,
            _ => return Err(InputError::file(&p, "expected a JSON object")),
        },
        None => Map::new(),
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
    })
}

fn read_json(p: &Path) -> Result<Value, InputError> {
    let text = std::fs::read_to_string(p).map_err(|e| InputError::file(p, e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| {
        InputError::at(
            p,
            format!("line {}", e.line()),
            format!("invalid JSON: {e}"),
        )
    })
}

/// A CSV file as strings.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Csv {
    /// Header.
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Parse the cell of data row `i` (0-based), column `j`: empty is `None`,
    /// anything else must be a finite number.
    fn cell(&self, p: &Path, i: usize, j: usize, s: &str) -> Result<Option<f64>, InputError> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(None);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(InputError::at(
                p,
                format!("line {}, column {}", i + 2, self.header[j]),
                format!("expected a finite number, found `{s}`"),
            )),
        }
    }

    /// Column `j` as numbers.
    fn numbers(&self, p: &Path, j: usize) -> Result<Vec<Option<f64>>, InputError> {
        self.rows
            .iter()
            .enumerate()
            .map(|(i, r)| self.cell(p, i, j, r.get(j).map_or("", String::as_str)))
            .collect()
    }

    /// Named column as numbers, or `None` if there is no such column.
    fn numbers_of(&self, p: &Path, name: &str) -> Result<Option<Vec<Option<f64>>>, InputError> {
        self.col(name).map(|j| self.numbers(p, j)).transpose()
    }
}

/// Read a CSV file with a header row.
pub fn read_csv(p: &Path) -> Result<Csv, InputError> {
    let mut rdr = csv::Reader::from_path(p).map_err(|e| InputError::file(p, e.to_string()))?;
    let header = rdr
        .headers()
        .map_err(|e| InputError::file(p, format!("cannot read the header: {e}")))?
        .iter()
        .map(|s| s.trim().to_string())
        .collect::<Vec<_>>();
    let mut rows = Vec::new();
    for (i, r) in rdr.records().enumerate() {
        let r = r.map_err(|e| InputError::at(p, format!("line {}", i + 2), e.to_string()))?;
        rows.push(r.iter().map(str::to_owned).collect());
    }
    Ok(Csv { header, rows })
}

fn xy(x: &[Option<f64>], y: &[Option<f64>]) -> Vec<Option<[f64; 2]>> {
    x.iter()
        .zip(y)
        .map(|(a, b)| match (a, b) {
            (Some(a), Some(b)) => Some([*a, *b]),
            _ => None,
        })
        .collect()
}

fn running_sum(e: &[Option<f64>]) -> Vec<Option<f64>> {
    let mut s = 0.0;
    e.iter()
        .map(|v| {
            v.map(|v| {
                s += v;
                s
            })
        })
        .collect()
}

fn distances(pos: &[Option<[f64; 2]>], truth: &[Option<[f64; 2]>]) -> Vec<Option<f64>> {
    pos.iter()
        .zip(truth)
        .map(|(p, t)| match (p, t) {
            (Some(p), Some(t)) => Some((p[0] - t[0]).hypot(p[1] - t[1])),
            _ => None,
        })
        .collect()
}

/// Split a parsed `track.csv` into tracks (the generic column convention:
/// `est_*` and the plain `error,ctte,regret` are `theta_bar`; `ml_*` is the
/// ML reference; any other `NAME_x,NAME_y` pair is a baseline with optional
/// `NAME_error,NAME_ctte,NAME_regret`; `bound_NAME` is a bound radius).
pub fn parse_track_csv(p: &Path, csv: &Csv) -> Result<TrackTable, InputError> {
    let j = csv.col("sample").ok_or_else(|| {
        InputError::at(p, "line 1", "no `sample` column: this is not a track.csv")
    })?;
    let sample = csv
        .numbers(p, j)?
        .into_iter()
        .enumerate()
        .map(|(i, v)| {
            v.ok_or_else(|| InputError::at(p, format!("line {}", i + 2), "empty `sample`"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let n = sample.len();
    let none = || vec![None; n];
    let get = |name: &str| -> Result<Vec<Option<f64>>, InputError> {
        Ok(csv.numbers_of(p, name)?.unwrap_or_else(none))
    };
    let truth = xy(&get("true_x")?, &get("true_y")?);
    let mut names: Vec<(String, TrackKind)> = Vec::new();
    if csv.col("est_x").is_some() && csv.col("est_y").is_some() {
        names.push(("est".into(), TrackKind::Distributed));
    }
    if csv.col("ml_x").is_some() && csv.col("ml_y").is_some() {
        names.push(("ml".into(), TrackKind::Reference));
    }
    for h in &csv.header {
        if let Some(base) = h.strip_suffix("_x")
            && !matches!(base, "true" | "est" | "ml")
            && csv.col(&format!("{base}_y")).is_some()
        {
            names.push((base.to_string(), TrackKind::Baseline));
        }
    }
    let mut tracks = Vec::new();
    for (prefix, kind) in &names {
        let pos = xy(&get(&format!("{prefix}_x"))?, &get(&format!("{prefix}_y"))?);
        let (err_col, ctte_col, regret_col) = if *kind == TrackKind::Distributed {
            (
                "error".to_string(),
                "ctte".to_string(),
                "regret".to_string(),
            )
        } else {
            (
                format!("{prefix}_error"),
                format!("{prefix}_ctte"),
                format!("{prefix}_regret"),
            )
        };
        let error = match csv.numbers_of(p, &err_col)? {
            Some(e) => e,
            None => distances(&pos, &truth),
        };
        let ctte = match csv.numbers_of(p, &ctte_col)? {
            Some(c) => c,
            None => running_sum(&error),
        };
        let regret = csv.numbers_of(p, &regret_col)?;
        let name = match kind {
            TrackKind::Distributed => THETA_BAR.to_string(),
            TrackKind::Reference => ML.to_string(),
            TrackKind::Baseline => prefix.clone(),
        };
        tracks.push(Track {
            name,
            kind: *kind,
            pos,
            error,
            ctte,
            regret,
        });
    }
    let claimed = |h: &str| {
        names.iter().any(|(b, k)| {
            *k == TrackKind::Baseline
                && ["_x", "_y", "_error", "_ctte", "_regret"]
                    .iter()
                    .any(|s| h == format!("{b}{s}"))
        })
    };
    let mut bounds = Vec::new();
    for (jj, h) in csv.header.iter().enumerate() {
        if let Some(name) = h.strip_prefix("bound_")
            && !claimed(h)
        {
            // Bound radii: an empty cell is an empty set; a non-finite radius
            // (an unbounded region) is not drawn either.
            let radius = csv
                .rows
                .iter()
                .map(|r| {
                    r.get(jj)
                        .and_then(|s| s.trim().parse::<f64>().ok())
                        .filter(|v| v.is_finite() && *v >= 0.0)
                })
                .collect();
            bounds.push(BoundSeries {
                name: name.to_string(),
                radius,
            });
        }
    }
    Ok(TrackTable {
        sample,
        truth,
        tracks,
        crlb: get("crlb")?,
        bounds,
    })
}

/// Parse `nodes.csv` (`sample,node,x,y,...`) or, with `iterations`,
/// `iterations.csv` (`iteration,sample,node,x,y,...`).
pub fn parse_node_points(
    p: &Path,
    csv: &Csv,
    iterations: bool,
) -> Result<Vec<NodePoint>, InputError> {
    let mut need = vec!["sample", "node", "x", "y"];
    if iterations {
        need.push("iteration");
    }
    let mut cols = Vec::new();
    for n in &need {
        cols.push(csv.col(n).ok_or_else(|| {
            InputError::at(
                p,
                "line 1",
                format!("no `{n}` column (expected {})", need.join(",")),
            )
        })?);
    }
    let mut out = Vec::with_capacity(csv.rows.len());
    for (i, r) in csv.rows.iter().enumerate() {
        let mut v = [0.0; 5];
        for (k, &j) in cols.iter().enumerate() {
            v[k] = csv
                .cell(p, i, j, r.get(j).map_or("", String::as_str))?
                .ok_or_else(|| {
                    InputError::at(
                        p,
                        format!("line {}, column {}", i + 2, need[k]),
                        "empty cell",
                    )
                })?;
        }
        let index = |x: f64, what: &str| -> Result<u64, InputError> {
            if x >= 0.0 && x.fract().abs() < 1e-9 {
                Ok(x as u64)
            } else {
                Err(InputError::at(
                    p,
                    format!("line {}, column {what}", i + 2),
                    format!("expected a non-negative integer, found {x}"),
                ))
            }
        };
        out.push(NodePoint {
            sample: index(v[0], "sample")? as usize,
            node: index(v[1], "node")? as usize,
            pos: [v[2], v[3]],
            iteration: if iterations {
                Some(index(v[4], "iteration")?)
            } else {
                None
            },
        });
    }
    Ok(out)
}

fn str_at(v: &Value, path: &[&str]) -> Option<String> {
    let mut cur = v;
    for k in path {
        cur = cur.get(k)?;
    }
    match cur {
        Value::String(s) => Some(s.clone()),
        Value::Null => None,
        other => Some(other.to_string()),
    }
}

fn points(p: &Path, v: Option<&Value>, key: &str) -> Result<Vec<[f64; 2]>, InputError> {
    let Some(v) = v else {
        return Ok(Vec::new());
    };
    let arr = v
        .as_array()
        .ok_or_else(|| InputError::at(p, key, "expected an array of [x, y] points"))?;
    arr.iter()
        .enumerate()
        .map(|(i, q)| {
            let a = q.as_array().filter(|a| a.len() == 2);
            match a.map(|a| (a[0].as_f64(), a[1].as_f64())) {
                Some((Some(x), Some(y))) if x.is_finite() && y.is_finite() => Ok([x, y]),
                _ => Err(InputError::at(
                    p,
                    format!("{key}[{i}]"),
                    "expected a point [x, y] of finite numbers",
                )),
            }
        })
        .collect()
}

/// Parse `run.json`.
pub fn parse_run_json(p: &Path, v: &Value) -> Result<RunInfo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let sc = v.get("scenario").cloned().unwrap_or(Value::Null);
    let geometry = sc.get("geometry");
    let transmitters = points(
        p,
        geometry.and_then(|g| g.get("transmitters")),
        "scenario.geometry.transmitters",
    )?;
    let receivers = points(
        p,
        geometry.and_then(|g| g.get("receivers")),
        "scenario.geometry.receivers",
    )?;
    let edges = match v.get("edges") {
        None | Some(Value::Null) => Vec::new(),
        Some(e) => {
            let arr = e
                .as_array()
                .ok_or_else(|| InputError::at(p, "edges", "expected an array of [a, b] pairs"))?;
            arr.iter()
                .enumerate()
                .map(|(i, q)| {
                    let a = q.as_array().filter(|a| a.len() == 2);
                    match a.map(|a| (a[0].as_u64(), a[1].as_u64())) {
                        Some((Some(a), Some(b)))
                            if (a as usize) < receivers.len() && (b as usize) < receivers.len() =>
                        {
                            Ok((a as usize, b as usize))
                        }
                        _ => Err(InputError::at(
                            p,
                            format!("edges[{i}]"),
                            format!(
                                "expected a pair of receiver indices below {}",
                                receivers.len()
                            ),
                        )),
                    }
                })
                .collect::<Result<_, _>>()?
        }
    };
    Ok(RunInfo {
        name: str_at(&sc, &["name"]).unwrap_or_else(|| {
            p.parent()
                .and_then(|d| d.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into())
        }),
        description: str_at(&sc, &["description"]),
        scenario_file: str_at(v, &["scenario_file"]),
        seed: v.get("seed").and_then(Value::as_u64),
        engine: str_at(v, &["engine"]),
        mode: str_at(v, &["mode"]),
        clock: str_at(v, &["clock"]),
        local_solver: str_at(v, &["local_solver"]),
        poll_us: v.get("poll_us").and_then(Value::as_u64),
        status: str_at(v, &["status"]),
        error: str_at(v, &["error"]),
        crate_version: str_at(v, &["crate_version"]),
        command_line: v
            .get("command_line")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .map(|s| s.as_str().map_or_else(|| s.to_string(), str::to_owned))
                    .collect()
            })
            .unwrap_or_default(),
        transmitters,
        receivers,
        edges,
        burn_in: sc
            .get("algorithm")
            .and_then(|a| a.get("burn_in"))
            .and_then(Value::as_u64)
            .map(|b| b as usize),
        scenario: sc,
    })
}

fn band(p: &Path, v: &Value, key: &str, n: usize) -> Result<BandCurve, InputError> {
    let arr = |k: &str| -> Result<Vec<Option<f64>>, InputError> {
        let loc = format!("{key}.{k}");
        let a = v
            .get(k)
            .and_then(Value::as_array)
            .ok_or_else(|| InputError::at(p, &loc, "missing or not an array"))?;
        if a.len() != n {
            return Err(InputError::at(
                p,
                &loc,
                format!("has {} entries but `sample` has {n}", a.len()),
            ));
        }
        a.iter()
            .enumerate()
            .map(|(i, x)| match x {
                Value::Null => Ok(None),
                x => match x.as_f64() {
                    Some(f) if f.is_finite() => Ok(Some(f)),
                    _ => Err(InputError::at(
                        p,
                        format!("{loc}[{i}]"),
                        "expected a finite number or null",
                    )),
                },
            })
            .collect()
    };
    Ok(BandCurve {
        mean: arr("mean")?,
        p5: arr("p5")?,
        p95: arr("p95")?,
    })
}

/// Parse `summary.json` (format in [`MonteCarlo`]).
pub fn parse_summary(p: &Path, v: &Value) -> Result<MonteCarlo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let sample: Vec<f64> = match v.get("sample") {
        None => Vec::new(),
        Some(s) => s
            .as_array()
            .ok_or_else(|| InputError::at(p, "sample", "expected an array of sample indices"))?
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_f64()
                    .filter(|f| f.is_finite())
                    .ok_or_else(|| InputError::at(p, format!("sample[{i}]"), "expected a number"))
            })
            .collect::<Result<_, _>>()?,
    };
    let n = sample.len();
    let mut curves = Vec::new();
    if let Some(c) = v.get("curves") {
        let obj = c
            .as_object()
            .ok_or_else(|| InputError::at(p, "curves", "expected an object keyed by track"))?;
        for (name, tc) in obj {
            let key = format!("curves.{name}");
            let one = |k: &str| {
                tc.get(k)
                    .filter(|x| !x.is_null())
                    .map(|x| band(p, x, &format!("{key}.{k}"), n))
                    .transpose()
            };
            curves.push(TrackCurves {
                name: name.clone(),
                error: one("error")?,
                ctte: one("ctte")?,
                regret: one("regret")?,
            });
        }
    }
    let rank = |n: &str| match n {
        THETA_BAR => 0,
        ML => 1,
        _ => 2,
    };
    curves.sort_by(|a, b| rank(&a.name).cmp(&rank(&b.name)).then(a.name.cmp(&b.name)));
    let crlb = v
        .get("crlb")
        .filter(|x| !x.is_null())
        .map(|x| band(p, x, "crlb", n))
        .transpose()?;
    Ok(MonteCarlo {
        trials: v.get("trials").and_then(Value::as_u64),
        sample,
        curves,
        crlb,
        trial_columns: Vec::new(),
        trial_rows: Vec::new(),
    })
}
