//! Baselines, bounds, variants and Monte Carlo through the real `sonarnet`
//! binary: the outputs a user reads with pandas.

use crate::util::{TempDir, header, read_rows, run_file, sonarnet};
use std::time::Duration;

const TOA: &str = r#"
name = "toa"
seed = 7
[geometry]
receivers = [[0.5, 0.5], [0.0, 0.5], [0.5, 0.0]]
[network]
generator = { kind = "ring" }
[target]
samples = 40
motion = { model = "random_walk", start = [2.0, 1.0], c = 0.005 }
[measurements]
bistatic = false
range = true
range_noise = { model = "gaussian", sigma = 1e-3 }
[algorithm]
mode = "sync"
gamma = 1.0
iterations_per_sample = 5
[[baselines]]
kind = "ogd"
[[baselines]]
kind = "onm"
[[baselines]]
kind = "pocs"
[[baselines]]
kind = "lls"
[bounds]
names = ["upp_rbbox", "upp_maxdis"]
rho = 0.005
tracks = ["pocs"]
[expect]
holds = ["onm.rmse < 0.05", "pocs.bounds.upp_rbbox.coverage >= 0.9"]
"#;

#[test]
fn baselines_and_bounds_get_their_own_track_columns_and_metrics() {
    let tmp = TempDir::new("baselines");
    let p = tmp.write("toa.toml", TOA);
    let out = tmp.path().join("out");
    let o = run_file(
        &p,
        &out,
        &["--engine", "inprocess", "--check"],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let h = header(&out.join("track.csv"));
    for col in [
        "regret",
        "ogd_x",
        "ogd_error",
        "ogd_ctte",
        "ogd_regret",
        "ogd_regret_pred",
        "onm_y",
        "pocs_bound_upp_rbbox",
        "pocs_bound_upp_maxdis",
        "lls_x",
    ] {
        assert!(h.iter().any(|c| c == col), "track.csv lacks {col}: {h:?}");
    }
    assert!(
        !h.iter().any(|c| c == "bound_upp_rbbox"),
        "theta_bar carries no bound here"
    );
    let m = crate::util::metrics(&out);
    let ogd = &m["baselines"]["ogd"];
    assert!(ogd["ctte"].as_f64().unwrap() > 0.0);
    assert!(ogd["regret"].is_number() && ogd["regret_pred"].is_number());
    let cov = m["baselines"]["pocs"]["bounds"]["upp_maxdis"]["coverage"]
        .as_f64()
        .unwrap();
    assert!((0.0..=1.0).contains(&cov));
    let expect = m["expect"].as_array().unwrap();
    assert_eq!(expect.len(), 2);
    assert!(expect.iter().all(|e| e["holds"] == true), "{expect:?}");
}

#[test]
fn a_per_track_bound_list_replaces_the_names_for_that_track_only() {
    let tmp = TempDir::new("per-track");
    let text = TOA.replace(
        "tracks = [\"pocs\"]",
        "tracks = [\"pocs\"]\nper_track = { lls = [\"upp_maxdis\"] }",
    );
    let p = tmp.write("toa.toml", &text);
    let out = tmp.path().join("out");
    let o = run_file(
        &p,
        &out,
        &["--engine", "inprocess"],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let h = header(&out.join("track.csv"));
    for (col, want) in [
        ("pocs_bound_upp_rbbox", true),
        ("pocs_bound_upp_maxdis", true),
        ("lls_bound_upp_maxdis", true),
        ("lls_bound_upp_rbbox", false),
        ("bound_upp_maxdis", false),
    ] {
        assert_eq!(h.iter().any(|c| c == col), want, "{col} in {h:?}");
    }
    let m = crate::util::metrics(&out);
    let lls = m["baselines"]["lls"]["bounds"].as_object().unwrap();
    assert_eq!(lls.keys().collect::<Vec<_>>(), ["upp_maxdis"]);
    // A per-track entry must name a track and list a bound.
    for (entry, key) in [
        (
            "per_track = { nope = [\"upp_maxdis\"] }",
            "bounds.per_track.nope",
        ),
        ("per_track = { lls = [] }", "bounds.per_track.lls"),
    ] {
        let bad = tmp.write(
            "bad.toml",
            &TOA.replace(
                "tracks = [\"pocs\"]",
                &format!("tracks = [\"pocs\"]\n{entry}"),
            ),
        );
        let o = sonarnet(
            &["validate", bad.to_str().unwrap()],
            Duration::from_secs(60),
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("bad.toml") && err.contains(key), "{err}");
    }
}

#[test]
fn a_failing_expectation_makes_check_exit_1_and_names_it() {
    let tmp = TempDir::new("check");
    let p = tmp.write(
        "toa.toml",
        &TOA.replace("\"onm.rmse < 0.05\"", "\"onm.rmse > 1000\""),
    );
    let out = tmp.path().join("out");
    let o = run_file(
        &p,
        &out,
        &["--engine", "inprocess", "--check"],
        Duration::from_secs(120),
    );
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("onm.rmse > 1000"), "{err}");
}

#[test]
fn monte_carlo_writes_one_row_per_trial_and_a_summary_with_bands() {
    let tmp = TempDir::new("mc");
    let p = tmp.write("toa.toml", TOA);
    let out = tmp.path().join("out");
    let o = run_file(&p, &out, &["--trials", "6"], Duration::from_secs(300));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = read_rows(&out.join("trials.csv"));
    let head = header(&out.join("trials.csv"));
    assert_eq!(rows.len(), 6, "6 trials");
    assert_eq!(&head[..3], &["trial", "seed", "failed"]);
    let seeds: Vec<&str> = rows.iter().map(|r| r[1].as_str()).collect();
    assert_eq!(seeds, ["7", "8", "9", "10", "11", "12"]);
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["trials"], 6);
    let n = s["sample"].as_array().unwrap().len();
    assert_eq!(n, 40);
    for track in ["theta_bar", "ml", "ogd", "onm", "pocs"] {
        let mean = s["curves"][track]["ctte"]["mean"].as_array().unwrap();
        assert_eq!(mean.len(), n, "{track}");
    }
    assert!(s["metrics"]["ogd.ctte"]["mean"].as_f64().unwrap() > 0.0);
    assert!(s["metrics"]["ogd.ctte"]["p95"].as_f64() >= s["metrics"]["ogd.ctte"]["p5"].as_f64());
    // Trial 0 of the Monte Carlo run is the single run with the same seed.
    let single = tmp.path().join("single");
    let o = run_file(
        &p,
        &single,
        &["--engine", "inprocess"],
        Duration::from_secs(120),
    );
    assert!(o.status.success());
    let t0 = &rows[0];
    let col = head.iter().position(|c| c == "ogd.ctte").unwrap();
    let m = crate::util::metrics(&single);
    let want = m["baselines"]["ogd"]["ctte"].as_f64().unwrap();
    approx::assert_relative_eq!(t0[col].parse::<f64>().unwrap(), want, max_relative = 1e-15);
    // The report renders a Monte Carlo directory.
    assert!(out.join("ctte.svg").is_file() && out.join("error.svg").is_file());
}

