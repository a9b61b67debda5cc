//! The engines: one coordinator, many ways to run the nodes.
//!
//! A run is a [`RunPlan`] (built once from a scenario) on a
//! [`Realization`]. The I/O-free [`Coordinator`] turns events into actions;
//! [`drive`] is its driver over any [`Network`]: the in-process engine
//! ([`inprocess::InProcess`]) implements [`Network`] with the
//! [`NodeCore`](crate::protocol::NodeCore)s in one thread, the threads engine
//! ([`threads`]) with node threads over the in-memory transport, and the
//! multi-process engine ([`processes`]) with node processes over iceoryx2;
//! the discrete-event engine ([`des`]) runs realtime clocks in virtual time.
//! All of them run the same coordinator and the same node core; [`run`] is
//! the one entry point.

pub mod actions;
pub mod agent;
pub mod checkpoint;
pub mod config;
pub mod coordinator;
pub mod des;
pub mod inprocess;
pub mod interrupt;
pub mod layout;
pub mod node;
pub mod plan;
pub mod preflight;
pub mod processes;
pub mod threads;
pub mod water;

pub use actions::Actuator;
pub use config::{Driver, Key, LONG_WALL_S, Refused, RunConfig, TransportKind};
pub use coordinator::{Action, Coordinator, Event, Timer};
pub use plan::{ChannelPlan, RealtimePlan, RunPlan, Scheduler};

use crate::model::geometry::Vec3;
use crate::model::synth::Realization;
use crate::protocol::Counters;
use crate::protocol::codec::Control;
use std::time::{Duration, Instant};

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// A node could not compute its prox.
    #[error("node {node} failed at sample {sample}: {reason}")]
    NodeFailed {
        /// Node id.
        node: u32,
        /// Sample.
        sample: u32,
        /// Reason.
        reason: String,
    },
    /// A node process died.
    #[error("node {node} died ({how}) at sample {sample}")]
    NodeDied {
        /// Node id.
        node: u32,
        /// Sample.
        sample: u32,
        /// Exit status or signal.
        how: String,
    },
    /// Nodes did not answer a liveness check (logical clocks): stopped
    /// (`kill -STOP`), or wedged.
    #[error(
        "{} not responding (stopped?) at sample {sample}: no report for {:.1} s and no answer to a liveness check",
        names(nodes),
        silent_for.as_secs_f64()
    )]
    NotResponding {
        /// The silent nodes.
        nodes: Vec<u32>,
        /// The oldest sample not complete.
        sample: u32,
        /// How long nothing had come from any node.
        silent_for: Duration,
    },
    /// The run was interrupted (SIGINT/SIGTERM).
    #[error("interrupted at sample {sample}")]
    Interrupted {
        /// Sample.
        sample: u32,
    },
    /// The transport failed (its error is part of this message, not a
    /// separate cause, so that it is printed once).
    #[error("transport: {0}")]
    Transport(crate::transport::TransportError),
    /// A frame from a node could not be decoded.
    #[error("bad frame: {0}")]
    BadFrame(crate::protocol::codec::DecodeError),
    /// The coordinator's transport was already closed.
    #[error("the coordinator's transport is closed")]
    TransportClosed,
    /// The node program does not exist.
    #[error(
        "node program {} not found (build it with `cargo build --release`, or set SONARNET_NODE_BIN)",
        path.display()
    )]
    NodeProgramMissing {
        /// Where it was looked for.
        path: std::path::PathBuf,
    },
    /// A node process could not be started.
    #[error("cannot start {} for node {node}: {reason}", program.display())]
    Spawn {
        /// The node.
        node: u32,
        /// The program.
        program: std::path::PathBuf,
        /// The operating system's reason.
        reason: String,
    },
    /// A node's launch configuration could not be encoded.
    #[error("cannot encode the launch configuration of node {node}: {reason}")]
    Launch {
        /// The node.
        node: u32,
        /// The encoder's reason.
        reason: String,
    },
    /// The start gate of the node processes could not be set up
    /// ([`processes::wait_at_gate`]).
    #[error("cannot set up the start gate of the node processes: {0}")]
    StartGate(String),
    /// The directory of the nodes' checkpoint files could not be created.
    #[error("cannot create the checkpoint directory {}: {reason}", dir.display())]
    Checkpoints {
        /// The directory.
        dir: std::path::PathBuf,
        /// The I/O error.
        reason: String,
    },
    /// The agents of some hosts of a placement did not connect in time.
    #[error(
        "no agent connected for host(s) {} within {waited:?}: start `sonarnet agent --connect tcp/<this host>:<port> --run-id {run_id} --host <name>` there (the coordinator listens on {listen})",
        missing.join(", ")
    )]
    AgentsMissing {
        /// The hosts without an agent.
        missing: Vec<String>,
        /// How long the coordinator waited.
        waited: Duration,
        /// The run id the agents must give.
        run_id: String,
        /// The coordinator's endpoints.
        listen: String,
    },
    /// Nodes did not report READY in time.
    #[error("nodes {missing:?} did not come up within {waited:?}")]
    Startup {
        /// The nodes that never reported.
        missing: Vec<u32>,
        /// How long the coordinator waited.
        waited: Duration,
    },
    /// This machine cannot hold the run ([`preflight`]): the key most to
    /// blame and the reason with the numbers. Found before anything starts.
    #[error("{key}: {reason}")]
    Resources {
        /// The scenario key.
        key: &'static str,
        /// What is needed and what there is.
        reason: String,
    },
    /// The engine cannot run this combination (e.g. realtime clocks in-process).
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// The run cannot be what it was asked to be ([`RunConfig::resolve`]).
    #[error("{0}")]
    Refused(#[from] Refused),
    /// Internal inconsistency (a bug): the protocol stalled.
    #[error("protocol stalled: {0}")]
    Stalled(String),
}

