//! Bad input gives one clear message naming the file, the key or line and
//! the reason, and the CLI exits with code 2.

use crate::util::{TempDir, sonarnet};
use std::time::Duration;

const GOOD: &str = r#"
name = "tiny"
seed = 1
[geometry]
transmitters = [[0.0, 0.0]]
receivers = [[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0]]
[network]
edges = [[0, 1], [1, 2]]
[target]
samples = 3
motion = { model = "static", position = [10.0, 20.0] }
[measurements]
doa = true
range_noise = { model = "gaussian", sigma = 1.0 }
doa_noise = { model = "gaussian", sigma = 0.1 }
[algorithm]
mode = "async"
gamma = 1e-6
iterations_per_sample = 5
"#;

fn run_bad(text: &str, extra: &[(&str, &str)]) -> (i32, String, std::path::PathBuf) {
    run_bad_with(text, extra, &[])
}

/// `run_bad` with extra command-line arguments.
fn run_bad_with(
    text: &str,
    extra: &[(&str, &str)],
    args: &[&str],
) -> (i32, String, std::path::PathBuf) {
    let tmp = TempDir::new("bad");
    for (name, body) in extra {
        tmp.write(name, body);
    }
    let p = tmp.write("scenario.toml", text);
    let out_dir = tmp.path().join("out");
    let mut all = vec![
        "run",
        p.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    let out = sonarnet(&all, Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    (out.status.code().unwrap_or(-1), stderr, p)
}

fn assert_clear(code: i32, stderr: &str, file: &std::path::Path, needles: &[&str]) {
    assert_eq!(
        code, 2,
        "exit code must be 2 for bad input; stderr:\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "must not panic:\n{stderr}");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "exactly one error line:\n{stderr}"
    );
    let fname = file.file_name().unwrap().to_string_lossy();
    assert!(
        stderr.contains(fname.as_ref()),
        "message must name {fname}:\n{stderr}"
    );
    for n in needles {
        assert!(stderr.contains(n), "message must contain `{n}`:\n{stderr}");
    }
}

#[test]
fn the_good_scenario_of_these_tests_runs() {
    let (code, stderr, _) = run_bad(GOOD, &[]);
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn malformed_toml_names_the_line() {
    let text = GOOD.replace("gamma = 1e-6", "gamma = = 1e-6");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["line 18"]);
}

#[test]
fn an_unknown_key_is_named() {
    let text = GOOD.replace("gamma = 1e-6", "gamma = 1e-6\ngama = 2.0");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["unknown field `gama`", "line 19"]);
}

#[test]
fn a_disconnected_graph_is_rejected_with_the_unreachable_node() {
    let text = GOOD.replace("edges = [[0, 1], [1, 2]]", "edges = [[0, 1]]");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["network.edges", "disconnected", "node 2"],
    );
}

#[test]
fn a_nan_in_a_trace_names_the_trace_and_line() {
    let text = GOOD
        .replace(
            "[target]\nsamples = 3\nmotion = { model = \"static\", position = [10.0, 20.0] }\n",
            "",
        )
        .replace("doa = true", "doa = true\ntrace = \"trace.csv\"");
    let trace =
        "sample,receiver,transmitter,kind,value\n0,0,0,bistatic_range,200.0\n0,1,,doa,NaN\n";
    let (code, stderr, _) = run_bad(&text, &[("trace.csv", trace)]);
    let tmp = std::path::PathBuf::from("trace.csv");
    assert_clear(code, &stderr, &tmp, &["line 3", "finite"]);
}

