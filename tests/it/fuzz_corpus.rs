//! The fuzz targets' kept inputs as ordinary tests: every file of
//! `fuzz/corpus/TARGET/` and `fuzz/regressions/TARGET/` runs through the
//! harness the target calls (`sonarnet::fuzz`), so a crash once found and
//! fixed stays fixed without a fuzzer on the machine.

use crate::util::root;
use sonarnet::fuzz;
use sonarnet::model::coords::Coords;
use sonarnet::protocol::codec::{Control, encode_control, encode_peer};
use sonarnet::protocol::{Command, PeerMsg};
use sonarnet::scenario::Scenario;

/// The frames a node of the spiral receives in its first sample: its
/// measurements, a sync round plan and a few gossip messages.
fn real_frames() -> Vec<sonarnet::transport::wire::Frame> {
    let sc = Scenario::load(&crate::util::scenario("mourya2017-spiral.toml")).expect("spiral");
    let real = sc.realize();
    let mut out = Vec::new();
    let sample = Command::Sample {
        sample: 0,
        meas: real.measurements[0].nodes[3].clone(),
        sigmas: real.sigmas[0],
    };
    encode_control(&Control::Command(sample), &mut out);
    encode_control(
        &Control::Command(Command::SyncRounds {
            sample: 0,
            first_round: 0,
            rounds: 2,
        }),
        &mut out,
    );
    let r = Coords::from([480.0, 510.0, 1700.0]);
    for m in [
        PeerMsg::Reflect { from: 2, seq: 0, r },
        PeerMsg::Request { from: 4, seq: 1, r },
        PeerMsg::Decline { from: 5, seq: 2 },
    ] {
        out.push(encode_peer(&m));
    }
    out
}

#[test]
fn real_frames_survive_the_harness_byte_layout_unchanged() {
    let frames = real_frames();
    let bytes = fuzz::bytes_of(&frames);
    assert_eq!(bytes.len(), frames.len() * fuzz::FRAME_BYTES);
    let back = fuzz::frames_of(&bytes);
    assert_eq!(back.len(), frames.len());
    for (a, b) in frames.iter().zip(&back) {
        assert_eq!(
            (a.kind, a.from, a.sample, a.aux, a.seq),
            (b.kind, b.from, b.sample, b.aux, b.seq)
        );
        assert_eq!(a.data.map(f64::to_bits), b.data.map(f64::to_bits));
    }
    // The seed of the node_frames corpus is exactly these frames.
    let seed = root().join("fuzz/corpus/node_frames/spiral-sample-0");
    if std::env::var_os("SONARNET_WRITE_FUZZ_SEEDS").is_some() {
        std::fs::create_dir_all(seed.parent().expect("dir")).expect("corpus dir");
        std::fs::write(&seed, &bytes).expect("write seed");
    }
    assert_eq!(std::fs::read(&seed).expect("the seed is kept"), bytes);
    fuzz::node_frames(&bytes);
}

#[test]
fn every_kept_fuzz_input_runs_through_its_harness_without_a_panic() {
    let mut counts = Vec::new();
    for target in fuzz::TARGETS {
        let harness = fuzz::harness(target).expect("a harness per target");
        let mut n = 0;
        for dir in ["corpus", "regressions"] {
            let Ok(entries) = std::fs::read_dir(root().join("fuzz").join(dir).join(target)) else {
                continue;
            };
            for e in entries.flatten() {
                let bytes = std::fs::read(e.path()).expect("read input");
                harness(&bytes);
                n += 1;
            }
        }
        counts.push((target, n));
    }
    for (target, n) in counts {
        assert!(n > 0, "fuzz/corpus/{target}/ has no input");
    }
}