/// `node 3 is` / `nodes 3, 4 are`.
fn names(nodes: &[u32]) -> String {
    let list: Vec<String> = nodes.iter().map(u32::to_string).collect();
    match nodes.len() {
        1 => format!("node {} is", list[0]),
        _ => format!("nodes {} are", list.join(", ")),
    }
}

/// Where the coordinator's messages go and the nodes' events come from.
pub trait Network {
    /// Queue a message for node `node`.
    fn send(&mut self, node: u32, msg: &Control) -> Result<(), EngineError>;
    /// Deliver everything queued.
    fn flush(&mut self) -> Result<(), EngineError>;
    /// Wait until at least one event is available, or `timeout` has passed
    /// (`None`: no limit); append the events to `out`.
    fn recv(&mut self, timeout: Option<Duration>, out: &mut Vec<Event>) -> Result<(), EngineError>;
    /// A line of the coordinator's verbose log.
    fn log(&mut self, _line: &str) {}
    /// The coordinator gave up on `node` ([`Action::Abandon`]): make sure it
    /// is gone (a node process is killed and reaped). Nothing by default.
    fn abandon(&mut self, _node: u32) {}
    /// `samples` samples are complete ([`Action::Progress`]). Nothing by
    /// default.
    fn sample_done(&mut self, _samples: usize) {}
}

