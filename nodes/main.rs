//! `sonarnet-node`: one sonar receiver as an OS process.
//!
//! The node's event loop and nothing else: it opens the run's transport,
//! reports READY, then feeds every decoded frame (and, in realtime mode, its
//! own Poisson clock ticks) to the library's I/O-free
//! [`NodeCore`](sonarnet::protocol::NodeCore) and sends what the core returns.
//! When idle it blocks in the transport's WaitSet (no busy-spinning). It
//! exits on STOP, on SIGTERM (sent by the kernel if the coordinator dies), or
//! when its parent is gone.
//!
//! Usage: `sonarnet-node --launch '<NodeLaunch JSON>'` (the coordinator
//! builds it; see `sonarnet::engine::processes::NodeLaunch`). Bad arguments
//! exit with code 2.

use clap::Parser;
use sonarnet::codec::{self, Control, NodeDecoder, NodeInput, Timing};
use sonarnet::engine::processes::NodeLaunch;
use sonarnet::protocol::{Command, Input, NodeCore, Output};
use sonarnet::transport::{Endpoint, IoxTransport, Transport};
use sonarnet::wire::Frame;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// One sonar receiver of a sonarnet run (started by `sonarnet run --engine processes`).
#[derive(Debug, Parser)]
#[command(name = "sonarnet-node", version, about)]
struct Args {
    /// The node's launch description (JSON, written by the coordinator).
    #[arg(long)]
    launch: String,
}

/// How long an idle node blocks before re-checking its parent and signals.
const IDLE_CHECK: Duration = Duration::from_millis(200);

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
    let args = match Args::try_parse_from(argv) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(2);
        }
    };
    let launch: NodeLaunch = match serde_json::from_str(&args.launch) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("sonarnet-node: error: --launch is not a valid node launch description: {e}");
            return ExitCode::from(2);
        }
    };
    if launch.node.id as usize >= launch.topology.len() {
        eprintln!(
            "sonarnet-node: error: --launch: node id {} is outside the topology of {} nodes",
            launch.node.id,
            launch.topology.len()
        );
        return ExitCode::from(2);
    }
    match run(launch) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sonarnet-node: error: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(launch: NodeLaunch) -> Result<(), String> {
    let id = launch.node.id;
    let verbose = launch.verbose;
    let term = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        signal_hook::flag::register(sig, Arc::clone(&term)).map_err(|e| e.to_string())?;
    }
    let parent = std::os::unix::process::parent_id();
    let topo = launch.run_topology().map_err(|e| e.to_string())?;
    let mut tx = IoxTransport::node(&topo, id).map_err(|e| e.to_string())?;
    tx.set_poll(Duration::from_micros(launch.poll_us));
    tx.send(Endpoint::Coordinator, &codec::encode_ready(id))
        .map_err(|e| e.to_string())?;
    tx.flush().map_err(|e| e.to_string())?;
    if verbose {
        eprintln!("[node {id}] up, neighbours {:?}", launch.node.neighbours);
    }

    let mut core = NodeCore::new(launch.node);
    let mut decoder = NodeDecoder::default();
    let mut frames: Vec<Frame> = Vec::new();
    let mut outputs: Vec<Output> = Vec::new();
    let mut encoded: Vec<Frame> = Vec::new();
    let mut iteration_reports: Vec<Frame> = Vec::new();
    let mut timing = Timing::default();
    // Realtime clock: rate and next wake-up.
    let mut clock: Option<(f64, Instant)> = None;

    loop {
        if term.load(Ordering::Relaxed) {
            if verbose {
                eprintln!("[node {id}] terminated by signal");
            }
            return Ok(());
        }
        let timeout = match clock {
            Some((_, next)) => next
                .saturating_duration_since(Instant::now())
                .min(IDLE_CHECK),
            None => IDLE_CHECK,
        };
        frames.clear();
        let waited = Instant::now();
        tx.recv(&mut frames, Some(timeout))
            .map_err(|e| e.to_string())?;
        // Only an idle node (nothing arrived) checks its parent: a system call per
        // message would cost more than the message.
        if frames.is_empty() && std::os::unix::process::parent_id() != parent {
            return Err("the coordinator is gone".into());
        }
        let busy = Instant::now();
        timing.wait_seconds += (busy - waited).as_secs_f64();

        for f in &frames {
            let input = decoder
                .feed(f)
                .map_err(|e| format!("bad frame from {}: {e}", f.from))?;
            match input {
                None => {}
                Some(NodeInput::Peer(m)) => core.handle(Input::Peer(m), &mut outputs),
                Some(NodeInput::Control(Control::Command(c))) => {
                    if verbose {
                        log_command(id, &c);
                    }
                    core.handle(Input::Command(c), &mut outputs)
                }
                Some(NodeInput::Control(Control::StartClock(rate))) => {
                    let wait = core.draw_wait(rate);
                    clock = Some((rate, Instant::now() + Duration::from_secs_f64(wait)));
                }
                Some(NodeInput::Control(Control::Stop)) => {
                    if verbose {
                        eprintln!("[node {id}] stop: {:?}", core.counters());
                    }
                    return Ok(());
                }
            }
        }
        if let Some((rate, next)) = clock
            && Instant::now() >= next
        {
            core.handle(Input::Command(Command::Tick), &mut outputs);
            let wait = core.draw_wait(rate);
            clock = Some((
                rate,
                next.max(Instant::now()) + Duration::from_secs_f64(wait),
            ));
        }
        if outputs.is_empty() {
            timing.busy_seconds += busy.elapsed().as_secs_f64();
            continue;
        }
        for o in outputs.drain(..) {
            match o {
                Output::Peer { to, msg } => tx
                    .send(Endpoint::Node(to), &codec::encode_peer(&msg))
                    .map_err(|e| e.to_string())?,
                Output::Broadcast(msg) => tx
                    .broadcast(&codec::encode_peer(&msg))
                    .map_err(|e| e.to_string())?,
                Output::Report(r @ sonarnet::protocol::Report::IterationDone { .. }) => {
                    // Batched: sent with the sample's final report, so the
                    // coordinator is woken once per sample, not per iteration.
                    codec::encode_report(&r, &mut iteration_reports);
                }
                Output::Report(r) => {
                    if verbose {
                        eprintln!("[node {id}] report {r:?}");
                    }
                    encoded.clear();
                    encoded.append(&mut iteration_reports);
                    if matches!(
                        r,
                        sonarnet::protocol::Report::SampleDone { .. }
                            | sonarnet::protocol::Report::Snapshot { .. }
                    ) {
                        let snapshot = Timing {
                            busy_seconds: timing.busy_seconds + busy.elapsed().as_secs_f64(),
                            wait_seconds: timing.wait_seconds,
                        };
                        encoded.push(codec::encode_timing(id, &snapshot));
                    }
                    codec::encode_report(&r, &mut encoded);
                    for f in &encoded {
                        tx.send(Endpoint::Coordinator, f)
                            .map_err(|e| e.to_string())?;
                    }
                }
            }
        }
        tx.flush().map_err(|e| e.to_string())?;
        timing.busy_seconds += busy.elapsed().as_secs_f64();
    }
}

fn log_command(id: u32, c: &Command) {
    match c {
        Command::Sample { sample, meas } => {
            eprintln!(
                "[node {id}] sample {sample}: {} measurements",
                meas.bistatic.len() + meas.doa.is_some() as usize + meas.range.is_some() as usize
            )
        }
        Command::AsyncPlan { sample, steps } => {
            eprintln!("[node {id}] sample {sample}: plan of {} steps", steps.len())
        }
        other => eprintln!("[node {id}] {other:?}"),
    }
}
