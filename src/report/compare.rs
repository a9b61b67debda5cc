//! `sonarnet report A B`: two runs side by side, with a metrics diff table and overlaid
//! curves.

use crate::plot;
use crate::plot::Figure;
use crate::plot::Formats;
use crate::plot::PlotError;
use crate::plot::data::RunData;
use crate::plot::load_run;
use crate::report::default_comparison_path;
use crate::report::html::esc;
use crate::report::html::figure_html;
use crate::report::html::fmt_num;
use crate::report::html::inline_svg;
use crate::report::html::page_head;
use crate::report::html::page_tail;
use crate::report::html::status_html;
use crate::report::sections::scenario_summary;
use crate::report::sections::shell_quote;
use crate::report::tables::comparison_metrics;
use std::fmt::Write as _;
use std::path::Path;
use std::path::PathBuf;
pub(super) fn better_is_lower(key: &str) -> Option<bool> {
    let last = key.rsplit('.').next().unwrap_or(key);
    match last {
        "rmse" | "rmse_after_burn_in" | "median_error" | "final_error" | "ctte" | "regret"
        | "max_disagreement" | "ml_rmse" | "wall_seconds" | "startup_seconds" | "declines" => {
            Some(true)
        }
        _ => None,
    }
}

/// The runs side by side (`<table id="runs">`), rows that differ
/// highlighted.
fn runs_table(s: &mut String, a: &RunData, b: &RunData) {
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
        status_html(a.info.run.status),
        status_html(b.info.run.status)
    );
}

/// Every metric of both runs with their difference and ratio
/// (`<table id="metrics-diff">`), coloured where lower is better.
fn metrics_diff(s: &mut String, a: &RunData, b: &RunData) {
    s.push_str("<h2 id=\"metrics\">Metrics diff</h2>\n<table id=\"metrics-diff\">\n<tr><th>metric</th><th>A</th><th>B</th><th>B − A</th><th>B / A</th></tr>\n");
    let (fa, fb) = (
        comparison_metrics(a.metrics.as_ref()),
        comparison_metrics(b.metrics.as_ref()),
    );
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
    runs_table(&mut s, a, b);
    metrics_diff(&mut s, a, b);
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
        let cmd: Vec<String> = d
            .info
            .run
            .command_line
            .iter()
            .map(|x| shell_quote(x))
            .collect();
        let _ = write!(
            s,
            "<h3>{tag} (seed {})</h3>\n<pre>{}</pre>\n",
            d.info.run.seed.map_or("-".into(), |x| x.to_string()),
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
