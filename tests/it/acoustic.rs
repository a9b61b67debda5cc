//! The acoustic channel on the discrete-event engine: exact
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
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
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
                // `late`: it arrived, after its exchange was given up.
                assert!(
                    ["collision", "half_duplex", "late"].contains(&r[7].as_str()),
                    "{r:?}"
                );
            }
            "in_flight" => assert!(r[1].is_empty() && r[7].is_empty(), "{r:?}"),
            other => panic!("fate {other}"),
        }
    }
    assert!(delivered > 0 && delivered < rows.len());
}

#[test]
fn in_3d_every_delivered_frame_takes_the_3d_distance_over_the_sound_speed_plus_its_length() {
    let tmp = TempDir::new("acoustic-3d");
    let file = scenario("mourya2017-spiral-3d-acoustic.toml");
    let Some(sonarnet::scenario::AnyScenario::Space(sc)) =
        sonarnet::scenario::AnyScenario::load_all(&file)
            .expect("loads")
            .into_iter()
            .next()
    else {
        panic!("the 3-D acoustic scenario is 3-D");
    };
    let sc = sc.with_samples(20).expect("20 samples");
    let opts = RunOptions {
        command_line: vec!["test".into()],
        ..RunOptions::inprocess()
            .with_out_dir(tmp.path())
            .with_clock(pipeline::default_clock(&sc))
    };
    let out = sc.run_and_write(&opts).expect("writes");
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
    let rows = read_rows(&tmp.path().join("messages.csv"));
    let rx = &sc.geometry.receivers;
    let (mut delivered, mut deeper) = (0, 0);
    for r in rows.iter().filter(|r| r[6] == "delivered") {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        // A header, and 64 bits per value: a reflected point (x, y, z, d) has 4.
        let bits: u64 = r[5].parse().unwrap();
        let values = if r[4] == "decline" { 0 } else { 4 };
        assert_eq!(bits, 48 + values * 64, "{r:?}");
        let took = r[1].parse::<f64>().unwrap() - r[0].parse::<f64>().unwrap();
        let d = (rx[from] - rx[to]).norm();
        let want = d / 1500.0 + bits as f64 / 1000.0;
        assert!((took - want).abs() < 1e-9, "{r:?}: {took} vs {want}");
        let plan = (rx[from].xy() - rx[to].xy()).norm();
        deeper += usize::from(d - plan > 1.0);
        delivered += 1;
    }
    assert!(delivered > 100, "{delivered} delivered");
    // The receivers sit at different depths: the delays are not the plan
    // view's.
    assert!(deeper > delivered / 2, "{deeper} of {delivered}");
}

