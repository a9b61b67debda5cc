//! A recorded trace plus the schedule used reproduce a synthesized run exactly.

use crate::util::{TempDir, read_rows, run_inprocess, scenario};
use sonarnet::scenario::Scenario;

#[test]
fn a_trace_and_schedule_replay_reproduces_the_synthesized_run_exactly() {
    let sc = Scenario::load(&scenario("mourya2017-spiral.toml"))
        .unwrap()
        .with_samples(20)
        .unwrap()
        .with_seed(3);
    let first = TempDir::new("replay-a");
    let a = run_inprocess(&sc, first.path());
    assert!(a.run.error.is_none());

    // A scenario that replays the first run's measurements, truth and schedule.
    let text = std::fs::read_to_string(scenario("mourya2017-spiral.toml")).unwrap();
    let text = text
        .replace(
            "[target]\nsamples = 100\n",
            "[target]\nsamples = 20\n",
        )
        .replace(
            "doa_noise = { model = \"gaussian\", sigma = 0.5 }",
            &format!(
                "doa_noise = {{ model = \"gaussian\", sigma = 0.5 }}\ntrace = \"{}\"\ntruth = \"{}\"",
                first.path().join("measurements.csv").display(),
                first.path().join("truth.csv").display()
            ),
        )
        .replace(
            "burn_in = 10",
            &format!("burn_in = 10\nschedule = \"{}\"", first.path().join("schedule.csv").display()),
        );
    // The trace replaces the motion model: drop [target]'s motion line.
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("motion ="))
        .collect::<Vec<_>>()
        .join("\n")
        .replace("[target]\nsamples = 20", "");
    let second = TempDir::new("replay-b");
    let p = second.write("replay.toml", &text);
    // A different seed proves nothing random is drawn.
    let sc2 = Scenario::load(&p).unwrap().with_seed(99);
    let b = run_inprocess(&sc2, second.path());
    assert!(b.run.error.is_none());
    let na = read_rows(&first.path().join("nodes.csv"));
    let nb = read_rows(&second.path().join("nodes.csv"));
    assert_eq!(na.len(), nb.len());
    for (ra, rb) in na.iter().zip(&nb) {
        assert_eq!(ra[..5], rb[..5], "nodes.csv differs");
    }
    approx::assert_relative_eq!(
        a.metrics.rmse.unwrap(),
        b.metrics.rmse.unwrap(),
        max_relative = 0.0
    );
}

#[test]
fn a_trace_without_truth_still_gives_estimates_and_says_why_errors_are_missing() {
    let sc = Scenario::load(&scenario("mourya2017-spiral.toml"))
        .unwrap()
        .with_samples(12)
        .unwrap();
    let first = TempDir::new("notruth-a");
    run_inprocess(&sc, first.path());
    let geometry = sonarnet::model::measure::Geometry::mourya2017().toml_table();
    let text = format!(
        r#"name = "no-truth"
[geometry]
{geometry}
[network]
edges = [[0, 1], [0, 2], [1, 3], [2, 3], [3, 4], [3, 5]]
[measurements]
trace = "{}"
[algorithm]
mode = "sync"
gamma = 2e-8
"#,
        first.path().join("measurements.csv").display()
    );
    let second = TempDir::new("notruth-b");
    let p = second.write("s.toml", &text);
    let out = run_inprocess(&Scenario::load(&p).unwrap(), second.path());
    assert!(out.run.error.is_none());
    assert_eq!(out.metrics.samples_completed, 12);
    assert!(out.metrics.rmse.is_none() && out.metrics.ml_rmse.is_none());
    assert!(
        out.metrics
            .note
            .as_deref()
            .unwrap_or("")
            .contains("no truth")
    );
    let rows = read_rows(&second.path().join("track.csv"));
    assert_eq!(rows.len(), 12);
    assert!(rows.iter().all(|r| r[1].is_empty() && !r[3].is_empty()));
}
