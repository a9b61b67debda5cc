//! The metrics tables of a run: every track's metrics, and the run's metrics
//! flattened for comparisons. Both read the typed `metrics.json`
//! ([`RunMetrics`]) and compute nothing.

use crate::pipeline::RunMetrics;
use crate::plot::data::ML;
use crate::plot::data::RunData;
use crate::plot::data::THETA_BAR;
use serde_json::Map;
use serde_json::Value;

/// Track metrics shown first, in this order (m, except `regret`).
pub const TRACK_KEYS: [&str; 6] = [
    "rmse",
    "rmse_after_burn_in",
    "median_error",
    "final_error",
    "ctte",
    "regret",
];

/// The metrics table of every track.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricsTable {
    /// Column keys ([`crate::pipeline::score::TrackMetrics`] fields with a value in some row).
    pub columns: Vec<String>,
    /// Rows: track name, legend label, value per column.
    pub rows: Vec<(String, String, Vec<Option<f64>>)>,
}

pub(super) fn num(v: &Value) -> Option<f64> {
    v.as_f64().filter(|f| f.is_finite())
}

/// The finite numbers of a serialised value, by key.
fn numbers(v: &impl serde::Serialize) -> Map<String, Value> {
    match serde_json::to_value(v) {
        Ok(Value::Object(o)) => o.into_iter().filter(|(_, v)| num(v).is_some()).collect(),
        _ => Map::new(),
    }
}

/// Metrics of every track as `metrics.json` records them: `theta_bar`, the
/// ML reference `ml` and `baselines.NAME`, in the order of `track.csv` (then
/// any track only `metrics.json` has). A value the file does not hold stays
/// empty; nothing is computed here.
pub fn track_metrics(data: &RunData) -> MetricsTable {
    let Some(m) = &data.metrics else {
        return MetricsTable {
            columns: Vec::new(),
            rows: Vec::new(),
        };
    };
    let mut names: Vec<(String, String)> = data
        .track
        .tracks
        .iter()
        .map(|t| (t.name.clone(), t.label()))
        .collect();
    for (n, label) in [(THETA_BAR, "distributed estimate"), (ML, "centralised ML")] {
        if !names.iter().any(|(x, _)| x == n) {
            names.push((n.into(), label.into()));
        }
    }
    for n in m.baselines.keys() {
        if !names.iter().any(|(x, _)| x == n) {
            names.push((n.clone(), n.clone()));
        }
    }
    let rows: Vec<(String, String, Map<String, Value>)> = names
        .into_iter()
        .filter_map(|(name, label)| {
            let metrics = match name.as_str() {
                THETA_BAR => m.theta_bar.clone(),
                ML => m.ml.clone(),
                other => m.baselines.get(other)?.clone(),
            };
            Some((name, label, numbers(&metrics)))
        })
        .collect();
    let mut columns: Vec<String> = Vec::new();
    for (_, _, given) in &rows {
        for k in given.keys() {
            if !columns.contains(k) {
                columns.push(k.clone());
            }
        }
    }
    let rank = |c: &str| {
        TRACK_KEYS
            .iter()
            .position(|k| *k == c)
            .unwrap_or(TRACK_KEYS.len())
    };
    columns.sort_by(|a, b| rank(a).cmp(&rank(b)).then(a.cmp(b)));
    let rows = rows
        .into_iter()
        .map(|(name, label, given)| {
            let cells = columns.iter().map(|c| given.get(c).and_then(num)).collect();
            (name, label, cells)
        })
        .collect();
    MetricsTable { columns, rows }
}

/// The run's metrics by flat name for the comparison table: every track's
/// metrics as `[expect]` names them ([`RunMetrics::flat`]: `theta_bar.rmse`,
/// `ml.rmse`, `NAME.ctte`, ...), then `wall_seconds`, `startup_seconds`,
/// `samples_completed` and `realtime.*`.
pub fn comparison_metrics(m: Option<&RunMetrics>) -> Vec<(String, f64)> {
    let Some(m) = m else {
        return Vec::new();
    };
    let flat = m.flat();
    let group = |k: &str| match k.split('.').next() {
        Some(THETA_BAR) => 0,
        Some(ML) => 1,
        _ if k.contains('.') => 2,
        _ => 3,
    };
    let rank = |k: &str| {
        let last = k.rsplit('.').next().unwrap_or(k);
        let depth = k.matches('.').count();
        (
            group(k),
            TRACK_KEYS
                .iter()
                .position(|t| *t == last && depth == 1)
                .unwrap_or(TRACK_KEYS.len()),
        )
    };
    let mut out: Vec<(String, f64)> = flat.into_iter().filter(|(_, v)| v.is_finite()).collect();
    out.push(("wall_seconds".into(), m.wall_seconds));
    if let Some(s) = m.startup_seconds {
        out.push(("startup_seconds".into(), s));
    }
    out.push(("samples_completed".into(), m.samples_completed as f64));
    if let Some(rt) = &m.realtime {
        for (k, v) in numbers(rt) {
            if let Some(f) = num(&v) {
                out.push((format!("realtime.{k}"), f));
            }
        }
    }
    out.sort_by_key(|a| rank(&a.0));
    out
}
