//! `sonarnet-node`: one sonar receiver as an OS process.
//!
//! Thin: it parses its launch description, installs the SIGTERM/SIGINT flag,
//! opens the run's transport (iceoryx2, or zenoh when the launch says so:
//! [`sonarnet::transport::open_node`]) and runs the library's node loop
//! ([`sonarnet::engine::node::run_node`]) over it. The loop feeds the I/O-free
//! [`NodeCore`](sonarnet::protocol::NodeCore) and blocks in the transport's
//! WaitSet when idle (no busy-spinning). It exits on STOP, on SIGTERM (sent by
//! the kernel if its parent, the coordinator or a `sonarnet agent`, dies), or
//! when its parent is gone.
//!
//! Usage: `sonarnet-node --launch '<NodeLaunch JSON>'` (the coordinator
//! builds it; see `sonarnet::runtime::processes::NodeLaunch`). Bad arguments
//! exit with code 2.

use clap::Parser;
use sonarnet::engine::node::{NodeLoop, run_node};
use sonarnet::runtime::processes::{
    NodeLaunch, NodeProcessError, TEMP_CHECKPOINTS, guard_parent, wait_at_gate,
};
use sonarnet::transport::{cleanup_run, open_node};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// One sonar receiver of a sonarnet run (started by `sonarnet run --engine processes`).
#[derive(Debug, Parser)]
#[command(name = "sonarnet-node", version, about)]
struct Args {
    /// The node's launch description (JSON, written by the coordinator).
    #[arg(long)]
    launch: String,
}

fn main() -> ExitCode {
    node_main(std::env::args_os())
}

/// The node program, given its command line (program name first). `sonarnet`
/// also compiles this file in and calls it for `sonarnet __node ...`.
pub fn node_main<I, T>(argv: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    ExitCode::from(node_status(argv))
}

/// [`node_main`]'s exit status as a number (the Python package's node
/// program returns it to the interpreter): 0 when stopped by the
/// coordinator, 143 by a signal, 2 for bad arguments, 1 for an error.
pub fn node_status<I, T>(argv: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let args = match Args::try_parse_from(argv) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return 2;
        }
    };
    let launch: NodeLaunch = match serde_json::from_str(&args.launch) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("sonarnet-node: error: --launch is not a valid node launch description: {e}");
            return 2;
        }
    };
    if launch.node.id as usize >= launch.topology.len() {
        eprintln!(
            "sonarnet-node: error: --launch: node id {} is outside the topology of {} nodes",
            launch.node.id,
            launch.topology.len()
        );
        return 2;
    }
    match run(launch) {
        Ok(Ended::Stopped) => 0,
        // Told to stop by a signal, not by the coordinator: say so, as a
        // shell does (128 + SIGTERM), so the coordinator can name the cause.
        Ok(Ended::Signalled) => SIGNALLED,
        Err(e) => {
            eprint!("sonarnet-node: {}", sonarnet::cli::error_report(&e));
            1
        }
    }
}

/// The exit status of a node stopped by SIGTERM or SIGINT (128 + 15).
const SIGNALLED: u8 = 143;

/// How a node's run ended without an error.
enum Ended {
    /// The coordinator's `Stop`.
    Stopped,
    /// SIGTERM or SIGINT.
    Signalled,
}

fn run(launch: NodeLaunch) -> Result<Ended, NodeProcessError> {
    guard_parent(launch.coordinator_pid)?;
    let term = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        signal_hook::flag::register(sig, Arc::clone(&term)).map_err(NodeProcessError::Signals)?;
    }
    let parent = std::os::unix::process::parent_id();
    let topo = launch.run_topology()?;
    wait_at_gate(&launch)?;
    let mut tx = open_node(
        &launch.transport,
        &topo,
        launch.node.id,
        Duration::from_micros(launch.poll_us),
    )?;
    let alive = move || std::os::unix::process::parent_id() == parent;
    let checkpoint = launch.checkpoint.clone();
    let opts = NodeLoop {
        verbose: launch.verbose,
        term: &term,
        coordinator_alive: &alive,
        channel: launch.channel,
        checkpoint: checkpoint.clone(),
        resume: launch.resume,
        peer_frames_per_sample: launch.peer_frames_per_sample,
        budget_period: launch.budget_period,
    };
    let result = run_node(&mut tx, launch.node, &opts);
    drop(tx);
    if !alive() {
        // The coordinator died without cleaning up (SIGKILL): the nodes
        // remove what it left, the last one to leave the rest of the run.
        let _ = cleanup_run(topo.run_id());
        // A run's temporary checkpoint directory goes too (the last node
        // out removes it); checkpoints in a results directory stay.
        if let Some(path) = &checkpoint
            && let Some(dir) = path.parent()
            && dir
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(TEMP_CHECKPOINTS))
        {
            let _ = std::fs::remove_file(path);
            let _ = std::fs::remove_dir(dir);
        }
    }
    result?;
    Ok(if term.load(Ordering::Relaxed) {
        Ended::Signalled
    } else {
        Ended::Stopped
    })
}
