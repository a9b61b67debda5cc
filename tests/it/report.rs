//! Plots and the HTML report: every run leaves its SVG plots,
//! `sonarnet report` writes a self-contained page that renders in headless
//! Chromium without errors, two runs compare side by side, and bad input
//! exits with code 2 and one clear message.

use crate::util::{
    TempDir, check_selftest, chromium_or_skip, page_selftest, png_is_blank, run_file, scenario,
    screenshot, sonarnet,
};
use std::path::Path;
use std::time::Duration;

const PLOTS: [&str; 5] = ["tracks", "error", "consensus", "ctte", "network"];

/// Run the spiral scenario briefly (20 samples, 10 iterations each) into `out`.
fn small_run(out: &Path, extra: &[&str]) {
    let sc = scenario("mourya2017-spiral.toml");
    let mut args = vec![
        "run",
        sc.to_str().unwrap(),
        "--samples",
        "20",
        "--iterations-per-sample",
        "10",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = sonarnet(&args, Duration::from_secs(120));
    assert!(
        o.status.success(),
        "sonarnet run failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()))
}

/// No external resource: the only URL allowed is the SVG namespace.
fn assert_self_contained(html: &str) {
    let stripped = html
        .replace("http://www.w3.org/2000/svg", "")
        .replace("http://www.w3.org/1999/xlink", "");
    for needle in ["http://", "https://", "<link", "src=", "@import", "url("] {
        assert!(
            !stripped.contains(needle),
            "page must be self-contained, found `{needle}`"
        );
    }
}

#[test]
fn every_run_leaves_svg_plots_in_its_results_directory() {
    let tmp = TempDir::new("plots");
    let out = tmp.path().join("run");
    small_run(&out, &[]);
    for p in PLOTS {
        let svg = read(&out.join(format!("{p}.svg")));
        assert!(
            svg.trim_start().starts_with("<svg"),
            "{p}.svg is not an SVG"
        );
        assert!(svg.trim_end().ends_with("</svg>"), "{p}.svg is truncated");
    }
    assert!(
        !out.join("report.html").exists(),
        "without --report, run writes no page"
    );
}

#[test]
fn run_with_report_writes_a_self_contained_page_with_metrics_plots_and_command_line() {
    let tmp = TempDir::new("report");
    let out = tmp.path().join("run");
    small_run(&out, &["--report", "--seed", "4"]);
    let html = read(&out.join("report.html"));
    assert_self_contained(&html);
    assert_eq!(html.matches("<figure class=\"plot\"").count(), PLOTS.len());
    for p in PLOTS {
        assert!(html.contains(&format!("id=\"plot-{p}\"")), "no {p} figure");
    }
    // Metrics of every track, scenario summary, command line and seed.
    assert!(html.contains("data-track=\"theta_bar\""));
    assert!(html.contains("data-track=\"ml\""));
    assert!(html.contains("mourya2017-spiral"));
    assert!(html.contains("--seed 4"), "command line missing");
    assert!(html.contains("<tr><th>seed</th><td>4</td></tr>"));
    // `sonarnet report DIR` rewrites it, and --png adds PNGs.
    std::fs::remove_file(out.join("report.html")).unwrap();
    let o = sonarnet(
        &["report", out.to_str().unwrap(), "--png"],
        Duration::from_secs(60),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("report.html").is_file());
    for p in PLOTS {
        let bytes = std::fs::read(out.join(format!("{p}.png"))).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{p}.png");
        assert!(
            !png_is_blank(&out.join(format!("{p}.png"))),
            "{p}.png is blank"
        );
    }
}

#[test]
fn report_of_two_runs_compares_them_side_by_side() {
    let tmp = TempDir::new("compare");
    let a = tmp.path().join("sync");
    let b = tmp.path().join("async");
    small_run(&a, &["--mode", "sync"]);
    small_run(&b, &["--mode", "async"]);
    let o = sonarnet(
        &["report", a.to_str().unwrap(), b.to_str().unwrap()],
        Duration::from_secs(60),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let page = a.join("compare-async.html");
    let html = read(&page);
    assert_self_contained(&html);
    assert!(html.contains("id=\"metrics-diff\""));
    assert!(
        html.contains("<tr><th>theta_bar.rmse</th>"),
        "diff table lacks theta_bar.rmse"
    );
    for id in [
        "plot-compare-error",
        "plot-compare-ctte",
        "plot-tracks-a",
        "plot-tracks-b",
    ] {
        assert!(html.contains(id), "no {id}");
    }
    // Both modes appear, and the mode row is flagged as differing.
    assert!(html.contains("<td>sync</td><td>async</td>"));
}

fn assert_bad_input(args: &[&str], needle: &str) {
    let o = sonarnet(args, Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "`sonarnet {}` must exit 2; stderr:\n{stderr}",
        args.join(" ")
    );
    assert!(!stderr.contains("panicked"), "must not panic:\n{stderr}");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "one error line:\n{stderr}"
    );
    assert!(
        stderr.contains(needle),
        "message must contain `{needle}`:\n{stderr}"
    );
}

#[test]
fn report_on_bad_input_fails_with_a_clear_message_and_exit_code_2() {
    let tmp = TempDir::new("report-bad");
    let missing = tmp.path().join("nope");
    assert_bad_input(&["report", missing.to_str().unwrap()], "no such directory");
    let empty = tmp.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    assert_bad_input(
        &["report", empty.to_str().unwrap()],
        "not a sonarnet results directory: it has no run.json",
    );
    let run = tmp.path().join("run");
    small_run(&run, &[]);
    std::fs::remove_file(run.join("track.csv")).unwrap();
    assert_bad_input(
        &["report", run.to_str().unwrap()],
        "track.csv: missing file",
    );
    // In a comparison too, and a corrupt file names its line.
    let other = tmp.path().join("other");
    small_run(&other, &[]);
    std::fs::write(other.join("metrics.json"), "{\n  \"rmse\": ,\n}").unwrap();
    assert_bad_input(
        &["report", empty.to_str().unwrap(), other.to_str().unwrap()],
        "has no run.json",
    );
    let good = tmp.path().join("good");
    small_run(&good, &[]);
    assert_bad_input(
        &["report", good.to_str().unwrap(), other.to_str().unwrap()],
        "metrics.json: line 2: invalid JSON",
    );
}

/// Turn a run directory into a Monte Carlo directory of 3 trials, with the
/// summary.json format documented in `plot::data::MonteCarlo`.
fn make_monte_carlo(dir: &Path) {
    let k = 20;
    let ramp = |base: f64| -> serde_json::Value {
        let mean: Vec<f64> = (0..k).map(|i| base / (1.0 + i as f64)).collect();
        let p5: Vec<f64> = mean.iter().map(|m| m * 0.5).collect();
        let p95: Vec<f64> = mean.iter().map(|m| m * 2.0).collect();
        serde_json::json!({"mean": mean, "p5": p5, "p95": p95})
    };
    let cum = |base: f64| -> serde_json::Value {
        let mut s = 0.0;
        let mean: Vec<f64> = (0..k)
            .map(|i| {
                s += base / (1.0 + i as f64);
                s
            })
            .collect();
        let p5: Vec<f64> = mean.iter().map(|m| m * 0.7).collect();
        let p95: Vec<f64> = mean.iter().map(|m| m * 1.4).collect();
        serde_json::json!({"mean": mean, "p5": p5, "p95": p95})
    };
    let summary = serde_json::json!({
        "trials": 3,
        "sample": (0..k).collect::<Vec<_>>(),
        "curves": {
            "theta_bar": {"error": ramp(300.0), "ctte": cum(300.0)},
            "ml": {"error": ramp(5.0), "ctte": cum(5.0)},
            "ogd": {"error": ramp(60.0), "ctte": cum(60.0), "regret": cum(2.0)}
        },
        "crlb": ramp(3.0)
    });
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary).unwrap(),
    )
    .unwrap();
    std::fs::write(
        dir.join("trials.csv"),
        "trial,seed,rmse,rmse_after_burn_in,ctte\n0,10,50.5,20.1,900\n1,11,40.25,18.5,850\n2,12,61,25.75,1002.5\n",
    )
    .unwrap();
}

