//! Ctrl-C and SIGTERM of in-process and Monte Carlo runs:
//! the completed work is written, marked `interrupted`, and the exit code is 1.

use crate::util::*;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn signal(pid: u32, sig: i32) {
    // SAFETY: plain kill(2) on our own child.
    unsafe { libc::kill(pid as i32, sig) };
}

fn rows(path: &std::path::Path) -> usize {
    read_rows(path).len()
}

#[test]
fn ctrl_c_stops_an_inprocess_run_and_writes_exactly_the_samples_completed() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("int-inprocess");
    let out = tmp.path().join("out");
    let sc = scenario("mourya2017-spiral.toml");
    // About 0.5 s per sample: the 100 samples cannot finish before the signal.
    let child = spawn_sonarnet(&[
        "run",
        sc.to_str().unwrap(),
        "--engine",
        "inprocess",
        "--iterations-per-sample",
        "50000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let pid = child.id();
    wait_for_sigint_handler(pid, LIMIT);
    std::thread::sleep(Duration::from_millis(1500));
    signal(pid, libc::SIGINT);
    let o = wait_watchdog(child, "interrupted in-process run", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("interrupted at sample"), "{stderr}");
    assert!(
        stderr.contains(out.to_str().unwrap()),
        "must say where: {stderr}"
    );
    let m = metrics(&out);
    assert_eq!(m["status"], "interrupted");
    let done = m["samples_completed"].as_u64().unwrap();
    assert!(done < 100, "{done} samples: the run was not interrupted");
    // Only completed samples are counted: the nodes' work on the samples
    // sent ahead is not (async: two prox solves per iteration).
    assert_eq!(m["iterations"].as_u64(), Some(done * 50_000));
    assert_eq!(m["prox_solves"].as_u64(), Some(2 * done * 50_000));
    assert_eq!(rows(&out.join("track.csv")) as u64, done);
}

#[test]
fn sigterm_stops_a_monte_carlo_run_keeping_and_summarising_the_completed_trials() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("int-mc");
    let out = tmp.path().join("out");
    let sc = scenario("mourya2017-spiral.toml");
    // About 0.5 s per trial on one core: 400 trials cannot finish in time.
    let child = spawn_sonarnet(&[
        "run",
        sc.to_str().unwrap(),
        "--trials",
        "400",
        "--iterations-per-sample",
        "5000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let pid = child.id();
    wait_for_sigint_handler(pid, LIMIT);
    std::thread::sleep(Duration::from_millis(2500));
    signal(pid, libc::SIGTERM);
    let o = wait_watchdog(child, "interrupted Monte Carlo run", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("interrupted after"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "interrupted");
    assert_eq!(summary["trials_requested"], 400);
    let done = summary["trials"].as_u64().unwrap();
    assert!(done < 400, "{done} trials: the run was not interrupted");
    // trials.csv holds the completed trials, none of them failed, and the
    // summary's statistics are over exactly those.
    let trials = read_rows(&out.join("trials.csv"));
    assert_eq!(trials.len() as u64, done);
    assert!(
        trials.iter().all(|r| r[2] == "0"),
        "a cut-short trial was kept"
    );
    if done > 0 {
        assert_eq!(
            summary["metrics"]["theta_bar.rmse"]["n"].as_f64(),
            Some(done as f64)
        );
    }
}