#[test]
fn a_trace_sample_far_ahead_is_refused_naming_the_line_before_anything_is_allocated() {
    let text = GOOD
        .replace(
            "[target]\nsamples = 3\nmotion = { model = \"static\", position = [10.0, 20.0] }\n",
            "",
        )
        .replace("doa = true", "doa = true\ntrace = \"trace.csv\"");
    // Sample 10^12 would size the trace at terabytes.
    let trace = "sample,receiver,transmitter,kind,value\n0,0,0,bistatic_range,200.0\n\
                 999999999999,1,,doa,0.5\n";
    let (code, stderr, _) = run_bad(&text, &[("trace.csv", trace)]);
    let tmp = std::path::PathBuf::from("trace.csv");
    assert_clear(code, &stderr, &tmp, &["line 3", "at most 1000000 samples"]);
    // A row that is not a row names its column.
    let corrupt = "sample,receiver,transmitter,kind,value\n0,0,0,bistatic_range,200.0\n\
                   1,0,0,bistatic_range,200.0\n1,x,,doa,0.5\n";
    let (code, stderr, _) = run_bad(&text, &[("trace.csv", corrupt)]);
    assert_clear(code, &stderr, &tmp, &["line 4", "column `receiver`"]);
}

#[test]
fn a_corrupted_truth_file_names_the_file_and_line() {
    let text = GOOD
        .replace(
            "[target]\nsamples = 3\nmotion = { model = \"static\", position = [10.0, 20.0] }\n",
            "",
        )
        .replace(
            "doa = true",
            "doa = true\ntrace = \"trace.csv\"\ntruth = \"truth.csv\"",
        );
    let trace = "sample,receiver,transmitter,kind,value\n0,0,0,bistatic_range,200.0\n";
    let truth = "sample,x,y\n0,10.0,20.0\n1,1e999x,20.0\n";
    let (code, stderr, _) = run_bad(&text, &[("trace.csv", trace), ("truth.csv", truth)]);
    assert_clear(
        code,
        &stderr,
        std::path::Path::new("truth.csv"),
        &["line 3", "column `x`"],
    );
}

#[test]
fn a_scenario_file_longer_than_16_mib_is_refused_before_it_is_read() {
    // Valid TOML: a comment line of 17 MiB after the scenario.
    let text = format!("{GOOD}\n# {}\n", "x".repeat(17 << 20));
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["longer than 16777216 bytes"]);
}

#[test]
fn a_missing_trace_file_is_named() {
    let text = GOOD
        .replace(
            "[target]\nsamples = 3\nmotion = { model = \"static\", position = [10.0, 20.0] }\n",
            "",
        )
        .replace("doa = true", "doa = true\ntrace = \"nowhere.csv\"");
    let (code, stderr, _) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        std::path::Path::new("nowhere.csv"),
        &["cannot open"],
    );
}

#[test]
fn a_schedule_that_names_a_non_edge_is_rejected() {
    let text = GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 1\nschedule = \"s.csv\"",
    );
    let sched = "iteration,v,w\n0,0,1\n1,0,2\n2,1,2\n";
    let (code, stderr, _) = run_bad(&text, &[("s.csv", sched)]);
    assert_clear(
        code,
        &stderr,
        std::path::Path::new("s.csv"),
        &["line 3", "(0, 2) is not an edge"],
    );
}

#[test]
fn a_corrupted_schedule_names_the_file_line_and_column() {
    let text = GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 1\nschedule = \"s.csv\"",
    );
    let sched = "iteration,v,w\n0,0,1\n1,1,\u{1}2\n2,2,1\n";
    let (code, stderr, _) = run_bad(&text, &[("s.csv", sched)]);
    assert_clear(
        code,
        &stderr,
        std::path::Path::new("s.csv"),
        &["line 3", "column `w`"],
    );
}

/// A valid 3-iteration schedule for GOOD with one iteration per sample.
const SCHEDULE: &str = "iteration,v,w\n0,0,1\n1,1,2\n2,2,1\n";

fn with_schedule(mode: &str) -> String {
    GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 1\nschedule = \"s.csv\"",
    )
    .replace("mode = \"async\"", &format!("mode = \"{mode}\""))
}