#[test]
fn every_variant_runs_into_its_own_directory_and_variant_picks_one() {
    let tmp = TempDir::new("variants");
    let text = format!(
        "{TOA}\n[[variants]]\nname = \"quiet\"\n\n[[variants]]\nname = \"noisy\"\nmeasurements = {{ range_noise = {{ model = \"gaussian\", sigma = 1e-2 }} }}\n"
    );
    let p = tmp.write("v.toml", &text);
    let out = tmp.path().join("out");
    let o = run_file(
        &p,
        &out,
        &["--engine", "inprocess"],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rmse = |d: &str| {
        crate::util::metrics(&out.join(d))["baselines"]["onm"]["rmse"]
            .as_f64()
            .unwrap()
    };
    assert!(rmse("noisy") > rmse("quiet"));
    let one = tmp.path().join("one");
    let o = run_file(
        &p,
        &one,
        &["--engine", "inprocess", "--variant", "noisy"],
        Duration::from_secs(120),
    );
    assert!(o.status.success());
    assert!(
        one.join("metrics.json").is_file(),
        "a single variant writes --out itself"
    );
    let o = sonarnet(
        &["run", p.to_str().unwrap(), "--variant", "loud"],
        Duration::from_secs(60),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("quiet, noisy"));
}

#[test]
fn a_toa_only_network_is_tracked_by_the_distributed_engine_in_sync_and_async_mode() {
    // Pun-So 2022's three anchors are the gossip nodes; each node has one
    // one-way range row [0, 0, 1] (g = r_v) and the same GTRS prox.
    let text = TOA
        .replace(
            "gamma = 1.0\niterations_per_sample = 5",
            "gamma = 3.0\niterations_per_sample = 50\nburn_in = 10",
        )
        .replace(
            "[expect]\nholds = [\"onm.rmse < 0.05\", \"pocs.bounds.upp_rbbox.coverage >= 0.9\"]\n",
            "",
        );
    let tmp = TempDir::new("toa-dr");
    let p = tmp.write("toa.toml", &text);
    for (mode, bound) in [("sync", 0.01), ("async", 0.05)] {
        let sc = sonarnet::scenario::Scenario::load(&p)
            .unwrap()
            .with_mode(if mode == "sync" {
                sonarnet::scenario::Mode::Sync
            } else {
                sonarnet::scenario::Mode::Async
            })
            .unwrap();
        let out = crate::util::run_inprocess(&sc, &tmp.path().join(mode));
        assert!(out.run.error.is_none());
        let r = out.metrics.rmse_after_burn_in.unwrap();
        // sigma = 1e-3: after the burn-in the consensus tracks within centimetres.
        assert!(r < bound, "{mode}: rmse_after_burn_in {r}");
    }
}

#[test]
fn replacing_the_baselines_must_keep_every_track_the_bounds_name() {
    let tmp = TempDir::new("rebase");
    let p = tmp.write("toa.toml", TOA);
    let sc = sonarnet::scenario::Scenario::load(&p).unwrap();
    let ogd = sonarnet::estimators::baselines::BaselineCfg::default_of("ogd").unwrap();
    let err = sc
        .clone()
        .with_baselines(vec![ogd])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("--baselines") && err.contains("bounds.tracks[0]") && err.contains("pocs"),
        "{err}"
    );
    let pocs = sonarnet::estimators::baselines::BaselineCfg::default_of("pocs").unwrap();
    assert!(sc.with_baselines(vec![pocs]).is_ok());
}

