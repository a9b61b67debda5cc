//! Self-contained HTML report of a results directory.
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

mod compare;
mod html;
mod sections;
mod sweep;
mod tables;
pub use compare::{comparison_html, write_comparison};
pub use html::{caption, esc, fmt_num};
use html::{figure_html, page_head, page_tail, status_html};
#[cfg(test)]
use sections::shell_quote;
use sections::{
    bounds_html, faults_html, kv_table, monte_carlo_html, nodes_html, reproduce_html,
    run_metrics_html, track_metrics_html,
};
pub use sections::{group_by_track, scenario_summary, trial_stats};
pub use sweep::{sweep_plot, write_sweep_report};
pub use tables::{MetricsTable, TRACK_KEYS, comparison_metrics, track_metrics};

use crate::plot::data::RunData;
#[cfg(test)]
use crate::plot::data::{ML, THETA_BAR};
use crate::plot::{self, Figure, Formats, PlotError, load_run};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The report page of one run, with the SVG text of each figure.
pub fn report_html(d: &RunData, figs: &[(Figure, String)]) -> String {
    let title = format!("sonarnet report: {}", d.title());
    let mut s = page_head(&title, figs.len());
    let _ = write!(
        s,
        "<h1>{}</h1>\n<p class=\"sub\">{} · status {}</p>\n",
        esc(&d.title()),
        esc(d.info.description.as_deref().unwrap_or("")),
        status_html(d.info.run.status)
    );
    if let Some(e) = &d.info.run.error {
        let _ = writeln!(
            s,
            "<p class=\"status-bad\">The run stopped early: {}</p>",
            esc(e)
        );
    }
    if let Some(n) = d.metrics.as_ref().and_then(|m| m.note.as_deref()) {
        let _ = writeln!(s, "<p class=\"note\">Note: {}</p>", esc(n));
    }
    s.push_str("<h2 id=\"scenario\">Scenario</h2>\n");
    s.push_str(&kv_table(&scenario_summary(d)));
    s.push_str(if d.monte_carlo.is_some() {
        "<h2 id=\"metrics\">Metrics</h2>\n<h3>Tracks: one trial (trial 0, the one in metrics.json and track.csv)</h3>\n"
    } else {
        "<h2 id=\"metrics\">Metrics</h2>\n<h3>Tracks</h3>\n"
    });
    s.push_str(&track_metrics_html(d));
    s.push_str(&monte_carlo_html(d));
    s.push_str(&faults_html(d));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::data::{RunInfo, Track, TrackKind, TrackTable};
    use serde_json::json;

    fn data() -> RunData {
        let errs = [Some(10.0), Some(4.0), Some(2.0), Some(3.0)];
        let track = |name: &str, kind, e: &[Option<f64>]| Track {
            name: name.into(),
            kind,
            pos: vec![Some([0.0, 0.0, 0.0]); 4],
            error: e.to_vec(),
            ctte: vec![None; 4],
            regret: None,
        };
        RunData {
            info: RunInfo {
                burn_in: Some(1),
                ..RunInfo::default()
            },
            metrics: Some(
                crate::pipeline::RunMetrics::from_json(json!({"rmse": 5.5, "ml_rmse": 1.25, "iterations": 10,
                    "ml": {"rmse": 1.25, "ctte": 19.5},
                    "baselines": {"ogd": {"rmse": 7.0, "regret": 3.0}},
                    "bounds": {"minball": {"coverage": 1.0, "invalid_fraction": 0.0,
                        "empty_fraction": 0.0, "mean_bound": 4.0, "seconds_per_instance": 1e-5}},
                    "realtime": {"iterations_per_sample_min": 1, "iterations_per_sample_median": 2.0,
                        "iterations_per_sample_max": 3, "declines": 4, "iterations_per_second": 5.0}}))
                .unwrap(),
            ),
            track: TrackTable {
                sample: vec![0.0, 1.0, 2.0, 3.0],
                truth: vec![Some([0.0, 0.0, 0.0]); 4],
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
    fn track_metrics_are_read_from_metrics_json_and_never_computed() {
        let d = data();
        let tm = track_metrics(&d);
        let row = |n: &str| &tm.rows.iter().find(|r| r.0 == n).unwrap().2;
        let col = |c: &str| tm.columns.iter().position(|x| x == c).unwrap();
        // Columns in TRACK_KEYS order first, then the rest alphabetically.
        assert_eq!(tm.columns[..2], ["rmse", "ctte"]);
        assert!(tm.columns.contains(&"regret".to_string()));
        // theta_bar: an older file without the `theta_bar` object is read
        // with its top-level metrics; the error series of track.csv is not scored.
        let tb = row(THETA_BAR);
        assert_eq!(tb[col("rmse")], Some(5.5));
        assert_eq!(tb[col("ctte")], None, "19.0 from track.csv is not computed");
        // ML from the `ml` object, ogd from `baselines.ogd`.
        assert_eq!(row(ML)[col("ctte")], Some(19.5));
        assert_eq!(row("ogd")[col("regret")], Some(3.0));
        assert_eq!(row("ogd")[col("ctte")], None);
        // Without metrics.json there is no table.
        let mut none = d.clone();
        none.metrics = None;
        assert!(track_metrics(&none).rows.is_empty());
    }

    #[test]
    fn the_comparison_names_metrics_as_expect_does_with_the_run_counters_after_them() {
        let d = data();
        let f = comparison_metrics(d.metrics.as_ref());
        let keys: Vec<&str> = f.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(keys[0], "theta_bar.rmse");
        for k in [
            "ml.ctte",
            "ogd.rmse",
            "ogd.regret",
            "theta_bar.bounds.minball.coverage",
            "theta_bar.iterations",
            "realtime.declines",
            "wall_seconds",
        ] {
            assert!(keys.contains(&k), "{k} missing from {keys:?}");
        }
        let pos = |k: &str| keys.iter().position(|x| *x == k).unwrap();
        assert!(pos("ml.ctte") < pos("ogd.rmse"));
        assert!(pos("ogd.rmse") < pos("wall_seconds"));
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
