//! Every shipped scenario (every variant) validates, runs in-process (as a
//! Monte Carlo run when it asks for trials), and meets its `[expect]` block.

use crate::util::{TempDir, root, run_inprocess};
use sonarnet::pipeline::{ExpectResult, RunOptions};
use sonarnet::scenario::{AnyScenario, Scenario};

fn describe(name: &str, checks: &[ExpectResult]) -> Vec<String> {
    checks
        .iter()
        .filter(|c| !c.holds)
        .map(|c| {
            format!(
                "{name}: expect {} fails (lhs {:?}, rhs {:?})",
                c.expect, c.lhs, c.rhs
            )
        })
        .collect()
}

/// The scenario files, sorted.
fn scenario_files() -> Vec<std::path::PathBuf> {
    let mut entries: Vec<_> = std::fs::read_dir(root().join("scenarios"))
        .expect("scenarios dir")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    entries.sort();
    entries
}

#[test]
fn every_scenario_validates_runs_and_meets_its_expect_block() {
    let mut failures = Vec::new();
    let mut count = 0;
    for path in scenario_files() {
        let file = path.file_name().unwrap().to_string_lossy().to_string();
        let all = match AnyScenario::load_all(&path) {
            Ok(v) => v,
            Err(e) => {
                failures.push(format!("{file}: does not validate: {e}"));
                continue;
            }
        };
        for sc in all {
            count += 1;
            let name = match sc.variant() {
                Some(v) => format!("{file} [{v}]"),
                None => file.clone(),
            };
            match &sc {
                AnyScenario::Plane(sc) => check(&name, sc, &mut failures),
                AnyScenario::Space(sc) => check(&name, sc, &mut failures),
            }
        }
    }
    assert!(count >= 2, "expected at least two scenarios, found {count}");
    assert!(
        failures.is_empty(),
        "scenario expectations failed:\n{}",
        failures.join("\n")
    );
}

/// Run one scenario (its Monte Carlo trials when it asks for them) and
/// add what fails to `failures`.
fn check<const D: usize>(name: &str, sc: &Scenario<D>, failures: &mut Vec<String>) {
    let tmp = TempDir::new("scenario");
    let checks = match sc.trials {
        Some(n) if n > 1 => {
            let opts = RunOptions {
                command_line: vec!["test".into()],
                check_expect: false,
                ..RunOptions::inprocess().with_out_dir(tmp.path())
            };
            // A Monte Carlo run keeps every core busy: it holds the
            // machine; the single runs (virtual time, one thread)
            // leave room for the other tests.
            let _cpu = crate::util::cpu_exclusive();
            match sonarnet::pipeline::montecarlo::run_monte_carlo(sc, n, &opts, &|_| {}) {
                Ok(mc) if mc.failed == 0 => mc.expect,
                Ok(mc) => {
                    failures.push(format!("{name}: {} trials failed", mc.failed));
                    return;
                }
                Err(e) => {
                    failures.push(format!("{name}: Monte Carlo failed: {e}"));
                    return;
                }
            }
        }
        _ => {
            let out = run_inprocess(sc, tmp.path());
            if let Some(e) = &out.run.error {
                failures.push(format!("{name}: run failed: {e}"));
                return;
            }
            out.metrics.expect
        }
    };
    if checks.is_empty() {
        failures.push(format!("{name}: has no [expect] checks"));
    }
    failures.extend(describe(name, &checks));
}