#[test]
fn a_replayed_schedule_is_refused_in_sync_mode_naming_the_key() {
    let (code, stderr, p) = run_bad(&with_schedule("sync"), &[("s.csv", SCHEDULE)]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["algorithm.schedule", "this run is sync"],
    );
    // Also when --mode sync turns an async file sync.
    let (code, stderr, p) = run_bad_with(
        &with_schedule("async"),
        &[("s.csv", SCHEDULE)],
        &["--mode", "sync"],
    );
    assert_clear(code, &stderr, &p, &["algorithm.schedule", "sync"]);
    // The same async file runs.
    let (code, stderr, _) = run_bad_with(
        &with_schedule("async"),
        &[("s.csv", SCHEDULE)],
        &["--engine", "inprocess", "--quiet"],
    );
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn a_replayed_schedule_is_refused_with_the_realtime_clock_naming_the_key() {
    let text = format!(
        "{}\n[realtime]\nsample_period_ms = 20.0\nwake_rate_hz = 100.0\n",
        with_schedule("async")
    );
    let (code, stderr, p) = run_bad_with(&text, &[("s.csv", SCHEDULE)], &["--clock", "realtime"]);
    assert_clear(code, &stderr, &p, &["algorithm.schedule", "realtime"]);
}

#[test]
fn per_node_initial_states_must_number_the_nodes() {
    let text = GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 5\ninit_u = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]",
    );
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["algorithm.init_u", "has 2 entries", "3"],
    );
    let text = GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 5\nprox_scaling = \"inverse\"",
    );
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["line 20", "inverse_probability"]);
    let text = GOOD.replace(
        "iterations_per_sample = 5",
        "iterations_per_sample = 5\ninit = \"fix\"",
    );
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["line 20", "first_fix"]);
}

#[test]
fn a_negative_gamma_is_rejected_with_its_key() {
    let text = GOOD.replace("gamma = 1e-6", "gamma = -1.0");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["algorithm.gamma", "> 0"]);
}

#[test]
fn a_kappa_not_below_the_row_count_of_a_node_is_rejected_with_its_key() {
    // One transmitter and a DOA: 3 rows per node.
    let text = GOOD.replace(
        "gamma = 1e-6",
        "gamma = 1e-6\nlocal_solver = \"gtrs_l0\"\nkappa = 3",
    );
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["algorithm.kappa", "node 0 has 3", "got 3"],
    );
    // The same kappa is fine with gtrs (unused) until --local-solver asks for gtrs_l0.
    let text = GOOD.replace("gamma = 1e-6", "gamma = 1e-6\nkappa = 3");
    let (code, stderr, _) = run_bad(&text, &[]);
    assert_eq!(code, 0, "{stderr}");
    let (code, stderr, p) = run_bad_with(&text, &[], &["--local-solver", "gtrs_l0"]);
    assert_clear(code, &stderr, &p, &["algorithm.kappa", "gtrs_l0"]);
    // kappa = 2 leaves one row: it runs.
    let text = GOOD.replace("gamma = 1e-6", "gamma = 1e-6\nkappa = 2");
    let (code, stderr, _) = run_bad_with(&text, &[], &["--local-solver", "gtrs_l0"]);
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn kappa_on_the_command_line_overrides_the_file_and_is_checked_like_it() {
    let tmp = TempDir::new("kappa");
    let text = GOOD.replace("gamma = 1e-6", "gamma = 1e-6\nlocal_solver = \"gtrs_l0\"");
    let p = tmp.write("scenario.toml", &text);
    let out = tmp.path().join("out");
    let run = |k: &str| {
        sonarnet(
            &[
                "run",
                p.to_str().unwrap(),
                "--engine",
                "inprocess",
                "--quiet",
                "--report",
                "--kappa",
                k,
                "--out",
                out.to_str().unwrap(),
            ],
            Duration::from_secs(60),
        )
    };
    // One transmitter and a DOA: 3 rows per node, so 3 is refused, naming the flag.
    let o = run("3");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.matches("error:").count(), 1, "{stderr}");
    for n in ["<command line>", "--kappa", "node 0 has 3", "got 3"] {
        assert!(stderr.contains(n), "message must contain `{n}`:\n{stderr}");
    }
    // 2 runs; run.json records it and the report shows it.
    let o = run("2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run_json["scenario"]["algorithm"]["kappa"], 2, "{run_json}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("<tr><th>κ (kappa, outlier rows per node)</th><td>2</td></tr>"),
        "report does not show kappa"
    );
}

