//! The multi-process engine: one `sonarnet-node` OS process per receiver,
//! frames over the transport (iceoryx2 shared memory), this process as the
//! coordinator.
//!
//! Life of a run:
//! 1. [`cleanup_stale_resources`](crate::transport::cleanup_stale_resources) removes what crashed runs left behind.
//! 2. The coordinator spawns the N children (posix_spawn), then creates the
//!    run's services (a fresh run id, limits sized to the graph), then opens
//!    the start gate: every child waits for the end of its stdin, one pipe
//!    for all, before it opens its ports ([`wait_at_gate`]). Each child gets
//!    a [`NodeLaunch`] (its own [`NodeConfig`] and the transport topology) as
//!    JSON, runs in its own process group (a terminal Ctrl-C reaches only the
//!    coordinator) and asks for SIGTERM if the coordinator dies
//!    (`PR_SET_PDEATHSIG`, [`guard_parent`]).
//! 3. Every node reports READY; [`drive`](crate::engine::drive) then runs the
//!    [`Coordinator`](crate::protocol::Coordinator) over [`Processes`], with logical or
//!    realtime clocks. A child that exits is an [`Event::NodeDied`]. Faults
//!    (the steps of [`crate::world::faults`], `faults.rs`) are real signals and real
//!    respawns: a restarted node gets a new process (fresh, or from its
//!    checkpoint file, [`crate::engine::checkpoint`]) and is an [`Event::NodeUp`]
//!    once it reports READY.
//! 4. On drop the coordinator sends STOP, waits for every child, kills the
//!    stragglers, reaps every one of them, and cleans up what a killed child
//!    left in `/dev/shm` and `/tmp/iceoryx2`.

use crate::engine::Network;
use crate::engine::layout::{NetworkLayout, network_layout};
use crate::engine::outcome::{ProcessStats, RunOutcome};
use crate::engine::water::{ChannelClock, Water};
use crate::model::synth::Feed;
use crate::protocol::EngineError;
use crate::protocol::NodeConfig;
use crate::protocol::codec::{self, Control, CoordinatorInput, ReportDecoder, Timing};
use crate::protocol::config::Driver;
use crate::protocol::coordinator::Event;
use crate::protocol::plan::RunPlan;
use crate::transport::wire::Frame;
use crate::transport::{Endpoint, Transport, TransportChoice, TransportError};
use crate::world::faults::FaultWorld;
use crate::world::medium::ChannelLog;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

mod faults;
pub mod fleet;
mod hop;
mod inbox;
pub use inbox::CUT_OFF_BAD_FRAMES;
use inbox::{Inbox, samples_word};
mod launch;
mod start;
pub use fleet::{NodeProc, Placement, RemoteFleet};
pub use hop::{HOPS_PER_TURN, measure_hop};
use launch::checkpoint_dir;
pub(crate) use launch::spawn_child;
pub use launch::{
    NodeLaunch, NodeProcessError, NodeProgram, ProcessOptions, TEMP_CHECKPOINTS,
    default_node_program, guard_parent, wait_at_gate,
};

/// The coordinator side of a multi-process run.
pub struct Processes {
    /// `None` only while dropping.
    tx: Option<Box<dyn Transport>>,
    /// The node processes and what restarting one takes.
    nodes: Nodes,
    /// Frames and reports on their way to the coordinator.
    inbox: Inbox,
    interrupt: Arc<AtomicBool>,
    /// Latest time split per node.
    pub timing: Vec<Timing>,
    /// Seconds from the start of spawning to the last READY.
    pub startup_seconds: f64,
    verbose: bool,
    /// The run's IPC namespace.
    pub run_id: String,
    stopped: bool,
    /// The acoustic channel between the nodes (`None`: the ideal channel,
    /// where nodes send to each other directly).
    water: Option<Water>,
    delivered: Vec<(u32, crate::protocol::PeerMsg)>,
    /// The run's faults, their wall-clock origin and emulated seconds per
    /// wall second ([`Processes::arm_faults`]).
    faults: Option<(FaultWorld, Instant, f64)>,
    /// Per node: frames held while it is paused ([`Processes::send_to_node`]).
    held: Vec<Vec<Frame>>,
}

