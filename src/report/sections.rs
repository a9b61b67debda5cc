//! The sections of a run's report: scenario summary, metrics, bounds, nodes, Monte
//! Carlo statistics, and how to reproduce the run.

use crate::plot::data::RunData;
use crate::report::html::esc;
use crate::report::html::fmt_num;
use crate::report::tables::TRACK_KEYS;
use crate::report::tables::num;
use crate::report::tables::track_metrics;
use serde_json::Map;
use serde_json::Value;
use std::fmt::Write as _;
pub(super) fn get<'a>(v: &'a Value, path: &[&str]) -> Option<&'a Value> {
    let mut c = v;
    for k in path {
        c = c.get(k)?;
    }
    (!c.is_null()).then_some(c)
}

pub(super) fn show(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Number(n) => n.to_string(),
        other => other.to_string(),
    }
}

pub(super) fn noise(v: Option<&Value>) -> Option<String> {
    noise_in(v, "")
}

/// [`noise`] with `unit` after every number that is a level of the noise
/// (`sigma`, `scale`, `mean`, ...): ` m` for ranges, ` rad` for DOA.
pub(super) fn noise_in(v: Option<&Value>, unit: &str) -> Option<String> {
    let v = v?;
    let model = v.get("model").map(show).unwrap_or_else(|| "?".into());
    let dimensionless = [
        "model", "p", "weights", "schedule", "alpha", "df", "nu", "shape",
    ];
    let rest: Vec<String> = v
        .as_object()?
        .iter()
        .filter(|(k, _)| k.as_str() != "model")
        .map(|(k, x)| {
            let u = if x.is_number() && !dimensionless.contains(&k.as_str()) {
                unit
            } else {
                ""
            };
            format!("{k} {}{u}", show(x))
        })
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
    let sc = &i.run.scenario;
    let mut rows: Vec<(String, String)> = Vec::new();
    let mut add = |k: &str, v: Option<String>| {
        if let Some(v) = v {
            rows.push((k.into(), v));
        }
    };
    add("scenario", Some(i.name.clone()));
    add("scenario file", i.run.scenario_file.clone());
    add(
        "geometry",
        Some(format!(
            "{}{} transmitters, {} receivers, {} network links",
            if d.dim() == 3 {
                "3-D (x, y, z; z up), "
            } else {
                "2-D, "
            },
            i.transmitters.len(),
            i.receivers.len(),
            i.edges.len()
        )),
    );
    add(
        "samples",
        get(sc, &["target", "samples"]).map(show).map(|s| {
            match d.metrics.as_ref().map(|m| m.samples_completed) {
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
        if d.dim() == 3 && meas.contains(&"DOA") {
            meas = meas
                .into_iter()
                .map(|m| {
                    if m == "DOA" {
                        "DOA (azimuth and elevation)"
                    } else {
                        m
                    }
                })
                .collect();
        }
        add("measurements", Some(meas.join(", ")));
    }
    add(
        "range noise",
        noise_in(get(sc, &["measurements", "range_noise"]), " m"),
    );
    add(
        "DOA noise",
        noise_in(get(sc, &["measurements", "doa_noise"]), " rad"),
    );
    add(
        "elevation noise",
        noise_in(get(sc, &["measurements", "elevation_noise"]), " rad"),
    );
    add("channel", channel_row(get(sc, &["channel"])));
    add("mode", i.run.mode.clone());
    add("local solver", i.run.local_solver.clone());
    if i.run.local_solver.as_deref() == Some("gtrs_l0") {
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
    add("engine", i.run.engine.clone());
    add("clock", i.run.clock.clone());
    if let Some(p) = i.run.poll_us.filter(|&p| p > 0) {
        add("node polling", Some(format!("{p} µs before blocking")));
    }
    add("seed", i.run.seed.map(|s| s.to_string()));
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

/// The network between the nodes in one line: ideal, or the acoustic
/// channel's bit rate, sound speed, time scale and switches.
fn channel_row(v: Option<&Value>) -> Option<String> {
    let Some(v) = v else {
        return Some("ideal (every frame arrives at once)".into());
    };
    let model = v.get("model").map(show).unwrap_or_else(|| "ideal".into());
    if model != "acoustic" {
        return Some(model);
    }
    let mut parts = vec!["acoustic".to_string()];
    for (k, label, unit) in [
        ("bit_rate", "bit rate", " bit/s"),
        ("sound_speed", "sound speed", " m/s"),
        ("time_scale", "time scale", "x"),
    ] {
        if let Some(x) = v.get(k) {
            parts.push(format!("{label} {}{unit}", show(x)));
        }
    }
    for k in ["half_duplex", "collisions"] {
        if let Some(b) = v.get(k).and_then(Value::as_bool) {
            parts.push(format!(
                "{} {}",
                k.replace('_', "-"),
                if b { "on" } else { "off" }
            ));
        }
    }
    if let Some(l) = v.get("loss") {
        parts.push(format!("loss {}", noise(Some(l)).unwrap_or_default()));
    }
    Some(parts.join(", "))
}

pub(super) fn kv_table(rows: &[(String, String)]) -> String {
    let mut s = String::from("<table class=\"kv\">\n");
    for (k, v) in rows {
        let _ = writeln!(s, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(v));
    }
    s.push_str("</table>\n");
    s
}

pub(super) fn track_metrics_html(d: &RunData) -> String {
    let tm = track_metrics(d);
    if tm.rows.is_empty() {
        return "<p class=\"note\">No track metrics (the directory has no metrics.json).</p>\n"
            .into();
    }
    // Wide tables (many bounds) scroll inside the page instead of
    // overflowing it.
    let mut s =
        String::from("<div class=\"scroll\">\n<table id=\"track-metrics\">\n<tr><th>track</th>");
    for c in &tm.columns {
        let unit = if TRACK_KEYS[..5].contains(&c.as_str()) {
            " (m)"
        } else {
            ""
        };
        let _ = write!(s, "<th>{}{unit}</th>", esc(c));
    }
    s.push_str("</tr>\n");
    for (name, label, cells) in &tm.rows {
        let _ = write!(
            s,
            "<tr data-track=\"{}\"><th>{}</th>",
            esc(name),
            esc(label)
        );
        for c in cells {
            match c {
                Some(v) => {
                    let _ = write!(s, "<td class=\"num\">{}</td>", fmt_num(*v));
                }
                None => s.push_str("<td class=\"num\">–</td>"),
            }
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n</div>\n");
    s
}

pub(super) fn run_metrics_html(d: &RunData) -> String {
    let Some(m) = &d.metrics else {
        return String::new();
    };
    let skip = |k: &str| {
        TRACK_KEYS.contains(&k)
            || matches!(
                k,
                "baselines"
                    | "bounds"
                    | "theta_bar"
                    | "ml"
                    | "nodes"
                    | "deaths"
                    | "realtime"
                    | "channel"
                    | "engine"
                    | "mode"
                    | "clock"
                    | "seed"
                    | "expect"
            )
    };
    let mut rows: Vec<(String, String)> = Vec::new();
    let all = match serde_json::to_value(m) {
        Ok(Value::Object(o)) => o,
        _ => Map::new(),
    };
    for (k, v) in &all {
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
    if let Some(Value::Object(rt)) = all.get("realtime") {
        for (k, v) in rt {
            rows.push((
                format!("realtime.{k}"),
                num(v).map_or_else(|| show(v), fmt_num),
            ));
        }
    }
    // The acoustic channel: its scalars, the losses by reason in one row;
    // the per-link ratios are drawn in channel.svg.
    if let Some(Value::Object(ch)) = all.get("channel") {
        for (k, v) in ch {
            match (k.as_str(), v) {
                ("links", _) => {}
                ("lost", Value::Object(by)) => {
                    let list: Vec<String> = by.iter().map(|(r, n)| format!("{r} {n}")).collect();
                    let text = if list.is_empty() {
                        "none".into()
                    } else {
                        list.join(", ")
                    };
                    rows.push(("channel.lost".into(), text));
                }
                _ => {
                    let text = num(v).map_or_else(|| show(v), fmt_num);
                    rows.push((format!("channel.{k}"), text));
                }
            }
        }
    }
    if !m.deaths.is_empty() {
        let list: Vec<String> = m
            .deaths
            .iter()
            .map(|x| format!("node {} at sample {} ({})", x.node, x.sample, x.how))
            .collect();
        rows.push(("deaths".into(), list.join("; ")));
    }
    let expect = expect_html(&m.expect);
    if rows.is_empty() {
        return expect;
    }
    format!("<h3>Run</h3>\n{}{expect}", kv_table(&rows))
}

/// The `[expect]` checks of a run as a table: the relation, both sides,
/// and whether it holds.
pub(super) fn expect_html(checks: &[crate::pipeline::ExpectResult]) -> String {
    if checks.is_empty() {
        return String::new();
    }
    let held = checks.iter().filter(|c| c.holds).count();
    let mut s = format!(
        "<h3 id=\"expect\">Expectations: {held} of {} hold</h3>\n<table id=\"expect-table\">\n<tr><th>expectation</th><th>left</th><th>right</th><th>holds</th></tr>\n",
        checks.len()
    );
    for c in checks {
        let side = |v: Option<f64>| v.map_or("–".to_string(), fmt_num);
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            esc(&c.expect),
            side(c.lhs),
            side(c.rhs),
            if c.holds {
                "<span class=\"status-ok\">yes</span>"
            } else {
                "<span class=\"status-bad\">no</span>"
            }
        );
    }
    s.push_str("</table>\n");
    s
}

/// A table of objects with the union of their keys as columns.
/// Columns that are `null` in every row are left out.
/// The faults of the run (`metrics.json` `faults`): one row each, with its
/// detection, recovery and peak error.
pub(super) fn faults_html(d: &RunData) -> String {
    let Some(m) = &d.metrics else {
        return String::new();
    };
    if m.faults.is_empty() {
        return String::new();
    }
    let rows: Vec<(String, Map<String, Value>)> = m
        .faults
        .iter()
        .enumerate()
        .filter_map(|(i, f)| match serde_json::to_value(f) {
            Ok(Value::Object(o)) => Some((format!("{i}"), o)),
            _ => None,
        })
        .collect();
    format!(
        "<h3>Faults</h3>\n<p>Recovery: samples from the end of a fault (its start if instantaneous) until the error of θ̄ is back within 1.5x its mean over the five samples before it.</p>\n{}",
        objects_table("faults", "#", &rows)
    )
}

pub(super) fn objects_table(
    id: &str,
    first: &str,
    rows: &[(String, Map<String, Value>)],
) -> String {
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

pub(super) fn bounds_html(d: &RunData) -> String {
    let Some(m) = d.metrics.as_ref().filter(|m| !m.bounds.is_empty()) else {
        return String::new();
    };
    let rows: Vec<(String, Map<String, Value>)> = m
        .bounds
        .iter()
        .map(|(k, v)| (k.clone(), object(v)))
        .collect();
    format!(
        "<h3>Bounds</h3>\n{}",
        objects_table("bounds", "bound", &rows)
    )
}

/// A typed record as a JSON object, for the generic tables.
fn object(v: &impl serde::Serialize) -> Map<String, Value> {
    match serde_json::to_value(v) {
        Ok(Value::Object(o)) => o,
        _ => Map::new(),
    }
}

pub(super) fn nodes_html(d: &RunData) -> String {
    let nodes = d.node_counters();
    if nodes.is_empty() {
        return String::new();
    }
    let rows: Vec<(String, Map<String, Value>)> = nodes
        .iter()
        .map(|c| {
            let mut o = object(c);
            o.remove("node");
            (format!("R{}", c.node), o)
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

pub(super) fn monte_carlo_html(d: &RunData) -> String {
    let Some(mc) = &d.monte_carlo else {
        return String::new();
    };
    let stats = trial_stats(mc);
    let mut s = format!(
        "<h3>Monte Carlo: {} trials</h3>\n<p class=\"note\">Statistics over the trials, one table per track. \
         For rmse, <b>mean</b> is the mean of the per-trial RMSE and <b>RMS over trials</b> is \
         √(mean of the per-trial RMSE²), the RMSE of every sample of every trial pooled.</p>\n",
        mc.trials.unwrap_or(mc.trial_rows.len() as u64)
    );
    for (track, rows) in group_by_track(&stats) {
        let _ = write!(
            s,
            "<h4>{}</h4>\n<table class=\"trial-stats\" id=\"trial-stats-{}\">\n<tr><th>metric</th><th>trials</th><th>mean</th><th>RMS over trials</th><th>std</th><th>p5</th><th>median</th><th>p95</th></tr>\n",
            esc(&track),
            esc(&track)
        );
        for (metric, n, v, rms) in rows {
            let _ = write!(s, "<tr><th>{}</th><td class=\"num\">{n}</td>", esc(&metric));
            let _ = write!(s, "<td class=\"num\">{}</td>", fmt_num(v[0]));
            let _ = write!(
                s,
                "<td class=\"num\">{}</td>",
                rms.map_or("–".to_string(), fmt_num)
            );
            for x in &v[1..] {
                let _ = write!(s, "<td class=\"num\">{}</td>", fmt_num(*x));
            }
            s.push_str("</tr>\n");
        }
        s.push_str("</table>\n");
    }
    s
}

/// A track's statistics: `(metric, n, [mean, std, p5, median, p95], RMS
/// over trials for the rmse metrics)`.
type TrackStats = Vec<(String, usize, [f64; 5], Option<f64>)>;

/// [`trial_stats`] grouped by track (the name before the first `.`;
/// `theta_bar` and `ml` first, run-wide columns under `run`), with the
/// RMS over trials of every `rmse*` metric.
pub fn group_by_track(stats: &[(String, usize, [f64; 5])]) -> Vec<(String, TrackStats)> {
    let mut groups: Vec<(String, TrackStats)> = Vec::new();
    for (c, n, v) in stats {
        let (track, metric) = c.split_once('.').unwrap_or(("run", c.as_str()));
        // sqrt(mean x^2) = sqrt(mean^2 + var (n-1)/n).
        let rms = metric.starts_with("rmse").then(|| {
            let var = v[1] * v[1] * (*n as f64 - 1.0).max(0.0) / (*n as f64).max(1.0);
            (v[0] * v[0] + var).sqrt()
        });
        let row = (metric.to_string(), *n, *v, rms);
        match groups.iter_mut().find(|g| g.0 == track) {
            Some(g) => g.1.push(row),
            None => groups.push((track.to_string(), vec![row])),
        }
    }
    let rank = |t: &str| match t {
        "theta_bar" => 0,
        "ml" => 1,
        "run" => 3,
        _ => 2,
    };
    groups.sort_by_key(|g| rank(&g.0));
    groups
}

/// Quote a command-line argument for a POSIX shell when needed.
pub(super) fn shell_quote(a: &str) -> String {
    if !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}

pub(super) fn reproduce_html(d: &RunData) -> String {
    let cmd = if d.info.run.command_line.is_empty() {
        "(not recorded)".to_string()
    } else {
        d.info
            .run
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
                d.info.run.seed.map_or("-".into(), |x| x.to_string())
            ),
            (
                "crate version".into(),
                d.info
                    .run
                    .crate_version
                    .clone()
                    .unwrap_or_else(|| "-".into())
            ),
            ("results directory".into(), d.dir.display().to_string()),
        ])
    );
    let pretty = serde_json::to_string_pretty(&d.info.run.scenario).unwrap_or_default();
    let _ = write!(
        s,
        "<details><summary>Resolved scenario (run.json)</summary>\n<pre>{}</pre>\n</details>\n",
        esc(&pretty)
    );
    s
}