/// What a run produced, complete or not.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunRecord {
    /// `thetas[k][i]`: node `i`'s `theta` after sample `k` (only completed samples).
    pub thetas: Vec<Vec<Vec3>>,
    /// The async schedule used, `(v, w)` per iteration (empty in sync mode).
    pub schedule: Vec<(usize, usize)>,
    /// DR iterations completed (rounds in sync mode).
    pub iterations: u64,
    /// Final per-node counters.
    pub counters: Vec<Counters>,
    /// Wall time of the run (seconds).
    pub wall_seconds: f64,
    /// `alive[k][i]`: node `i` was alive at the end of sample `k` (empty when
    /// no node ever died). Dead nodes are left out of `theta_bar`.
    pub alive: Vec<Vec<bool>>,
    /// Realtime: DR exchanges completed during each sample.
    pub iterations_per_sample: Vec<u64>,
    /// Nodes that died, with the sample at which the coordinator noticed.
    pub deaths: Vec<(u32, u32, String)>,
    /// Multi-process: per-node busy/wait time split.
    pub timing: Vec<crate::protocol::codec::Timing>,
    /// Multi-process: seconds from spawning to all nodes ready.
    pub startup_seconds: Option<f64>,
    /// Multi-process: the run's IPC namespace.
    pub run_id: Option<String>,
    /// Multi-process: peak RSS (KiB) of every node process at the end of the run.
    pub peak_rss_kib: Vec<Option<u64>>,
    /// `--trace-iterations`: `(iteration, sample, node, theta)` for every node
    /// updated by every iteration (sync: every node every round), in order.
    pub iteration_trace: Vec<(u64, u32, u32, Vec3)>,
    /// Acoustic channel: every frame between two nodes, in the order sent
    /// (`messages.csv`; empty on the ideal channel).
    pub messages: Vec<crate::world::medium::MessageRecord>,
    /// Acoustic channel: the emulated time the run covered, seconds.
    pub emulated_seconds: Option<f64>,
    /// Discrete-event engine: events handled (node ticks, deliveries, frame
    /// judgements, coordinator timers and reports).
    pub events: Option<u64>,
    /// Processes engine on the acoustic channel: every delivered frame's
    /// realised error, forwarded minus planned end of arrival (emulated ms).
    pub delivery_errors_ms: Vec<f64>,
    /// Faults: every fault applied, in the order applied.
    pub faults: Vec<crate::world::faults::FaultRecord>,
    /// Faults: which nodes were paused at the end of each completed sample
    /// (empty without faults).
    pub paused: Vec<Vec<bool>>,
    /// What ran the nodes ([`run`] sets it).
    pub driver: Option<Driver>,
}

impl RunRecord {
    /// The nodes counted in `theta_bar` at sample `k`.
    pub fn alive_thetas(&self, k: usize) -> Vec<crate::model::geometry::Vec3> {
        match self.alive.get(k) {
            Some(mask) => self.thetas[k]
                .iter()
                .zip(mask)
                .filter(|(_, a)| **a)
                .map(|(t, _)| *t)
                .collect(),
            None => self.thetas[k].clone(),
        }
    }

    /// Total prox solves over all nodes.
    pub fn prox_solves(&self) -> u64 {
        self.counters.iter().map(|c| c.prox_solves).sum()
    }
}

/// Progress callback: `(samples done, iterations done)`.
pub type Progress<'a> = &'a mut dyn FnMut(usize, u64);

/// How many samples the coordinator keeps in flight: it sends the commands of
/// sample `k + LOOKAHEAD - 1` as soon as sample `k` is complete, so nodes that finish
/// a sample early go straight on with the next one instead of waiting for the
/// slowest node and a round trip to the coordinator. Nodes run queued samples in
/// order ([`NodeCore::handle`](crate::protocol::NodeCore::handle)), so the results
/// do not depend on it.
pub const LOOKAHEAD: usize = 3;

/// Run `plan` on `real` over `net`: the driver of the [`Coordinator`] under
/// the wall clock. Returns the record of everything completed and, if the run
/// stopped early, why.
pub fn drive(
    plan: &RunPlan,
    real: &Realization,
    net: &mut dyn Network,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let start = Instant::now();
    // The coordinator's clock: emulated time on the acoustic channel
    // (`channel.time_scale` emulated seconds per wall second), else wall time.
    let scale = plan.channel.as_ref().map(|c| c.cfg.time_scale);
    let to_coord = |wall: Duration| scale.map_or(wall, |s| wall.mul_f64(s));
    let to_wall = |coord: Duration| scale.map_or(coord, |s| coord.div_f64(s));
    let mut coord = Coordinator::new(plan, real);
    let mut actions = Vec::new();
    let mut events = Vec::new();
    let mut wired = Wired {
        net,
        timers: Vec::new(),
    };
    coord.handle(Duration::ZERO, [Event::Start], &mut actions);
    let result = loop {
        if let Some(r) = actions::carry_out(&mut actions, &mut wired, progress) {
            break r;
        }
        if coord.is_done() {
            break Ok(());
        }
        let timers = &mut wired.timers;
        timers.sort_by_key(|t| t.0);
        let timeout = timers
            .first()
            .map(|(at, _)| to_wall(at.saturating_sub(to_coord(start.elapsed()))));
        if let Err(e) = wired.net.recv(timeout, &mut events) {
            break Err(e);
        }
        let now = to_coord(start.elapsed());
        let due = timers.partition_point(|(at, _)| *at <= now);
        events.extend(timers.drain(..due).map(|(_, t)| Event::Timer(t)));
        coord.handle(now, events.drain(..), &mut actions);
    };
    let mut rec = coord.into_record(result.is_err());
    rec.wall_seconds = start.elapsed().as_secs_f64();
    (rec, result)
}