/// The node processes of a run: here or on the agents' hosts, which are
/// gone, which are restarting, and what it takes to start one again.
struct Nodes {
    children: Vec<Option<NodeProc>>,
    /// The agents of the other hosts (a `[deploy]` placement over zenoh).
    fleet: Option<Arc<RemoteFleet>>,
    /// Which host runs which node (`None`: all here).
    placement: Option<Placement>,
    dead: Vec<bool>,
    /// Per node: restarted, its READY not yet seen.
    restarting: Vec<bool>,
    /// What it takes to start a node (again, after a `restart` fault).
    relaunch: Relaunch,
    /// When start-up last looked at the children.
    checked: Instant,
    /// Over zenoh: the run's users, a password per node.
    credentials: Option<crate::transport::credentials::RunCredentials>,
    /// Nodes cut off during start-up and how: their deaths reach the
    /// coordinator with the run's first events.
    cut_at_startup: Vec<(u32, String)>,
}

/// What starting a node takes: the node program, what every node is told at
/// start (node 0's launch), every node's configuration, and where the
/// checkpoint files go.
struct Relaunch {
    program: NodeProgram,
    launch0: NodeLaunch,
    configs: Vec<NodeConfig>,
    /// Where the nodes' checkpoint files go, and whether that directory is
    /// a temporary one of this run (removed at the end).
    checkpoints: Option<(std::path::PathBuf, bool)>,
}

impl Processes {
    /// Create the run's services (namespace `run_id`, from
    /// [`unique_run_id`](crate::transport::unique_run_id)) and spawn one node
    /// process per receiver; returns once every node reported READY.
    /// With `water`, the nodes gossip through it (the acoustic channel, or
    /// the ideal channel's relay under link faults).
    pub fn spawn(
        run_id: String,
        layout: NetworkLayout,
        water: Option<Water>,
        opts: &ProcessOptions,
    ) -> Result<Processes, EngineError> {
        let NetworkLayout {
            configs,
            neighbours: graph_neighbours,
            inbox: inbox_buffer,
            broadcast,
            flood_frames_per_sample,
            peer_frames_per_sample,
            budget_period,
        } = layout;
        let prog = &opts.node_program;
        if !prog.program.exists() {
            return Err(EngineError::NodeProgramMissing {
                path: prog.program.clone(),
            });
        }
        let zenoh = match &opts.transport {
            TransportChoice::Zenoh(z) => Some(z.clone()),
            TransportChoice::Iceoryx2 => None,
        };
        if opts.placement.is_some() && zenoh.is_none() {
            return Err(EngineError::Unsupported(
                "nodes placed on other hosts ([deploy], --place) need --transport zenoh".into(),
            ));
        }
        let interrupt = crate::engine::interrupt::flag();
        let _ = crate::transport::cleanup_stale_resources();
        let n = configs.len();
        // Sync nodes run in lock-step rounds: at most two rounds in flight.
        let broadcast_buffer = broadcast.then_some(4);
        let launch0 = NodeLaunch {
            run_id: run_id.clone(),
            topology: graph_neighbours,
            inbox_buffer,
            broadcast_buffer,
            send_timeout_ms: 10_000,
            node: configs[0].clone(),
            verbose: opts.verbose,
            poll_us: opts.poll_us,
            channel: water.as_ref().map(Water::clock),
            checkpoint: None,
            resume: false,
            coordinator_pid: Some(std::process::id()),
            gate: false,
            transport: match &zenoh {
                Some(z) => TransportChoice::Zenoh(z.for_local_nodes()),
                None => TransportChoice::Iceoryx2,
            },
            peer_frames_per_sample,
            budget_period,
        };
        let topo = launch0.run_topology().map_err(EngineError::Transport)?;
        let start = Instant::now();
        let mut p = Processes {
            tx: None,
            nodes: Nodes {
                children: Vec::with_capacity(n),
                fleet: None,
                placement: opts.placement.clone(),
                dead: vec![false; n],
                restarting: vec![false; n],
                relaunch: Relaunch {
                    program: prog.clone(),
                    launch0,
                    checkpoints: checkpoint_dir(&configs, &run_id, opts)?,
                    configs: configs.clone(),
                },
                checked: Instant::now(),
                credentials: None,
                cut_at_startup: Vec::new(),
            },
            inbox: Inbox {
                decoder: ReportDecoder::new(configs[0].dim()),
                frames: Vec::new(),
                encoded: Vec::new(),
                events: Vec::new(),
                bad: vec![0; n + 1],
                cut: vec![false; n],
                posed_as: vec![None; n],
                received: vec![0; n],
                samples: vec![0; n],
                flood_frames_per_sample,
                budget_period,
                started: Instant::now(),
                flooded: vec![false; n],
            },
            interrupt,
            timing: vec![Timing::default(); n],
            startup_seconds: 0.0,
            verbose: opts.verbose,
            run_id: run_id.clone(),
            stopped: false,
            water,
            delivered: Vec::new(),
            faults: None,
            held: vec![Vec::new(); n],
        };
        if let Some(z) = &zenoh {
            p.start_zenoh(&topo, z, &configs, opts)?;
        } else {
            p.start_iceoryx2(&topo, &configs)?;
        }
        p.log(format_args!(
            "spawned {n} node processes (run {})",
            p.run_id
        ));
        p.wait_ready(start, opts.startup_timeout)?;
        Ok(p)
    }