#[test]
fn the_user_files_seeds_are_files_sonarnet_accepts_and_the_kept_crash_is_refused() {
    use sonarnet::engine::checkpoint::Checkpoint;
    use sonarnet::scenario::{AnyScenario, schedule_from, trace_from, truth_from};
    let dir = root().join("fuzz/corpus/user_files");
    let read = |name: &str| std::fs::read(dir.join(name)).expect("a seed");
    let p = std::path::Path::new("seed.csv");
    let spiral = |name: &str| {
        AnyScenario::all_from_toml_str(
            &std::fs::read_to_string(crate::util::scenario(name)).expect("shipped"),
            std::path::Path::new(name),
        )
        .expect("loads")
        .remove(0)
    };
    let AnyScenario::Plane(plane) = spiral("mourya2017-spiral.toml") else {
        panic!("2-D");
    };
    let AnyScenario::Space(space) = spiral("mourya2017-spiral-3d.toml") else {
        panic!("3-D");
    };
    let t2 = trace_from(&read("trace-2d.csv")[..], p, &plane.geometry).expect("2-D trace");
    assert_eq!(t2.len(), 3, "samples 0-2 of the head of a real trace");
    trace_from(&read("trace-3d.csv")[..], p, &space.geometry).expect("3-D trace");
    assert_eq!(
        truth_from::<2, _>(&read("truth-2d.csv")[..], p)
            .expect("2-D truth")
            .len(),
        5
    );
    assert_eq!(
        truth_from::<3, _>(&read("truth-3d.csv")[..], p)
            .expect("3-D truth")
            .len(),
        5
    );
    assert_eq!(
        schedule_from(&read("schedule.csv")[..], p, &plane.graph).expect("schedule"),
        vec![(0, 1), (3, 4), (2, 3), (3, 5)]
    );
    let ck = Checkpoint::parse(&read("checkpoint-2d.json"), p, 3, 2).expect("2-D checkpoint");
    assert_eq!(ck.sample, 12);
    Checkpoint::parse(&read("checkpoint-3d.json"), p, 3, 3).expect("3-D checkpoint");
    // A checkpoint longer than the limit is refused before it is parsed.
    let long = vec![b' '; 64 * 1024 + 1];
    let e = Checkpoint::parse(&long, p, 3, 2).unwrap_err();
    assert!(e.contains("65536 bytes"), "{e}");
    // The kept crash: a sample 10^12 far ahead.
    let crash = std::fs::read(
        root().join("fuzz/regressions/user_files/trace-sample-far-ahead-allocates-terabytes"),
    )
    .expect("kept");
    let e = trace_from(&crash[..], p, &plane.geometry).unwrap_err();
    assert!(e.to_string().contains("line 3"), "{e}");
}

/// The reports every node of the spiral sends the coordinator for its
/// first three samples (a `theta` each), and an answer to a liveness check.
fn real_reports() -> Vec<sonarnet::transport::wire::Frame> {
    use sonarnet::protocol::Report;
    let mut out = Vec::new();
    for sample in 0..3u32 {
        for node in 0..6u32 {
            sonarnet::protocol::codec::encode_report(
                &Report::SampleDone {
                    node,
                    sample,
                    theta: Coords::from([480.0 + f64::from(node), 510.0, 1700.0]),
                    counters: Default::default(),
                },
                &mut out,
            );
        }
    }
    out.push(sonarnet::protocol::codec::encode_pong(2, 0));
    out
}

#[test]
fn the_coordinator_seed_holds_real_reports_of_every_node() {
    let bytes = fuzz::bytes_of(&real_reports());
    let seed = root().join("fuzz/corpus/node_frames/spiral-reports-0");
    if std::env::var_os("SONARNET_WRITE_FUZZ_SEEDS").is_some() {
        std::fs::write(&seed, &bytes).expect("write seed");
    }
    assert_eq!(std::fs::read(&seed).expect("the seed is kept"), bytes);
    // They decode as the coordinator's reports.
    let mut dec = sonarnet::protocol::codec::ReportDecoder::new(2);
    let decoded = fuzz::frames_of(&bytes)
        .iter()
        .filter(|f| matches!(dec.feed(f), Ok(Some(_))))
        .count();
    assert_eq!(decoded, 19);
    fuzz::node_frames(&bytes);
}
