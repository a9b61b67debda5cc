//! A node program with one broken node, to see what a run does with a peer
//! that sends garbage: node `$SONARNET_GARBAGE_NODE` says READY and then
//! sends the coordinator frames that do not decode, every millisecond,
//! until it is killed or its coordinator is gone; every other node is the
//! real node program (`nodes/main.rs`, compiled in). With
//! `SONARNET_GARBAGE_MODE=impostor` it sends frames that decode instead, in
//! the name of the next node: reports of sample 0 with a wild `theta`; with
//! `SONARNET_GARBAGE_MODE=flood`, well-formed timing reports in its own
//! name, 256 at a time; with `SONARNET_GARBAGE_MODE=peer-flood`, well-formed
//! gossip requests to its first neighbour, 256 at a time (and nothing to
//! the coordinator after READY); with `SONARNET_GARBAGE_MODE=peer-impostor`,
//! well-formed gossip requests to its first neighbour in a third node's
//! name, 4 at a time; with `SONARNET_GARBAGE_MODE=bad-checkpoint`
//! it is the real node program, but writes a truncated checkpoint file where
//! its checkpoints go and none of its own, so that a `restart` from its
//! checkpoint finds the file corrupted. A mode written `early-<mode>` sends
//! the same frames without ever saying READY, so that the coordinator cuts
//! the node off while it is still starting the run.
//!
//! ```sh
//! cargo build --release --examples
//! SONARNET_NODE_BIN=target/release/examples/garbage_node SONARNET_GARBAGE_NODE=3 \
//!     cargo run --release -- run scenarios/mourya2017-spiral-faults.toml --engine processes
//! ```
//!
//! The coordinator counts the bad frames, names the node and cuts it off
//! after `sonarnet::runtime::processes::CUT_OFF_BAD_FRAMES` of them; the
//! run goes on as after a crash of that node.

use sonarnet::protocol::codec;
use sonarnet::runtime::processes::{NodeLaunch, guard_parent, wait_at_gate};
use sonarnet::transport::wire::Frame;
use sonarnet::transport::{Endpoint, open_node};
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[path = "../nodes/main.rs"]
#[allow(dead_code)]
mod node_program;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let garbage: Option<u32> = std::env::var("SONARNET_GARBAGE_NODE")
        .ok()
        .and_then(|v| v.parse().ok());
    let launch = args
        .windows(2)
        .find(|w| w[0] == "--launch")
        .and_then(|w| serde_json::from_str::<NodeLaunch>(&w[1]).ok());
    let mode = std::env::var("SONARNET_GARBAGE_MODE").unwrap_or_default();
    match launch {
        Some(l) if Some(l.node.id) == garbage && mode == "bad-checkpoint" => {
            bad_checkpoint(l, &args)
        }
        Some(l) if Some(l.node.id) == garbage => match send_garbage(&l) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("garbage_node: {e}");
                ExitCode::from(1)
            }
        },
        _ => node_program::node_main(args),
    }
}

/// The first incarnation of a checkpointing node: a truncated checkpoint
/// file where its checkpoints go, then the real node program told to write
/// none. A restarted incarnation (`resume`) is the real node program.
fn bad_checkpoint(mut l: NodeLaunch, args: &[String]) -> ExitCode {
    if l.resume {
        return node_program::node_main(args.to_vec());
    }
    if let Some(path) = l.checkpoint.take() {
        let junk = format!("{{\"node\": {}, \"sample\": 29, \"u\": [1.5, ", l.node.id);
        if let Err(e) = std::fs::write(&path, junk) {
            eprintln!("garbage_node: {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    let Ok(json) = serde_json::to_string(&l) else {
        return ExitCode::from(1);
    };
    let mut argv: Vec<String> = args.to_vec();
    if let Some(k) = argv.iter().position(|a| a == "--launch") {
        argv.truncate(k);
    }
    argv.extend(["--launch".to_string(), json]);
    node_program::node_main(argv)
}

/// READY, then a frame of an unknown kind every millisecond for at most a
/// minute, while the coordinator lives.
fn send_garbage(l: &NodeLaunch) -> Result<(), Box<dyn std::error::Error>> {
    guard_parent(l.coordinator_pid)?;
    let parent = std::os::unix::process::parent_id();
    let topo = l.run_topology()?;
    wait_at_gate(l)?;
    let id = l.node.id;
    let mut tx = open_node(&l.transport, &topo, id, Duration::ZERO)?;
    let mode = std::env::var("SONARNET_GARBAGE_MODE").unwrap_or_default();
    // `early-<mode>`: the same frames, without ever saying READY.
    let early = mode.starts_with("early-");
    let mode = mode.trim_start_matches("early-");
    if !early {
        tx.send(Endpoint::Coordinator, &codec::encode_ready(id))?;
        tx.flush()?;
    }
    let impostor = mode == "impostor";
    let mut junk = vec![Frame {
        kind: 0xdead,
        from: id,
        ..Frame::default()
    }];
    if impostor {
        let victim = (id + 1) % l.node.n_nodes.max(1);
        junk.clear();
        let wild = sonarnet::model::coords::Coords::from([1e9, 1e9, 1e9]);
        codec::encode_report(
            &sonarnet::protocol::Report::SampleDone {
                node: victim,
                sample: 0,
                theta: wild,
                counters: Default::default(),
            },
            &mut junk,
        );
    }
    if mode == "flood" {
        let timing = codec::Timing {
            busy_seconds: 0.0,
            wait_seconds: 0.0,
        };
        junk = vec![codec::encode_timing(id, &timing); 256];
    }
    let mut to = Endpoint::Coordinator;
    if mode == "peer-flood"
        && let Some(&nb) = l.node.neighbours.first()
    {
        to = Endpoint::Node(nb);
        let r = sonarnet::model::coords::Coords::from([480.0, 510.0, 1700.0]);
        junk = (0..256u64)
            .map(|seq| {
                codec::encode_peer(&sonarnet::protocol::PeerMsg::Request { from: id, seq, r })
            })
            .collect();
    }
    if mode == "peer-impostor"
        && let Some(&nb) = l.node.neighbours.first()
    {
        // Gossip to its first neighbour in the name of a third node.
        let n = l.node.n_nodes.max(3);
        let posed = (1..n)
            .map(|k| (id + k) % n)
            .find(|&k| k != nb)
            .unwrap_or(id);
        to = Endpoint::Node(nb);
        let r = sonarnet::model::coords::Coords::from([480.0, 510.0, 1700.0]);
        junk = (0..4u64)
            .map(|seq| {
                codec::encode_peer(&sonarnet::protocol::PeerMsg::Request {
                    from: posed,
                    seq,
                    r,
                })
            })
            .collect();
    }
    let start = Instant::now();
    let mut inbox = Vec::new();
    while std::os::unix::process::parent_id() == parent && start.elapsed() < Duration::from_secs(60)
    {
        for f in &junk {
            tx.send(to, f)?;
        }
        tx.flush()?;
        inbox.clear();
        tx.recv(&mut inbox, Some(Duration::from_millis(1)))?;
    }
    Ok(())
}