#[test]
fn the_default_ogd_step_tracks_the_spiral_and_a_diverging_constant_step_counts_failures() {
    let t = TempDir::new("ogd-step");
    let spiral = crate::util::scenario("mourya2017-spiral.toml");
    // The book's command: the default step (1/L_t) is stable.
    let out = t.path().join("default");
    let o = run_file(
        &spiral,
        &out,
        &[
            "--engine",
            "inprocess",
            "--quiet",
            "--baselines",
            "ogd,onm,ls",
        ],
        Duration::from_secs(120),
    );
    assert!(o.status.success());
    let m = crate::util::metrics(&out);
    let ogd = &m["baselines"]["ogd"];
    assert_eq!(ogd["failures"], 0);
    assert!(ogd["rmse"].as_f64().unwrap() < 200.0, "{ogd}");
    // Pun-So 2022's constant eta = 0.1 explodes on this km-scale geometry: the
    // samples beyond 100 scene diameters are failures, no number is absurd.
    let out = t.path().join("constant");
    let o = run_file(
        &spiral,
        &out,
        &[
            "--engine",
            "inprocess",
            "--set",
            "baselines=[{kind = \"ogd\", step = {rule = \"constant\", eta = 0.1}}]",
        ],
        Duration::from_secs(120),
    );
    assert!(o.status.success());
    let stdout = String::from_utf8_lossy(&o.stdout);
    let m = crate::util::metrics(&out);
    let ogd = &m["baselines"]["ogd"];
    assert!(ogd["failures"].as_u64().unwrap() > 0, "{ogd}");
    assert!(
        ogd["first_failure"].as_str().unwrap().contains("exploded"),
        "{ogd}"
    );
    // The exploded estimates stay the track's: its error is huge, and the
    // terminal prints it in engineering notation, never 90 digits.
    assert!(ogd["rmse"].as_f64().unwrap() > 1e6, "{ogd}");
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("ogd "))
        .unwrap();
    assert!(row.contains('e') && row.len() < 100, "{row}");
    assert!(
        stdout.lines().all(|l| l.len() < 120),
        "no 90-digit numbers:\n{stdout}"
    );
    // track.csv holds finite numbers, never inf or NaN.
    let track = std::fs::read_to_string(out.join("track.csv")).unwrap();
    assert!(!track.contains("inf") && !track.contains("NaN"));
}

#[test]
fn the_listed_baseline_kinds_are_exactly_the_kinds_a_file_may_name() {
    use sonarnet::estimators::baselines::{BaselineCfg, KINDS};
    for k in KINDS {
        let b = BaselineCfg::default_of(k).unwrap_or_else(|| panic!("{k} does not parse"));
        assert_eq!(b.kind(), *k);
    }
    // serde names every variant it knows when a kind is unknown.
    let err = toml::from_str::<BaselineCfg>("kind = \"none_such\"")
        .unwrap_err()
        .to_string();
    let known: Vec<&str> = err.split('`').skip(3).step_by(2).collect();
    let mut listed: Vec<&str> = KINDS.to_vec();
    let mut known_sorted = known.clone();
    listed.sort_unstable();
    known_sorted.sort_unstable();
    assert_eq!(listed, known_sorted, "serde's kinds: {err}");
}
