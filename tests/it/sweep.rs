//! `sonarnet sweep`: the grid times the seeds, the tables, the
//! plot and the page, input errors before any work, Ctrl-C.

use crate::util::{
    TempDir, check_selftest, chromium_or_skip, metrics, page_selftest, read_rows, run_file,
    scenario, sonarnet, spawn_sonarnet, wait_for_sigint_handler, wait_watchdog,
};
use std::collections::HashMap;
use std::time::{Duration, Instant};

const LIMIT: Duration = Duration::from_secs(300);

fn table(path: &std::path::Path) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let mut r = csv::Reader::from_path(path).unwrap();
    let head: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| {
            head.iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect();
    (head, rows)
}

fn sweep(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let spiral = scenario("mourya2017-spiral.toml");
    let mut args = vec![
        "sweep",
        spiral.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    sonarnet(&args, LIMIT)
}

#[test]
fn a_sweep_runs_every_grid_point_at_every_seed_and_summarises_them() {
    let t = TempDir::new("sweep");
    let out = t.path().join("s");
    let o = sweep(
        &out,
        &[
            "--grid",
            "algorithm.gamma=1e-8,1e-7",
            "--grid",
            "algorithm.mode=sync,async",
            "--seeds",
            "0..1",
            "--set",
            "target.samples=12",
            "--plots",
            "--quiet",
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains(&format!("report     {}", out.join("report.html").display())));
    // sweep.csv: 2 x 2 points x 2 seeds, in grid order, then seed order.
    let (head, runs) = table(&out.join("sweep.csv"));
    assert_eq!(runs.len(), 8);
    for k in [
        "point",
        "algorithm.gamma",
        "algorithm.mode",
        "seed",
        "status",
        "dir",
    ] {
        assert!(head.iter().any(|h| h == k), "{k} in {head:?}");
    }
    let order: Vec<(&str, &str, &str)> = runs
        .iter()
        .map(|r| {
            (
                r["algorithm.gamma"].as_str(),
                r["algorithm.mode"].as_str(),
                r["seed"].as_str(),
            )
        })
        .collect();
    assert_eq!(order[0], ("1e-8", "sync", "0"));
    assert_eq!(order[1], ("1e-8", "sync", "1"));
    assert_eq!(order[2], ("1e-8", "async", "0"));
    assert_eq!(order[7], ("1e-7", "async", "1"));
    // Each row is its run directory's metrics.json.
    for r in &runs {
        let m = metrics(&out.join(&r["dir"]));
        let v: f64 = r["theta_bar.rmse_after_burn_in"].parse().unwrap();
        approx::assert_relative_eq!(
            v,
            m["rmse_after_burn_in"].as_f64().unwrap(),
            max_relative = 0.0
        );
        assert_eq!(r["status"], "ok");
        // --plots: each run's plots, as `sonarnet run` draws them.
        for f in ["error.svg", "tracks.svg", "network.svg"] {
            assert!(out.join(&r["dir"]).join(f).exists(), "{f} of {}", r["dir"]);
        }
    }
    // One point equals the same run made by `sonarnet run --set`.
    let single = t.path().join("single");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &single,
        &[
            "--engine",
            "inprocess",
            "--quiet",
            "--seed",
            "1",
            "--set",
            "target.samples=12",
            "--set",
            "algorithm.gamma=1e-7",
            "--set",
            "algorithm.mode=async",
        ],
        LIMIT,
    );
    assert!(o.status.success());
    assert_eq!(
        std::fs::read_to_string(single.join("nodes.csv")).unwrap(),
        std::fs::read_to_string(out.join(&runs[7]["dir"]).join("nodes.csv")).unwrap()
    );
    // The summary: mean and std over the two seeds of each point.
    let (_, sum) = table(&out.join("sweep-summary.csv"));
    assert_eq!(sum.len(), 4);
    for (i, s) in sum.iter().enumerate() {
        assert_eq!(s["n"], "2");
        let xs: Vec<f64> = runs[2 * i..2 * i + 2]
            .iter()
            .map(|r| r["theta_bar.rmse_after_burn_in"].parse().unwrap())
            .collect();
        let mean = (xs[0] + xs[1]) / 2.0;
        let std = ((xs[0] - mean).powi(2) + (xs[1] - mean).powi(2)).sqrt();
        let got = |k: &str| {
            s[&format!("theta_bar.rmse_after_burn_in.{k}")]
                .parse::<f64>()
                .unwrap()
        };
        approx::assert_relative_eq!(got("mean"), mean, max_relative = 1e-15);
        approx::assert_relative_eq!(got("std"), std, max_relative = 1e-12);
    }
    // The plot: one line per mode, on a linear x axis (1e-8..1e-7 spans 10x).
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("algorithm.mode=sync") && svg.contains("algorithm.mode=async"));
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.contains("id=\"sweep-points\"") && page.contains("runs/p000-seed0/"));
    // The page renders.
    if let Some(chromium) = chromium_or_skip("sweep report") {
        let v = page_selftest(&chromium, &out.join("report.html")).unwrap();
        check_selftest(&v).unwrap();
        let shot = t.path().join("sweep.png");
        crate::util::screenshot(&chromium, &out.join("report.html"), &shot);
        assert!(
            !crate::util::png_is_blank(&shot),
            "the sweep page renders blank"
        );
    }
}