    fn log(&self, args: std::fmt::Arguments<'_>) {
        if self.verbose {
            crate::protocol::words::log_line("coordinator", &args.to_string());
        }
    }

    /// Check every child; returns the first newly dead node and how it died.
    pub fn check_children(&mut self) -> Option<(u32, String)> {
        for (i, c) in self.nodes.children.iter_mut().enumerate() {
            if self.nodes.dead[i] && !self.nodes.restarting[i] {
                continue;
            }
            if let Some(child) = c
                && let Some(status) = child.try_wait()
            {
                *c = None;
                if self.nodes.restarting[i] {
                    // It is dead to the coordinator already.
                    self.nodes.restarting[i] = false;
                    eprintln!(
                        "warning: restarted node {i} exited before it was ready ({})",
                        status
                    );
                    continue;
                }
                self.nodes.dead[i] = true;
                if let Some(claimed) = self.inbox.posed_as.get(i).copied().flatten() {
                    return Some((
                        i as u32,
                        format!(
                            "cut off by the coordinator for a frame in the name of node {claimed}"
                        ),
                    ));
                }
                if self.inbox.flooded.get(i).copied().unwrap_or(false) {
                    return Some((
                        i as u32,
                        format!(
                            "cut off by the coordinator as a flood ({} frames for {})",
                            self.inbox.received[i],
                            samples_word(self.inbox.samples[i])
                        ),
                    ));
                }
                if self.inbox.cut.get(i).copied().unwrap_or(false) {
                    return Some((
                        i as u32,
                        format!(
                            "cut off by the coordinator after {} frames that do not decode",
                            self.inbox.bad[i]
                        ),
                    ));
                }
                return Some((i as u32, status));
            }
        }
        None
    }

    /// Start-up: receive and decode whatever arrives within `timeout`. Fails on
    /// a dead child, an interrupt, or a transport error; with `keep_cut_offs`,
    /// a node the coordinator cut off is no failure: its death is kept for
    /// the run's first events, and the run goes on as after a crash.
    fn poll(
        &mut self,
        timeout: Duration,
        keep_cut_offs: bool,
    ) -> Result<Vec<CoordinatorInput>, EngineError> {
        if self.interrupt.load(Ordering::SeqCst) {
            return Err(EngineError::Interrupted { sample: 0 });
        }
        let out = self.receive(timeout)?;
        // One waitpid per child: every 50 ms at most, not after every batch
        // of READYs (that made start-up O(N^2) system calls).
        if self.nodes.checked.elapsed() < Duration::from_millis(50) {
            return Ok(out);
        }
        self.nodes.checked = Instant::now();
        while let Some((node, how)) = self.check_children() {
            if keep_cut_offs && self.inbox.cut.get(node as usize).copied().unwrap_or(false) {
                self.nodes.cut_at_startup.push((node, how));
                continue;
            }
            return Err(EngineError::NodeDied {
                node,
                sample: 0,
                how,
            });
        }
        Ok(out)
    }