#[test]
fn an_unknown_local_solver_lists_gtrs_l0_among_the_choices() {
    let out = sonarnet(
        &["run", "x.toml", "--local-solver", "l0"],
        Duration::from_secs(30),
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("[possible values: gtrs, relaxed, gtrs_l0]"),
        "{err}"
    );
}

#[test]
fn usage_errors_exit_with_code_2() {
    let out = sonarnet(&["run"], Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(2));
    let out = sonarnet(
        &["run", "x.toml", "--mode", "sideways"],
        Duration::from_secs(30),
    );
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn an_unknown_baseline_kind_is_named_with_its_index() {
    let text = format!("{GOOD}\n[[baselines]]\nkind = \"kalman\"\n");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["kalman"]);
}

#[test]
fn a_bad_expect_relation_is_rejected_at_load_time() {
    let text = format!("{GOOD}\n[expect]\nholds = [\"theta_bar.rmse <\"]\n");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["expect.holds"]);
}

#[test]
fn a_bad_variant_is_named_by_index_and_name() {
    let text = format!(
        "{GOOD}\n[[variants]]\nname = \"fine\"\n\n[[variants]]\nname = \"broken\"\nalgorithm = {{ gamma = -1.0 }}\n"
    );
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["variants[1] (broken)", "algorithm.gamma"],
    );
}

#[test]
fn bounds_on_a_track_that_does_not_exist_are_rejected() {
    let text = format!("{GOOD}\n[bounds]\nnames = [\"upp_rbbox\"]\ntracks = [\"pocs\"]\n");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(code, &stderr, &p, &["bounds.tracks[0]", "pocs"]);
}

#[test]
fn with_a_trace_kappa_is_checked_against_the_most_rows_each_node_ever_has() {
    let tmp = TempDir::new("kappa-trace");
    // Node 0: a bistatic range and a DOA (3 rows); node 1: a DOA (2 rows) at sample 1
    // only; node 2: nothing (exempt: it runs the plain prox).
    tmp.write(
        "trace.csv",
        "sample,receiver,transmitter,kind,value\n\
         0,0,0,bistatic_range,200.0\n0,0,,doa,0.5\n1,1,,doa,0.7\n",
    );
    let text = |kappa: usize| {
        GOOD.replace(
            "[target]\nsamples = 3\nmotion = { model = \"static\", position = [10.0, 20.0] }\n",
            "",
        )
        .replace("doa = true", "doa = true\ntrace = \"trace.csv\"")
        .replace(
            "gamma = 1e-6",
            &format!("gamma = 1e-6\nlocal_solver = \"gtrs_l0\"\nkappa = {kappa}"),
        )
    };
    let p = tmp.path().join("scenario.toml");
    let sc = sonarnet::scenario::Scenario::from_toml_str(&text(1), &p).unwrap();
    assert_eq!(
        (0..3).map(|n| sc.nominal_rows(n)).collect::<Vec<_>>(),
        vec![3, 2, 0]
    );
    let e = sonarnet::scenario::Scenario::from_toml_str(&text(2), &p).unwrap_err();
    assert_eq!(e.location.as_deref(), Some("algorithm.kappa"));
    assert!(e.reason.contains("node 1 has 2"), "{e}");
}

