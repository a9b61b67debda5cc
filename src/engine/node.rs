//! The node program's event loop, generic over the [`Transport`]: report
//! READY, then feed every decoded frame (and, in realtime mode, the node's own
//! Poisson clock ticks) to the I/O-free [`NodeCore`] and send what it returns.
//! `sonarnet-node` (`nodes/main.rs`) runs it over iceoryx2; any transport that
//! implements the trait runs the same loop. An idle node blocks in
//! [`Transport::recv`] (no busy-spinning) for at most [`IDLE_CHECK`] before it
//! looks at `term` and asks whether its coordinator is still there.

use super::checkpoint::Checkpoint;
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
    /// The node's checkpoint file ([`super::checkpoint`]): written at every
    /// [`Output::Checkpoint`]. `None`: checkpoints are not kept.
    pub checkpoint: Option<std::path::PathBuf>,
    /// Start from the checkpoint file, if there is one (a restart with
    /// `state = "checkpoint"`); else from `init_u`.
    pub resume: bool,
    /// Gossip frames a peer may send this node per sample the node was
    /// given (and one more sample's worth); past that the peer's frames
    /// are dropped, counted as bad frames, and the peer is named once
    /// ([`crate::engine::layout::peer_budget`]). `u64::MAX`: no bound.
    pub peer_frames_per_sample: u64,
    /// On the realtime clock, a sample period in wall time: the peers'
    /// budgets also grow by one per period gone by
    /// ([`crate::engine::layout::budgets_earned`]).
    pub budget_period: Option<Duration>,
}

impl<'a> NodeLoop<'a> {
    /// A node inside its coordinator's process (the threads engine, tests):
    /// quiet, on the ideal channel, without checkpoints, its coordinator
    /// always alive; it stops when `term` is set.
    pub fn in_process(term: &'a AtomicBool) -> Self {
        fn alive() -> bool {
            true
        }
        NodeLoop {
            verbose: false,
            term,
            coordinator_alive: &alive,
            channel: None,
            checkpoint: None,
            resume: false,
            peer_frames_per_sample: u64::MAX,
            budget_period: None,
        }
    }
}

/// Why a node stopped other than by STOP or `term`.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The transport failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
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
        let nb: Vec<String> = node.neighbours.iter().map(u32::to_string).collect();
        vlog(id, &format!("up, neighbours {}", nb.join(", ")));
    }
    let mut l = Loop::new(start_core(node, opts), opts);
    let mut frames: Vec<Frame> = Vec::new();
    // The end of the last busy stretch: the wait that follows runs from it
    // (one clock read per stretch, not two).
    let mut idle_since = Instant::now();
    loop {
        if opts.term.load(Ordering::Relaxed) {
            if opts.verbose {
                vlog(id, "terminated by a signal");
            }
            return Ok(());
        }
        frames.clear();
        tx.recv(&mut frames, Some(l.timeout()))?;
        // Only an idle node (nothing arrived) checks its parent: a system call per
        // message would cost more than the message.
        if frames.is_empty() && !(opts.coordinator_alive)() {
            return Err(NodeError::CoordinatorGone);
        }
        let busy = Instant::now();
        l.timing.wait_seconds += (busy - idle_since).as_secs_f64();
        let mut stop = false;
        for f in &frames {
            if l.take(tx, f)? {
                // What the frames before STOP produced is still sent
                // (below); frames after it are not looked at.
                stop = true;
                break;
            }
        }
        // After STOP, no timer fires and the clock starts no exchange.
        if !stop {
            l.fire_due();
        }
        if l.outputs.is_empty() && !stop {
            idle_since = Instant::now();
            l.timing.busy_seconds += (idle_since - busy).as_secs_f64();
            continue;
        }
        let urgent = l.send_outputs(tx, busy)?;
        if urgent || stop {
            tx.flush()?;
        } else {
            tx.flush_lazily(Endpoint::Coordinator)?;
        }
        idle_since = Instant::now();
        l.timing.busy_seconds += (idle_since - busy).as_secs_f64();
        if stop {
            if opts.verbose {
                vlog(id, &format!("stops: {}", l.core.counters().in_words()));
            }
            // The run is over: what a neighbour (killed, say) did not
            // read no longer matters; the last reports to the
            // coordinator still do.
            tx.forget_unread(Some(Endpoint::Coordinator));
            return Ok(());
        }
    }
}