    /// Forward every frame of the water whose judgement is due (delivered
    /// ones to their addressee), and flush.
    fn pump(&mut self) -> Result<(), EngineError> {
        let Some(w) = &mut self.water else {
            return Ok(());
        };
        w.judge_due(w.clock().now_s(), &mut self.delivered);
        if self.delivered.is_empty() {
            return Ok(());
        }
        let mut delivered = std::mem::take(&mut self.delivered);
        for (to, msg) in delivered.drain(..) {
            if !self.nodes.dead.get(to as usize).copied().unwrap_or(true) {
                self.send_to_node(to, &[codec::encode_peer(&msg)])?;
            }
        }
        self.delivered = delivered;
        self.flush_all()
    }

    /// Send signal `sig` to node `node`'s process, if it has one.
    fn signal(&self, node: u32, sig: i32) {
        if let Some(Some(child)) = self.nodes.children.get(node as usize) {
            child.signal(sig);
        }
    }

    /// Whether node `node` is paused now (SIGSTOP, a `pause` fault).
    fn is_paused(&self, node: u32) -> bool {
        self.faults
            .as_ref()
            .is_some_and(|(s, _, _)| s.is_paused(node))
    }

    /// Send `frames` to node `node`, or hold them while it is paused (a
    /// stopped process drains nothing: its inbox would fill and the sender
    /// wait), to be sent when it continues ([`Processes::release`]), as the
    /// discrete-event engine holds a paused node's inputs. A node that has
    /// exited is skipped: the next child check reports its death.
    fn send_to_node(&mut self, node: u32, frames: &[Frame]) -> Result<(), EngineError> {
        if self.is_paused(node) {
            if let Some(h) = self.held.get_mut(node as usize) {
                h.extend_from_slice(frames);
            }
            return Ok(());
        }
        let tx = self.tx.as_mut().ok_or(EngineError::TransportClosed)?;
        for f in frames {
            match tx.send(Endpoint::Node(node), f) {
                Err(TransportError::PeerGone { .. }) => return Ok(()),
                r => r.map_err(EngineError::Transport)?,
            }
        }
        Ok(())
    }

    /// Node `node` continues: send what was held for it.
    fn release(&mut self, node: u32) -> Result<(), EngineError> {
        let held = self
            .held
            .get_mut(node as usize)
            .map(std::mem::take)
            .unwrap_or_default();
        if !held.is_empty() && !self.nodes.dead.get(node as usize).copied().unwrap_or(true) {
            self.send_to_node(node, &held)?;
            self.flush_all()?;
        }
        Ok(())
    }

    /// The water's records and delivery errors, times moved `offset_s`
    /// earlier (`None` on the ideal channel).
    fn take_water(
        &mut self,
        offset_s: f64,
    ) -> Option<(Vec<crate::world::medium::MessageRecord>, Vec<f64>)> {
        self.water
            .take()
            .filter(Water::is_acoustic)
            .map(|w| w.into_records(offset_s))
    }

    /// Send a control message to one node.
    pub fn control(&mut self, node: u32, c: &Control) -> Result<(), EngineError> {
        if self.stopped || self.nodes.dead.get(node as usize).copied().unwrap_or(true) {
            return Ok(());
        }
        if let Control::Command(crate::protocol::Command::Sample { .. }) = c
            && let Some(k) = self.inbox.samples.get_mut(node as usize)
        {
            *k += 1;
        }
        let mut encoded = std::mem::take(&mut self.inbox.encoded);
        encoded.clear();
        codec::encode_control(c, &mut encoded);
        let r = self.send_to_node(node, &encoded);
        self.inbox.encoded = encoded;
        r
    }

