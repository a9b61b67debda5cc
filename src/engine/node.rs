//! The node program's event loop, generic over the [`Transport`]: report
//! READY, then feed every decoded frame (and, in realtime mode, the node's own
//! Poisson clock ticks) to the I/O-free [`NodeCore`] and send what it returns.
//! `sonarnet-node` (`nodes/main.rs`) runs it over iceoryx2; any transport that
//! implements the trait runs the same loop. An idle node blocks in
//! [`Transport::recv`] (no busy-spinning) for at most [`IDLE_CHECK`] before it
//! looks at `term` and asks whether its coordinator is still there.

use crate::protocol::codec::{self, Control, NodeDecoder, NodeInput, Timing};
use crate::protocol::{Command, Input, NodeConfig, NodeCore, Output, Report};
use crate::transport::wire::Frame;
use crate::transport::{Endpoint, Transport, TransportError};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long an idle node blocks before re-checking its coordinator and signals.
pub const IDLE_CHECK: Duration = Duration::from_millis(200);

/// What the loop needs from its process besides the transport.
pub struct NodeLoop<'a> {
    /// Log commands, reports and the stop to stderr, tagged `[node ID]`.
    pub verbose: bool,
    /// Set (e.g. by SIGTERM or SIGINT) to make the loop return `Ok` at its next
    /// wake-up.
    pub term: &'a AtomicBool,
    /// Asked only when idle (a system call per message would cost more than the
    /// message): `false` once the coordinator is gone, which fails the loop.
    pub coordinator_alive: &'a dyn Fn() -> bool,
    /// The acoustic channel's shared clock ([`super::water`]): gossip frames
    /// go to the coordinator's water stamped with their emulated send time,
    /// and the node's clock waits and timers are emulated seconds. `None`
    /// (the ideal channel): frames go straight to the peers, in wall time.
    pub channel: Option<super::water::ChannelClock>,
}

/// Why a node stopped other than by STOP or `term`.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The transport failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// A frame did not decode.
    #[error("bad frame from {from}: {error}")]
    BadFrame {
        /// The sender.
        from: u32,
        /// What the decoder found.
        error: crate::protocol::codec::DecodeError,
    },
    /// The coordinator went away while the node was idle.
    #[error("the coordinator is gone")]
    CoordinatorGone,
}

