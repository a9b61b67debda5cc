//! `sonarnet run`, Monte Carlo, sweep, replay and report on a 3-D scenario:
//! the same commands as in 2-D, with a `z` beside every `x, y` in the
//! outputs, a depth figure, and the dimension stated.

use crate::util::{TempDir, header, read_rows, run_file, scenario, sonarnet};
use sonarnet::pipeline::RunOptions;
use sonarnet::scenario::AnyScenario;
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn col(path: &Path, name: &str) -> Vec<f64> {
    let h = header(path);
    let j = h
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("{} has no column {name}: {h:?}", path.display()));
    read_rows(path)
        .iter()
        .map(|r| r[j].parse::<f64>().expect("a number"))
        .collect()
}

#[test]
fn sonarnet_run_on_the_3d_scenario_writes_depth_columns_and_a_depth_figure_and_replays_identically()
{
    let tmp = TempDir::new("run-3d");
    let out = tmp.path().join("run");
    let file = scenario("mourya2017-spiral-3d.toml");
    let o = run_file(
        &file,
        &out,
        &["--engine", "inprocess", "--samples", "20", "--report"],
        LIMIT,
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("sonarnet run: 3-D, inprocess"), "{stdout}");
    let track = out.join("track.csv");
    let h = header(&track);
    for c in ["true_z", "est_z", "ml_z"] {
        assert!(h.contains(&c.to_string()), "{h:?}");
    }
    assert_eq!(
        header(&out.join("nodes.csv")),
        ["sample", "node", "x", "y", "z", "d", "alive", "seed"]
    );
    assert_eq!(
        header(&out.join("truth.csv")),
        ["sample", "x", "y", "z", "seed"]
    );
    // The error is the 3-D distance, and the estimate is the nodes' mean.
    let (ex, ey, ez, err) = (
        col(&track, "est_x"),
        col(&track, "est_y"),
        col(&track, "est_z"),
        col(&track, "error"),
    );
    let (tx, ty, tz) = (
        col(&track, "true_x"),
        col(&track, "true_y"),
        col(&track, "true_z"),
    );
    assert_eq!(err.len(), 20);
    for k in 0..20 {
        let d =
            ((ex[k] - tx[k]).powi(2) + (ey[k] - ty[k]).powi(2) + (ez[k] - tz[k]).powi(2)).sqrt();
        assert!((err[k] - d).abs() <= 1e-9 * d.max(1.0), "sample {k}");
        // The helix descends 1 m a sample from 100 m.
        assert!((tz[k] + 100.0 + k as f64).abs() < 1e-9, "sample {k}");
    }
    let nodes = read_rows(&out.join("nodes.csv"));
    let last: Vec<f64> = nodes
        .iter()
        .filter(|r| r[0] == "19")
        .map(|r| r[4].parse::<f64>().expect("z"))
        .collect();
    assert_eq!(last.len(), 6);
    let mean = last.iter().sum::<f64>() / 6.0;
    assert!((mean - ez[19]).abs() < 1e-9, "{mean} vs {}", ez[19]);
    // Elevations are in the replayable measurement trace.
    let kinds: Vec<String> = read_rows(&out.join("measurements.csv"))
        .into_iter()
        .map(|r| r[3].clone())
        .collect();
    assert_eq!(kinds.iter().filter(|k| *k == "elevation").count(), 6 * 20);
    // The plan view, the depth figure, and a report that says 3-D.
    for f in ["tracks.svg", "depth.svg", "consensus.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    assert!(html.contains("3-D (x, y, z; z up)"));
    assert!(html.contains("depth.svg") || html.contains("Depth"));
    let r = sonarnet(&["replay", out.to_str().expect("utf-8")], LIMIT);
    let said = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{said}");
    assert!(said.contains("identical results"), "{said}");
}

#[test]
fn a_3d_run_through_the_library_writes_exactly_the_numbers_it_computed() {
    let file = scenario("mourya2017-spiral-3d.toml");
    let Some(AnyScenario::Space(sc)) = AnyScenario::load_all(&file)
        .expect("valid")
        .into_iter()
        .next()
    else {
        panic!("the 3-D scenario reads as 3-D");
    };
    let sc = sc.with_samples(12).expect("12 samples").with_seed(5);
    let tmp = TempDir::new("lib-3d");
    let out = sc
        .run_and_write(&RunOptions::inprocess().with_out_dir(tmp.path()))
        .expect("written");
    assert!(out.run.error.is_none());
    let track = tmp.path().join("track.csv");
    let tb = &out.scored.tracks[0];
    for (axis, name) in ["est_x", "est_y", "est_z"].iter().enumerate() {
        let written = col(&track, name);
        for (k, w) in written.iter().enumerate() {
            let x = tb.est[k].expect("an estimate")[axis];
            assert_eq!(w.to_bits(), x.to_bits(), "{name} sample {k}");
        }
    }
    // Every check of the shipped [expect] block is there (and holds at the
    // scenario's own seed; the shipped-scenarios test runs it).
    assert!(!out.metrics.expect.is_empty());
}

#[test]
fn upp_exact_with_bistatic_ranges_in_3d_bounds_every_error_and_is_never_above_upp_maxdis() {
    let tmp = TempDir::new("exact-3d");
    let out = tmp.path().join("run");
    let o = run_file(
        &scenario("mourya2017-spiral-3d.toml"),
        &out,
        &[
            "--engine",
            "inprocess",
            "--samples",
            "14",
            "--set",
            "bounds.names=[\"upp_maxdis\", \"upp_exact\"]",
            "--set",
            "bounds.rho_sigmas=3",
            "--quiet",
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let track = out.join("track.csv");
    let (error, exact, maxdis) = (
        col(&track, "error"),
        col(&track, "bound_upp_exact"),
        col(&track, "bound_upp_maxdis"),
    );
    assert_eq!(exact.len(), 14);
    for k in 0..exact.len() {
        // The truth is in the enlarged set: the worst case covers the error,
        // and the SDP relaxation is never below the exact worst case.
        assert!(
            error[k] <= exact[k],
            "sample {k}: {} > {}",
            error[k],
            exact[k]
        );
        assert!(
            exact[k] <= maxdis[k] * (1.0 + 1e-7),
            "sample {k}: exact {} above upp_maxdis {}",
            exact[k],
            maxdis[k]
        );
    }
}

#[test]
fn a_3d_scenario_runs_as_monte_carlo_trials_and_as_a_sweep() {
    let tmp = TempDir::new("mc-3d");
    let file = scenario("mourya2017-spiral-3d.toml");
    let mc = tmp.path().join("mc");
    let o = run_file(
        &file,
        &mc,
        &["--trials", "3", "--samples", "12", "--quiet"],
        LIMIT,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_rows(&mc.join("trials.csv")).len(), 3);
    assert!(mc.join("depth.svg").is_file());
    let sw = tmp.path().join("sweep");
    let o = sonarnet(
        &[
            "sweep",
            file.to_str().expect("utf-8"),
            "--grid",
            "algorithm.gamma=1e-8,2e-8",
            "--seeds",
            "0..1",
            "--set",
            "target.samples=12",
            "--engine",
            "inprocess",
            "--out",
            sw.to_str().expect("utf-8"),
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_rows(&sw.join("sweep.csv")).len(), 4);
}