/// The node loop's state between two waits: the core, what it asked for
/// (its clock, its timers, a hop measurement) and the buffers reused from
/// one batch of frames to the next.
struct Loop<'o, 'a> {
    id: u32,
    opts: &'o NodeLoop<'a>,
    core: NodeCore,
    /// The clock's drift factor (a `clock_drift` fault,
    /// [`Control::ClockFactor`]).
    drift: f64,
    decoder: NodeDecoder,
    outputs: Vec<Output>,
    encoded: Vec<Frame>,
    /// Iteration reports, sent with the sample's next report.
    iteration_reports: Vec<Frame>,
    timing: Timing,
    /// Realtime clock: rate and next wake-up.
    clock: Option<(f64, Instant)>,
    /// Over a lossy channel: the core's timers (when, the command to hand it).
    timers: Vec<(Instant, Command)>,
    /// A hop measurement in progress ([`Control::ProbePeer`]).
    probe: Option<Probe>,
    /// Samples given to this node, and gossip frames each peer sent it
    /// ([`NodeLoop::peer_frames_per_sample`]).
    samples_given: u64,
    peer_frames: std::collections::BTreeMap<u32, u64>,
    /// Peers already named for a frame written in another's name.
    posers: std::collections::BTreeSet<u32>,
    started: Instant,
}

impl<'o, 'a> Loop<'o, 'a> {
    fn new(core: NodeCore, opts: &'o NodeLoop<'a>) -> Self {
        let dim = core.dim();
        Loop {
            id: core.id(),
            opts,
            core,
            drift: 1.0,
            decoder: NodeDecoder::new(dim),
            outputs: Vec::new(),
            encoded: Vec::new(),
            iteration_reports: Vec::new(),
            timing: Timing::default(),
            clock: None,
            timers: Vec::new(),
            probe: None,
            samples_given: 0,
            peer_frames: std::collections::BTreeMap::new(),
            posers: std::collections::BTreeSet::new(),
            started: Instant::now(),
        }
    }

    /// Count a gossip frame from `peer`; `false` once the peer is past its
    /// allowance (named the first time).
    fn within_allowance(&mut self, peer: u32) -> bool {
        let budget = self.opts.peer_frames_per_sample;
        let sent = self.peer_frames.entry(peer).or_insert(0);
        *sent = sent.saturating_add(1);
        let sent = *sent;
        let (given, period, start) = (self.samples_given, self.opts.budget_period, self.started);
        if crate::engine::layout::within_budget(sent, budget, given, period, start) {
            return true;
        }
        let earned = crate::engine::layout::budgets_earned(given, period, start);
        if sent == budget.saturating_mul(earned).saturating_add(1) {
            eprintln!(
                "[node {}] warning: node {peer} sent more than the {budget} gossip frames a \
                 sample allows ({given} samples given): its frames are dropped",
                self.id
            );
        }
        false
    }

    /// Emulated seconds as wall seconds, times the clock's drift.
    fn wall(&self, emulated: f64) -> f64 {
        let w = match self.opts.channel {
            Some(c) => emulated / c.time_scale,
            None => emulated,
        };
        w * self.drift
    }

    /// How long to wait for frames: until the clock's next tick or the
    /// first timer, at most [`IDLE_CHECK`].
    fn timeout(&self) -> Duration {
        self.clock
            .map(|(_, next)| next)
            .into_iter()
            .chain(self.timers.iter().map(|t| t.0))
            .map(|at| at.saturating_duration_since(Instant::now()))
            .fold(IDLE_CHECK, Duration::min)
    }