/// Run node `node` over `tx` until STOP, `opts.term` or an error. Sends READY
/// first.
pub fn run_node<T: Transport>(
    tx: &mut T,
    node: NodeConfig,
    opts: &NodeLoop<'_>,
) -> Result<(), NodeError> {
    let id = node.id;
    tx.send(Endpoint::Coordinator, &codec::encode_ready(id))?;
    tx.flush()?;
    if opts.verbose {
        eprintln!("[node {id}] up, neighbours {:?}", node.neighbours);
    }

    let mut core = NodeCore::new(node);
    // Emulated seconds as wall seconds, times the clock's drift (a
    // `clock_drift` fault, [`Control::ClockFactor`]).
    let drift = std::cell::Cell::new(1.0f64);
    let wall = |emulated: f64| {
        let w = match opts.channel {
            Some(c) => emulated / c.time_scale,
            None => emulated,
        };
        w * drift.get()
    };
    let mut decoder = NodeDecoder::default();
    let mut frames: Vec<Frame> = Vec::new();
    let mut outputs: Vec<Output> = Vec::new();
    let mut encoded: Vec<Frame> = Vec::new();
    let mut iteration_reports: Vec<Frame> = Vec::new();
    let mut timing = Timing::default();
    // Realtime clock: rate and next wake-up.
    let mut clock: Option<(f64, Instant)> = None;
    // Over a lossy channel: the core's timers (when, the command to hand it).
    let mut timers: Vec<(Instant, Command)> = Vec::new();

    loop {
        if opts.term.load(Ordering::Relaxed) {
            if opts.verbose {
                eprintln!("[node {id}] terminated by signal");
            }
            return Ok(());
        }
        let timeout = clock
            .map(|(_, next)| next)
            .into_iter()
            .chain(timers.iter().map(|t| t.0))
            .map(|at| at.saturating_duration_since(Instant::now()))
            .fold(IDLE_CHECK, Duration::min);
        frames.clear();
        let waited = Instant::now();
        tx.recv(&mut frames, Some(timeout))?;
        // Only an idle node (nothing arrived) checks its parent: a system call per
        // message would cost more than the message.
        if frames.is_empty() && !(opts.coordinator_alive)() {
            return Err(NodeError::CoordinatorGone);
        }
        let busy = Instant::now();
        timing.wait_seconds += (busy - waited).as_secs_f64();

        for f in &frames {
            let input = decoder.feed(f).map_err(|error| NodeError::BadFrame {
                from: f.from,
                error,
            })?;
            match input {
                None => {}
                Some(NodeInput::Peer(m)) => {
                    let late = core.counters().late;
                    core.handle(Input::Peer(m), &mut outputs);
                    if opts.channel.is_some() && core.counters().late > late {
                        tx.send(Endpoint::Coordinator, &codec::encode_late(id, &m))?;
                    }
                }
                Some(NodeInput::Control(Control::Command(c))) => {
                    if opts.verbose {
                        log_command(id, &c);
                    }
                    core.handle(Input::Command(c), &mut outputs)
                }
                Some(NodeInput::Control(Control::StartClock(rate))) => {
                    let wait = core.draw_wait(rate);
                    clock = Some((rate, after(Instant::now(), wall(wait))));
                }
                Some(NodeInput::Control(Control::ClockFactor(f))) if f.is_finite() && f > 0.0 => {
                    drift.set(f)
                }
                Some(NodeInput::Control(Control::ClockFactor(_))) => {}
                Some(NodeInput::Control(Control::Ping(seq))) => {
                    // Answered by the loop, not the protocol core: a node that
                    // waits for a neighbour is alive, and says so at once
                    // (pings are rare: only after half a stall timeout).
                    tx.send(Endpoint::Coordinator, &codec::encode_pong(id, seq))?;
                    tx.flush()?;
                }
                Some(NodeInput::Control(Control::Stop)) => {
                    if opts.verbose {
                        eprintln!("[node {id}] stop: {:?}", core.counters());
                    }
                    // The run is over: what a neighbour (killed, say) did not
                    // read no longer matters; the last reports to the
                    // coordinator still do.
                    tx.forget_unread(Some(Endpoint::Coordinator));
                    return Ok(());
                }
            }
        }
        let now = Instant::now();
        timers.retain(|(at, then)| {
            let due = *at <= now;
            if due {
                core.handle(Input::Command(then.clone()), &mut outputs);
            }
            !due
        });
        if let Some((rate, next)) = clock
            && Instant::now() >= next
        {
            core.handle(Input::Command(Command::Tick), &mut outputs);
            let wait = core.draw_wait(rate);
            clock = Some((rate, after(next.max(Instant::now()), wall(wait))));
        }
        if outputs.is_empty() {
            timing.busy_seconds += busy.elapsed().as_secs_f64();
            continue;
        }
        let mut gone: Vec<u32> = Vec::new();
        for o in outputs.drain(..) {
            match o {
                Output::Peer { to, msg } if let Some(c) = opts.channel => {
                    let f = codec::encode_channel(&msg, to, c.now_s());
                    tx.send(Endpoint::Coordinator, &f)?;
                }
                Output::Broadcast(msg) if let Some(c) = opts.channel => {
                    let f = codec::encode_channel(&msg, codec::TO_ALL, c.now_s());
                    tx.send(Endpoint::Coordinator, &f)?;
                }
                Output::Peer { to, msg } => {
                    match tx.send(Endpoint::Node(to), &codec::encode_peer(&msg)) {
                        // A neighbour that exited on its own (SIGTERM, a panic,
                        // an error exit) is down, as if the coordinator had said
                        // so; the coordinator also notices and tells the others.
                        Err(TransportError::PeerGone { .. }) => gone.push(to),
                        r => r?,
                    }
                }
                Output::Broadcast(msg) => tx.broadcast(&codec::encode_peer(&msg))?,
                // Faults (and so checkpoints) run on the discrete-event
                // engine so far.
                Output::Checkpoint { .. } => {}
                Output::Timer { after_s, then } => {
                    timers.push((after(Instant::now(), wall(after_s)), then))
                }
                Output::Report(r @ Report::IterationDone { .. }) => {
                    // Batched: sent with the sample's final report, so the
                    // coordinator is woken once per sample, not per iteration.
                    codec::encode_report(&r, &mut iteration_reports);
                }
                Output::Report(r) => {
                    if opts.verbose {
                        eprintln!("[node {id}] report {r:?}");
                    }
                    encoded.clear();
                    encoded.append(&mut iteration_reports);
                    if matches!(r, Report::SampleDone { .. } | Report::Snapshot { .. }) {
                        let snapshot = Timing {
                            busy_seconds: timing.busy_seconds + busy.elapsed().as_secs_f64(),
                            wait_seconds: timing.wait_seconds,
                        };
                        encoded.push(codec::encode_timing(id, &snapshot));
                    }
                    codec::encode_report(&r, &mut encoded);
                    for f in &encoded {
                        tx.send(Endpoint::Coordinator, f)?;
                    }
                }
            }
        }
        for node in gone {
            if opts.verbose {
                eprintln!("[node {id}] node {node} has exited: treated as down");
            }
            core.handle(Input::Command(Command::NodeDown { node }), &mut outputs);
        }
        tx.flush()?;
        timing.busy_seconds += busy.elapsed().as_secs_f64();
    }
}

/// `from` plus `secs` seconds of a drawn wait, clamped to `[0, 1 day]` so
/// that no rate (or a NaN) can make the clock arithmetic panic.
fn after(from: Instant, secs: f64) -> Instant {
    const DAY: Duration = Duration::from_secs(86_400);
    let wait = Duration::try_from_secs_f64(secs).map_or(DAY, |d| d.min(DAY));
    from.checked_add(wait).unwrap_or(from)
}

fn log_command(id: u32, c: &Command) {
    match c {
        Command::Sample { sample, meas, .. } => {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drawn_wait_of_any_size_gives_a_clock_time_without_panicking() {
        let t = Instant::now();
        assert_eq!(after(t, 0.5), t + Duration::from_millis(500));
        for w in [1e300, f64::INFINITY, f64::NAN, -1.0] {
            let a = after(t, w);
            assert!(a >= t && a <= t + Duration::from_secs(86_400), "{w}");
        }
    }
}