#[test]
fn through_mackenzies_sound_speed_every_delivered_frame_takes_its_slanted_paths_travel_time() {
    let tmp = TempDir::new("acoustic-mackenzie");
    let text = std::fs::read_to_string(scenario("mourya2017-spiral-3d-acoustic.toml"))
        .expect("reads")
        .replace(
            "[channel]\n",
            "[channel]\nsound_speed_profile = { model = \"mackenzie\", temperature_c = 10.0, salinity_psu = 35.0 }\n",
        );
    let file = tmp.write("mackenzie.toml", &text);
    let Some(sonarnet::scenario::AnyScenario::Space(sc)) =
        sonarnet::scenario::AnyScenario::load_all(&file)
            .expect("loads")
            .into_iter()
            .next()
    else {
        panic!("3-D");
    };
    let sc = sc.with_samples(15).expect("15 samples");
    let dir = tmp.path().join("out");
    let opts = RunOptions {
        command_line: vec!["test".into()],
        ..RunOptions::inprocess()
            .with_out_dir(&dir)
            .with_clock(pipeline::default_clock(&sc))
    };
    let out = sc.run_and_write(&opts).expect("writes");
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
    // Mackenzie 1981 written out again, integrated along the path by a
    // midpoint sum on 20000 pieces.
    let c = |d: f64| {
        let (t, s) = (10.0, 35.0);
        1448.96 + 4.591 * t - 5.304e-2 * t * t
            + 2.374e-4 * t * t * t
            + 1.340 * (s - 35.0)
            + 1.630e-2 * d
            + 1.675e-7 * d * d
            - 1.025e-2 * t * (s - 35.0)
            - 7.139e-13 * t * d * d * d
    };
    let rx = &sc.geometry.receivers;
    let mut delivered = 0;
    for r in read_rows(&dir.join("messages.csv"))
        .iter()
        .filter(|r| r[6] == "delivered")
    {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let (a, b) = (rx[from], rx[to]);
        let n = 20_000;
        let travel: f64 = (0..n)
            .map(|k| {
                let p = a + (b - a) * ((k as f64 + 0.5) / n as f64);
                (b - a).norm() / n as f64 / c((-p.z).max(0.0))
            })
            .sum();
        let bits: f64 = r[5].parse().unwrap();
        let took = r[1].parse::<f64>().unwrap() - r[0].parse::<f64>().unwrap();
        let want = travel + bits / 1000.0;
        // The medium rounds the delay and the airtime to the nanosecond.
        assert!((took - want).abs() < 5e-9, "{r:?}: {took} vs {want}");
        assert!((took - ((b - a).norm() / 1500.0 + bits / 1000.0)).abs() > 1e-4);
        delivered += 1;
    }
    assert!(delivered > 50, "{delivered} delivered");
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
            "channel = { model = \"acoustic\", time_scale = 60.0, loss = { model = \"bernoulli\", p = 0.2 } }",
            "channel = { model = \"acoustic\", half_duplex = false, collisions = false, loss = { model = \"bernoulli\", p = 0.2 } }",
        );
    assert!(
        text.contains("collisions = false, loss"),
        "the variant changed"
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
    // Besides the loss draws, only answers that came after their timeout.
    assert!(
        ch.lost.keys().all(|k| k == "loss" || k == "late"),
        "{:?}",
        ch.lost
    );
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
    // Every frame is a row: judged (the channel's frames) or in flight.
    assert_eq!((ch.frames + ch.in_flight) as usize, rows.len());
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

/// Counts the frames of `kind` to (or, with `to = None`, between any) nodes
/// that were lost for any reason, late included.
fn lost_frames(rows: &[Vec<String>], kind: &str, to: Option<&str>) -> u64 {
    rows.iter()
        .filter(|r| r[4] == kind && r[6] == "lost" && to.is_none_or(|t| r[3] == t))
        .count() as u64
}

/// Sync rounds over a lossy channel: the root averages at
/// its round timeout the points that came, so every reflected point lost on
/// the way to the root or late is one point missing from its round; a node
/// without the root's Average keeps its state, so every Average lost or late
/// is one round timed out. The counts add up frame for frame.
#[test]
fn sync_rounds_on_a_lossy_channel_count_each_missing_point_and_each_missed_average() {
    let tmp = TempDir::new("acoustic-sync");
    let mut sc = variant("sync-modem");
    sc.channel =
        sonarnet::model::channel::ChannelCfg::Acoustic(sonarnet::model::channel::AcousticCfg {
            loss: sonarnet::model::channel::LossCfg::Bernoulli { p: 0.2 },
            ..Default::default()
        });
    let out = run(&sc, tmp.path());
    let ch = out.metrics.channel.expect("channel metrics");
    let rows = read_rows(&tmp.path().join("messages.csv"));
    let rounds = (sc.samples * sc.algorithm.iterations_per_sample) as u64;
    let n = sc.graph.len() as u64;
    let reflects = rows.iter().filter(|r| r[4] == "reflect").count() as u64;
    assert_eq!(reflects, rounds * (n - 1), "one point per node and round");
    assert!(
        ch.points_missing > 100 && ch.rounds_timed_out > 100,
        "{ch:?}"
    );
    assert_eq!(ch.points_missing, lost_frames(&rows, "reflect", Some("0")));
    assert_eq!(ch.rounds_timed_out, lost_frames(&rows, "average", None));
    assert_eq!(ch.exchanges_timed_out + ch.steps_timed_out, 0);
    // Every node still went through every round.
    assert_eq!(out.metrics.samples_completed, sc.samples);
}

/// Async logical steps over a lossy channel: a node whose
/// partner's point is lost or late keeps its state for that step; the frames
/// lost or late account for the steps timed out, up to the frames still on
/// their way when the run ended (at most one per node).
#[test]
fn async_logical_steps_on_a_lossy_channel_time_out_once_per_lost_or_late_point() {
    let tmp = TempDir::new("acoustic-logical");
    let sc = variant("logical-modem");
    let out = run(&sc, tmp.path());
    let ch = out.metrics.channel.expect("channel metrics");
    let rows = read_rows(&tmp.path().join("messages.csv"));
    let lost = lost_frames(&rows, "reflect", None);
    let n = sc.graph.len() as u64;
    assert!(lost > 100, "{ch:?}");
    assert!(
        ch.steps_timed_out >= lost && ch.steps_timed_out <= lost + n,
        "{} steps timed out, {lost} points lost or late",
        ch.steps_timed_out
    );
    assert_eq!(
        ch.rounds_timed_out + ch.points_missing + ch.exchanges_timed_out,
        0
    );
    assert_eq!(out.metrics.samples_completed, sc.samples);
}

/// The acoustic scenario made short for node processes: `samples` samples 5
/// emulated seconds apart, nodes waking once a second, `time_scale = 10`.
fn short_acoustic(tmp: &TempDir, samples: usize) -> std::path::PathBuf {
    let text = std::fs::read_to_string(scenario("mourya2017-spiral-acoustic.toml"))
        .unwrap()
        .replace("samples = 100", &format!("samples = {samples}"))
        .replace("burn_in = 10", "burn_in = 2")
        .replace("sample_period_ms = 60000.0", "sample_period_ms = 5000.0")
        .replace("wake_rate_hz = 0.2", "wake_rate_hz = 1.0")
        .replace("time_scale = 60.0", "time_scale = 10.0");
    tmp.write("short.toml", &text)
}

/// The fraction of `rows` (messages.csv) the channel delivered (a late frame
/// was delivered too, and discarded by its node), and the row count.
fn channel_delivered(rows: &[Vec<String>]) -> (f64, f64) {
    let ok = rows
        .iter()
        .filter(|r| r[6] == "delivered" || r[7] == "late")
        .count();
    (ok as f64 / rows.len().max(1) as f64, rows.len() as f64)
}

/// The processes engine applies the same channel.
/// A run at `time_scale = 10` completes; every delivered frame's planned delay
/// is exactly distance / c + bits / rate, and none is forwarded early (the
/// realised error, reported as p50 and p99, is never negative); its delivery
/// ratio agrees with the discrete-event engine's (five seeds pooled) within
/// the 99.9 % interval of the difference of two proportions; and nothing is
/// left behind.
#[test]
fn an_acoustic_processes_run_agrees_with_the_discrete_event_engine() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("acoustic-processes");
    let file = short_acoustic(&tmp, 40);
    let p = tmp.path().join("p");
    let out = crate::util::wait_watchdog(
        crate::util::spawn_sonarnet(&[
            "run",
            file.to_str().unwrap(),
            "--variant",
            "modem",
            "--engine",
            "processes",
            "--out",
            p.to_str().unwrap(),
        ]),
        "an acoustic processes run",
        std::time::Duration::from_secs(300),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    crate::util::assert_nothing_left(&crate::util::run_id_of(&p));
    let m = crate::util::metrics(&p);
    let ch = &m["channel"];
    let (p50, p99) = (
        ch["delivery_error_p50_ms"].as_f64().unwrap(),
        ch["delivery_error_p99_ms"].as_f64().unwrap(),
    );
    println!("realised delivery error: p50 {p50:.2} ms, p99 {p99:.2} ms (emulated)");
    assert!(p50 >= 0.0 && p99 >= p50, "{ch}");
    let rows = read_rows(&p.join("messages.csv"));
    let sc = Scenario::load_all(&file)
        .unwrap()
        .into_iter()
        .find(|s| s.variant.as_deref() == Some("modem"))
        .unwrap();
    let rx = &sc.geometry.receivers;
    for r in rows.iter().filter(|r| r[6] == "delivered") {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let took = r[1].parse::<f64>().unwrap() - r[0].parse::<f64>().unwrap();
        let bits: f64 = r[5].parse().unwrap();
        let want = (rx[from] - rx[to]).norm() / 1500.0 + bits / 1000.0;
        assert!((took - want).abs() < 1e-9, "{r:?}: {took} vs {want}");
    }
    let (pp, np) = channel_delivered(&rows);
    // The discrete-event engine, five seeds pooled.
    let (mut ok, mut n) = (0.0, 0.0);
    for seed in 0..5 {
        let d = tmp.path().join(format!("d{seed}"));
        run(&sc.clone().with_seed(seed), &d);
        let (r, k) = channel_delivered(&read_rows(&d.join("messages.csv")));
        ok += r * k;
        n += k;
    }
    let pd = ok / n;
    let pool = (pp * np + ok) / (np + n);
    let sd = (pool * (1.0 - pool) * (1.0 / np + 1.0 / n)).sqrt();
    println!("delivered: processes {pp:.4} of {np} frames, discrete-event {pd:.4} of {n}");
    assert!(np > 300.0, "{np} frames");
    assert!(
        (pp - pd).abs() < 3.29 * sd,
        "processes {pp:.4} vs discrete-event {pd:.4} (sd {sd:.4})"
    );
}

/// An acoustic run draws `messages.svg` and `channel.svg`,
/// and the HTML report shows both with the channel's metrics; a run on the
/// ideal channel draws neither.
#[test]
fn an_acoustic_run_draws_the_message_diagram_and_the_delivery_by_length() {
    let tmp = TempDir::new("acoustic-plots");
    let file = scenario("mourya2017-spiral-acoustic.toml");
    for (v, acoustic) in [("bernoulli-0.2", true), ("ideal", false)] {
        let out = tmp.path().join(v);
        let o = crate::util::run_file(
            &file,
            &out,
            &["--variant", v, "--engine", "inprocess", "--report"],
            std::time::Duration::from_secs(120),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for f in ["messages.svg", "channel.svg"] {
            assert_eq!(out.join(f).is_file(), acoustic, "{v}: {f}");
        }
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        for needle in [
            "id=\"plot-messages\"",
            "id=\"plot-channel\"",
            "channel.delivery_ratio",
        ] {
            assert_eq!(html.contains(needle), acoustic, "{v}: {needle}");
        }
    }
}

/// The discrete-event engine is the fast path for Monte Carlo runs over the
/// channel: trials of an acoustic variant run in virtual
/// time, each from its own seed (so each has its own channel fates), trial 0
/// is the single run of the base seed number for number, and the channel's
/// metrics are columns of `trials.csv`. Node processes are refused.
#[test]
fn monte_carlo_trials_run_the_acoustic_channel_in_virtual_time() {
    let tmp = TempDir::new("acoustic-mc");
    let file = scenario("mourya2017-spiral-acoustic.toml");
    let mc = tmp.path().join("mc");
    let o = crate::util::run_file(
        &file,
        &mc,
        &["--variant", "modem", "--trials", "4"],
        std::time::Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(mc.join("trials.csv")).unwrap();
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    let col = |n: &str| {
        header
            .iter()
            .position(|h| h == n)
            .unwrap_or_else(|| panic!("no {n}"))
    };
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 4);
    let frames: Vec<&str> = rows.iter().map(|r| &r[col("channel.frames")]).collect();
    assert!(
        frames.iter().any(|f| *f != frames[0]),
        "every trial had the same channel: {frames:?}"
    );
    let single = run(&variant("modem"), &tmp.path().join("single"));
    let rmse0: f64 = rows[0][col("theta_bar.rmse_after_burn_in")]
        .parse()
        .unwrap();
    let want = single.metrics.rmse_after_burn_in.unwrap();
    assert!(rmse0.to_bits() == want.to_bits(), "{rmse0} vs {want}");
    let o = crate::util::run_file(
        &file,
        &tmp.path().join("p"),
        &[
            "--variant",
            "modem",
            "--trials",
            "4",
            "--engine",
            "processes",
        ],
        std::time::Duration::from_secs(60),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--engine"));
}

/// `messages.csv` times as integer nanoseconds (they are written from
/// them, so the round trip is exact).
fn ns(cell: &str) -> u64 {
    (cell.parse::<f64>().expect("a time") * 1e9).round() as u64
}

/// Judge every frame of `rows` (messages.csv of `sc`) again from the rows
/// alone, in integer nanoseconds with half-open intervals, and compare with
/// the recorded fate: `half_duplex` exactly when the addressee transmitted
/// during the arrival, `collision` exactly when (else) another transmission
/// that reaches the addressee arrived during it (each only when the
/// variant's channel has the rule on), and a delivered frame neither. Returns how many frames were judged.
fn rejudge(sc: &Scenario, rows: &[Vec<String>]) -> usize {
    let n = sc.geometry.receivers.len();
    let c = 1500.0;
    let delay = |i: usize, j: usize| -> u64 {
        ((sc.geometry.receivers[i] - sc.geometry.receivers[j]).norm() / c * 1e9).round() as u64
    };
    let airtime = |bits: u64| -> u64 { (bits as f64 / 1000.0 * 1e9).round() as u64 };
    // One transmission per (sender, start): its airtime and addressees,
    // per sender in the order of their starts.
    let mut tx: std::collections::BTreeMap<(usize, u64), (u64, Vec<usize>)> = Default::default();
    for r in rows {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let e = tx
            .entry((from, ns(&r[0])))
            .or_insert((airtime(r[5].parse().unwrap()), Vec::new()));
        e.1.push(to);
    }
    let longest = tx.values().map(|t| t.0).max().unwrap_or(0);
    let mut by_node: Vec<Vec<(u64, u64, Vec<usize>)>> = vec![Vec::new(); n];
    for ((i, s), (t, to)) in tx {
        by_node[i].push((s, t, to));
    }
    // The transmissions of node `i` that start in `[lo, hi)`.
    let starting = |i: usize, lo: u64, hi: u64| {
        let v = &by_node[i];
        let k = v.partition_point(|x| x.0 < lo);
        v[k..].iter().take_while(move |x| x.0 < hi)
    };
    let reach = |i: usize, j: usize| sc.graph.neighbours(i).contains(&j);
    // Which rules are on: (half-duplex, collisions).
    let cfg = sc.channel.acoustic().expect("an acoustic variant");
    let rules = (cfg.half_duplex, cfg.collisions);
    let mut judged = 0;
    for r in rows.iter().filter(|r| r[6] != "in_flight") {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let t0 = ns(&r[0]);
        let a = t0 + delay(from, to);
        let b = a + airtime(r[5].parse().unwrap());
        let overlaps = |s: u64, e: u64| s < b && a < e;
        let half_duplex =
            rules.0 && starting(to, a.saturating_sub(longest), b).any(|x| overlaps(x.0, x.0 + x.1));
        let collision = rules.1
            && (0..n).filter(|&i| i != to).any(|i| {
                let d = delay(i, to);
                starting(i, a.saturating_sub(longest + d), b.saturating_sub(d)).any(|x| {
                    (i, x.0) != (from, t0)
                        && (reach(i, to) || x.2.contains(&to))
                        && overlaps(x.0 + d, x.0 + d + x.1)
                })
            });
        let want = if half_duplex {
            Some("half_duplex")
        } else if collision {
            Some("collision")
        } else {
            None
        };
        match (r[6].as_str(), r[7].as_str(), want) {
            ("lost", got @ ("half_duplex" | "collision"), Some(w)) => {
                assert_eq!(got, w, "{r:?}")
            }
            ("lost", got @ ("half_duplex" | "collision"), None) => {
                panic!("recorded {got}, but nothing overlaps its arrival: {r:?}")
            }
            ("delivered", _, Some(w)) => panic!("delivered, but {w} overlaps it: {r:?}"),
            // Lost for a reason judged after the overlaps (loss, late,
            // node_down, blocked) only when nothing overlaps.
            ("lost", other, w) => assert_eq!(w, None, "{other}: {r:?}"),
            _ => {}
        }
        assert!(to < n);
        judged += 1;
    }
    judged
}

#[test]
fn every_recorded_fate_agrees_with_an_independent_judgement_in_integer_nanoseconds() {
    for name in [
        "delay",
        "modem",
        "range-loss",
        "bernoulli-0.2",
        "graph-quiet",
        "logical-modem",
        "sync-modem",
        "tdma",
        "csma",
    ] {
        let tmp = TempDir::new(&format!("rejudge-{name}"));
        let sc = variant(name);
        run(&sc, tmp.path());
        let rows = read_rows(&tmp.path().join("messages.csv"));
        let judged = rejudge(&sc, &rows);
        assert!(judged > 1000, "{name}: {judged} frames");
    }
}

/// The SINR rule's numbers of the `sinr` variant, written out again here.
const SL_DB: f64 = 170.0;
const NL_DB: f64 = 50.0;
const SPREADING: f64 = 1.5;
const F_KHZ: f64 = 12.0;
const B_KHZ: f64 = 4.0;
const THRESHOLD_DB: f64 = 10.0;
const DETECTION_DB: f64 = 3.0;

/// Judge every frame of an SINR run again from the rows and the positions
/// alone: levels `SL - k 10 log10 d - d/1000 a(f)` with Thorp's `a(f)` (Thorp
/// 1967 as Stojanovic 2007 eq. 3 writes it), noise `NL + 10 log10 B`, every
/// transmission reaching every node; the worst SINR over the arrival, the
/// interference summed where an interferer starts. Checks the recorded
/// `sinr_db` and fate; returns how many frames were judged and how many were
/// delivered although another frame overlapped them (captures).
fn rejudge_sinr(sc: &Scenario, rows: &[Vec<String>]) -> (usize, usize) {
    let pos = &sc.geometry.receivers;
    let dist = |i: usize, j: usize| (pos[i] - pos[j]).norm();
    let delay = |i: usize, j: usize| -> u64 { (dist(i, j) / 1500.0 * 1e9).round() as u64 };
    let airtime = |bits: u64| -> u64 { (bits as f64 / 1000.0 * 1e9).round() as u64 };
    let f2 = F_KHZ * F_KHZ;
    let thorp = 0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003;
    let level = |i: usize, j: usize| {
        let d = dist(i, j);
        SL_DB - (SPREADING * 10.0 * d.max(1.0).log10() + d / 1000.0 * thorp)
    };
    let noise = NL_DB + 10.0 * (B_KHZ * 1e3).log10();
    let power = |db: f64| 10f64.powf(db / 10.0);
    // Every transmission: (sender, start, airtime).
    let mut tx: std::collections::BTreeSet<(usize, u64, u64)> = Default::default();
    for r in rows {
        tx.insert((
            r[2].parse().unwrap(),
            ns(&r[0]),
            airtime(r[5].parse().unwrap()),
        ));
    }
    let (mut judged, mut captures) = (0, 0);
    for r in rows.iter().filter(|r| r[6] != "in_flight") {
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let t0 = ns(&r[0]);
        let a = t0 + delay(from, to);
        let b = a + airtime(r[5].parse().unwrap());
        let overlaps = |s: u64, e: u64| s < b && a < e;
        let half_duplex = tx.iter().any(|&(i, s, t)| i == to && overlaps(s, s + t));
        // Interferers at `to`: (start, end, power), detected ones only.
        let others: Vec<(u64, u64, f64)> = tx
            .iter()
            .filter(|&&(i, s, _)| i != to && (i, s) != (from, t0))
            .map(|&(i, s, t)| (s + delay(i, to), s + delay(i, to) + t, i))
            .filter(|&(s, e, _)| overlaps(s, e))
            .filter(|&(_, _, i)| level(i, to) - noise >= DETECTION_DB)
            .map(|(s, e, i)| (s, e, power(level(i, to))))
            .collect();
        let sum_at = |t: u64| -> f64 {
            others
                .iter()
                .filter(|x| x.0 <= t && t < x.1)
                .map(|x| x.2)
                .sum()
        };
        let worst = others
            .iter()
            .filter(|x| x.0 > a && x.0 < b)
            .map(|x| sum_at(x.0))
            .fold(sum_at(a), f64::max);
        let sinr = 10.0 * (power(level(from, to)) / (power(noise) + worst)).log10();
        let recorded: f64 = r[8].parse().expect("an sinr_db");
        assert!(
            (recorded - sinr).abs() <= 1e-9 * sinr.abs().max(1.0),
            "sinr {recorded} recorded, {sinr} judged: {r:?}"
        );
        let snr = level(from, to) - noise;
        let want = if half_duplex {
            Some("half_duplex")
        } else if sinr < THRESHOLD_DB {
            Some(if snr >= THRESHOLD_DB {
                "collision"
            } else {
                "loss"
            })
        } else {
            None
        };
        match (r[6].as_str(), want) {
            ("lost", Some(w)) => assert_eq!(r[7], w, "{r:?}"),
            ("delivered", Some(w)) => panic!("delivered, but judged {w}: {r:?}"),
            // Lost for a reason judged after reception (late, node_down).
            ("lost", None) => assert!(
                ["late", "node_down", "loss", "blocked"].contains(&r[7].as_str()),
                "{r:?}"
            ),
            _ => {}
        }
        if r[6] == "delivered" && !others.is_empty() {
            captures += 1;
        }
        judged += 1;
    }
    (judged, captures)
}

#[test]
fn every_sinr_fate_and_level_agrees_with_an_independent_judgement_and_strong_frames_capture() {
    let tmp = TempDir::new("rejudge-sinr");
    let sc = variant("sinr");
    run(&sc, tmp.path());
    let path = tmp.path().join("messages.csv");
    assert_eq!(
        crate::util::header(&path),
        [
            "t_send", "t_recv", "from", "to", "kind", "bits", "fate", "reason", "sinr_db", "seed"
        ]
    );
    let rows = read_rows(&path);
    let (judged, captures) = rejudge_sinr(&sc, &rows);
    assert!(judged > 1000, "{judged} frames");
    assert!(
        captures > 100,
        "{captures} frames delivered through an overlap"
    );
}

/// Variant `name` of the short acoustic scenario run on node processes into
/// `p` under the returned directory (nothing left behind), and its scenario.
fn processes_run_of(name: &str) -> (TempDir, Scenario) {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new(&format!("{name}-processes"));
    let file = short_acoustic(&tmp, 20);
    let p = tmp.path().join("p");
    let out = crate::util::wait_watchdog(
        crate::util::spawn_sonarnet(&[
            "run",
            file.to_str().unwrap(),
            "--variant",
            name,
            "--engine",
            "processes",
            "--out",
            p.to_str().unwrap(),
        ]),
        &format!("a {name} processes run"),
        std::time::Duration::from_secs(300),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    crate::util::assert_nothing_left(&crate::util::run_id_of(&p));
    let sc = Scenario::load_all(&file)
        .unwrap()
        .into_iter()
        .find(|s| s.variant.as_deref() == Some(name))
        .unwrap();
    (tmp, sc)
}

#[test]
fn an_sinr_run_on_node_processes_is_judged_by_the_same_rule() {
    let (tmp, sc) = processes_run_of("sinr");
    let p = tmp.path().join("p");
    let (judged, _) = rejudge_sinr(&sc, &read_rows(&p.join("messages.csv")));
    assert!(judged > 100, "{judged} frames");
}

#[test]
fn a_csma_run_on_node_processes_is_judged_by_the_same_rules() {
    let (tmp, sc) = processes_run_of("csma");
    let p = tmp.path().join("p");
    let judged = rejudge(&sc, &read_rows(&p.join("messages.csv")));
    assert!(judged > 100, "{judged} frames");
}

#[test]
fn frames_still_in_the_water_when_the_run_ends_are_recorded_in_flight() {
    let tmp = TempDir::new("in-flight");
    let sc = variant("modem");
    let out = run(&sc, tmp.path());
    let rows = read_rows(&tmp.path().join("messages.csv"));
    let flying: Vec<&Vec<String>> = rows.iter().filter(|r| r[6] == "in_flight").collect();
    assert!(
        !flying.is_empty(),
        "a realtime run ends with frames on their way"
    );
    let last_judged = rows
        .iter()
        .filter(|r| r[6] != "in_flight")
        .map(|r| ns(&r[0]))
        .max()
        .expect("judged frames");
    for r in &flying {
        assert!(r[1].is_empty() && r[7].is_empty(), "{r:?}");
        // Sent near the end: no later than the last judged transmission
        // plus one sample period.
        assert!(ns(&r[0]) <= last_judged + 60_000_000_000, "{r:?}");
    }
    let ch = out.metrics.channel.as_ref().expect("channel stats");
    assert_eq!(ch.in_flight as usize, flying.len());
    assert_eq!(ch.frames as usize, rows.len() - flying.len());
}

#[test]
fn tdma_with_sync_rounds_under_the_graph_rule_is_refused_naming_the_key() {
    let tmp = TempDir::new("tdma-sync");
    let out = crate::util::sonarnet(
        &[
            "run",
            scenario("mourya2017-spiral-acoustic.toml")
                .to_str()
                .unwrap(),
            "--variant",
            "tdma",
            "--mode",
            "sync",
            "--out",
            tmp.path().join("o").to_str().unwrap(),
        ],
        std::time::Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("channel.mac") && err.contains("sinr"), "{err}");
}

#[test]
fn under_csma_a_crashed_node_sends_nothing_after_its_crash_not_even_a_frame_it_was_backing_off() {
    use sonarnet::model::fault::{Fault, FaultKind};
    let tmp = TempDir::new("csma-crash");
    let mut sc = variant("csma");
    sc.samples = 12;
    let base = tmp.path().join("base");
    run(&sc, &base);
    let rows = read_rows(&base.join("messages.csv"));
    let node = 2usize;
    let mut sends: Vec<u64> = rows
        .iter()
        .filter(|r| r[2].parse::<usize>().ok() == Some(node))
        .map(|r| ns(&r[0]))
        .collect();
    sends.dedup();
    let delivered: Vec<u64> = rows
        .iter()
        .filter(|r| r[3].parse::<usize>().ok() == Some(node) && r[6] == "delivered")
        .map(|r| ns(&r[1]))
        .collect();
    // Instants between a delivery to the node and its next transmission,
    // less than a second later, with nothing sent in between: where a
    // frame of the node may be pending its carrier sense. The crashed run
    // is the base run up to the crash.
    let crash_times: Vec<u64> = sends
        .windows(2)
        .filter_map(|w| {
            let r = *delivered.iter().filter(|&&r| r > w[0] && r < w[1]).max()?;
            (w[1] - r < 1_000_000_000).then_some(r + (w[1] - r) / 2)
        })
        .filter(|&c| c > 180_000_000_000)
        .take(4)
        .collect();
    assert!(!crash_times.is_empty(), "no backoff to crash into");
    for c in crash_times {
        let mut crashed = sc.clone();
        crashed.faults.push(Fault {
            kind: FaultKind::Crash { node: node as u32 },
            at_s: c as f64 / 1e9,
            until_s: None,
        });
        let dir = tmp.path().join(format!("crash-{c}"));
        run(&crashed, &dir);
        let late: Vec<Vec<String>> = read_rows(&dir.join("messages.csv"))
            .into_iter()
            .filter(|r| r[2].parse::<usize>().ok() == Some(node) && ns(&r[0]) >= c)
            .collect();
        assert!(late.is_empty(), "crashed at {c} ns, sent {late:?}");
    }
}