#[test]
fn monte_carlo_directory_reports_trial_statistics_and_percentile_bands() {
    let tmp = TempDir::new("report-mc");
    let out = tmp.path().join("mc");
    small_run(&out, &[]);
    make_monte_carlo(&out);
    let o = sonarnet(&["report", out.to_str().unwrap()], Duration::from_secs(60));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = read(&out.join("report.html"));
    // Grouped by track (these columns have no track prefix: `run`).
    assert!(html.contains("id=\"trial-stats-run\""));
    assert!(html.contains("Monte Carlo: 3 trials"));
    // mean of rmse over the three trials: (50.5 + 40.25 + 61) / 3 = 50.58,
    // RMS over trials: sqrt((50.5^2 + 40.25^2 + 61^2) / 3) = 51.29.
    assert!(
        html.contains("<td class=\"num\">50.58</td><td class=\"num\">51.29</td>"),
        "mean and RMS of rmse"
    );
    assert!(html.contains("Tracks: one trial"));
    let err = read(&out.join("error.svg"));
    assert!(err.contains("<polygon"), "error.svg has no percentile band");
    assert!(err.contains("ogd"), "error.svg lacks the ogd baseline");
    let ctte = read(&out.join("ctte.svg"));
    assert!(
        ctte.contains("dynamic regret"),
        "ctte.svg has no regret panel"
    );
}

