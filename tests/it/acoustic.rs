//! The acoustic channel on the discrete-event engine (issue 16): exact
//! delays, seeded loss, deterministic runs, and its outputs.

use crate::util::{TempDir, read_rows, scenario};
use sonarnet::pipeline::{self, RunOptions};
use sonarnet::scenario::Scenario;

/// A variant of `scenarios/mourya2017-spiral-acoustic.toml`.
fn variant(name: &str) -> Scenario {
    Scenario::load_all(&scenario("mourya2017-spiral-acoustic.toml"))
        .expect("loads")
        .into_iter()
        .find(|s| s.variant.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no variant {name}"))
}

/// Run `sc` on its own clock in-process and write it to `dir`.
fn run(sc: &Scenario, dir: &std::path::Path) -> pipeline::Outcome {
    let opts = RunOptions {
        command_line: vec!["test".into()],
        ..RunOptions::inprocess()
            .with_out_dir(dir)
            .with_clock(pipeline::default_clock(sc))
    };
    let out = sc.run_and_write(&opts).expect("writes");
    assert!(out.error.is_none(), "{:?}", out.error);
    out
}

#[test]
fn every_delivered_frame_takes_exactly_the_distance_over_the_sound_speed_plus_its_length() {
    let tmp = TempDir::new("acoustic-delay");
    let sc = variant("modem");
    run(&sc, tmp.path());
    let rows = read_rows(&tmp.path().join("messages.csv"));
    assert!(rows.len() > 1000, "{} frames", rows.len());
    let rx = &sc.geometry.receivers;
    let mut delivered = 0;
    for r in &rows {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        // A header, and 64 bits per value: a reflected point has 3.
        let bits: u64 = r[5].parse().unwrap();
        let values = if r[4] == "decline" { 0 } else { 3 };
        assert_eq!(bits, 48 + values * 64, "{r:?}");
        let bits = bits as f64;
        match r[6].as_str() {
            "delivered" => {
                delivered += 1;
                let took = r[1].parse::<f64>().unwrap() - r[0].parse::<f64>().unwrap();
                let want = (rx[from] - rx[to]).norm() / 1500.0 + bits / 1000.0;
                assert!((took - want).abs() < 1e-9, "{r:?}: {took} vs {want}");
                assert_eq!(r[7], "");
            }
            "lost" => {
                assert!(r[1].is_empty(), "{r:?}");
                assert!(
                    ["collision", "half_duplex"].contains(&r[7].as_str()),
                    "{r:?}"
                );
            }
            other => panic!("fate {other}"),
        }
    }
    assert!(delivered > 0 && delivered < rows.len());
}

#[test]
fn the_discrete_event_engine_gives_identical_files_from_the_same_seed() {
    let tmp = TempDir::new("acoustic-determinism");
    let sc = variant("range-loss");
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    run(&sc, &a);
    run(&sc, &b);
    for f in ["messages.csv", "nodes.csv", "track.csv"] {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs between two runs of one seed");
    }
    // Another seed, other fates.
    let c = tmp.path().join("c");
    run(&sc.clone().with_seed(1), &c);
    assert_ne!(
        std::fs::read(a.join("messages.csv")).unwrap(),
        std::fs::read(c.join("messages.csv")).unwrap()
    );
}

#[test]
fn bernoulli_loss_on_the_channel_lies_within_its_999_per_mille_binomial_interval() {
    let tmp = TempDir::new("acoustic-bernoulli");
    // Loss only: no half-duplex or collision loss to confuse the count.
    let text = std::fs::read_to_string(scenario("mourya2017-spiral-acoustic.toml"))
        .unwrap()
        .replace(
            "channel = { model = \"acoustic\", loss = { model = \"bernoulli\", p = 0.2 } }",
            "channel = { model = \"acoustic\", half_duplex = false, collisions = false, loss = { model = \"bernoulli\", p = 0.2 } }",
        );
    let path = tmp.write("bern.toml", &text);
    let sc = Scenario::load_all(&path)
        .unwrap()
        .into_iter()
        .find(|s| s.variant.as_deref() == Some("bernoulli-0.2"))
        .unwrap();
    let out = run(&sc, &tmp.path().join("out"));
    let ch = out.metrics.channel.expect("channel metrics");
    let lost = ch.lost.get("loss").copied().unwrap_or(0);
    assert_eq!(ch.lost.len(), 1, "{:?}", ch.lost);
    let n = ch.frames as f64;
    let sd = (0.2 * 0.8 / n).sqrt();
    let rate = lost as f64 / n;
    assert!((rate - 0.2).abs() < 3.29 * sd, "{rate} over {n} frames");
}

#[test]
fn the_channel_metrics_count_the_frames_and_the_ideal_channel_writes_none() {
    let tmp = TempDir::new("acoustic-metrics");
    let out = run(&variant("modem"), &tmp.path().join("modem"));
    let ch = out.metrics.channel.expect("channel metrics");
    let rows = read_rows(&tmp.path().join("modem").join("messages.csv"));
    assert_eq!(ch.frames as usize, rows.len());
    let delivered = rows.iter().filter(|r| r[6] == "delivered").count() as u64;
    assert_eq!(ch.delivered, delivered);
    assert_eq!(
        ch.lost.values().sum::<u64>() + ch.delivered,
        ch.frames,
        "{:?}",
        ch.lost
    );
    assert!(ch.exchanges_completed <= ch.exchanges_attempted);
    assert!(ch.exchanges_timed_out > 0);
    assert!((ch.emulated_seconds - 100.0 * 60.0).abs() < 60.0);
    // Every frame is an event (its judgement), and so is every node tick.
    assert!(
        ch.events > ch.frames + ch.exchanges_attempted,
        "{} events",
        ch.events
    );
    let json = std::fs::read_to_string(tmp.path().join("modem").join("metrics.json")).unwrap();
    assert!(json.contains("\"delivery_ratio\""));
    // The ideal variant: no channel key, no messages.csv.
    let ideal = run(&variant("ideal"), &tmp.path().join("ideal"));
    assert!(ideal.metrics.channel.is_none());
    assert!(!tmp.path().join("ideal").join("messages.csv").exists());
    let json = std::fs::read_to_string(tmp.path().join("ideal").join("metrics.json")).unwrap();
    assert!(!json.contains("\"channel\""));
}
