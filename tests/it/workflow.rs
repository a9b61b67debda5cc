//! The researcher's workflow: `--set`, provenance in `run.json`,
//! `scenario.toml` and `sonarnet replay`, results directories that never mix
//! runs.

use crate::util::{TempDir, read_rows, run_file, scenario, sonarnet};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn text(o: &std::process::Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn run_json(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).unwrap()).unwrap()
}

#[test]
fn set_overrides_any_key_and_is_recorded_in_run_json() {
    let t = TempDir::new("set");
    let out = t.path().join("r");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &out,
        &[
            "--engine",
            "inprocess",
            "--quiet",
            "--set",
            "target.samples=14",
            "--set",
            "algorithm.gamma=3e-7",
            "--set",
            "algorithm.mode=sync",
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    // 14 samples of 6 nodes.
    assert_eq!(read_rows(&out.join("nodes.csv")).len(), 14 * 6);
    let rj = run_json(&out);
    assert_eq!(
        rj["overrides"],
        serde_json::json!([
            "target.samples=14",
            "algorithm.gamma=3e-7",
            "algorithm.mode=sync"
        ])
    );
    assert_eq!(rj["scenario"]["algorithm"]["gamma"], 3e-7);
    assert_eq!(rj["mode"], "sync");
}

#[test]
fn set_with_variant_applies_to_the_chosen_variant_only() {
    let t = TempDir::new("set-variant");
    let out = t.path().join("r");
    // `crash` is instantaneous: for_samples would be invalid there, but only
    // `pause` is run.
    let o = run_file(
        &scenario("mourya2017-spiral-faults.toml"),
        &out,
        &[
            "--variant",
            "pause",
            "--set",
            "faults[0].for_samples=5",
            "--quiet",
            "--samples",
            "40",
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    assert_eq!(run_json(&out)["scenario"]["faults"][0]["for_samples"], 5);
}

#[test]
fn a_bad_set_names_the_flag_and_the_key_and_exits_2_before_any_work() {
    let t = TempDir::new("set-bad");
    for (flag, says) in [
        (
            "algorithm.gamma=-1",
            "--set algorithm.gamma=-1: algorithm.gamma: must be finite and > 0",
        ),
        (
            "algorithm.gama=1",
            "--set algorithm.gama=1: unknown field `gama`",
        ),
        (
            "target.samples=many words",
            "--set target.samples=many words: not a TOML value",
        ),
        (
            "geometry.receivers[40]=[0,0]",
            "geometry.receivers has 6 entries, no [40]",
        ),
    ] {
        let out = t.path().join("r");
        let o = run_file(
            &scenario("mourya2017-spiral.toml"),
            &out,
            &["--engine", "inprocess", "--set", flag],
            LIMIT,
        );
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(err.contains(says), "{flag}: {err}");
        assert_eq!(err.matches("error:").count(), 1, "{err}");
        assert!(
            !out.join("run.json").exists(),
            "no work was done for {flag}"
        );
    }
}

#[test]
fn run_json_records_when_where_and_from_what_a_run_was_made() {
    let t = TempDir::new("provenance");
    let out = t.path().join("r");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &out,
        &["--engine", "inprocess", "--quiet", "--samples", "12"],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let rj = run_json(&out);
    let started = rj["started_utc"].as_str().unwrap();
    assert_eq!(started.len(), 20, "{started}");
    assert!(
        started.starts_with("20") && started.ends_with('Z'),
        "{started}"
    );
    assert!(!rj["host"].as_str().unwrap().is_empty());
    assert_eq!(rj["crate_version"], env!("CARGO_PKG_VERSION"));
    let scen = rj["inputs"]["scenario"].as_str().unwrap();
    assert!(std::path::Path::new(scen).is_absolute(), "{scen}");
    assert!(scen.ends_with("scenarios/mourya2017-spiral.toml"), "{scen}");
    // Built from this git checkout: the commit is embedded.
    if crate::util::root().join(".git").exists() {
        let c = rj["git_commit"].as_str().unwrap();
        assert_eq!(c.len(), 40, "{c}");
    }
}

#[test]
fn scenario_toml_reruns_the_run_bit_for_bit_and_replay_says_so() {
    let t = TempDir::new("replay-cmd");
    let a = t.path().join("a");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &a,
        &[
            "--engine",
            "inprocess",
            "--quiet",
            "--samples",
            "15",
            "--seed",
            "7",
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    // `sonarnet run DIR/scenario.toml` by hand.
    let b = t.path().join("b");
    let o = run_file(
        &a.join("scenario.toml"),
        &b,
        &["--engine", "inprocess", "--quiet"],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    for f in ["nodes.csv", "track.csv", "schedule.csv", "measurements.csv"] {
        assert_eq!(
            std::fs::read_to_string(a.join(f)).unwrap(),
            std::fs::read_to_string(b.join(f)).unwrap(),
            "{f}"
        );
    }
    // `sonarnet replay DIR`.
    let o = sonarnet(&["replay", a.to_str().unwrap()], LIMIT);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{stdout}{err}");
    assert!(stdout.contains("identical results"), "{stdout}");
    // One changed digit in nodes.csv is found and named.
    let nodes = std::fs::read_to_string(a.join("nodes.csv")).unwrap();
    let mut lines: Vec<String> = nodes.lines().map(String::from).collect();
    lines[5] = lines[5].replacen(',', ",9", 2);
    std::fs::write(a.join("nodes.csv"), lines.join("\n") + "\n").unwrap();
    let o = sonarnet(&["replay", a.to_str().unwrap()], LIMIT);
    let (stdout, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{stdout}{err}");
    assert!(err.contains("nodes.csv: row 5"), "{err}");
    // The differing replay is kept, and named.
    let kept = err
        .lines()
        .find_map(|l| l.strip_prefix("the replay's results are in "))
        .unwrap();
    assert!(std::path::Path::new(kept).join("nodes.csv").exists());
    std::fs::remove_dir_all(kept).unwrap();
}

#[test]
fn a_variant_and_a_monte_carlo_run_replay_exactly() {
    let t = TempDir::new("replay-variants");
    let out = t.path().join("v");
    let o = run_file(
        &scenario("mourya2017-spiral-acoustic.toml"),
        &out,
        &["--quiet", "--samples", "12", "--variant", "modem"],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let o = sonarnet(&["replay", out.to_str().unwrap()], LIMIT);
    assert!(o.status.success(), "{:?}", text(&o));
    let mc = t.path().join("mc");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &mc,
        &["--quiet", "--samples", "12", "--trials", "3"],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let o = sonarnet(&["replay", mc.to_str().unwrap()], LIMIT);
    assert!(o.status.success(), "{:?}", text(&o));
}

#[test]
fn replay_refuses_what_it_cannot_reproduce_with_exit_2() {
    let t = TempDir::new("replay-refuse");
    let o = sonarnet(&["replay", t.path().to_str().unwrap()], LIMIT);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("has no scenario.toml"), "{err}");
}

#[test]
fn replay_of_a_corrupted_run_json_names_the_file_and_line_with_exit_2() {
    let t = TempDir::new("replay-corrupt");
    let dir = t.path().join("r");
    let spiral = scenario("mourya2017-spiral.toml");
    let o = run_file(
        &spiral,
        &dir,
        &["--engine", "inprocess", "--quiet", "--samples", "12"],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let good = std::fs::read_to_string(dir.join("run.json")).unwrap();
    // Cut in the middle of its third line.
    let cut: String = good.lines().take(3).collect::<Vec<_>>().join("\n");
    std::fs::write(dir.join("run.json"), &cut[..cut.len() - 3]).unwrap();
    let o = sonarnet(&["replay", dir.to_str().unwrap()], LIMIT);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("run.json") && err.contains("line 3"), "{err}");
    assert_eq!(err.matches("error:").count(), 1, "{err}");
}

#[test]
fn a_run_into_a_previous_runs_directory_replaces_its_files_and_refuses_foreign_ones() {
    let t = TempDir::new("outdir");
    let out = t.path().join("r");
    let spiral = scenario("mourya2017-spiral.toml");
    let args = ["--engine", "inprocess", "--quiet", "--samples", "12"];
    let o = run_file(&spiral, &out, &args, LIMIT);
    assert!(o.status.success(), "{:?}", text(&o));
    // A Monte Carlo run's trials.csv must not survive a single run into the
    // same directory: plant one as a previous run's leftover.
    std::fs::write(out.join("trials.csv"), "trial\n0\n").unwrap();
    let o = run_file(&spiral, &out, &args, LIMIT);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(!out.join("trials.csv").exists());
    assert!(out.join("track.csv").exists());
    // A file sonarnet does not write: refused, exit 2, nothing removed.
    std::fs::write(out.join("my-notes.txt"), "mine").unwrap();
    let o = run_file(&spiral, &out, &args, LIMIT);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--out") && err.contains("my-notes.txt"),
        "{err}"
    );
    assert!(out.join("my-notes.txt").exists() && out.join("track.csv").exists());
}

#[test]
fn default_directories_of_different_overrides_never_collide() {
    let t = TempDir::new("default-dirs");
    let bin = env!("CARGO_BIN_EXE_sonarnet");
    let spiral = scenario("mourya2017-spiral.toml");
    let run = |extra: &[&str]| {
        let o = std::process::Command::new(bin)
            .current_dir(t.path())
            .args([
                "run",
                spiral.to_str().unwrap(),
                "--engine",
                "inprocess",
                "--quiet",
            ])
            .args(["--samples", "12"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{:?}", text(&o));
        let s = String::from_utf8_lossy(&o.stdout).into_owned();
        s.lines()
            .find_map(|l| l.trim().strip_prefix("results in ").map(String::from))
            .unwrap()
    };
    let dirs = [
        run(&[]),
        run(&["--local-solver", "relaxed"]),
        run(&["--kappa", "1", "--local-solver", "gtrs_l0"]),
        run(&["--set", "algorithm.gamma=1e-7"]),
        run(&["--set", "algorithm.gamma=2e-7"]),
        run(&[
            "--set",
            "algorithm.gamma=2e-7",
            "--set",
            "geometry.transmitters=[[0.0,0.0],[2000.0,2100.0]]",
        ]),
    ];
    let unique: std::collections::BTreeSet<_> = dirs.iter().collect();
    assert_eq!(unique.len(), dirs.len(), "{dirs:?}");
    assert!(dirs[1].ends_with("-relaxed-samples12"), "{}", dirs[1]);
    assert!(
        dirs[5].contains("-o"),
        "a long suffix is hashed: {}",
        dirs[5]
    );
    assert!(dirs.iter().all(|d| d.len() < 120), "{dirs:?}");
}

#[test]
fn new_writes_a_commented_scenario_that_validates_runs_and_describes_itself() {
    let t = TempDir::new("new");
    let file = t.path().join("mine.toml");
    let o = sonarnet(
        &[
            "new",
            file.to_str().unwrap(),
            "--receivers",
            "grid:3x3:800",
            "--transmitters",
            "line:2:-500,0:500,0",
            "--network",
            "grid",
            "--motion",
            "line",
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let toml = std::fs::read_to_string(&file).unwrap();
    assert!(
        toml.lines().filter(|l| l.starts_with('#')).count() >= 5,
        "commented:\n{toml}"
    );
    let out = t.path().join("r");
    let o = run_file(&file, &out, &["--engine", "inprocess", "--quiet"], LIMIT);
    assert!(o.status.success(), "{:?}", text(&o));
    assert_eq!(read_rows(&out.join("nodes.csv")).len(), 100 * 9);
    // describe reads it back in words.
    let o = sonarnet(&["describe", file.to_str().unwrap()], LIMIT);
    let (d, _) = text(&o);
    assert!(o.status.success());
    for says in [
        "9 receivers",
        "2 transmitters",
        "12 links, 800 m to 800 m long",
        "100 samples of a target moving as constant_velocity",
        "asynchronous randomized Douglas-Rachford gossip",
        "channel  ideal",
        "expect  nothing",
    ] {
        assert!(d.contains(says), "{says} in:\n{d}");
    }
    // It does not overwrite, and a layout that cannot make a connected graph
    // is refused naming the flag.
    let o = sonarnet(
        &["new", file.to_str().unwrap(), "--receivers", "circle:5:100"],
        LIMIT,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("exists"), "{:?}", text(&o));
    let o = sonarnet(
        &[
            "new",
            t.path().join("x.toml").to_str().unwrap(),
            "--receivers",
            "circle:8:5000",
            "--network",
            "rgg:100",
        ],
        LIMIT,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o)
            .1
            .contains("--network: the scenario would not validate"),
        "{:?}",
        text(&o)
    );
    assert!(!t.path().join("x.toml").exists());
}

#[test]
fn list_names_every_shipped_scenario_with_its_description_and_variants() {
    let dir = crate::util::root().join("scenarios");
    let o = sonarnet(&["list", "--dir", dir.to_str().unwrap()], LIMIT);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let shipped = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "toml"))
        .count();
    assert_eq!(
        out.lines().filter(|l| l.ends_with(".toml")).count(),
        shipped
    );
    assert!(out.contains("mourya2017-spiral-faults.toml"));
    assert!(out.contains("variants: pause, crash"), "{out}");
    assert!(!out.contains("invalid"), "{out}");
    assert!(
        out.lines().all(|l| l.chars().count() <= 120),
        "one line each:\n{out}"
    );
}

#[test]
fn describe_names_faults_channel_baselines_and_expectations_in_words() {
    let o = sonarnet(
        &[
            "describe",
            scenario("mourya2017-spiral-faults.toml").to_str().unwrap(),
            "--variant",
            "partition",
        ],
        LIMIT,
    );
    let (d, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        d.contains("partition (at_sample 30, for_samples 20, groups [[0, 1, 2], [3, 4, 5]])"),
        "{d}"
    );
    assert!(d.contains("faults.0.recovery_samples <= 3"), "{d}");
    let o = sonarnet(
        &[
            "describe",
            scenario("mourya2017-spiral-acoustic.toml")
                .to_str()
                .unwrap(),
            "--variant",
            "modem",
        ],
        LIMIT,
    );
    let (d, _) = text(&o);
    assert!(d.contains("channel  acoustic"), "{d}");
}

#[test]
fn report_says_where_it_wrote_the_page() {
    let t = TempDir::new("report-path");
    let out = t.path().join("r");
    let o = run_file(
        &scenario("mourya2017-spiral.toml"),
        &out,
        &[
            "--engine",
            "inprocess",
            "--quiet",
            "--samples",
            "12",
            "--report",
        ],
        LIMIT,
    );
    let (stdout, _) = text(&o);
    assert!(o.status.success());
    let line = format!("report             {}", out.join("report.html").display());
    assert!(stdout.contains(&line), "{stdout}");
    assert!(out.join("report.html").is_file());
}

#[test]
fn verbose_node_processes_log_one_whole_line_per_event_in_words() {
    let t = TempDir::new("verbose");
    for mode in ["async", "sync"] {
        let out = t.path().join(mode);
        let o = run_file(
            &scenario("mourya2017-spiral.toml"),
            &out,
            &[
                "--engine",
                "processes",
                "--samples",
                "12",
                "--mode",
                mode,
                "--verbose",
                "--quiet",
            ],
            LIMIT,
        );
        let (_, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let lines: Vec<&str> = err.lines().collect();
        assert!(lines.len() > 6 * 12, "{mode}: {} lines", lines.len());
        for l in &lines {
            let node = l
                .strip_prefix("[node ")
                .and_then(|r| r.split_once("] "))
                .is_some_and(|(i, _)| i.parse::<u32>().is_ok());
            assert!(
                node || l.starts_with("[coordinator] "),
                "{mode}: not one event per line: {l:?}"
            );
            assert!(
                !l.contains('{') && !l.contains("::") && !l.contains("Counters"),
                "{mode}: raw Debug: {l:?}"
            );
        }
        for i in 0..6 {
            assert!(
                lines
                    .iter()
                    .any(|l| l.starts_with(&format!("[node {i}] stops: "))),
                "{mode}: node {i}"
            );
        }
    }
}

#[test]
fn bench_prints_figures_not_debug_lines() {
    let _cpu = crate::util::cpu_exclusive();
    let t = TempDir::new("bench");
    let scen = crate::util::root().join("scenarios");
    let o = sonarnet(
        &[
            "bench",
            "--scale",
            "2",
            "--repeats",
            "1",
            "--scenarios",
            scen.to_str().unwrap(),
            "--out",
            t.path().to_str().unwrap(),
        ],
        Duration::from_secs(300),
    );
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("N=   2  start-up"), "{out}");
    assert!(
        !out.contains("None") && !err.contains("None") && !out.contains("NaN"),
        "debug lines:\n{out}{err}"
    );
    assert!(out.contains("two node processes"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.path().join("bench.json")).unwrap())
            .unwrap();
    // Every row against the floor has a finite positive ratio, with hops
    // measured between node processes: blocking and polling on the
    // spiral, async and sync, and on the pair.
    for key in ["overhead", "pair"] {
        let rows = json[key].as_array().unwrap();
        assert_eq!(rows.len(), if key == "pair" { 2 } else { 4 });
        for r in rows {
            let ratio = r["floor_ratio"].as_f64().unwrap();
            let hop = r["hop_median_s"].as_f64().unwrap();
            assert!(ratio.is_finite() && ratio > 0.0, "{r}");
            assert!(hop > 0.0 && hop < 0.1, "{r}");
            // One repeat: the ratio is the node processes' wall time over
            // the floor (not the in-process engine's).
            let f = |k: &str| r[k].as_f64().unwrap();
            approx::assert_relative_eq!(
                ratio * f("floor_seconds"),
                f("processes_seconds"),
                max_relative = 1e-9
            );
            approx::assert_relative_eq!(
                f("strict_floor_ratio") * f("strict_floor_seconds"),
                f("processes_seconds"),
                max_relative = 1e-9
            );
        }
    }
    let bad = TempDir::new("bench-bad");
    let o = sonarnet(
        &[
            "bench",
            "--scale",
            "1",
            "--out",
            bad.path().to_str().unwrap(),
        ],
        LIMIT,
    );
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn the_monte_carlo_table_prints_mean_and_rms_rmse_in_significant_digits() {
    let t = TempDir::new("mc-table");
    let out = t.path().join("mc");
    let o = run_file(
        &scenario("pun-so-small-noise.toml"),
        &out,
        &[
            "--variant",
            "sigma_1e-4",
            "--trials",
            "3",
            "--samples",
            "50",
        ],
        LIMIT,
    );
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        stdout.contains("rmse (mean)") && stdout.contains("rmse (rms)"),
        "{stdout}"
    );
    // sigma = 1e-4: errors of a few 1e-4 m print with their digits, not 0.000.
    assert!(
        !stdout.contains(" 0.000 ") && !stdout.contains("-0.000"),
        "{stdout}"
    );
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("ml "))
        .unwrap();
    assert!(row.contains("e-6"), "{row}");
}
