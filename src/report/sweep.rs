//! The page and plot of a sweep (`sonarnet sweep`): `sweep.svg` and
//! `report.html`, with the grid, the chosen metric per point (mean ± std
//! over the seeds), and a link to every run.

use crate::pipeline::sweep::{Summary, SweepOutcome, SweepPlan, metric_key, summarise};
use crate::plot;
use crate::plot::Figure;
use crate::plot::PlotError;
use crate::plot::figures::{SweepCurve, sweep_figure};
use crate::report::html::esc;
use crate::report::html::fmt_num;
use crate::report::html::inline_svg;
use crate::report::html::page_head;
use crate::report::html::page_tail;
use crate::report::sections::kv_table;
use std::fmt::Write as _;
use std::path::Path;
use std::path::PathBuf;

/// The sweep figure of `metric` (a full name, see [`metric_key`]).
pub fn sweep_plot(plan: &SweepPlan, summary: &Summary, metric: &str) -> Figure {
    let first = &plan.axes[0];
    let numeric: Option<Vec<f64>> = first
        .values
        .iter()
        .map(|v| v.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    let x_of = |v: &str| -> f64 {
        let i = first.values.iter().position(|x| x == v).unwrap_or(0);
        numeric.as_ref().map_or(i as f64, |n| n[i])
    };
    // One curve per combination of the other keys (and the variant).
    let mut curves: Vec<SweepCurve> = Vec::new();
    for (p, _, _, stats) in summary {
        let (pt, _) = &plan.points[*p];
        let mut rest: Vec<String> = pt.values[1..]
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        if let Some(v) = &pt.variant {
            rest.push(format!("variant={v}"));
        }
        let label = if rest.is_empty() {
            metric.to_string()
        } else {
            rest.join(", ")
        };
        let Some((Some(mean), std, _)) = stats.get(metric).copied() else {
            continue;
        };
        let x = x_of(&pt.values[0].1);
        match curves.iter_mut().find(|c| c.label == label) {
            Some(c) => c.points.push((x, mean, std)),
            None => curves.push(SweepCurve {
                label,
                points: vec![(x, mean, std)],
            }),
        }
    }
    for c in &mut curves {
        c.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let cats = numeric.is_none().then_some(first.values.as_slice());
    sweep_figure(&first.key, cats, metric, &curves)
}

/// The grid points' table: each point's values, how many runs completed
/// and failed, `key`'s mean ± std, and links to its runs' directories
/// (relative to `out`).
fn points_table(
    s: &mut String,
    plan: &SweepPlan,
    o: &SweepOutcome,
    summary: &Summary,
    (key, out): (&str, &Path),
) {
    s.push_str(
        "<h2 id=\"points\">Grid points</h2>\n<table id=\"sweep-points\">\n<tr><th>point</th>",
    );
    for a in &plan.axes {
        let _ = write!(s, "<th>{}</th>", esc(&a.key));
    }
    if plan.has_variants {
        s.push_str("<th>variant</th>");
    }
    let _ = writeln!(
        s,
        "<th>n</th><th>failed</th><th>{} (mean ± std)</th><th>runs</th></tr>",
        esc(key)
    );
    for (p, ok, failed, stats) in summary {
        let (pt, _) = &plan.points[*p];
        let _ = write!(s, "<tr><td class=\"num\">{p}</td>");
        for (_, v) in &pt.values {
            let _ = write!(s, "<td>{}</td>", esc(v));
        }
        if plan.has_variants {
            let _ = write!(s, "<td>{}</td>", esc(pt.variant.as_deref().unwrap_or("")));
        }
        let cell = match stats.get(key).copied() {
            Some((Some(m), Some(sd), _)) => format!("{} ± {}", fmt_num(m), fmt_num(sd)),
            Some((Some(m), None, _)) => fmt_num(m),
            _ => "–".into(),
        };
        let links: Vec<String> = o
            .runs
            .iter()
            .filter(|r| r.point == *p)
            .map(|r| {
                let rel = r
                    .dir
                    .strip_prefix(out)
                    .unwrap_or(&r.dir)
                    .display()
                    .to_string();
                format!("<a href=\"{}/\">{}</a>", esc(&rel), r.seed)
            })
            .collect();
        let _ = writeln!(
            s,
            "<td class=\"num\">{ok}</td><td class=\"num\">{failed}</td><td class=\"num\">{}</td><td>seeds {}</td></tr>",
            esc(&cell),
            links.join(" ")
        );
    }
}

/// Write `sweep.svg` and `report.html` of a sweep into `out`; returns the
/// report's path. `metric` is the plotted metric as the user named it.
pub fn write_sweep_report(
    plan: &SweepPlan,
    o: &SweepOutcome,
    out: &Path,
    metric: &str,
    command: &str,
) -> Result<PathBuf, PlotError> {
    let summary = summarise(plan, &o.runs);
    let key = metric_key(&o.runs, metric).unwrap_or_else(|| metric.to_string());
    let fig = sweep_plot(plan, &summary, &key);
    // Drawn even after Ctrl-C (one quick figure): the completed points are
    // the sweep's results.
    let svg = plot::render_svg(&fig)?;
    let svg_path = out.join("sweep.svg");
    std::fs::write(&svg_path, &svg).map_err(|e| PlotError::Write {
        path: svg_path,
        source: e,
    })?;
    let mut s = page_head("sonarnet sweep", 1);
    let name = plan.points.first().map_or("", |(_, sc)| sc.name());
    let _ = write!(
        s,
        "<h1>Sweep of {}</h1>\n<p class=\"sub\">{} runs of {} grid points × {} seeds{}</p>\n",
        esc(name),
        o.runs.len(),
        plan.points.len(),
        plan.seeds.len(),
        if o.interrupted {
            format!(
                " · <span class=\"status-bad\">interrupted: {} of {} runs done</span>",
                o.runs.len(),
                o.requested
            )
        } else {
            String::new()
        }
    );
    s.push_str("<h2 id=\"grid\">Grid</h2>\n");
    let mut rows: Vec<(String, String)> = plan
        .axes
        .iter()
        .map(|a| (a.key.clone(), a.values.join(", ")))
        .collect();
    rows.push((
        "seeds".into(),
        plan.seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    ));
    s.push_str(&kv_table(&rows));
    s.push_str("<h2 id=\"plots\">Plot</h2>\n");
    let _ = write!(
        s,
        "<figure class=\"plot\" id=\"plot-sweep\">\n{}\n<figcaption><b>sweep.svg</b> — {} \
         (mean over the seeds of each grid point, error bars ± one standard deviation) against \
         {}, one line per combination of the other keys.</figcaption>\n</figure>\n",
        inline_svg(&svg),
        esc(&key),
        esc(&plan.axes[0].key)
    );
    points_table(&mut s, plan, o, &summary, (&key, out));
    s.push_str("</table>\n<p class=\"note\">Every run: sweep.csv; mean, std and n per point and metric: sweep-summary.csv.</p>\n");
    let _ = writeln!(
        s,
        "<h2 id=\"reproduce\">Reproduce</h2>\n<pre>{}</pre>",
        esc(command)
    );
    s.push_str(&page_tail());
    let path = out.join("report.html");
    std::fs::write(&path, s).map_err(|e| PlotError::Write {
        path: path.clone(),
        source: e,
    })?;
    Ok(path)
}