    /// Decode frame `f` and act on it; `true` for STOP.
    fn take<T: Transport>(&mut self, tx: &mut T, f: &Frame) -> Result<bool, NodeError> {
        let id = self.id;
        if f.kind == crate::transport::wire::IMPOSTOR {
            // The transport knows the sender, and it is not the one the
            // frame names: dropped, and the sender named once.
            if self.posers.insert(f.from) {
                eprintln!(
                    "[node {id}] warning: node {} sent a frame in node {}'s name: dropped, as is every such frame",
                    f.from, f.aux
                );
            }
            self.core.note_bad_frame();
            return Ok(false);
        }
        let input = match self.decoder.feed(f) {
            Ok(input) => input,
            Err(error) => {
                // Garbage from a peer (or a flood past a reassembly
                // limit) is counted and dropped: the node goes on.
                if self.opts.verbose {
                    eprintln!("[node {id}] dropped a bad frame from {}: {error}", f.from);
                }
                self.core.note_bad_frame();
                return Ok(false);
            }
        };
        match input {
            None => {}
            Some(NodeInput::Peer(m)) => {
                if !self.within_allowance(m.from()) {
                    self.core.note_bad_frame();
                    return Ok(false);
                }
                let late = self.core.counters().late;
                self.core.handle(Input::Peer(m), &mut self.outputs);
                if self.opts.channel.is_some() && self.core.counters().late > late {
                    tx.send(Endpoint::Coordinator, &codec::encode_late(id, &m))?;
                }
            }
            Some(NodeInput::Control(Control::Command(c))) => {
                if self.opts.verbose {
                    log_command(id, &c);
                }
                if matches!(c, crate::protocol::Command::Sample { .. }) {
                    self.samples_given += 1;
                }
                self.core.handle(Input::Command(c), &mut self.outputs)
            }
            Some(NodeInput::Control(Control::StartClock(rate))) => {
                let wait = self.core.draw_wait(rate);
                self.clock = Some((rate, after(Instant::now(), self.wall(wait))));
            }
            Some(NodeInput::Control(Control::ClockFactor(f))) if f.is_finite() && f > 0.0 => {
                self.drift = f;
            }
            Some(NodeInput::Control(Control::ClockFactor(_))) => {}
            Some(NodeInput::Control(Control::Ping(seq))) => {
                // Answered by the loop, not the protocol core: a node that
                // waits for a neighbour is alive, and says so at once
                // (pings are rare: only after half a stall timeout).
                tx.send(Endpoint::Coordinator, &codec::encode_pong(id, seq))?;
                tx.flush()?;
            }
            Some(NodeInput::Control(Control::ProbePeer { peer, count })) => {
                let mut p = Probe::start(peer, count);
                self.probe = p.send(id, tx)?.then_some(p);
            }
            Some(NodeInput::Probe {
                from,
                seq,
                back: false,
            }) => {
                tx.send(Endpoint::Node(from), &codec::encode_probe(id, seq, true))?;
                tx.flush()?;
            }
            Some(NodeInput::Probe {
                from,
                seq,
                back: true,
            }) => self.probe_answered(tx, from, seq)?,
            Some(NodeInput::Control(Control::Stop)) => return Ok(true),
        }
        Ok(false)
    }

    /// The answer to probe `seq` came back from `from`: the next probe, or
    /// the hops to the coordinator once all are in.
    fn probe_answered<T: Transport>(
        &mut self,
        tx: &mut T,
        from: u32,
        seq: u64,
    ) -> Result<(), NodeError> {
        let Some(p) = &mut self.probe else {
            return Ok(());
        };
        if p.peer != from || p.hops.len() as u64 != seq {
            return Ok(());
        }
        p.hops.push(p.sent.elapsed().as_secs_f64() / 2.0);
        if !p.send(self.id, tx)? {
            self.encoded.clear();
            codec::encode_hops(self.id, 0, &p.hops, &mut self.encoded);
            for f in &self.encoded {
                tx.send(Endpoint::Coordinator, f)?;
            }
            tx.flush()?;
            self.probe = None;
        }
        Ok(())
    }