    /// Peak resident set size (`VmHWM`, KiB) of every live node process.
    pub fn peak_rss_kib(&self) -> Vec<Option<u64>> {
        self.nodes
            .children
            .iter()
            .map(|c| {
                let pid = c.as_ref()?.local_pid()?;
                let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
                status
                    .lines()
                    .find(|l| l.starts_with("VmHWM:"))?
                    .split_whitespace()
                    .nth(1)?
                    .parse()
                    .ok()
            })
            .collect()
    }

    /// Flush queued frames.
    pub fn flush_all(&mut self) -> Result<(), EngineError> {
        self.tx()?.flush().map_err(EngineError::Transport)
    }

    fn tx(&mut self) -> Result<&mut Box<dyn Transport>, EngineError> {
        self.tx.as_mut().ok_or(EngineError::TransportClosed)
    }

    /// Stop every node and reap it (idempotent; also done on drop).
    pub fn shutdown(&mut self) {
        if self.stopped {
            return;
        }
        let n = self.nodes.children.len();
        for i in 0..n {
            // A node paused at the end continues, to hear the stop.
            if self.is_paused(i as u32) {
                self.signal(i as u32, libc::SIGCONT);
                if let Some((s, _, _)) = self.faults.as_mut() {
                    s.released(i as u32);
                }
                let _ = self.release(i as u32);
            }
            if !self.nodes.dead[i] && self.nodes.children[i].is_some() {
                let _ = self.control(i as u32, &Control::Stop);
            }
            // A restarted node not ready yet cannot be told to stop.
            if self.nodes.restarting[i]
                && let Some(mut child) = self.nodes.children[i].take()
            {
                child.kill();
                child.wait();
                self.nodes.restarting[i] = false;
            }
        }
        self.stopped = true;
        if let Some(tx) = self.tx.as_mut() {
            let _ = tx.flush();
        }
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let mut alive = 0;
            for c in self.nodes.children.iter_mut() {
                if let Some(child) = c {
                    match child.try_wait() {
                        Some(_) => *c = None,
                        None => alive += 1,
                    }
                }
            }
            if alive == 0 {
                break;
            }
            if Instant::now() > deadline {
                for (i, c) in self.nodes.children.iter_mut().enumerate() {
                    if let Some(child) = c {
                        child.kill();
                        child.wait();
                        self.nodes.dead[i] = true;
                    }
                    *c = None;
                }
                break;
            }
            // Keep draining so no node blocks on a full coordinator inbox.
            self.inbox.frames.clear();
            match self.tx.as_mut() {
                Some(tx) => {
                    let _ = tx.recv(&mut self.inbox.frames, Some(Duration::from_millis(10)));
                }
                None => std::thread::sleep(Duration::from_millis(10)),
            }
        }
        // Every node is reaped: the agents may go.
        if let Some(f) = &self.nodes.fleet {
            f.end(Duration::from_secs(2));
        }
    }
}