/// The coordinator's actions on a [`Network`], with the coordinator's
/// timers kept here until they are due.
struct Wired<'n> {
    net: &'n mut dyn Network,
    timers: Vec<(Duration, Timer)>,
}

impl Actuator for Wired<'_> {
    fn send(&mut self, node: u32, msg: Control) -> Result<(), EngineError> {
        self.net.send(node, &msg)
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        self.net.flush()
    }

    fn set_timer(&mut self, at: Duration, timer: Timer) {
        self.timers.push((at, timer));
    }

    fn sample_done(&mut self, samples: usize) {
        self.net.sample_done(samples);
    }

    fn log(&mut self, line: &str) {
        self.net.log(line);
    }

    fn abandon(&mut self, node: u32) {
        self.net.abandon(node);
    }
}

/// Run `plan` in-process; SIGINT/SIGTERM ([`interrupt`]) end it with
/// [`EngineError::Interrupted`] and the samples completed.
pub fn run_inprocess(
    plan: &RunPlan,
    real: &Realization,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let mut net = inprocess::InProcess::new(plan.nodes.clone()).with_interrupt(interrupt::flag());
    drive(plan, real, &mut net, progress)
}

crate::named_enum! {
    /// Which engine runs the nodes ([`inprocess`], [`des`], [`processes`],
    /// [`threads`]).
    pub enum EngineKind {
        /// All nodes in one thread of this process (in virtual time for
        /// realtime clocks and the acoustic channel).
        Inprocess = "inprocess",
        /// One `sonarnet-node` OS process per receiver, over iceoryx2.
        Processes = "processes",
        /// One thread per node in this process, over the in-memory transport.
        Threads = "threads",
    }
}

crate::named_enum! {
    /// How a run is clocked.
    pub enum Clock {
        /// The coordinator sequences rounds/iterations; results are exact.
        Logical = "logical",
        /// Free-running nodes on Poisson clocks (async only): in wall time on
        /// node processes, in virtual time in-process.
        Realtime = "realtime",
    }
}

/// The one entry point of the engines: run `plan` on `real` on the engine
/// its [`RunConfig`] chose (`popts` applies to node processes only): logical
/// clocks on the ideal channel on the in-process, threads or processes
/// engine; realtime clocks and the acoustic channel in-process in virtual
/// time ([`des`]) or on node processes in wall time.
pub fn run(
    plan: &RunPlan,
    real: &Realization,
    popts: &processes::ProcessOptions,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let driver = plan.driver();
    let (mut rec, res) = match driver {
        Driver::LockStep => run_inprocess(plan, real, progress),
        Driver::DiscreteEvent => des::run_des(plan, real, progress),
        // `RunConfig::resolve` refuses these before a plan exists.
        Driver::Threads if plan.clock != Clock::Logical || plan.channel.is_some() => (
            RunRecord::empty(plan.n()),
            Err(EngineError::Unsupported(
                "the threads engine runs logical clocks on the ideal channel".into(),
            )),
        ),
        Driver::Threads => threads::run_threads(plan, real, progress),
        Driver::Processes => processes::run_processes(plan, real, popts, progress),
    };
    rec.driver = Some(driver);
    (rec, res)
}