    /// Fire the timers that are due, then the clock's tick if it is due.
    fn fire_due(&mut self) {
        if !self.timers.is_empty() {
            let now = Instant::now();
            let (core, outputs) = (&mut self.core, &mut self.outputs);
            self.timers.retain(|(at, then)| {
                let due = *at <= now;
                if due {
                    core.handle(Input::Command(then.clone()), outputs);
                }
                !due
            });
        }
        if let Some((rate, next)) = self.clock
            && Instant::now() >= next
        {
            self.core
                .handle(Input::Command(Command::Tick), &mut self.outputs);
            let wait = self.core.draw_wait(rate);
            self.clock = Some((rate, after(next.max(Instant::now()), self.wall(wait))));
        }
    }

    /// Send what the core returned (`busy`: when this busy stretch began);
    /// `true` if the coordinator must be woken for it. Peers found gone are
    /// handed to the core as down; what that returns waits for the next
    /// batch.
    fn send_outputs<T: Transport>(&mut self, tx: &mut T, busy: Instant) -> Result<bool, NodeError> {
        let id = self.id;
        let mut gone: Vec<u32> = Vec::new();
        // A sample's report can wait while the node has samples queued
        // (`flush_lazily`), anything else cannot.
        let mut urgent = false;
        let mut outputs = std::mem::take(&mut self.outputs);
        for o in outputs.drain(..) {
            match o {
                Output::Peer { to, msg } if let Some(c) = self.opts.channel => {
                    let f = codec::encode_channel(&msg, to, c.now_s());
                    tx.send(Endpoint::Coordinator, &f)?;
                    urgent = true;
                }
                Output::Broadcast(msg) if let Some(c) = self.opts.channel => {
                    let f = codec::encode_channel(&msg, codec::TO_ALL, c.now_s());
                    tx.send(Endpoint::Coordinator, &f)?;
                    urgent = true;
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
                Output::Checkpoint { sample, u, theta } => self.checkpoint(sample, &u, &theta),
                Output::Timer { after_s, then } => {
                    let at = after(Instant::now(), self.wall(after_s));
                    self.timers.push((at, then));
                }
                Output::Report(r @ Report::IterationDone { .. }) => {
                    // Batched: sent with the sample's final report, so the
                    // coordinator is woken once per sample, not per iteration.
                    codec::encode_report(&r, &mut self.iteration_reports);
                }
                Output::Report(r) => urgent |= self.report(tx, &r, busy)?,
            }
        }
        self.outputs = outputs;
        for node in gone {
            if self.opts.verbose {
                vlog(id, &format!("node {node} has exited: treated as down"));
            }
            self.core.handle(
                Input::Command(Command::NodeDown { node }),
                &mut self.outputs,
            );
        }
        Ok(urgent)
    }

    /// Write the core's checkpoint. A failed write keeps the previous
    /// checkpoint (the write is atomic); the node goes on, and says so.
    fn checkpoint(
        &self,
        sample: u32,
        u: &crate::model::coords::Coords,
        theta: &crate::model::coords::Coords,
    ) {
        let Some(path) = &self.opts.checkpoint else {
            return;
        };
        if let Err(e) = Checkpoint::new(self.id, sample, u, theta).write(path) {
            eprintln!(
                "[node {}] warning: checkpoint of sample {sample} not written to {}: {e}",
                self.id,
                path.display()
            );
        }
    }

    /// Send report `r` to the coordinator, after the batched iteration
    /// reports and (for a sample's report) the node's timing so far; `true`
    /// if the coordinator must be woken for it.
    fn report<T: Transport>(
        &mut self,
        tx: &mut T,
        r: &Report,
        busy: Instant,
    ) -> Result<bool, NodeError> {
        let id = self.id;
        if self.opts.verbose {
            vlog(id, &format!("reports {}", r.in_words()));
        }
        self.encoded.clear();
        self.encoded.append(&mut self.iteration_reports);
        if matches!(r, Report::SampleDone { .. } | Report::Snapshot { .. }) {
            let snapshot = Timing {
                busy_seconds: self.timing.busy_seconds + busy.elapsed().as_secs_f64(),
                wait_seconds: self.timing.wait_seconds,
            };
            self.encoded.push(codec::encode_timing(id, &snapshot));
        }
        let urgent = !matches!(r, Report::SampleDone { .. }) || self.core.samples_queued() == 0;
        codec::encode_report(r, &mut self.encoded);
        for f in &self.encoded {
            tx.send(Endpoint::Coordinator, f)?;
        }
        Ok(urgent)
    }
}

/// A hop measurement ([`Control::ProbePeer`]): one probe at a time to
/// `peer`, each sent as soon as the last one's answer is in, so that the
/// two processes block (or poll) between probes as between gossip steps.
struct Probe {
    peer: u32,
    count: usize,
    /// When the probe in flight was sent.
    sent: Instant,
    /// Half of each round trip so far (s).
    hops: Vec<f64>,
}

impl Probe {
    /// At most [`Probe::MAX`] ping-pongs (the count comes from a frame).
    const MAX: usize = 10_000;