impl Drop for Processes {
    fn drop(&mut self) {
        self.shutdown();
        // Every node is reaped: nothing unread matters (a killed node's
        // frames used to hold the coordinator for a whole linger).
        if let Some(tx) = self.tx.as_mut() {
            tx.forget_unread(None);
        }
        // Close our own ports first: with no live process left in the run,
        // the cleanup also removes what killed children left behind.
        self.tx = None;
        if self.nodes.dead.iter().any(|&d| d) {
            let _ = crate::transport::cleanup_stale_resources();
        }
        if let Some((dir, true)) = &self.nodes.relaunch.checkpoints {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

impl Network for Processes {
    fn send(&mut self, node: u32, msg: &Control) -> Result<(), EngineError> {
        self.control(node, msg)
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        self.flush_all()
    }

    /// Reports as they arrive; a dead child or an interrupt is noticed within
    /// 50 ms.
    fn recv(&mut self, timeout: Option<Duration>, out: &mut Vec<Event>) -> Result<(), EngineError> {
        let deadline = timeout.map(|t| Instant::now() + t);
        loop {
            if self.interrupt.load(Ordering::SeqCst) {
                out.push(Event::Interrupted);
                return Ok(());
            }
            let mut slice = deadline.map_or(Duration::from_millis(50), |d| {
                d.saturating_duration_since(Instant::now())
                    .min(Duration::from_millis(50))
            });
            if let Some(due) = self.water.as_ref().and_then(Water::next_due) {
                slice = slice.min(due);
            }
            if let (Some(now), Some((sched, _, scale))) = (self.fault_now(), self.faults.as_ref())
                && let Some(next) = sched.next_at()
            {
                let wait = (next.as_secs_f64() - now).max(0.0);
                slice = slice.min(Duration::from_secs_f64((wait / scale).min(0.05)));
            }
            for x in self.receive(slice)? {
                match x {
                    CoordinatorInput::Report(r) => out.push(Event::Report(r)),
                    CoordinatorInput::Pong { node, seq } => out.push(Event::Pong { node, seq }),
                    CoordinatorInput::Ready { node } => self.ready(node),
                    CoordinatorInput::Timing { .. }
                    | CoordinatorInput::Channel { .. }
                    | CoordinatorInput::Late { .. }
                    | CoordinatorInput::Hops { .. } => {}
                }
            }
            self.pump()?;
            self.apply_faults()?;
            out.append(&mut self.inbox.events);
            let mut died = std::mem::take(&mut self.nodes.cut_at_startup);
            while let Some(d) = self.check_children() {
                died.push(d);
            }
            for (node, how) in died {
                if let Some(w) = &mut self.water {
                    w.set_dead(node);
                }
                self.fault_died(node);
                out.push(Event::NodeDied { node, how });
            }
            if !out.is_empty() || deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(());
            }
        }
    }

    fn log(&mut self, line: &str) {
        Processes::log(self, format_args!("{line}"));
    }

    /// SIGKILL and reap the node's process (it is stopped or wedged); it is
    /// dead from now on, and its death is not reported again.
    fn sample_done(&mut self, samples: usize) {
        if let Some((s, _, _)) = self.faults.as_mut() {
            s.sample_done(samples);
        }
        if let Some(w) = self.water.as_mut() {
            w.at_sample(samples);
        }
    }

    fn abandon(&mut self, node: u32) {
        let i = node as usize;
        self.fault_abandoned(node);
        if let Some(Some(child)) = self.nodes.children.get_mut(i) {
            child.kill();
            child.wait();
            Processes::log(
                self,
                format_args!("node {node} abandoned: killed and reaped"),
            );
        }
        if let Some(c) = self.nodes.children.get_mut(i) {
            *c = None;
        }
        if let Some(d) = self.nodes.dead.get_mut(i) {
            *d = true;
        }
        if let Some(w) = &mut self.water {
            w.set_dead(node);
        }
    }
}

/// Run `plan` on node processes, with logical or realtime clocks
/// ([`crate::protocol::Coordinator`] over [`Processes`]).
///
/// Realtime (`--clock realtime`, async): every node gossips on its own Poisson
/// clock; measurements arrive every sample period; at each sample boundary the
/// coordinator snapshots every live node's `theta`. A node that dies is left
/// out from then on, and the run continues while the remaining graph is
/// connected.
pub fn run_processes(
    plan: &RunPlan,
    real: Feed<'_>,
    opts: &ProcessOptions,
    progress: crate::engine::Progress<'_>,
) -> RunOutcome {
    let failed = |e| RunOutcome::failed(Driver::Processes, plan.n(), e);
    let layout = network_layout(plan);
    let needs = super::preflight::needs_of(&layout);
    if let Err(e) = super::preflight::check(&needs, &super::preflight::machine()) {
        return failed(EngineError::Resources(e));
    }
    super::preflight::raise_fd_limit(needs.coordinator_fds.max(needs.node_fds));
    // The run id is chosen first, so that a run that fails to start still
    // records the namespace it used.
    let run_id = match (&opts.run_id, &opts.transport) {
        (Some(id), _) => id.clone(),
        (None, crate::transport::TransportChoice::Zenoh(_)) => crate::transport::secret_run_id(),
        (None, crate::transport::TransportChoice::Iceoryx2) => crate::transport::unique_run_id(),
    };
    // The acoustic channel's water; on the ideal channel, a relay through
    // the coordinator when link faults are scheduled (the nodes cannot
    // apply them to each other) or pauses (a stopped node drains nothing:
    // the coordinator holds its frames, where a peer would wait on its full
    // inbox).
    let water = match &plan.channel {
        Some(c) => Some(Water::new(
            c,
            plan.seed,
            ChannelClock::start(c.cfg.time_scale),
        )),
        None if plan.faults.iter().any(|f| {
            f.kind.on_links() || matches!(f.kind, crate::model::fault::FaultKind::Pause { .. })
        }) =>
        {
            Some(Water::ideal(plan.n(), plan.seed, ChannelClock::start(1.0)))
        }
        None => None,
    };
    let spawned = Processes::spawn(run_id.clone(), layout, water, opts);
    let mut procs = match spawned {
        Ok(p) => p,
        Err(e) => {
            let mut out = failed(e);
            out.processes = Some(ProcessStats {
                run_id,
                ..Default::default()
            });
            return out;
        }
    };
    // The run's emulated time 0 is the start of the drive, as in the
    // discrete-event engine.
    let offset_s = procs.water.as_ref().map_or(0.0, |w| w.clock().now_s());
    procs.arm_faults(plan);
    let (rec, res) = crate::engine::drive(plan, real, &mut procs, progress);
    let samples = rec.thetas.len();
    let wall_seconds = rec.wall_seconds;
    let mut out = RunOutcome::new(Driver::Processes, rec, res);
    if !plan.faults.is_empty() {
        out.faults = Some(procs.take_faults(samples));
    }
    if let Some((messages, errors)) = procs.take_water(offset_s) {
        out.channel = Some(ChannelLog {
            messages,
            emulated_seconds: wall_seconds
                * plan.channel.as_ref().map_or(1.0, |c| c.cfg.time_scale),
            events: None,
            delivery_errors_ms: errors,
        });
    }
    out.processes = Some(ProcessStats {
        run_id: procs.run_id.clone(),
        startup_seconds: Some(procs.startup_seconds),
        timing: procs.timing.clone(),
        peak_rss_kib: procs.peak_rss_kib(),
        bad_frames: procs.inbox.bad.clone(),
    });
    procs.shutdown();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_node_program_is_a_typed_error_before_anything_is_created() {
        let opts = ProcessOptions {
            node_program: NodeProgram::binary("/nonexistent/sonarnet-node"),
            ..Default::default()
        };
        let layout = NetworkLayout {
            configs: vec![],
            neighbours: vec![],
            inbox: 8,
            broadcast: false,
            flood_frames_per_sample: 1024,
            peer_frames_per_sample: 64,
            budget_period: None,
        };
        let Err(e) = Processes::spawn("r".into(), layout, None, &opts) else {
            panic!("spawned without a node program");
        };
        assert_eq!(
            e,
            EngineError::NodeProgramMissing {
                path: "/nonexistent/sonarnet-node".into()
            }
        );
        assert!(e.to_string().contains("set SONARNET_NODE_BIN"), "{e}");
    }

    #[test]
    fn a_transport_failure_keeps_its_type_and_is_printed_once() {
        let t = TransportError::Closed(Endpoint::Node(3));
        let e = EngineError::Transport(t.clone());
        assert!(matches!(&e, EngineError::Transport(x) if *x == t));
        let report = crate::cli::error_report(&e);
        assert_eq!(report, format!("error: transport: {t}\n"));
    }
}
