//! Faults as a schedule on the discrete-event engine: each kind
//! through `scenarios/mourya2017-spiral-faults.toml`, which every-scenario
//! test also runs; here the properties the issue names.

use crate::util::{TempDir, read_rows, run_file, scenario};
use sonarnet::pipeline::{self, RunOptions};
use sonarnet::scenario::Scenario;
use std::collections::BTreeMap;
use std::time::Duration;

/// A variant of `scenarios/mourya2017-spiral-faults.toml`.
fn variant(name: &str) -> Scenario {
    Scenario::load_all(&scenario("mourya2017-spiral-faults.toml"))
        .expect("loads")
        .into_iter()
        .find(|s| s.variant.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no variant {name}"))
}

fn run(sc: &Scenario, dir: &std::path::Path, stall: Option<Duration>) -> pipeline::Outcome {
    let mut opts = RunOptions {
        command_line: vec!["test".into()],
        ..RunOptions::inprocess()
            .with_out_dir(dir)
            .with_clock(pipeline::default_clock(sc))
    };
    if let Some(s) = stall {
        opts.stall_timeout = s;
    }
    sc.run_and_write(&opts).expect("writes")
}

/// `nodes.csv` as sample -> node -> (x, y).
fn positions(dir: &std::path::Path) -> BTreeMap<usize, BTreeMap<usize, (f64, f64)>> {
    let mut out: BTreeMap<usize, BTreeMap<usize, (f64, f64)>> = BTreeMap::new();
    for r in read_rows(&dir.join("nodes.csv")) {
        let (k, i): (usize, usize) = (r[0].parse().unwrap(), r[1].parse().unwrap());
        out.entry(k)
            .or_default()
            .insert(i, (r[2].parse().unwrap(), r[3].parse().unwrap()));
    }
    out
}

/// The largest distance between a node of `a` and a node of `b` at sample `k`.
fn spread(
    p: &BTreeMap<usize, BTreeMap<usize, (f64, f64)>>,
    k: usize,
    a: &[usize],
    b: &[usize],
) -> f64 {
    let mut m = 0.0f64;
    for &i in a {
        for &j in b {
            let (x, y) = (p[&k][&i], p[&k][&j]);
            m = m.max((x.0 - y.0).hypot(x.1 - y.1));
        }
    }
    m
}

/// The median of `v` (the upper one of an even count): a sample in which a
/// node process was descheduled on a loaded host and reported late moves a
/// mean of 10 samples by metres, but not the median.
fn median(v: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = v.collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The spread between the halves {0, 1, 2} and {3, 4, 5} of the partition
/// variant (partitioned for samples 30-49), as medians over samples, so
/// that one late sample of a realtime run on a busy host does not decide.
struct Halves {
    /// Samples 20-29, before the partition.
    before: f64,
    /// Samples 31-49: the largest distance between the halves.
    across: f64,
    /// Samples 31-49: the largest distance within a half.
    within: f64,
    /// Samples 53-62, after the heal at sample 50.
    after: f64,
}

/// Reads the partition variant's results in `dir` and asserts that during
/// the partition the nodes of a half stay closer to each other than to the
/// other half, by 2x.
fn assert_two_consensuses_during_the_partition(dir: &std::path::Path) -> Halves {
    let p = positions(dir);
    let (a, b) = ([0, 1, 2], [3, 4, 5]);
    let h = Halves {
        before: median((20..30).map(|k| spread(&p, k, &a, &b))),
        across: median((31..50).map(|k| spread(&p, k, &a, &b))),
        within: median((31..50).map(|k| spread(&p, k, &a, &a).max(spread(&p, k, &b, &b)))),
        after: median((53..63).map(|k| spread(&p, k, &a, &b))),
    };
    println!(
        "before {:.2} m, across {:.2} m, within {:.2} m, after {:.2} m",
        h.before, h.across, h.within, h.after
    );
    assert!(
        h.across > 2.0 * h.within,
        "across {:.2} m, within {:.2} m",
        h.across,
        h.within
    );
    h
}

/// A partition of the spiral graph into two connected halves, {0, 1, 2} and
/// {3, 4, 5}, for samples 30-49: each half keeps its own consensus (the
/// nodes of a half stay closer to each other than to the other half), and
/// within 3 samples of the heal the two halves agree again as closely as
/// before the partition (the book, Faults).
#[test]
fn a_partitioned_network_keeps_two_consensuses_and_agrees_again_after_the_heal() {
    let tmp = TempDir::new("faults-partition");
    let out = run(&variant("partition"), tmp.path(), None);
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
    let h = assert_two_consensuses_during_the_partition(tmp.path());
    assert!(
        h.after < 1.5 * h.before,
        "after the heal {:.2} m, before the partition {:.2} m",
        h.after,
        h.before
    );
    let f = &out.metrics.faults[0];
    assert_eq!((f.kind.as_str(), f.sample), ("partition", 30));
}

/// A pause shorter than the stall timeout changes only the timing: the node
/// is never reported, every sample is scored, and nodes.csv flags it paused
/// during the sample it stalled. Longer than the stall timeout, the node is
/// reported (left out as dead), and the fault's detection time is the
/// snapshot deadline that noticed it.
#[test]
fn a_short_pause_only_delays_and_a_long_one_gets_the_node_reported() {
    let tmp = TempDir::new("faults-pause");
    let short = tmp.path().join("short");
    let out = run(&variant("pause"), &short, None);
    assert!(out.run.error.is_none() && out.metrics.deaths.is_empty());
    assert_eq!(out.metrics.samples_completed, 100);
    let rows = read_rows(&short.join("nodes.csv"));
    let paused: Vec<usize> = rows
        .iter()
        .filter(|r| r[6] == "true")
        .map(|r| r[0].parse().unwrap())
        .collect();
    assert!(rows.iter().all(|r| r[5] == "true"), "every node alive");
    // Sample 30's snapshot waits for node 2 until it resumes (0.8 s); the
    // samples due meanwhile follow at once, with node 2 running.
    assert_eq!(paused, vec![30], "node 2 paused during sample 30");
    assert!(out.metrics.faults[0].detected_s.is_none());
    // The same pause, 20 samples (0.4 s) long, with a 0.1 s stall timeout.
    let long = tmp.path().join("long");
    let mut sc = variant("pause");
    sc.faults[0].until_s = Some(1.0);
    let out = run(&sc, &long, Some(Duration::from_millis(100)));
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
    assert_eq!(out.metrics.deaths.len(), 1, "{:?}", out.metrics.deaths);
    assert_eq!(out.metrics.deaths[0].node, 2);
    let detected = out.metrics.faults[0].detected_s.expect("detected");
    assert!(
        detected > 0.6 && detected <= 0.6 + 0.02 + 0.1 + 1e-9,
        "detected at {detected} s"
    );
}

/// The random nemesis draws its faults from the run seed: the same seed
/// gives the same faults.csv and the same outputs, another seed other
/// faults.
#[test]
fn the_nemesis_with_one_seed_gives_the_same_faults_and_outputs() {
    let tmp = TempDir::new("faults-nemesis");
    let sc = variant("nemesis");
    let (a, b, c) = (
        tmp.path().join("a"),
        tmp.path().join("b"),
        tmp.path().join("c"),
    );
    run(&sc, &a, None);
    run(&sc, &b, None);
    run(&sc.clone().with_seed(7), &c, None);
    for f in ["faults.csv", "nodes.csv", "track.csv"] {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs between two runs of one seed");
    }
    let fa = read_rows(&a.join("faults.csv"));
    assert!(fa.len() > 5, "{} faults", fa.len());
    let fc = read_rows(&c.join("faults.csv"));
    let cols = |rows: &[Vec<String>]| rows.iter().map(|r| r[2..5].to_vec()).collect::<Vec<_>>();
    assert_ne!(cols(&fa), cols(&fc), "seed 7 drew the same faults");
}

/// A crash that cuts the network (node 3 joins the leaves 4 and 5 to the
/// rest) cannot be recovered: the run says why, ends `failed`, and keeps
/// what it scored, faults.csv included.
#[test]
fn a_crash_that_cuts_the_network_fails_the_run_with_its_partial_results() {
    let tmp = TempDir::new("faults-cut");
    let o = run_file(
        &scenario("mourya2017-spiral-faults.toml"),
        tmp.path(),
        &["--variant", "crash", "--fault", "crash:node=3,at_sample=40"],
        Duration::from_secs(120),
    );
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("node 3") && err.contains("disconnected"),
        "{err}"
    );
    let m = crate::util::metrics(tmp.path());
    assert_eq!(m["status"], "failed");
    assert_eq!(m["samples_completed"], 40);
    assert_eq!(read_rows(&tmp.path().join("faults.csv")).len(), 2);
}

/// A bad fault is refused before anything runs, naming the flag or the key,
/// and faults refuse what does not run them (the threads engine, a logical
/// clock).
#[test]
fn a_bad_fault_is_refused_naming_the_flag_or_the_key() {
    let tmp = TempDir::new("faults-bad");
    let file = scenario("mourya2017-spiral-faults.toml");
    for (args, needle) in [
        (
            &["--variant", "crash", "--fault", "pause:node=9,at_s=1"][..],
            "--fault",
        ),
        (
            &["--variant", "crash", "--fault", "pause:at_s=1"][..],
            "node",
        ),
        (
            &["--variant", "crash", "--nemesis", "flood"][..],
            "--nemesis",
        ),
        (&["--variant", "crash", "--engine", "threads"][..], "faults"),
        (&["--variant", "crash", "--clock", "logical"][..], "faults"),
    ] {
        let o = run_file(&file, &tmp.path().join("x"), args, Duration::from_secs(60));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let text = std::fs::read_to_string(&file).unwrap().replace(
        "{ kind = \"crash\", node = 4,",
        "{ kind = \"crash\", node = 40,",
    );
    let bad = tmp.write("bad.toml", &text);
    let o = run_file(
        &bad,
        &tmp.path().join("y"),
        &["--variant", "crash"],
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("faults[0].node") && err.contains("does not exist"),
        "{err}"
    );
}

/// Every applied fault is shaded on `error.svg` (and on `messages.svg` on
/// the acoustic channel) and listed in the HTML report.
#[test]
fn faults_are_shaded_on_the_error_plot_and_listed_in_the_report() {
    let tmp = TempDir::new("faults-report");
    let o = run_file(
        &scenario("mourya2017-spiral-faults.toml"),
        tmp.path(),
        &["--variant", "partition", "--report"],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(tmp.path().join("error.svg")).unwrap();
    assert!(svg.contains("partition 0 1 2 | 3 4 5"), "no fault caption");
    let html = std::fs::read_to_string(tmp.path().join("report.html")).unwrap();
    assert!(html.contains("<table id=\"faults\">") && html.contains("recovery_samples"));
    // On the acoustic channel, messages.svg is shaded too.
    let ac = tmp.path().join("ac");
    let o = run_file(
        &scenario("mourya2017-spiral-acoustic.toml"),
        &ac,
        &[
            "--variant",
            "modem",
            "--fault",
            "partition:groups=[[0,1,2],[3,4,5]],at_s=10,for_s=30",
        ],
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(ac.join("messages.svg")).unwrap();
    assert!(
        svg.contains("partition 0 1 2 | 3 4 5"),
        "no fault on messages.svg"
    );
    let rows = read_rows(&ac.join("messages.csv"));
    assert!(
        rows.iter().any(|r| r[7] == "blocked"),
        "no frame blocked by the partition"
    );
}

/// On node processes a pause is SIGSTOP and SIGCONT and a crash SIGKILL: a
/// paused node that outlasts the stall timeout is
/// reported, a crashed one is detected when the coordinator reaps it (its
/// `detected_s` is after the kill), both runs write faults.csv, and neither
/// leaves a process or a shared-memory file behind.
#[test]
fn node_processes_take_real_signals_for_pause_and_crash_and_leave_nothing_behind() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("faults-processes");
    let file = scenario("mourya2017-spiral-faults.toml");
    let crash = tmp.path().join("crash");
    let o = run_file(
        &file,
        &crash,
        &["--variant", "crash", "--engine", "processes"],
        Duration::from_secs(300),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    crate::util::assert_nothing_left(&crate::util::run_id_of(&crash));
    let m = crate::util::metrics(&crash);
    let f = &m["faults"][0];
    assert_eq!(f["kind"], "crash");
    let (t, d) = (
        f["t_s"].as_f64().unwrap(),
        f["detected_s"].as_f64().unwrap(),
    );
    println!("crash at {t} s detected at {d} s");
    assert!(d >= t, "detected before the kill: {d} < {t}");
    assert_eq!(m["deaths"][0]["node"], 4);
    // A pause of 10 samples (0.2 s) with a 0.1 s stall timeout: reported.
    let pause = tmp.path().join("pause");
    let o = run_file(
        &file,
        &pause,
        &[
            "--variant",
            "pause",
            "--engine",
            "processes",
            "--stall-timeout",
            "0.1",
        ],
        Duration::from_secs(300),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    crate::util::assert_nothing_left(&crate::util::run_id_of(&pause));
    let m = crate::util::metrics(&pause);
    assert_eq!(m["deaths"][0]["node"], 2, "{}", m["deaths"]);
    assert!(m["faults"][0]["detected_s"].as_f64().is_some());
    assert_eq!(read_rows(&pause.join("faults.csv")).len(), 1);
}

/// A `restart` on node processes: the coordinator kills
/// the node, removes what the dead process left in shared memory, and
/// starts a new process, which rejoins when it is ready (detected at once,
/// alive again in nodes.csv after the restart). With `state =
/// "checkpoint"` the node writes its checkpoint file in the results
/// directory (`checkpoints/node-2.json`, the last sample's); fresh, it
/// writes none. Nothing is left behind, the restarted process included.
/// (That a node program resumes exactly at its file's state is
/// `engine::node::tests::a_node_program_resumed_from_its_checkpoint_file_...`.)
#[test]
fn node_processes_restart_a_node_from_its_checkpoint_file_and_leave_nothing_behind() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("faults-restart-processes");
    let file = scenario("mourya2017-spiral-faults.toml");
    for (v, checkpoint) in [("restart", true), ("restart-fresh", false)] {
        let dir = tmp.path().join(v);
        let o = run_file(
            &file,
            &dir,
            &["--variant", v, "--engine", "processes"],
            Duration::from_secs(300),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        crate::util::assert_nothing_left(&crate::util::run_id_of(&dir));
        let m = crate::util::metrics(&dir);
        assert_eq!(m["status"], "ok", "{v}");
        assert_eq!(m["samples_completed"], 100, "{v}");
        let f = &m["faults"][0];
        assert_eq!(
            (f["kind"].as_str(), f["sample"].as_u64()),
            (Some("restart"), Some(30))
        );
        assert_eq!(
            f["detected_s"], f["t_s"],
            "{v}: the coordinator knows at once"
        );
        assert_eq!(m["deaths"][0]["node"], 2, "{v}");
        let alive: Vec<bool> = read_rows(&dir.join("nodes.csv"))
            .iter()
            .filter(|r| r[1] == "2")
            .map(|r| r[5] == "true")
            .collect();
        assert_eq!(alive.len(), 100);
        // A new process starts in about one 20 ms sample; five samples
        // leave room for a loaded host.
        assert!(alive[35..].iter().all(|a| *a), "{v}: node 2 is back");
        let ck = dir.join("checkpoints").join("node-2.json");
        assert_eq!(ck.exists(), checkpoint, "{v}");
        if checkpoint {
            let c = sonarnet::engine::checkpoint::Checkpoint::read(&ck, 2, 2)
                .unwrap()
                .unwrap();
            assert_eq!(c.sample, 99, "the last sample's checkpoint");
        }
    }
    // A run that is not written keeps its checkpoints in a temporary
    // directory of its own, removed when the run ends.
    let sc = variant("restart");
    let opts = RunOptions::inprocess()
        .with_engine(sonarnet::protocol::EngineKind::Processes)
        .with_clock(pipeline::default_clock(&sc));
    let out = sc.run(&opts);
    assert!(out.run.error.is_none(), "{:?}", out.run.error);
    let run_id = out
        .run
        .processes
        .as_ref()
        .map(|p| p.run_id.clone())
        .expect("a run id");
    let temp = std::env::temp_dir().join(format!(
        "{}{run_id}",
        sonarnet::runtime::processes::TEMP_CHECKPOINTS
    ));
    assert!(!temp.exists(), "{} left behind", temp.display());
    crate::util::assert_nothing_left(&run_id);
}

/// Link faults on the ideal channel of node processes go through the
/// coordinator's relay: a partition {0, 1, 2} / {3, 4, 5}
/// for samples 30-49 keeps two consensuses, and after the heal the halves
/// agree again: closer than the nodes of one half were during the
/// partition, and within a third of the distance between the halves then.
/// (How soon they agree as closely as before the partition, which the
/// discrete-event test checks, depends in realtime on how many exchanges a
/// loaded host fits into each 20 ms sample: 1.0-1.7x in samples 53-62 over
/// seven runs, 2.5x once under CI load.)
#[test]
fn a_partition_of_node_processes_on_the_ideal_channel_keeps_two_consensuses_until_the_heal() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("faults-partition-processes");
    let o = run_file(
        &scenario("mourya2017-spiral-faults.toml"),
        tmp.path(),
        &["--variant", "partition", "--engine", "processes"],
        Duration::from_secs(300),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    crate::util::assert_nothing_left(&crate::util::run_id_of(tmp.path()));
    let h = assert_two_consensuses_during_the_partition(tmp.path());
    assert!(
        h.after < h.within.min(h.across / 3.0),
        "after the heal {:.2} m, during the partition {:.2} m within a half and {:.2} m across",
        h.after,
        h.within,
        h.across
    );
    assert_eq!(read_rows(&tmp.path().join("faults.csv")).len(), 1);
}

/// `clock_drift`: a node whose clock runs 50 % fast wakes 50 % more often, so
/// it takes part in more exchanges than with no drift (the control is the
/// same run with a drift of 0 ppm, so that both have faults' exchange
/// timeout); on node processes the same fault runs and is recorded.
#[test]
fn a_fast_clock_makes_its_node_call_more_often_in_both_engines() {
    let tmp = TempDir::new("faults-drift");
    let file = scenario("mourya2017-spiral.toml");
    let solves = |ppm: &str, engine: &str| -> Vec<u64> {
        let out = tmp.path().join(format!("{engine}-{ppm}"));
        let o = run_file(
            &file,
            &out,
            &[
                "--clock",
                "realtime",
                "--engine",
                engine,
                "--fault",
                &format!("clock_drift:node=1,ppm={ppm},at_s=0"),
            ],
            Duration::from_secs(300),
        );
        // The spiral's own [expect] may fail under a fault: exit 1, not 2.
        assert!(
            o.status.code() != Some(2),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        if engine == "processes" {
            crate::util::assert_nothing_left(&crate::util::run_id_of(&out));
        }
        let m = crate::util::metrics(&out);
        assert_eq!(m["faults"][0]["kind"], "clock_drift");
        m["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n["prox_solves"].as_u64().unwrap())
            .collect()
    };
    let (none, fast) = (solves("0", "inprocess"), solves("500000", "inprocess"));
    assert!(
        fast[1] as f64 > 1.15 * none[1] as f64,
        "node 1: {} prox solves with a fast clock, {} without",
        fast[1],
        none[1]
    );
    let _cpu = crate::util::cpu_exclusive();
    let p = solves("500000", "processes");
    assert_eq!(p.len(), 6);
}

/// `link_loss` and `delay` on node processes (the ideal channel's relay)
/// act as in the discrete-event engine: with link 3-4 lost for the whole
/// run, leaf node 4 hears nothing and never updates; with 5 ms more on link
/// 3-5 (its exchange timeout is 1 ms), node 5's answers come late, while a
/// node away from both links is hardly touched.
#[test]
fn link_loss_and_delay_act_alike_on_node_processes_and_in_virtual_time() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("faults-links-both");
    for engine in ["inprocess", "processes"] {
        let dir = tmp.path().join(engine);
        let o = run_file(
            &scenario("mourya2017-spiral-faults.toml"),
            &dir,
            &[
                "--variant",
                "link_loss",
                "--engine",
                engine,
                "--fault",
                "link_loss:a=3,b=4,p=1,at_s=0",
                "--fault",
                "delay:a=3,b=5,extra_s=0.005,at_s=0",
            ],
            Duration::from_secs(300),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let m = crate::util::metrics(&dir);
        let count = |node: usize, key: &str| m["nodes"][node][key].as_u64().unwrap_or(0);
        println!(
            "{engine}: node 4 in {} updates {}; node 5 updates {} late {}; node 2 updates {} late {}",
            count(4, "messages_in"),
            count(4, "updates"),
            count(5, "updates"),
            count(5, "late"),
            count(2, "updates"),
            count(2, "late")
        );
        assert_eq!(
            (count(4, "messages_in"), count(4, "updates")),
            (0, 0),
            "{engine}"
        );
        assert!(count(4, "timeouts") > 100, "{engine}");
        assert!(count(5, "late") > 3 * count(5, "updates"), "{engine}");
        // Node 2 is away from both links: none late in virtual time, a
        // few on processes of a loaded host (each exchange waits 1 ms).
        assert!(4 * count(2, "late") < count(2, "updates"), "{engine}");
        assert_eq!(read_rows(&dir.join("faults.csv")).len(), 3, "{engine}");
        if engine == "processes" {
            crate::util::assert_nothing_left(&crate::util::run_id_of(&dir));
        }
    }
}

/// The random nemesis on node processes applies the schedule the run seed
/// draws, the same as in virtual time (times, kinds and nodes of every
/// fault; crashes come back as restarts), and leaves nothing behind.
#[test]
fn the_nemesis_on_node_processes_applies_the_faults_the_seed_draws() {
    let _cpu = crate::util::cpu_exclusive();
    let tmp = TempDir::new("faults-nemesis-both");
    let mut schedules = Vec::new();
    for engine in ["inprocess", "processes"] {
        let dir = tmp.path().join(engine);
        let o = run_file(
            &scenario("mourya2017-spiral-faults.toml"),
            &dir,
            &["--variant", "nemesis", "--engine", engine],
            Duration::from_secs(300),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let rows: Vec<Vec<String>> = read_rows(&dir.join("faults.csv"))
            .into_iter()
            .map(|r| r[..5].to_vec())
            .collect();
        schedules.push(rows);
        if engine == "processes" {
            crate::util::assert_nothing_left(&crate::util::run_id_of(&dir));
        }
    }
    assert!(schedules[0].iter().any(|r| r[2] == "restart"));
    assert_eq!(schedules[0], schedules[1]);
}