    fn start(peer: u32, count: u32) -> Probe {
        let count = (count as usize).min(Probe::MAX);
        Probe {
            peer,
            count,
            sent: Instant::now(),
            hops: Vec::with_capacity(count),
        }
    }

    /// Sends the next probe; `false` once all `count` are answered.
    fn send<T: Transport>(&mut self, id: u32, tx: &mut T) -> Result<bool, TransportError> {
        if self.hops.len() >= self.count {
            return Ok(false);
        }
        self.sent = Instant::now();
        let f = codec::encode_probe(id, self.hops.len() as u64, false);
        tx.send(Endpoint::Node(self.peer), &f)?;
        tx.flush()?;
        Ok(true)
    }
}

/// The node's core: restored from its checkpoint file when `opts.resume`
/// and the file exists, else in its initial state. The coordinator reads
/// the file before it restarts the node, and fails the run if it does not
/// read; should it break in between, the node reports it and starts fresh.
fn start_core(node: NodeConfig, opts: &NodeLoop<'_>) -> NodeCore {
    let id = node.id;
    let Some(path) = opts.checkpoint.as_ref().filter(|_| opts.resume) else {
        return NodeCore::new(node);
    };
    match Checkpoint::read(path, id, node.dim()) {
        Ok(Some(ck)) => {
            if opts.verbose {
                eprintln!(
                    "[node {id}] resumes from its checkpoint of sample {}",
                    ck.sample
                );
            }
            match ck.state(node.dim()) {
                Ok((u, theta)) => NodeCore::restore(node, u, theta),
                Err(e) => {
                    eprintln!("[node {id}] warning: starts fresh: checkpoint unreadable: {e}");
                    NodeCore::new(node)
                }
            }
        }
        Ok(None) => NodeCore::new(node),
        Err(e) => {
            eprintln!("[node {id}] warning: starts fresh: checkpoint unreadable: {e}");
            NodeCore::new(node)
        }
    }
}

/// `from` plus `secs` seconds of a drawn wait, clamped to `[0, 1 day]` so
/// that no rate (or a NaN) can make the clock arithmetic panic.
fn after(from: Instant, secs: f64) -> Instant {
    from.checked_add(crate::world::time::wait(secs))
        .unwrap_or(from)
}

fn log_command(id: u32, c: &Command) {
    vlog(id, &c.in_words());
}

/// One whole line of this node's verbose log.
fn vlog(id: u32, text: &str) {
    crate::protocol::words::log_line(&format!("node {id}"), text);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::coords::Coords;
    use crate::model::measure::{NodeMeasurements, Sigmas};
    use crate::model::xy::Pt;
    use crate::protocol::codec::{CoordinatorInput, ReportDecoder};
    use crate::transport::{MemNetwork, RunTopology};

    fn lone_node(checkpoint_every: Option<u32>) -> NodeConfig {
        NodeConfig {
            drift: None,
            id: 0,
            n_nodes: 1,
            anchor: Pt::xy(1.0, 2.0),
            transmitters: vec![Pt::xy(0.0, 0.0)],
            neighbours: vec![],
            omega: 1.0,
            gamma: 1e-3,
            solver: crate::estimators::prox::LocalSolver::Gtrs,
            kappa: 1,
            init_u: Coords::from([5.0, 6.0, 7.0]),
            first_fix: false,
            noise_weights: false,
            seed: 7,
            mode: crate::protocol::NodeMode::Realtime,
            trace_iterations: false,
            exchange_timeout_s: None,
            round_timeout_s: None,
            checkpoint_every,
        }
    }

    /// [`run_node`] on the ideal channel, never signalled, its coordinator
    /// always alive.
    fn run_lone<T: Transport>(
        tx: &mut T,
        cfg: NodeConfig,
        checkpoint: Option<std::path::PathBuf>,
        resume: bool,
    ) -> Result<(), NodeError> {
        let term = AtomicBool::new(false);
        let opts = NodeLoop {
            checkpoint,
            resume,
            ..NodeLoop::in_process(&term)
        };
        run_node(tx, cfg, &opts)
    }

    /// Run a lone node program over the in-memory transport with
    /// `checkpoint` and `resume`; send it sample `sample` then a snapshot
    /// request, and return the `theta` it reports.
    fn snapshot_after_start(cfg: NodeConfig, checkpoint: &std::path::Path, resume: bool) -> Coords {
        let topo = RunTopology::new("ck", vec![vec![]], 16).unwrap();
        let net = MemNetwork::new(&topo);
        let mut coord = net.endpoint(Endpoint::Coordinator).unwrap();
        let mut node_tx = net.endpoint(Endpoint::Node(0)).unwrap();
        let path = checkpoint.to_path_buf();
        let node = std::thread::spawn(move || run_lone(&mut node_tx, cfg, Some(path), resume));
        let mut frames = Vec::new();
        for c in [
            Command::Sample {
                sample: 4,
                meas: NodeMeasurements {
                    elevation: None,
                    bistatic: vec![(0, 10.0)],
                    doa: Some(0.3),
                    range: None,
                },
                sigmas: Sigmas {
                    elevation: 0.0,
                    range: 1.0,
                    doa: 0.1,
                },
            },
            Command::Snapshot { sample: 4 },
        ] {
            codec::encode_control(&Control::Command(c), &mut frames);
        }
        for f in &frames {
            coord.send(Endpoint::Node(0), f).unwrap();
        }
        coord.flush().unwrap();
        let mut dec = ReportDecoder::new(2);
        let mut got = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(30);
        let theta = loop {
            assert!(Instant::now() < deadline, "no snapshot within 30 s");
            got.clear();
            coord
                .recv(&mut got, Some(Duration::from_millis(100)))
                .unwrap();
            let snap = got.iter().find_map(|f| match dec.feed(f).unwrap() {
                Some(CoordinatorInput::Report(Report::Snapshot { theta, .. })) => Some(theta),
                _ => None,
            });
            if let Some(t) = snap {
                break t;
            }
        };
        frames.clear();
        codec::encode_control(&Control::Stop, &mut frames);
        coord.send(Endpoint::Node(0), &frames[0]).unwrap();
        coord.flush().unwrap();
        node.join().unwrap().unwrap();
        theta
    }

    /// A node program that checkpoints writes its file when the
    /// sample arrives; started again with `resume`, it reports exactly the
    /// saved `theta` (not `init_u`); without `resume`, or with no file, it
    /// starts at `init_u`.
    #[test]
    fn a_node_program_resumed_from_its_checkpoint_file_reports_exactly_the_saved_state() {
        let dir = std::env::temp_dir().join(format!("sonarnet-node-ck-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = super::super::checkpoint::path(&dir, 0);
        let init = Coords::from([5.0, 6.0, 7.0]);
        assert_eq!(snapshot_after_start(lone_node(None), &path, true), init);
        assert!(!path.exists(), "no checkpoint without checkpoint_every");
        let saved = Coords::from([0.1 + 0.2, -1.0 / 3.0, 123.456_789]);
        Checkpoint::new(0, 3, &Coords::zeros(3), &saved)
            .write(&path)
            .unwrap();
        let theta = snapshot_after_start(lone_node(Some(1)), &path, true);
        let bits = |c: &Coords| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&theta), bits(&saved));
        // The arrival of sample 4 wrote the restored state.
        let ck = Checkpoint::read(&path, 0, 2).unwrap().unwrap();
        assert_eq!(ck.sample, 4);
        assert_eq!(bits(&ck.state(2).unwrap().1), bits(&saved));
        assert_eq!(snapshot_after_start(lone_node(Some(1)), &path, false), init);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A report the node owes for a frame that came in the same batch as
    /// STOP is still sent: here a snapshot request and STOP sent together.
    #[test]
    fn a_snapshot_requested_in_the_same_batch_as_stop_is_still_reported() {
        let topo = RunTopology::new("stop-batch", vec![vec![]], 16).unwrap();
        let net = MemNetwork::new(&topo);
        let mut coord = net.endpoint(Endpoint::Coordinator).unwrap();
        let mut node_tx = net.endpoint(Endpoint::Node(0)).unwrap();
        let mut frames = Vec::new();
        codec::encode_control(
            &Control::Command(Command::Snapshot { sample: 7 }),
            &mut frames,
        );
        codec::encode_control(&Control::Stop, &mut frames);
        // Both are in the node's inbox before it first reads it.
        for f in &frames {
            coord.send(Endpoint::Node(0), f).unwrap();
        }
        coord.flush().unwrap();
        run_lone(&mut node_tx, lone_node(None), None, false).unwrap();
        let mut got = Vec::new();
        coord.recv(&mut got, Some(Duration::from_secs(1))).unwrap();
        let mut dec = ReportDecoder::new(2);
        let snapshots: Vec<u32> = got
            .iter()
            .filter_map(|f| match dec.feed(f).unwrap() {
                Some(CoordinatorInput::Report(Report::Snapshot { sample, .. })) => Some(sample),
                _ => None,
            })
            .collect();
        assert_eq!(snapshots, vec![7]);
    }

    /// Garbage in a node's inbox (an unknown kind, a peer message with an
    /// impossible field, a frame in another's name) is counted and dropped: the node answers what
    /// follows and reports the count with its counters.
    #[test]
    fn a_node_counts_and_drops_bad_frames_and_goes_on() {
        let topo = RunTopology::new("bad-frames", vec![vec![]], 16).unwrap();
        let net = MemNetwork::new(&topo);
        let mut coord = net.endpoint(Endpoint::Coordinator).unwrap();
        let mut node_tx = net.endpoint(Endpoint::Node(0)).unwrap();
        let mut frames = vec![
            Frame {
                kind: 0xdead,
                from: 0,
                ..Frame::default()
            },
            Frame {
                kind: codec::kind::REFLECT,
                from: 0,
                data: [f64::NAN; 5],
                ..Frame::default()
            },
            // A frame its transport found written in another's name.
            Frame {
                kind: crate::transport::wire::IMPOSTOR,
                from: 0,
                aux: 3,
                ..Frame::default()
            },
        ];
        codec::encode_control(
            &Control::Command(Command::Snapshot { sample: 7 }),
            &mut frames,
        );
        codec::encode_control(&Control::Stop, &mut frames);
        for f in &frames {
            coord.send(Endpoint::Node(0), f).unwrap();
        }
        coord.flush().unwrap();
        run_lone(&mut node_tx, lone_node(None), None, false).expect("the node goes on");
        let mut got = Vec::new();
        coord.recv(&mut got, Some(Duration::from_secs(1))).unwrap();
        let mut dec = ReportDecoder::new(2);
        let counted: Vec<u64> = got
            .iter()
            .filter_map(|f| match dec.feed(f).unwrap() {
                Some(CoordinatorInput::Report(Report::Snapshot { counters, .. })) => {
                    Some(counters.bad_frames)
                }
                _ => None,
            })
            .collect();
        assert_eq!(counted, vec![3]);
    }

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
