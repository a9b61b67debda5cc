//! Self-contained HTML report of a results directory (issue 7).
//!
//! `sonarnet report DIR` writes `DIR/report.html`: the scenario summary, the
//! metrics table of every track (distributed `theta_bar`, centralised ML,
//! baselines), bounds and run counters, Monte Carlo trial statistics when
//! present, the five plots of [`crate::plot`] inlined as SVG, and the run's
//! command line and seed. `sonarnet report A B` compares two runs: a metrics
//! diff table, overlaid error and CTTE curves and both track maps side by side.
//!
//! The page needs nothing but itself: SVG is inline, there is no network fetch
//! (a Content-Security-Policy forbids any), and the only script is a small
//! self-test that, when the URL ends in `?selftest`, writes the rendered size
//! of every plot and every error the page raised into `<pre id="selftest">`
//! (read by the headless-browser test).

use crate::plot::data::{ML, RunData, THETA_BAR};
use crate::plot::{self, Figure, Formats, PlotError, load_run};
use serde_json::{Map, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
pub struct TrackMetrics {
    /// Column keys.
    pub columns: Vec<String>,
    /// Rows: track name, legend label, cells per column.
    pub rows: Vec<(String, String, Vec<Option<Cell>>)>,
}

fn num(v: &Value) -> Option<f64> {
    v.as_f64().filter(|f| f.is_finite())
}

/// Metrics of every track: `theta_bar` from the top level of `metrics.json`,
/// the ML reference from `ml_rmse`, baselines from `baselines.NAME`; whatever
/// is missing is computed from the error series of `track.csv` with
/// [`crate::model::metrics::score`] (and marked as computed).
pub fn track_metrics(data: &RunData) -> TrackMetrics {
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
    TrackMetrics {
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

/// Escape text for HTML.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// A number for a table: 4 significant digits, integers exact.
pub fn fmt_num(v: f64) -> String {
    if v.fract().abs() < 1e-12 && v.abs() < 1e15 {
        return format!("{}", v as i64);
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        format!("{v:.3e}")
    } else {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    }
}

/// What each figure shows (the report's captions).
pub fn caption(name: &str) -> &'static str {
    match name {
        "tracks" => {
            "True track (black, dots at samples), distributed estimate θ̄ = mean of the node estimates (blue), centralised ML reference (orange, dashed) and any baselines. Transmitters (red triangles), receivers (squares) and network links drawn to scale, as in seed 002 Fig. 2b. Where bounds are present, the certified error discs around θ̄ are drawn at every n-th sample."
        }
        "error" => {
            "Position error ‖x_k − x_k*‖ per sample for every track, with the Cramér-Rao bound √tr(J⁻¹) at the true position (grey, dashed). The shaded region is the burn-in, excluded from rmse_after_burn_in. Monte Carlo runs: mean across trials with a 5th–95th percentile band."
        }
        "consensus" => {
            "Each node's estimate θ_v (thin lines), their mean θ̄ and the true position, x and y coordinates against the sample (or against the iteration when the run traced iterations), as seed 002 Fig. 2a; bottom: the consensus disagreement maxᵥ‖θᵥ − θ̄‖."
        }
        "ctte" => {
            "Running cumulative target tracking error CTTE_k = Σ_{j≤k} ‖x_j − x_j*‖ (seed 000) of every track, and the running dynamic regret (seed 001) when present. Monte Carlo runs: mean with a 5th–95th percentile band."
        }
        "network" => {
            "The gossip graph to scale. Each node is coloured by its number of prox solves and labelled with its counters: prox solves, gossip messages sent (↑) and received (↓), and declined exchanges."
        }
        "compare-error" => "Error per sample of every track: run A solid, run B dashed.",
        "compare-ctte" => "Running CTTE of every track: run A solid, run B dashed.",
        _ => "",
    }
}

const STYLE: &str = r#"
body { font-family: "DejaVu Sans", "Helvetica Neue", Arial, sans-serif; color: #222; margin: 0; background: #fafafa; }
main { max-width: 1240px; margin: 0 auto; padding: 16px 28px 48px; background: #fff; }
h1 { font-size: 26px; margin: 12px 0 4px; }
h2 { font-size: 20px; border-bottom: 1px solid #ddd; padding-bottom: 4px; margin-top: 36px; }
h3 { font-size: 16px; margin: 20px 0 6px; }
p.sub { color: #555; margin: 0 0 12px; }
table { border-collapse: collapse; margin: 8px 0 12px; font-size: 14px; }
th, td { border: 1px solid #d4d4d4; padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: #f1f3f5; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: "DejaVu Sans Mono", monospace; }
td.computed { color: #555; font-style: italic; }
td.better { background: #e6f4ea; } td.worse { background: #fce8e6; }
.status-ok { color: #137333; font-weight: bold; } .status-bad { color: #b3261e; font-weight: bold; }
figure.plot { margin: 18px 0 28px; }
figure.plot svg { display: block; max-width: 100%; height: auto; border: 1px solid #e3e3e3; }
figcaption { font-size: 14px; color: #444; max-width: 1000px; margin-top: 6px; }
pre { background: #f6f8fa; border: 1px solid #e1e4e8; padding: 8px 12px; overflow-x: auto; font-size: 13px; white-space: pre-wrap; word-break: break-all; }
.grid2 { display: grid; grid-template-columns: 1fr 1fr; gap: 16px; }
.note { color: #666; font-size: 13px; }
details summary { cursor: pointer; color: #1a5fb4; }
"#;

/// The self-test script, run only when the URL contains `?selftest`.
const SELFTEST_HEAD: &str = r#"<script>
(function () {
  var errs = [];
  window.__sonarnetErrors = errs;
  window.addEventListener('error', function (e) {
    var t = e.target;
    errs.push(e.message ? String(e.message) : ('failed to load ' + (t && (t.src || t.href || t.tagName))));
  }, true);
  window.addEventListener('unhandledrejection', function (e) { errs.push('unhandled rejection: ' + e.reason); });
  document.addEventListener('securitypolicyviolation', function (e) { errs.push('CSP violation: ' + e.blockedURI); });
  var ce = console.error;
  console.error = function () { errs.push('console.error: ' + Array.prototype.join.call(arguments, ' ')); return ce.apply(console, arguments); };
})();
</script>"#;

const SELFTEST_TAIL: &str = r#"<pre id="selftest" hidden></pre>
<script>
(function () {
  function run() {
    if (location.search.indexOf('selftest') < 0) return;
    var meta = document.querySelector('meta[name="sonarnet-plots"]');
    var out = { expected: meta ? parseInt(meta.content, 10) : -1, errors: window.__sonarnetErrors || ['self-test hook missing'], plots: [] };
    var figs = document.querySelectorAll('figure.plot');
    for (var i = 0; i < figs.length; i++) {
      var s = figs[i].querySelector('svg');
      // Content box (without the border), so an empty svg measures 0.
      var w = s ? s.clientWidth : 0, h = s ? s.clientHeight : 0;
      var n = s ? s.querySelectorAll('*').length : 0;
      out.plots.push({ id: figs[i].id, width: w, height: h, elements: n });
    }
    document.getElementById('selftest').textContent = JSON.stringify(out);
  }
  run();
  window.addEventListener('load', run);
})();
</script>"#;

fn page_head(title: &str, plots: usize) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:\">\n\
<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
<meta name=\"sonarnet-plots\" content=\"{plots}\">\n<title>{}</title>\n<style>{STYLE}</style>\n{SELFTEST_HEAD}\n</head>\n<body>\n<main>\n",
        esc(title)
    )
}

fn page_tail() -> String {
    format!(
        "<p class=\"note\">Written by sonarnet {}.</p>\n</main>\n{SELFTEST_TAIL}\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION")
    )
}

/// Strip anything before `<svg` (an XML declaration) so the SVG inlines.
fn inline_svg(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |i| &svg[i..])
}

fn figure_html(fig: &Figure, svg: &str) -> String {
    format!(
        "<figure class=\"plot\" id=\"plot-{}\">\n{}\n<figcaption><b>{}.svg</b> — {}</figcaption>\n</figure>\n",
        esc(&fig.name),
        inline_svg(svg),
        esc(&fig.name),
        esc(caption(&fig.name))
    )
}

fn status_html(s: Option<&str>) -> String {
    match s {
        Some("ok") => "<span class=\"status-ok\">ok</span>".into(),
        Some(s) => format!("<span class=\"status-bad\">{}</span>", esc(s)),
        None => "-".into(),
    }
}

fn get<'a>(v: &'a Value, path: &[&str]) -> Option<&'a Value> {
    let mut c = v;
    for k in path {
        c = c.get(k)?;
    }
    (!c.is_null()).then_some(c)
}

fn show(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Number(n) => n.to_string(),
        other => other.to_string(),
    }
}

fn noise(v: Option<&Value>) -> Option<String> {
    let v = v?;
    let model = v.get("model").map(show).unwrap_or_else(|| "?".into());
    let rest: Vec<String> = v
        .as_object()?
        .iter()
        .filter(|(k, _)| k.as_str() != "model")
        .map(|(k, x)| format!("{k} {}", show(x)))
        .collect();
    Some(if rest.is_empty() {
        model
    } else {
        format!("{model}, {}", rest.join(", "))
    })
}

/// Rows `(field, value)` of the scenario summary.
pub fn scenario_summary(d: &RunData) -> Vec<(String, String)> {
    let i = &d.info;
    let sc = &i.scenario;
    let mut rows: Vec<(String, String)> = Vec::new();
    let mut add = |k: &str, v: Option<String>| {
        if let Some(v) = v {
            rows.push((k.into(), v));
        }
    };
    add("scenario", Some(i.name.clone()));
    add("scenario file", i.scenario_file.clone());
    add(
        "geometry",
        Some(format!(
            "{} transmitters, {} receivers, {} network links",
            i.transmitters.len(),
            i.receivers.len(),
            i.edges.len()
        )),
    );
    add(
        "samples",
        get(sc, &["target", "samples"]).map(show).map(|s| {
            match d.metrics.get("samples_completed").and_then(Value::as_u64) {
                Some(c) => format!("{c} completed of {s}"),
                None => s,
            }
        }),
    );
    add(
        "motion",
        get(sc, &["target", "motion"]).and_then(|m| noise(Some(m))),
    );
    let mut meas = Vec::new();
    for (k, label) in [
        ("bistatic", "bistatic ranges"),
        ("doa", "DOA"),
        ("range", "ranges"),
    ] {
        if get(sc, &["measurements", k]).and_then(Value::as_bool) == Some(true) {
            meas.push(label);
        }
    }
    if !meas.is_empty() {
        add("measurements", Some(meas.join(", ")));
    }
    add(
        "range noise",
        noise(get(sc, &["measurements", "range_noise"])),
    );
    add("DOA noise", noise(get(sc, &["measurements", "doa_noise"])));
    add("mode", i.mode.clone());
    add("local solver", i.local_solver.clone());
    if i.local_solver.as_deref() == Some("gtrs_l0") {
        add(
            "κ (kappa, outlier rows per node)",
            get(sc, &["algorithm", "kappa"]).map(show),
        );
    }
    add(
        "iterations per sample",
        get(sc, &["algorithm", "iterations_per_sample"]).map(show),
    );
    add("γ (gamma)", get(sc, &["algorithm", "gamma"]).map(show));
    add("burn-in", i.burn_in.map(|b| format!("{b} samples")));
    add("engine", i.engine.clone());
    add("clock", i.clock.clone());
    if let Some(p) = i.poll_us.filter(|&p| p > 0) {
        add("node polling", Some(format!("{p} µs before blocking")));
    }
    add("seed", i.seed.map(|s| s.to_string()));
    if let Some(mc) = &d.monte_carlo {
        add(
            "Monte Carlo",
            Some(format!(
                "{} trials",
                mc.trials
                    .map(|t| t.to_string())
                    .unwrap_or_else(|| mc.trial_rows.len().to_string())
            )),
        );
    }
    rows
}

fn kv_table(rows: &[(String, String)]) -> String {
    let mut s = String::from("<table class=\"kv\">\n");
    for (k, v) in rows {
        let _ = writeln!(s, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(v));
    }
    s.push_str("</table>\n");
    s
}

fn track_metrics_html(d: &RunData) -> String {
    let tm = track_metrics(d);
    if tm.rows.is_empty() {
        return "<p class=\"note\">No track metrics (metrics.json has none and track.csv has no tracks).</p>\n".into();
    }
    let mut s = String::from("<table id=\"track-metrics\">\n<tr><th>track</th>");
    for c in &tm.columns {
        let unit = if TRACK_KEYS[..5].contains(&c.as_str()) {
            " (m)"
        } else {
            ""
        };
        let _ = write!(s, "<th>{}{unit}</th>", esc(c));
    }
    s.push_str("</tr>\n");
    let mut any_computed = false;
    for (name, label, cells) in &tm.rows {
        let _ = write!(
            s,
            "<tr data-track=\"{}\"><th>{}</th>",
            esc(name),
            esc(label)
        );
        for c in cells {
            match c {
                Some(c) if c.computed => {
                    any_computed = true;
                    let _ = write!(s, "<td class=\"num computed\">{}</td>", fmt_num(c.value));
                }
                Some(c) => {
                    let _ = write!(s, "<td class=\"num\">{}</td>", fmt_num(c.value));
                }
                None => s.push_str("<td class=\"num\">–</td>"),
            }
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    if any_computed {
        s.push_str("<p class=\"note\">Values in italics are not in metrics.json; the report computed them from the error series of track.csv with the same definitions.</p>\n");
    }
    s
}

fn run_metrics_html(d: &RunData) -> String {
    let skip = |k: &str| {
        TRACK_KEYS.contains(&k)
            || matches!(
                k,
                "baselines"
                    | "bounds"
                    | "nodes"
                    | "deaths"
                    | "realtime"
                    | "engine"
                    | "mode"
                    | "clock"
                    | "seed"
            )
    };
    let mut rows: Vec<(String, String)> = Vec::new();
    for (k, v) in &d.metrics {
        if skip(k) || v.is_null() {
            continue;
        }
        let unit = match k.as_str() {
            "max_disagreement" | "ml_rmse" | "crlb_rms" => " m",
            "wall_seconds" | "startup_seconds" => " s",
            _ => "",
        };
        let text = match num(v) {
            Some(f) => fmt_num(f),
            None => show(v),
        };
        rows.push((k.clone(), format!("{text}{unit}")));
    }
    if let Some(Value::Object(rt)) = d.metrics.get("realtime") {
        for (k, v) in rt {
            rows.push((format!("realtime.{k}"), show(v)));
        }
    }
    if let Some(Value::Array(deaths)) = d.metrics.get("deaths")
        && !deaths.is_empty()
    {
        let list: Vec<String> = deaths
            .iter()
            .map(|x| {
                format!(
                    "node {} at sample {} ({})",
                    x.get("node").map(show).unwrap_or_default(),
                    x.get("sample").map(show).unwrap_or_default(),
                    x.get("how").map(show).unwrap_or_default()
                )
            })
            .collect();
        rows.push(("deaths".into(), list.join("; ")));
    }
    if rows.is_empty() {
        return String::new();
    }
    format!("<h3>Run</h3>\n{}", kv_table(&rows))
}

/// A table of objects with the union of their keys as columns.
/// Columns that are `null` in every row are left out.
fn objects_table(id: &str, first: &str, rows: &[(String, Map<String, Value>)]) -> String {
    let mut cols: Vec<String> = Vec::new();
    for (_, o) in rows {
        for (k, v) in o {
            if !v.is_null() && !cols.contains(k) {
                cols.push(k.clone());
            }
        }
    }
    let mut s = format!("<table id=\"{id}\">\n<tr><th>{}</th>", esc(first));
    for c in &cols {
        let _ = write!(s, "<th>{}</th>", esc(c));
    }
    s.push_str("</tr>\n");
    for (name, o) in rows {
        let _ = write!(s, "<tr><th>{}</th>", esc(name));
        for c in &cols {
            match o.get(c) {
                Some(v @ Value::Number(_)) => {
                    let text = num(v).map_or_else(|| show(v), fmt_num);
                    let _ = write!(s, "<td class=\"num\">{}</td>", esc(&text));
                }
                Some(Value::Null) | None => s.push_str("<td>–</td>"),
                Some(v) => {
                    let _ = write!(s, "<td>{}</td>", esc(&show(v)));
                }
            }
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    s
}

fn bounds_html(d: &RunData) -> String {
    match d.metrics.get("bounds") {
        Some(Value::Object(b)) if !b.is_empty() => {
            let rows: Vec<(String, Map<String, Value>)> = b
                .iter()
                .map(|(k, v)| {
                    let o = match v {
                        Value::Object(o) => o.clone(),
                        other => {
                            let mut m = Map::new();
                            m.insert("value".into(), other.clone());
                            m
                        }
                    };
                    (k.clone(), o)
                })
                .collect();
            format!(
                "<h3>Bounds</h3>\n{}",
                objects_table("bounds", "bound", &rows)
            )
        }
        _ => String::new(),
    }
}

fn nodes_html(d: &RunData) -> String {
    let nodes = d.node_counters();
    if nodes.is_empty() {
        return String::new();
    }
    let rows: Vec<(String, Map<String, Value>)> = nodes
        .into_iter()
        .map(|mut o| {
            let id = o.remove("node").map(|v| show(&v)).unwrap_or_default();
            (format!("R{id}"), o)
        })
        .collect();
    format!(
        "<h3>Per-node counters</h3>\n{}",
        objects_table("node-counters", "node", &rows)
    )
}

/// Per-metric statistics over the rows of `trials.csv`: `(metric, n, mean,
/// std, p5, median, p95)`.
pub fn trial_stats(mc: &crate::plot::data::MonteCarlo) -> Vec<(String, usize, [f64; 5])> {
    let mut out = Vec::new();
    for (j, c) in mc.trial_columns.iter().enumerate() {
        if c == "trial" || c == "seed" {
            continue;
        }
        let xs: Vec<f64> = mc
            .trial_rows
            .iter()
            .filter_map(|r| r.get(j).copied().flatten())
            .collect();
        if xs.is_empty() {
            continue;
        }
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = if xs.len() > 1 {
            xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
        } else {
            0.0
        };
        let q = |p| crate::model::metrics::quantile(&xs, p).unwrap_or(mean);
        out.push((
            c.clone(),
            xs.len(),
            [mean, var.sqrt(), q(0.05), q(0.5), q(0.95)],
        ));
    }
    out
}

fn monte_carlo_html(d: &RunData) -> String {
    let Some(mc) = &d.monte_carlo else {
        return String::new();
    };
    let stats = trial_stats(mc);
    let mut s = format!(
        "<h3>Monte Carlo: {} trials</h3>\n<table id=\"trial-stats\">\n<tr><th>metric</th><th>trials</th><th>mean</th><th>std</th><th>p5</th><th>median</th><th>p95</th></tr>\n",
        mc.trials.unwrap_or(mc.trial_rows.len() as u64)
    );
    for (c, n, v) in stats {
        let _ = write!(s, "<tr><th>{}</th><td class=\"num\">{n}</td>", esc(&c));
        for x in v {
            let _ = write!(s, "<td class=\"num\">{}</td>", fmt_num(x));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    s
}

/// Quote a command-line argument for a POSIX shell when needed.
fn shell_quote(a: &str) -> String {
    if !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}

fn reproduce_html(d: &RunData) -> String {
    let cmd = if d.info.command_line.is_empty() {
        "(not recorded)".to_string()
    } else {
        d.info
            .command_line
            .iter()
            .map(|a| shell_quote(a))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut s = String::from("<h2 id=\"reproduce\">Command line and seed</h2>\n");
    let _ = write!(
        s,
        "<pre id=\"command-line\">{}</pre>\n{}",
        esc(&cmd),
        kv_table(&[
            (
                "seed".into(),
                d.info.seed.map_or("-".into(), |x| x.to_string())
            ),
            (
                "crate version".into(),
                d.info.crate_version.clone().unwrap_or_else(|| "-".into())
            ),
            ("results directory".into(), d.dir.display().to_string()),
        ])
    );
    let pretty = serde_json::to_string_pretty(&d.info.scenario).unwrap_or_default();
    let _ = write!(
        s,
        "<details><summary>Resolved scenario (run.json)</summary>\n<pre>{}</pre>\n</details>\n",
        esc(&pretty)
    );
    s
}

/// The report page of one run, with the SVG text of each figure.
pub fn report_html(d: &RunData, figs: &[(Figure, String)]) -> String {
    let title = format!("sonarnet report: {}", d.title());
    let mut s = page_head(&title, figs.len());
    let _ = write!(
        s,
        "<h1>{}</h1>\n<p class=\"sub\">{} · status {}</p>\n",
        esc(&d.title()),
        esc(d.info.description.as_deref().unwrap_or("")),
        status_html(d.info.status.as_deref())
    );
    if let Some(e) = &d.info.error {
        let _ = writeln!(
            s,
            "<p class=\"status-bad\">The run stopped early: {}</p>",
            esc(e)
        );
    }
    if let Some(n) = d.metrics.get("note").and_then(Value::as_str) {
        let _ = writeln!(s, "<p class=\"note\">Note: {}</p>", esc(n));
    }
    s.push_str("<h2 id=\"scenario\">Scenario</h2>\n");
    s.push_str(&kv_table(&scenario_summary(d)));
    s.push_str(if d.monte_carlo.is_some() {
        "<h2 id=\"metrics\">Metrics</h2>\n<h3>Tracks (the trial in metrics.json and track.csv)</h3>\n"
    } else {
        "<h2 id=\"metrics\">Metrics</h2>\n<h3>Tracks</h3>\n"
    });
    s.push_str(&track_metrics_html(d));
    s.push_str(&monte_carlo_html(d));
    s.push_str(&bounds_html(d));
    s.push_str(&run_metrics_html(d));
    s.push_str(&nodes_html(d));
    s.push_str("<h2 id=\"plots\">Plots</h2>\n");
    for (f, svg) in figs {
        s.push_str(&figure_html(f, svg));
    }
    s.push_str(&reproduce_html(d));
    s.push_str(&page_tail());
    s
}

/// Build the figures of `dir`, write them (SVG, and PNG with `png`) and
/// `dir/report.html`; returns the report's path.
pub fn write_report(dir: &Path, png: bool) -> Result<PathBuf, PlotError> {
    let data = load_run(dir)?;
    let figs = plot::run_figures(&data);
    let svgs = plot::write_figures(&figs, dir, Formats { svg: true, png })?;
    let html = report_html(&data, &figs.into_iter().zip(svgs).collect::<Vec<_>>());
    let path = dir.join("report.html");
    std::fs::write(&path, html).map_err(|e| PlotError::Write {
        path: path.clone(),
        source: e,
    })?;
    Ok(path)
}

/// Where `sonarnet report A B` writes by default: `A/compare-<B's name>.html`.
pub fn default_comparison_path(a: &Path, b: &Path) -> PathBuf {
    let name = b
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .or_else(|| b.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "b".into());
    a.join(format!("compare-{name}.html"))
}

fn better_is_lower(key: &str) -> Option<bool> {
    let last = key.rsplit('.').next().unwrap_or(key);
    match last {
        "rmse" | "rmse_after_burn_in" | "median_error" | "final_error" | "ctte" | "regret"
        | "max_disagreement" | "ml_rmse" | "wall_seconds" | "startup_seconds" | "declines" => {
            Some(true)
        }
        _ => None,
    }
}

/// The comparison page of runs `a` and `b`.
pub fn comparison_html(
    a: &RunData,
    b: &RunData,
    overlays: &[(Figure, String)],
    tracks: [&str; 2],
) -> String {
    let (la, lb) = ("A", "B");
    let title = format!("sonarnet comparison: {} vs {}", a.title(), b.title());
    let mut s = page_head(&title, overlays.len() + 2);
    let _ = write!(
        s,
        "<h1>Comparison</h1>\n<p class=\"sub\"><b>A</b> = {} ({})<br><b>B</b> = {} ({})</p>\n",
        esc(&a.title()),
        esc(&a.dir.display().to_string()),
        esc(&b.title()),
        esc(&b.dir.display().to_string())
    );
    // Scenario side by side.
    s.push_str("<h2 id=\"scenario\">Runs</h2>\n<table id=\"runs\">\n<tr><th></th><th>A</th><th>B</th></tr>\n");
    let (sa, sb) = (scenario_summary(a), scenario_summary(b));
    let mut keys: Vec<String> = sa.iter().map(|r| r.0.clone()).collect();
    for (k, _) in &sb {
        if !keys.contains(k) {
            keys.push(k.clone());
        }
    }
    let find = |rows: &[(String, String)], k: &str| {
        rows.iter()
            .find(|r| r.0 == k)
            .map_or("–".to_string(), |r| r.1.clone())
    };
    for k in keys.iter().filter(|k| k.as_str() != "description") {
        let (va, vb) = (find(&sa, k), find(&sb, k));
        let style = if va != vb {
            " style=\"background:#fff8e1\""
        } else {
            ""
        };
        let _ = writeln!(
            s,
            "<tr{style}><th>{}</th><td>{}</td><td>{}</td></tr>",
            esc(k),
            esc(&va),
            esc(&vb)
        );
    }
    let _ = writeln!(
        s,
        "<tr><th>status</th><td>{}</td><td>{}</td></tr>\n</table>",
        status_html(a.info.status.as_deref()),
        status_html(b.info.status.as_deref())
    );
    // Metrics diff.
    s.push_str("<h2 id=\"metrics\">Metrics diff</h2>\n<table id=\"metrics-diff\">\n<tr><th>metric</th><th>A</th><th>B</th><th>B − A</th><th>B / A</th></tr>\n");
    let (fa, fb) = (flat_metrics(&a.metrics), flat_metrics(&b.metrics));
    let mut keys: Vec<String> = fa.iter().map(|r| r.0.clone()).collect();
    for (k, _) in &fb {
        if !keys.contains(k) {
            keys.push(k.clone());
        }
    }
    let get = |rows: &[(String, f64)], k: &str| rows.iter().find(|r| r.0 == k).map(|r| r.1);
    for k in &keys {
        if k == "seed" {
            continue;
        }
        let (va, vb) = (get(&fa, k), get(&fb, k));
        let cell = |v: Option<f64>| v.map_or("–".into(), fmt_num);
        let (diff, ratio, class) = match (va, vb) {
            (Some(x), Some(y)) => {
                let class = match better_is_lower(k) {
                    Some(true) if y < x * (1.0 - 1e-9) => " better",
                    Some(true) if y > x * (1.0 + 1e-9) => " worse",
                    _ => "",
                };
                (
                    fmt_num(y - x),
                    if x.abs() > 0.0 {
                        format!("{:.3}", y / x)
                    } else {
                        "–".into()
                    },
                    class,
                )
            }
            _ => ("–".into(), "–".into(), ""),
        };
        let _ = writeln!(
            s,
            "<tr><th>{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num{class}\">{diff}</td><td class=\"num{class}\">{ratio}</td></tr>",
            esc(k),
            cell(va),
            cell(vb)
        );
    }
    s.push_str("</table>\n<p class=\"note\">Green: B is lower (better) on an error or cost metric; red: B is higher.</p>\n");
    s.push_str("<h2 id=\"plots\">Plots</h2>\n");
    for (f, svg) in overlays {
        s.push_str(&figure_html(f, svg));
    }
    let _ = write!(
        s,
        "<h3>Tracks</h3>\n<div class=\"grid2\">\n<figure class=\"plot\" id=\"plot-tracks-a\">\n{}\n<figcaption><b>{la}</b>: {}</figcaption>\n</figure>\n<figure class=\"plot\" id=\"plot-tracks-b\">\n{}\n<figcaption><b>{lb}</b>: {}</figcaption>\n</figure>\n</div>\n",
        inline_svg(tracks[0]),
        esc(&a.title()),
        inline_svg(tracks[1]),
        esc(&b.title())
    );
    s.push_str("<h2 id=\"reproduce\">Command lines and seeds</h2>\n");
    for (tag, d) in [(la, a), (lb, b)] {
        let cmd: Vec<String> = d.info.command_line.iter().map(|x| shell_quote(x)).collect();
        let _ = write!(
            s,
            "<h3>{tag} (seed {})</h3>\n<pre>{}</pre>\n",
            d.info.seed.map_or("-".into(), |x| x.to_string()),
            esc(&cmd.join(" "))
        );
    }
    s.push_str(&page_tail());
    s
}

/// Compare runs `a` and `b`: writes the comparison page to `out` (default
/// [`default_comparison_path`]) and, with `png`, the overlay plots as PNG
/// next to it; returns the page's path.
pub fn write_comparison(
    a: &Path,
    b: &Path,
    out: Option<&Path>,
    png: bool,
) -> Result<PathBuf, PlotError> {
    let da = load_run(a)?;
    let db = load_run(b)?;
    let overlays = plot::comparison_figures(&da, &db, "A", "B");
    let path = out.map_or_else(|| default_comparison_path(a, b), Path::to_path_buf);
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let svgs = plot::write_figures(&overlays, &dir, Formats { svg: false, png })?;
    let ta = plot::render_svg(&plot::figures::tracks_figure(&da))?;
    let tb = plot::render_svg(&plot::figures::tracks_figure(&db))?;
    let figs: Vec<(Figure, String)> = overlays.into_iter().zip(svgs).collect();
    let html = comparison_html(&da, &db, &figs, [&ta, &tb]);
    std::fs::write(&path, html).map_err(|e| PlotError::Write {
        path: path.clone(),
        source: e,
    })?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::data::{RunInfo, Track, TrackKind, TrackTable};
    use approx::assert_abs_diff_eq;
    use serde_json::json;

    fn data() -> RunData {
        let errs = [Some(10.0), Some(4.0), Some(2.0), Some(3.0)];
        let track = |name: &str, kind, e: &[Option<f64>]| Track {
            name: name.into(),
            kind,
            pos: vec![Some([0.0, 0.0]); 4],
            error: e.to_vec(),
            ctte: vec![None; 4],
            regret: None,
        };
        RunData {
            info: RunInfo {
                burn_in: Some(1),
                ..RunInfo::default()
            },
            metrics: json!({"rmse": 5.5, "ml_rmse": 1.25, "iterations": 10,
                "baselines": {"ogd": {"rmse": 7.0, "dynamic_regret": 3.0}},
                "bounds": {"minball": {"coverage": 1.0}},
                "realtime": {"declines": 4}})
            .as_object()
            .unwrap()
            .clone(),
            track: TrackTable {
                sample: vec![0.0, 1.0, 2.0, 3.0],
                truth: vec![Some([0.0, 0.0]); 4],
                tracks: vec![
                    track(THETA_BAR, TrackKind::Distributed, &errs),
                    track(ML, TrackKind::Reference, &errs),
                    track(
                        "ogd",
                        TrackKind::Baseline,
                        &[Some(1.0), None, Some(1.0), Some(1.0)],
                    ),
                ],
                ..TrackTable::default()
            },
            ..RunData::default()
        }
    }

    #[test]
    fn track_metrics_prefer_metrics_json_and_compute_the_rest_from_track_csv() {
        let d = data();
        let tm = track_metrics(&d);
        assert_eq!(
            tm.columns,
            [
                "rmse",
                "rmse_after_burn_in",
                "median_error",
                "final_error",
                "ctte",
                "dynamic_regret"
            ]
        );
        let row = |n: &str| &tm.rows.iter().find(|r| r.0 == n).unwrap().2;
        let col = |c: &str| tm.columns.iter().position(|x| x == c).unwrap();
        // theta_bar: rmse from metrics.json, the rest computed like metrics::score.
        let tb = row(THETA_BAR);
        assert_eq!(
            tb[col("rmse")],
            Some(Cell {
                value: 5.5,
                computed: false
            })
        );
        let s = crate::model::metrics::score(&[10.0, 4.0, 2.0, 3.0], 1).unwrap();
        let c = tb[col("rmse_after_burn_in")].unwrap();
        assert!(c.computed);
        assert_abs_diff_eq!(c.value, s.rmse_after_burn_in, epsilon = 1e-12);
        assert_abs_diff_eq!(tb[col("ctte")].unwrap().value, 19.0, epsilon = 1e-12);
        // ML: rmse is ml_rmse.
        assert_abs_diff_eq!(row(ML)[col("rmse")].unwrap().value, 1.25);
        // ogd: given values kept; a gap in its errors means nothing is computed.
        let ogd = row("ogd");
        assert_abs_diff_eq!(ogd[col("dynamic_regret")].unwrap().value, 3.0);
        assert_eq!(ogd[col("ctte")], None);
    }

    #[test]
    fn flat_metrics_include_baselines_bounds_and_realtime() {
        let f = flat_metrics(&data().metrics);
        let keys: Vec<&str> = f.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(keys[0], "rmse");
        for k in [
            "baselines.ogd.rmse",
            "baselines.ogd.dynamic_regret",
            "bounds.minball.coverage",
            "realtime.declines",
            "iterations",
        ] {
            assert!(keys.contains(&k), "{k} missing from {keys:?}");
        }
    }

    #[test]
    fn html_text_is_escaped_and_numbers_are_compact() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
        assert_eq!(fmt_num(5000.0), "5000");
        assert_eq!(fmt_num(2.50050041), "2.501");
        assert_eq!(fmt_num(0.0022714), "0.002271");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("--seed"), "--seed");
    }
}