/// The headless-browser check: the page loads without console errors, every
/// plot has a non-zero size, the screenshot is not blank; and each of these
/// checks fails on a page broken on purpose.
#[test]
fn report_renders_in_headless_chromium_without_errors() {
    let Some(chromium) = chromium_or_skip("report_renders_in_headless_chromium_without_errors")
    else {
        return;
    };
    let tmp = TempDir::new("report-chromium");
    let out = tmp.path().join("run");
    small_run(&out, &["--report"]);
    let page = out.join("report.html");
    let st = page_selftest(&chromium, &page).unwrap();
    check_selftest(&st).unwrap_or_else(|e| panic!("report.html: {e}\n{st}"));
    assert_eq!(st["plots"].as_array().unwrap().len(), PLOTS.len());
    let shot = tmp.path().join("shot.png");
    screenshot(&chromium, &page, &shot);
    assert!(
        !png_is_blank(&shot),
        "the screenshot of report.html is blank"
    );

    // The comparison page passes the same checks.
    let b = tmp.path().join("sync");
    small_run(&b, &["--mode", "sync"]);
    let o = sonarnet(
        &["report", out.to_str().unwrap(), b.to_str().unwrap()],
        Duration::from_secs(60),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cmp = out.join("compare-sync.html");
    let st = page_selftest(&chromium, &cmp).unwrap();
    check_selftest(&st).unwrap_or_else(|e| panic!("compare-sync.html: {e}\n{st}"));

    // The checks fail on broken pages.
    let html = read(&page);
    let zero = tmp.path().join("zero.html");
    let i = html.find("<svg width=\"").expect("an inline svg");
    let j = i + html[i..].find('>').unwrap();
    let broken = format!(
        "{}<svg width=\"0\" height=\"0\" xmlns=\"http://www.w3.org/2000/svg\"{}",
        &html[..i],
        &html[j..]
    );
    std::fs::write(&zero, broken).unwrap();
    let e = check_selftest(&page_selftest(&chromium, &zero).unwrap()).unwrap_err();
    assert!(e.contains("zero size"), "{e}");
    let scripted = tmp.path().join("error.html");
    std::fs::write(
        &scripted,
        html.replacen(
            "</main>",
            "<script>no_such_function_in_sonarnet_report();</script></main>",
            1,
        ),
    )
    .unwrap();
    let e = check_selftest(&page_selftest(&chromium, &scripted).unwrap()).unwrap_err();
    assert!(e.contains("no_such_function_in_sonarnet_report"), "{e}");
    let logged = tmp.path().join("console.html");
    std::fs::write(
        &logged,
        html.replacen(
            "</main>",
            "<script>console.error('plot failed');</script></main>",
            1,
        ),
    )
    .unwrap();
    let e = check_selftest(&page_selftest(&chromium, &logged).unwrap()).unwrap_err();
    assert!(e.contains("plot failed"), "{e}");
    let blank = tmp.path().join("blank.html");
    std::fs::write(&blank, "<!DOCTYPE html><html><body></body></html>").unwrap();
    let blank_shot = tmp.path().join("blank.png");
    screenshot(&chromium, &blank, &blank_shot);
    assert!(
        png_is_blank(&blank_shot),
        "a blank page must be detected as blank"
    );
}

#[test]
fn a_4096_node_network_is_drawn_with_its_markers_and_without_a_label_per_node() {
    let tmp = TempDir::new("plot-4096");
    let n = 4096;
    let file = tmp.write("ring.toml", &sonarnet::pipeline::bench::ring_toml(n, 2, 2));
    let out = tmp.path().join("out");
    let o = run_file(
        &file,
        &out,
        &["--engine", "inprocess"],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = read(&out.join("network.svg"));
    // A marker per node (every node is drawn), no "R<i>" label past 256 nodes.
    assert!(svg.matches("<circle").count() >= n, "markers missing");
    assert!(
        !svg.contains(">R4095"),
        "per-node labels drawn for 4096 nodes"
    );
}

#[test]
fn the_report_lists_expectations_as_a_table_and_the_ml_regret_it_has() {
    let tmp = TempDir::new("report-expect");
    let out = tmp.path().join("r");
    small_run(&out, &["--engine", "inprocess", "--baselines", "ogd,ls"]);
    let o = sonarnet(&["report", out.to_str().unwrap()], Duration::from_secs(60));
    assert!(o.status.success());
    let html = read(&out.join("report.html"));
    assert!(html.contains("id=\"expect-table\""), "expectations table");
    assert!(html.contains("<td>theta_bar.rmse_after_burn_in &lt;= 20.0</td>"));
    assert!(!html.contains("[{&quot;expect"), "raw JSON in the report");
    // The ML reference's regret is in metrics.json and in the track table.
    let m = crate::util::metrics(&out);
    let regret = m["ml"]["regret"]
        .as_f64()
        .expect("ml.regret in metrics.json");
    let row_start = html
        .find("<th>centralised ML</th>")
        .or_else(|| html.find(">centralised ML<"))
        .unwrap();
    let row = &html[row_start..row_start + html[row_start..].find("</tr>").unwrap()];
    assert!(row.contains(&sonarnet::report::fmt_num(regret)), "{row}");
}
