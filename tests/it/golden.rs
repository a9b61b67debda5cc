//! Golden outputs: a handful of runs through the command line, whose
//! `nodes.csv`, `track.csv`, `trials.csv` and the values of `metrics.json` and
//! `summary.json` must stay bit for bit what they were when `tests/golden/runs/` was written.
//! A refactor changes no number; a new feature with its defaults off leaves
//! these files as they are.
//!
//! The runs cover sync and async gossip, both engines, `gtrs` and `gtrs_l0`,
//! the relaxed prox, certified bounds, centralised baselines and a Monte Carlo
//! batch. Timings (`*seconds`, rates per second), memory footprints and the
//! command line (it holds the temporary results path) are not compared.
//!
//! To write the files anew (only when a change of numbers is intended, and
//! say so in the commit):
//! `SONARNET_BLESS_GOLDEN=1 cargo test --release --test it golden`.

use crate::util::{TempDir, root, run_file, scenario};
use serde_json::Value;
use sonarnet::pipeline::replay::{scalars, without_timing};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// (name, scenario file, extra flags).
const RUNS: &[(&str, &str, &[&str])] = &[
    (
        "spiral-async-inprocess",
        "mourya2017-spiral.toml",
        &["--engine", "inprocess"],
    ),
    (
        "spiral-sync-inprocess",
        "mourya2017-spiral.toml",
        &["--engine", "inprocess", "--mode", "sync"],
    ),
    (
        "spiral-async-processes",
        "mourya2017-spiral.toml",
        &["--engine", "processes", "--samples", "25"],
    ),
    (
        "spiral-sync-processes",
        "mourya2017-spiral.toml",
        &["--engine", "processes", "--mode", "sync", "--samples", "15"],
    ),
    (
        "spiral-relaxed-seed3",
        "mourya2017-spiral.toml",
        &[
            "--engine",
            "inprocess",
            "--local-solver",
            "relaxed",
            "--seed",
            "3",
            "--samples",
            "40",
        ],
    ),
    (
        "spiral-nlos-gtrs-l0",
        "mourya2017-spiral-nlos.toml",
        &["--engine", "inprocess"],
    ),
    (
        "spiral-certified-bounds",
        "mourya2017-spiral-certified.toml",
        &["--engine", "inprocess"],
    ),
    (
        "spiral-baselines",
        "mourya2017-spiral.toml",
        &[
            "--engine",
            "inprocess",
            "--samples",
            "40",
            "--baselines",
            "ogd,onm,ls,ml,lls,pocs",
        ],
    ),
    (
        "gholami-moving-target",
        "gholami-moving-target.toml",
        &["--engine", "inprocess"],
    ),
    (
        "spiral-monte-carlo",
        "mourya2017-spiral.toml",
        &["--engine", "inprocess", "--samples", "20", "--trials", "4"],
    ),
];

const FILES: &[&str] = &[
    "nodes.csv",
    "track.csv",
    "trials.csv",
    "metrics.json",
    "summary.json",
];

fn golden_dir(name: &str) -> PathBuf {
    root().join("tests/golden/runs").join(name)
}

/// A CSV with its timing columns removed (the processes engine writes
/// per-node busy and wait seconds into `nodes.csv`), by the rule `sonarnet
/// replay` uses ([`sonarnet::pipeline::replay::is_timing`]).
fn without_timing_columns(text: &str) -> String {
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return String::new();
    };
    let mut out = without_timing(header, header);
    for l in lines {
        out.push('\n');
        out.push_str(&without_timing(header, l));
    }
    out
}

/// The comparable content of one output file.
pub(crate) fn canonical(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    if path.extension().is_some_and(|e| e == "json") {
        let v: Value = serde_json::from_str(&text).expect("metrics.json parses");
        let mut nums = vec![];
        scalars(&v, "", &mut nums);
        Some(
            nums.into_iter()
                .map(|(p, n)| format!("{p} = {n}\n"))
                .collect(),
        )
    } else {
        Some(without_timing_columns(&text))
    }
}

/// The compared files under `dir` (variants write into subdirectories),
/// by relative path, with their comparable content.
fn outputs(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read results dir") {
            let p = e.expect("dir entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if FILES.iter().any(|f| p.file_name().is_some_and(|n| n == *f)) {
                let rel = p
                    .strip_prefix(dir)
                    .expect("under dir")
                    .to_string_lossy()
                    .into_owned();
                out.insert(rel, canonical(&p).expect("readable output"));
            }
        }
    }
    out
}

/// The golden files of one run, by the relative path of the output they hold.
fn golden(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries {
            let p = e.expect("dir entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if let Some(rel) = p
                .strip_prefix(dir)
                .expect("under dir")
                .to_string_lossy()
                .strip_suffix(".golden")
            {
                out.insert(
                    rel.to_string(),
                    std::fs::read_to_string(&p).expect("read golden"),
                );
            }
        }
    }
    out
}

#[test]
fn golden_outputs_are_reproduced_bit_for_bit() {
    let bless = std::env::var("SONARNET_BLESS_GOLDEN").as_deref() == Ok("1");
    let tmp = TempDir::new("golden");
    let mut compared = 0;
    for (name, file, args) in RUNS {
        let out = tmp.path().join(name);
        let o = run_file(&scenario(file), &out, args, Duration::from_secs(300));
        assert!(
            o.status.success(),
            "{name}: sonarnet failed\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let now = outputs(&out);
        let want_dir = golden_dir(name);
        if bless {
            let _ = std::fs::remove_dir_all(&want_dir);
            for (rel, text) in &now {
                let p = want_dir.join(format!("{rel}.golden"));
                std::fs::create_dir_all(p.parent().expect("parent")).expect("mkdir golden");
                std::fs::write(&p, text).expect("write golden");
            }
            continue;
        }
        let want = golden(&want_dir);
        assert_eq!(
            now.keys().collect::<Vec<_>>(),
            want.keys().collect::<Vec<_>>(),
            "{name}: the run writes other files than tests/golden/runs/{name} holds"
        );
        for (rel, text) in &now {
            let g = &want[rel];
            if text != g {
                let first = text
                    .lines()
                    .zip(g.lines())
                    .position(|(a, b)| a != b)
                    .unwrap_or(text.lines().count().min(g.lines().count()));
                panic!(
                    "{name}/{rel} differs from tests/golden/runs/{name}/{rel}.golden at line {}:\n  now:    {}\n  golden: {}",
                    first + 1,
                    text.lines().nth(first).unwrap_or("<end>"),
                    g.lines().nth(first).unwrap_or("<end>")
                );
            }
            compared += 1;
        }
    }
    if !bless {
        assert!(compared >= 30, "only {compared} golden files compared");
    }
}