#[test]
fn an_unusable_out_directory_is_refused_before_the_run_naming_out() {
    let tmp = TempDir::new("bad-out");
    let p = tmp.write("scenario.toml", GOOD);
    let file = tmp.write("taken", "not a directory");
    for (out, why) in [
        (file.clone(), "is not a directory"),
        (file.join("below"), "cannot create"),
        (
            std::path::PathBuf::from("/proc/sonarnet-x"),
            "cannot create",
        ),
    ] {
        for extra in [&[][..], &["--trials", "3"][..]] {
            let mut args = vec!["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()];
            args.extend_from_slice(extra);
            let o = sonarnet(&args, Duration::from_secs(60));
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{out:?} {extra:?}: {stderr}");
            assert_eq!(stderr.matches("error:").count(), 1, "{stderr}");
            assert!(stderr.contains("--out") && stderr.contains(why), "{stderr}");
            // Refused before any work: nothing ran, so nothing was summarised.
            assert!(
                o.stdout.is_empty(),
                "{}",
                String::from_utf8_lossy(&o.stdout)
            );
        }
    }
}

#[test]
fn realtime_rates_outside_their_documented_range_are_refused_naming_the_key() {
    for (key, value) in [
        ("wake_rate_hz", "1e-300"),
        ("wake_rate_hz", "1e9"),
        ("sample_period_ms", "1e-9"),
        ("sample_period_ms", "1e300"),
    ] {
        let table = if key == "wake_rate_hz" {
            format!("sample_period_ms = 20.0\nwake_rate_hz = {value}")
        } else {
            format!("sample_period_ms = {value}\nwake_rate_hz = 100.0")
        };
        let text = format!("{GOOD}\n[realtime]\n{table}\n");
        let (code, stderr, p) = run_bad_with(&text, &[], &["--clock", "realtime"]);
        assert_clear(
            code,
            &stderr,
            &p,
            &[&format!("realtime.{key}"), "must be in ["],
        );
    }
}

#[test]
fn counts_outside_their_documented_range_are_refused_before_any_allocation() {
    let many: String = (0..5000)
        .map(|i| format!("[{}.0, 1.0]", i))
        .collect::<Vec<_>>()
        .join(", ");
    for (from, to, key) in [
        (
            "iterations_per_sample = 5",
            "iterations_per_sample = 9223372036854775807",
            "algorithm.iterations_per_sample: must be at most 1000000",
        ),
        (
            "iterations_per_sample = 5",
            "iterations_per_sample = 100000000",
            "algorithm.iterations_per_sample: must be at most 1000000",
        ),
        (
            "samples = 3",
            "samples = 1000000000",
            "target.samples: must be at most 1000000",
        ),
        (
            "receivers = [[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0]]\n[network]\nedges = [[0, 1], [1, 2]]",
            &format!("receivers = [{many}]\n[network]\ngenerator = {{ kind = \"ring\" }}"),
            "geometry.receivers: 5000 receivers, at most 4096",
        ),
        (
            "transmitters = [[0.0, 0.0]]",
            &format!("transmitters = [{many}]"),
            "geometry.transmitters: 5000 transmitters, at most 4096",
        ),
        // 1e6 samples x 1e6 iterations: each is in range, their record is not.
        ("samples = 3\n", "samples = 1000000\n", ""),
    ] {
        let mut text = GOOD.replace(from, to);
        let mut needle = key.to_string();
        if key.is_empty() {
            text = text.replace(
                "iterations_per_sample = 5",
                "iterations_per_sample = 1000000",
            );
            needle = "algorithm.iterations_per_sample: 1000000 samples x 1000000 iterations on 3 nodes need about".into();
        }
        assert_ne!(text, GOOD, "{from}");
        let (code, stderr, p) = run_bad(&text, &[]);
        assert_clear(code, &stderr, &p, &[&needle]);
    }
    for (flag, value, needle) in [
        ("--samples", "1000001", "--samples: must be at most 1000000"),
        (
            "--iterations-per-sample",
            "1000001",
            "--iterations-per-sample: must be at most",
        ),
        ("--trials", "10000000", "--trials: must be at most 1000000"),
    ] {
        let (code, stderr, _) = run_bad_with(GOOD, &[], &[flag, value]);
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(needle), "{stderr}");
    }
}

