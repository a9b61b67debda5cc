//! Every shipped scenario validates, runs in-process, and meets its `[expect]` block.

use crate::util::{TempDir, root, run_inprocess};
use sonarnet::scenario::{ExpectCfg, Scenario};

fn check(name: &str, what: &str, got: Option<f64>, max: Option<f64>) -> Option<String> {
    let max = max?;
    match got {
        Some(v) if v <= max => None,
        Some(v) => Some(format!(
            "{name}: {what} = {v:.4} exceeds the expected maximum {max}"
        )),
        None => Some(format!(
            "{name}: {what} was not computed but [expect] bounds it"
        )),
    }
}

#[test]
fn every_scenario_validates_runs_and_meets_its_expect_block() {
    let mut failures = Vec::new();
    let mut count = 0;
    let mut entries: Vec<_> = std::fs::read_dir(root().join("scenarios"))
        .expect("scenarios dir")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    entries.sort();
    for path in entries {
        count += 1;
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let sc = match Scenario::load(&path) {
            Ok(sc) => sc,
            Err(e) => {
                failures.push(format!("{name}: does not validate: {e}"));
                continue;
            }
        };
        let tmp = TempDir::new("scenario");
        let out = run_inprocess(&sc, tmp.path());
        if let Some(e) = &out.error {
            failures.push(format!("{name}: run failed: {e}"));
            continue;
        }
        let m = &out.metrics;
        let ExpectCfg {
            rmse_max,
            rmse_after_burn_in_max,
            median_error_max,
            final_error_max,
            max_disagreement_max,
            ml_rmse_max,
        } = sc.expect.clone();
        failures.extend(
            [
                check(&name, "rmse", m.rmse, rmse_max),
                check(
                    &name,
                    "rmse_after_burn_in",
                    m.rmse_after_burn_in,
                    rmse_after_burn_in_max,
                ),
                check(&name, "median_error", m.median_error, median_error_max),
                check(&name, "final_error", m.final_error, final_error_max),
                check(
                    &name,
                    "max_disagreement",
                    Some(m.max_disagreement),
                    max_disagreement_max,
                ),
                check(&name, "ml_rmse", m.ml_rmse, ml_rmse_max),
            ]
            .into_iter()
            .flatten(),
        );
    }
    assert!(count >= 2, "expected at least two scenarios, found {count}");
    assert!(
        failures.is_empty(),
        "scenario expectations failed:\n{}",
        failures.join("\n")
    );
}