#[test]
fn a_bad_grid_is_refused_before_any_work_with_exit_2() {
    let t = TempDir::new("sweep-bad");
    for (args, says) in [
        (
            vec!["--grid", "algorithm.gamma=1e-7,-1"],
            "--grid algorithm.gamma=-1: algorithm.gamma: must be finite and > 0",
        ),
        (vec!["--grid", "algorithm.gama=1"], "unknown field `gama`"),
        (
            vec!["--grid", "algorithm.gamma=1e-7", "--seeds", "9..1"],
            "--seeds: `9..1`: the range is empty",
        ),
        (vec!["--grid", "algorithm.gamma=1,1"], "1 is listed twice"),
    ] {
        let out = t.path().join("s");
        let o = sweep(&out, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!out.join("runs").exists(), "no run was made for {args:?}");
    }
}

#[test]
fn ctrl_c_stops_a_sweep_and_keeps_the_completed_points() {
    let _cpu = crate::util::cpu_exclusive();
    let t = TempDir::new("sweep-int");
    let out = t.path().join("s");
    let spiral = scenario("mourya2017-spiral.toml");
    let child = spawn_sonarnet(&[
        "sweep",
        spiral.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--grid",
        "algorithm.gamma=1e-9,1e-8,1e-7,1e-6",
        "--seeds",
        "0..49",
        "--jobs",
        "1",
        "--quiet",
    ]);
    let pid = child.id();
    wait_for_sigint_handler(pid, Duration::from_secs(60));
    // Wait for three finished runs.
    let start = Instant::now();
    let finished = || {
        std::fs::read_dir(out.join("runs"))
            .map(|d| {
                d.flatten()
                    .filter(|e| e.path().join("metrics.json").exists())
                    .count()
            })
            .unwrap_or(0)
    };
    while finished() < 3 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "watchdog: no runs finished"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: plain kill(2) on our own child.
    unsafe { libc::kill(pid as i32, libc::SIGINT) };
    let o = wait_watchdog(child, "interrupted sweep", Duration::from_secs(120));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("interrupted after") && err.contains("of 200 runs"),
        "{err}"
    );
    let rows = read_rows(&out.join("sweep.csv"));
    assert!(rows.len() >= 3 && rows.len() < 200, "{} rows", rows.len());
    assert!(out.join("sweep-summary.csv").exists() && out.join("report.html").exists());
    // Without --plots the runs hold their results only.
    let svgs = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .flatten()
        .flat_map(|run| std::fs::read_dir(run.path()).unwrap().flatten())
        .filter(|f| f.path().extension().is_some_and(|e| e == "svg"))
        .count();
    assert_eq!(svgs, 0, "plots drawn without --plots");
}