#[test]
fn a_machine_without_enough_open_files_for_the_nodes_is_refused_before_spawning() {
    let tmp = TempDir::new("nofile");
    let out = tmp.path().join("out");
    let sc = crate::util::scenario("rgg16-waypoints.toml");
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_sonarnet"));
    cmd.args(["run", sc.to_str().unwrap(), "--out"]).arg(&out);
    // 16 nodes need about 9 x 16 + 64 = 208 open files in the coordinator.
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: setrlimit is async-signal-safe; nothing else runs between
        // fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let lim = libc::rlimit {
                    rlim_cur: 200,
                    rlim_max: 200,
                };
                if libc::setrlimit(libc::RLIMIT_NOFILE, &lim) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    let child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet");
    let o = crate::util::wait_watchdog(child, "a run with too few files", Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(
            "rgg16-waypoints.toml: geometry.receivers: 16 node processes need about 208 open files"
        ),
        "{stderr}"
    );
    assert!(o.stdout.is_empty(), "refused before any work");
}

#[test]
fn receivers_at_the_same_position_are_run_with_one_warning_naming_both() {
    let text = GOOD.replace(
        "receivers = [[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0]]",
        "receivers = [[100.0, 0.0], [0.0, 100.0], [100.0, 0.0]]",
    );
    let tmp = TempDir::new("dup-rx");
    let p = tmp.write("scenario.toml", &text);
    let out = tmp.path().join("out");
    for args in [
        vec!["validate", p.to_str().unwrap()],
        vec![
            "run",
            p.to_str().unwrap(),
            "--engine",
            "inprocess",
            "--out",
            out.to_str().unwrap(),
        ],
    ] {
        let o = sonarnet(&args, Duration::from_secs(60));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{stderr}");
        assert_eq!(stderr.matches("warning:").count(), 1, "{stderr}");
        assert!(
            stderr.contains("scenario.toml: geometry.receivers: receivers 0 and 2 are at the same position (100, 0)"),
            "{stderr}"
        );
    }
}

/// `[channel]`: every number of the acoustic channel is checked at load, an
/// ideal channel takes no other key, the acoustic channel runs only where it
/// is built (the discrete-event engine), and `algorithm.clock = "realtime"`
/// needs async mode and a `[realtime]` table.
#[test]
fn a_bad_channel_or_clock_is_refused_naming_the_key() {
    let realtime = "[realtime]\nsample_period_ms = 1000.0\nwake_rate_hz = 1.0\n";
    for (table, needles) in [
        (
            "[channel]\nmodel = \"acoustic\"\nbit_rate = 0.0\n",
            &["channel.bit_rate", "outside [1, 1000000000]"][..],
        ),
        (
            "[channel]\nmodel = \"acoustic\"\nloss = { model = \"bernoulli\", p = 1.5 }\n",
            &["channel.loss.p"][..],
        ),
        (
            "[channel]\nmodel = \"acoustic\"\nlinks = [{ a = 0, b = 7 }]\n",
            &["channel.links[0].b", "node 7 does not exist"][..],
        ),
        (
            "[channel]\nmodel = \"ideal\"\nbit_rate = 500.0\n",
            &["unknown field `bit_rate`"][..],
        ),
        (
            "[channel]\nmodel = \"acoustic\"\nbitrate = 500.0\n",
            &["unknown field `bitrate`"][..],
        ),
    ] {
        let text = format!("{GOOD}\n{realtime}\n{table}");
        let (code, stderr, p) = run_bad(&text, &[]);
        assert_clear(code, &stderr, &p, needles);
    }
    // The acoustic channel on node threads.
    let acoustic = format!("{GOOD}\n{realtime}\n[channel]\nmodel = \"acoustic\"\n");
    let (code, stderr, p) = run_bad_with(&acoustic, &[], &["--engine", "threads"]);
    assert_clear(code, &stderr, &p, &["channel.model", "--engine inprocess"]);
    // algorithm.clock = "realtime" without a [realtime] table, or in sync mode.
    let no_table = GOOD.replace("mode = \"async\"", "mode = \"async\"\nclock = \"realtime\"");
    let (code, stderr, p) = run_bad(&no_table, &[]);
    assert_clear(code, &stderr, &p, &["algorithm.clock", "[realtime] table"]);
    let sync = format!(
        "{}\n{realtime}",
        GOOD.replace("mode = \"async\"", "mode = \"sync\"\nclock = \"realtime\"")
    );
    let (code, stderr, p) = run_bad(&sync, &[]);
    assert_clear(code, &stderr, &p, &["algorithm.clock", "async"]);
}

