//! The metrics tables of a run: every track's metrics, and `metrics.json` flattened for
//! comparisons.

use super::*;

/// Track metrics shown first, in this order (m, except `regret`).
pub const TRACK_KEYS: [&str; 6] = [
    "rmse",
    "rmse_after_burn_in",
    "median_error",
    "final_error",
    "ctte",
    "regret",
];

/// One cell of the track metrics table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The value.
    pub value: f64,
    /// Computed here from `track.csv` (not found in `metrics.json`).
    pub computed: bool,
}

/// The metrics table of every track.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricsTable {
    /// Column keys.
    pub columns: Vec<String>,
    /// Rows: track name, legend label, cells per column.
    pub rows: Vec<(String, String, Vec<Option<Cell>>)>,
}

pub(super) fn num(v: &Value) -> Option<f64> {
    v.as_f64().filter(|f| f.is_finite())
}

/// Metrics of every track: `theta_bar` from the top level of `metrics.json`,
/// the ML reference from `ml_rmse`, baselines from `baselines.NAME`; whatever
/// is missing is computed from the error series of `track.csv` with
/// [`crate::model::metrics::score`] (and marked as computed).
pub fn track_metrics(data: &RunData) -> MetricsTable {
    let mut columns: Vec<String> = Vec::new();
    let mut rows: Vec<(String, String, Map<String, Value>, bool)> = Vec::new();
    let baselines = data
        .metrics
        .get("baselines")
        .and_then(Value::as_object)
        .cloned()
        .unwrap_or_default();
    let mut names: Vec<(String, String)> = data
        .track
        .tracks
        .iter()
        .map(|t| (t.name.clone(), t.label()))
        .collect();
    if names.is_empty() && data.metrics.contains_key("rmse") {
        names.push((THETA_BAR.into(), "distributed estimate".into()));
    }
    for n in baselines.keys() {
        if !names.iter().any(|(x, _)| x == n) {
            names.push((n.clone(), n.clone()));
        }
    }
    for (name, label) in names {
        let mut given = Map::new();
        if name == THETA_BAR {
            for k in TRACK_KEYS {
                if let Some(v) = data.metrics.get(k).filter(|v| num(v).is_some()) {
                    given.insert(k.into(), v.clone());
                }
            }
        } else if name == ML {
            if let Some(v) = data.metrics.get("ml_rmse").filter(|v| num(v).is_some()) {
                given.insert("rmse".into(), v.clone());
            }
        } else if let Some(Value::Object(o)) = baselines.get(&name) {
            for (k, v) in o {
                if num(v).is_some() {
                    given.insert(k.clone(), v.clone());
                }
            }
        }
        for k in given.keys() {
            if !columns.contains(k) {
                columns.push(k.clone());
            }
        }
        rows.push((name, label, given, false));
    }
    for k in TRACK_KEYS {
        let computable = k != "regret" || data.track.tracks.iter().any(|t| t.regret.is_some());
        if computable && !columns.iter().any(|c| c == k) {
            columns.push(k.into());
        }
    }
    let rank = |c: &str| {
        TRACK_KEYS
            .iter()
            .position(|k| *k == c)
            .unwrap_or(TRACK_KEYS.len())
    };
    columns.sort_by(|a, b| rank(a).cmp(&rank(b)).then(a.cmp(b)));
    let burn_in = data.info.burn_in.unwrap_or(0);
    let out_rows = rows
        .into_iter()
        .map(|(name, label, given, _)| {
            let track = data.track.track(&name);
            let computed: Option<crate::model::metrics::TrackScore> = track.and_then(|t| {
                let e: Option<Vec<f64>> = t.error.iter().copied().collect();
                let e = e.filter(|e| !e.is_empty())?;
                crate::model::metrics::score(&e, burn_in.min(e.len() - 1))
            });
            let regret_last = track
                .and_then(|t| t.regret.as_ref())
                .and_then(|r| r.iter().rev().find_map(|x| *x));
            let cells = columns
                .iter()
                .map(|c| {
                    if let Some(v) = given.get(c).and_then(num) {
                        return Some(Cell {
                            value: v,
                            computed: false,
                        });
                    }
                    let v = match (c.as_str(), &computed) {
                        ("rmse", Some(s)) => Some(s.rmse),
                        ("rmse_after_burn_in", Some(s)) => Some(s.rmse_after_burn_in),
                        ("median_error", Some(s)) => Some(s.median_error),
                        ("final_error", Some(s)) => Some(s.final_error),
                        ("ctte", Some(s)) => Some(s.ctte),
                        ("regret", _) => regret_last,
                        _ => None,
                    };
                    v.map(|value| Cell {
                        value,
                        computed: true,
                    })
                })
                .collect();
            (name, label, cells)
        })
        .collect();
    MetricsTable {
        columns,
        rows: out_rows,
    }
}

/// Flatten `metrics.json` into `key -> number` for the comparison table:
/// top-level numbers, `realtime.*`, `baselines.NAME.*`, `bounds.NAME.*`.
pub fn flat_metrics(m: &Map<String, Value>) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for (k, v) in m {
        match v {
            Value::Number(_) => {
                if let Some(f) = num(v) {
                    out.push((k.clone(), f));
                }
            }
            Value::Object(o) if k == "realtime" => {
                for (k2, v2) in o {
                    if let Some(f) = num(v2) {
                        out.push((format!("realtime.{k2}"), f));
                    }
                }
            }
            Value::Object(o) if k == "baselines" || k == "bounds" => {
                for (name, inner) in o {
                    if let Value::Object(inner) = inner {
                        for (k2, v2) in inner {
                            if let Some(f) = num(v2) {
                                out.push((format!("{k}.{name}.{k2}"), f));
                            }
                        }
                    }
                }
            }
            _ => {}
        }
    }
    let rank = |c: &str| {
        TRACK_KEYS
            .iter()
            .position(|k| *k == c)
            .unwrap_or(TRACK_KEYS.len() + usize::from(c.contains('.')))
    };
    out.sort_by_key(|a| rank(&a.0));
    out
}