/// A choice that takes no keys (`generator = { kind = "ring" }`, `loss = {
/// model = "none" }`) refuses one given anyway, as every other table does,
/// instead of silently ignoring it.
#[test]
fn a_key_given_to_a_choice_that_takes_none_is_refused_naming_it() {
    let ring = GOOD.replace(
        "edges = [[0, 1], [1, 2]]",
        "generator = { kind = \"ring\", degree = 3 }",
    );
    let (code, stderr, p) = run_bad(&ring, &[]);
    assert_clear(code, &stderr, &p, &["line 8", "unknown field `degree`"]);
    let realtime = "[realtime]\nsample_period_ms = 1000.0\nwake_rate_hz = 1.0\n";
    let loss = "[channel]\nmodel = \"acoustic\"\nloss = { model = \"none\", p = 0.1 }\n";
    let (code, stderr, p) = run_bad(&format!("{GOOD}\n{realtime}\n{loss}"), &[]);
    assert_clear(code, &stderr, &p, &["unknown field `p`"]);
}

#[test]
fn a_deploy_table_that_leaves_a_node_on_no_host_or_names_a_stranger_is_refused() {
    for (deploy, needles) in [
        (
            "hosts = { a = [0, 1] }",
            ["deploy.hosts", "nodes [2] are on no host"],
        ),
        (
            "hosts = { a = [0, 1], b = [1, 2] }",
            ["deploy.hosts", "node 1 is placed on both"],
        ),
        (
            "hosts = { a = [0, 1, 2, 7] }",
            ["deploy.hosts", "lists node 7"],
        ),
        (
            r#"hosts = { "a b" = [0, 1, 2] }"#,
            ["deploy.hosts", "host name"],
        ),
        (
            "hosts = { a = [0, 1, 2] }\nport = 7",
            ["line 23", "unknown field `port`"],
        ),
    ] {
        let text = format!("{GOOD}\n[deploy]\n{deploy}\n");
        let (code, stderr, p) = run_bad(&text, &[]);
        assert_clear(code, &stderr, &p, &needles);
    }
}

#[test]
fn an_elevation_noise_is_refused_in_a_2d_scenario_naming_the_key() {
    let text = GOOD.replace(
        "doa_noise = { model = \"gaussian\", sigma = 0.1 }",
        "doa_noise = { model = \"gaussian\", sigma = 0.1 }\nelevation_noise = { model = \"gaussian\", sigma = 0.2 }",
    );
    assert_ne!(text, GOOD);
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["measurements.elevation_noise", "only in 3-D"],
    );
}

#[test]
fn the_sdp_baseline_without_one_way_ranges_is_refused_naming_its_key() {
    let text = format!("{GOOD}\n[[baselines]]\nkind = \"sdp\"\n");
    let (code, stderr, p) = run_bad(&text, &[]);
    assert_clear(
        code,
        &stderr,
        &p,
        &["baselines[0].kind", "one-way ranges", "measurements.range"],
    );
    // With one-way ranges it runs.
    let text = text.replace("doa = true", "doa = true\nrange = true");
    let (code, stderr, _) = run_bad(&text, &[]);
    assert_eq!(code, 0, "{stderr}");
}
