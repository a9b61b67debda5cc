//! The coordinator logic, shared by both engines.
//!
//! [`drive`] runs a scenario over any [`Network`]: it sends each node its own
//! measurements, runs the sync rounds or hands out the async schedule, and
//! collects every node's `theta` at the end of every sample. The in-process
//! engine ([`inprocess::InProcess`]) implements [`Network`] with the
//! [`NodeCore`](crate::protocol::NodeCore)s in one thread; the multi-process
//! engine implements it over the transport. Both therefore run the same
//! coordinator and the same node core.

pub mod inprocess;
pub mod node;
pub mod processes;
pub mod threads;

use crate::geometry::Vec3;
use crate::protocol::{Command, Counters, NodeConfig, NodeMode, Report};
use crate::rng::{Stream, stream_rng};
use crate::scenario::{Mode, Realization, Scenario};
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::time::Instant;

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
    /// The run was interrupted (SIGINT/SIGTERM).
    #[error("interrupted at sample {sample}")]
    Interrupted {
        /// Sample.
        sample: u32,
    },
    /// Transport or process-management failure.
    #[error("transport: {0}")]
    Transport(String),
    /// The engine cannot run this combination (e.g. realtime clocks in-process).
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// Internal inconsistency (a bug): the protocol stalled.
    #[error("protocol stalled: {0}")]
    Stalled(String),
}

/// Where commands go and reports come from.
pub trait Network {
    /// Queue a command for node `node`.
    fn send(&mut self, node: u32, cmd: Command) -> Result<(), EngineError>;
    /// Deliver everything queued.
    fn flush(&mut self) -> Result<(), EngineError>;
    /// Block until at least one report is available; append them to `out`.
    fn recv(&mut self, out: &mut Vec<Report>) -> Result<(), EngineError>;
    /// The oldest sample not yet complete (errors such as a node death are
    /// attributed to it). Called by [`drive`] whenever it changes.
    fn working_on(&mut self, _sample: u32) {}
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
    pub timing: Vec<crate::codec::Timing>,
    /// Multi-process: seconds from spawning to all nodes ready.
    pub startup_seconds: Option<f64>,
    /// Multi-process: the run's IPC namespace.
    pub run_id: Option<String>,
    /// Multi-process: peak RSS (KiB) of every node process at the end of the run.
    pub peak_rss_kib: Vec<Option<u64>>,
    /// `--trace-iterations`: `(iteration, sample, node, theta)` for every node
    /// updated by every iteration (sync: every node every round), in order.
    pub iteration_trace: Vec<(u64, u32, u32, Vec3)>,
}

impl RunRecord {
    /// The nodes counted in `theta_bar` at sample `k`.
    pub fn alive_thetas(&self, k: usize) -> Vec<crate::geometry::Vec3> {
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

/// The configuration of node `id` in `scenario` (what the node is allowed to know).
pub fn node_config(sc: &Scenario, seed: u64, id: usize, mode: NodeMode) -> NodeConfig {
    NodeConfig {
        id: id as u32,
        n_nodes: sc.graph.len() as u32,
        anchor: sc.geometry.receivers[id],
        transmitters: sc.geometry.transmitters.clone(),
        neighbours: sc.graph.neighbours(id).iter().map(|&w| w as u32).collect(),
        omega: sc.measurements.omega,
        gamma: sc.algorithm.gamma,
        solver: sc.algorithm.local_solver,
        kappa: sc.algorithm.kappa,
        init_u: sc.algorithm.init_u,
        seed,
        mode,
        trace_iterations: sc.trace_iterations,
    }
}

/// The node mode of a logical-clock run.
pub fn logical_mode(mode: Mode) -> NodeMode {
    match mode {
        Mode::Sync => NodeMode::Sync,
        Mode::Async => NodeMode::AsyncLogical,
    }
}

/// Draws the async schedule: `v` uniform over nodes, `w` uniform over `v`'s
/// neighbours (seed 002 Sec. II-B), from the run's schedule stream; or replays
/// a given schedule.
pub struct Scheduler<'a> {
    sc: &'a Scenario,
    rng: crate::rng::SonarRng,
    next: usize,
}

impl<'a> Scheduler<'a> {
    /// A scheduler for a run with `seed`.
    pub fn new(sc: &'a Scenario, seed: u64) -> Self {
        Scheduler {
            sc,
            rng: stream_rng(seed, Stream::Schedule, 0),
            next: 0,
        }
    }

    /// The edge of the next iteration.
    pub fn next_pair(&mut self) -> (usize, usize) {
        let it = self.next;
        self.next += 1;
        if let Some((_, s)) = &self.sc.algorithm.schedule {
            return s[it];
        }
        let n = self.sc.graph.len();
        let v = self.rng.random_range(0..n);
        let nb = self.sc.graph.neighbours(v);
        let w = nb[self.rng.random_range(0..nb.len())];
        (v, w)
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

/// Run `scenario` with logical clocks over `net`. Returns the record of
/// everything completed and, if the run stopped early, why.
///
/// Up to [`LOOKAHEAD`] samples are in flight; the async schedule is drawn sample
/// by sample in order, exactly as without lookahead.
pub fn drive(
    sc: &Scenario,
    seed: u64,
    real: &Realization,
    net: &mut dyn Network,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let start = Instant::now();
    let n = sc.graph.len();
    let ips = sc.algorithm.iterations_per_sample;
    let mut rec = RunRecord {
        counters: vec![Counters::default(); n],
        ..Default::default()
    };
    let mut sched = Scheduler::new(sc, seed);
    let mut reports = Vec::new();
    let result = (|| {
        // thetas of the samples in flight, oldest first, with their count of reports.
        let mut in_flight: std::collections::VecDeque<(Vec<Option<Vec3>>, usize)> =
            std::collections::VecDeque::new();
        let mut sent = 0usize;
        let mut send_sample =
            |k: usize, net: &mut dyn Network, rec: &mut RunRecord| -> Result<(), EngineError> {
                let sample = k as u32;
                for (i, meas) in real.measurements[k].nodes.iter().enumerate() {
                    net.send(
                        i as u32,
                        Command::Sample {
                            sample,
                            meas: meas.clone(),
                        },
                    )?;
                }
                match sc.algorithm.mode {
                    Mode::Sync => {
                        for i in 0..n {
                            net.send(
                                i as u32,
                                Command::SyncRounds {
                                    sample,
                                    first_round: (k * ips) as u64,
                                    rounds: ips as u32,
                                },
                            )?;
                        }
                    }
                    Mode::Async => {
                        let mut steps: Vec<Vec<(u64, u32)>> = vec![Vec::new(); n];
                        for j in 0..ips {
                            let it = (k * ips + j) as u64;
                            let (v, w) = sched.next_pair();
                            rec.schedule.push((v, w));
                            steps[v].push((it, w as u32));
                            steps[w].push((it, v as u32));
                        }
                        for (i, s) in steps.into_iter().enumerate() {
                            net.send(i as u32, Command::AsyncPlan { sample, steps: s })?;
                        }
                    }
                }
                Ok(())
            };
        net.working_on(0);
        while sent < sc.samples.min(LOOKAHEAD) {
            send_sample(sent, net, &mut rec)?;
            in_flight.push_back((vec![None; n], 0));
            sent += 1;
        }
        net.flush()?;
        let mut completed = 0usize;
        while completed < sc.samples {
            reports.clear();
            net.recv(&mut reports)?;
            for r in reports.drain(..) {
                match r {
                    Report::SampleDone {
                        node,
                        sample: s,
                        theta,
                        counters,
                    } => {
                        let i = node as usize;
                        let Some(slot) = (s as usize)
                            .checked_sub(completed)
                            .and_then(|d| in_flight.get_mut(d))
                        else {
                            continue;
                        };
                        if i < n && slot.0[i].is_none() {
                            slot.0[i] = Some(theta);
                            slot.1 += 1;
                            // Reports of one node arrive in sample order.
                            rec.counters[i] = counters;
                        }
                    }
                    Report::IterationDone {
                        node,
                        iteration,
                        theta,
                    } if sc.trace_iterations => rec.iteration_trace.push((
                        iteration,
                        (iteration / ips.max(1) as u64) as u32,
                        node,
                        theta,
                    )),
                    Report::Failed {
                        node,
                        sample,
                        reason,
                    } => {
                        return Err(EngineError::NodeFailed {
                            node,
                            sample,
                            reason,
                        });
                    }
                    _ => {}
                }
            }
            let mut advanced = false;
            while in_flight.front().is_some_and(|(_, done)| *done == n) {
                let Some((thetas, _)) = in_flight.pop_front() else {
                    break;
                };
                rec.thetas
                    .push(thetas.into_iter().map(|t| t.unwrap_or_default()).collect());
                completed += 1;
                rec.iterations += ips as u64;
                progress(completed, rec.iterations);
                if sent < sc.samples {
                    send_sample(sent, net, &mut rec)?;
                    in_flight.push_back((vec![None; n], 0));
                    sent += 1;
                }
                advanced = true;
            }
            if advanced {
                net.working_on(completed as u32);
                net.flush()?;
            }
        }
        Ok(())
    })();
    if result.is_err() {
        // As without lookahead: the schedule of the completed samples and of the one
        // in progress, not of the samples sent ahead.
        let keep = ((rec.thetas.len() + 1) * ips).min(rec.schedule.len());
        rec.schedule.truncate(keep);
    }
    if sc.trace_iterations {
        // Arrival order differs between engines; the file is ordered.
        rec.iteration_trace.sort_by_key(|e| (e.0, e.2));
        // Iterations of samples that did not complete are not part of the record.
        let done = rec.thetas.len() as u32;
        rec.iteration_trace.retain(|e| e.1 < done);
    }
    rec.wall_seconds = start.elapsed().as_secs_f64();
    (rec, result)
}

/// Run `sc` in-process.
pub fn run_inprocess(
    sc: &Scenario,
    real: &Realization,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let mode = logical_mode(sc.algorithm.mode);
    let configs = (0..sc.graph.len())
        .map(|i| node_config(sc, sc.seed, i, mode))
        .collect();
    let mut net = inprocess::InProcess::new(configs);
    drive(sc, sc.seed, real, &mut net, progress)
}

/// Which engine runs the nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EngineKind {
    /// All nodes in one thread of this process.
    Inprocess,
    /// One `sonarnet-node` OS process per receiver, over iceoryx2.
    Processes,
    /// One thread per node in this process, over the in-memory transport
    /// ([`threads`]): the node program's loop without processes.
    Threads,
}

impl EngineKind {
    /// Name as written to outputs.
    pub fn as_str(self) -> &'static str {
        match self {
            EngineKind::Inprocess => "inprocess",
            EngineKind::Processes => "processes",
            EngineKind::Threads => "threads",
        }
    }
}

/// How a run is clocked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Clock {
    /// The coordinator sequences rounds/iterations; results are exact.
    Logical,
    /// Free-running nodes on Poisson clocks (multi-process async only).
    Realtime,
}

/// The one entry point of the engines: run `sc` on `real` with the engine
/// `kind` and clock `clock` (`popts` applies to node processes only).
/// Realtime clocks need node processes; asking for them on another engine is
/// an error before anything starts.
pub fn run(
    sc: &Scenario,
    real: &Realization,
    kind: EngineKind,
    clock: Clock,
    popts: &processes::ProcessOptions,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    match (kind, clock) {
        (EngineKind::Inprocess, Clock::Logical) => run_inprocess(sc, real, progress),
        (EngineKind::Threads, Clock::Logical) => threads::run_threads(sc, real, progress),
        (EngineKind::Processes, Clock::Logical) => {
            let (rec, res, _) = processes::run_logical(sc, real, popts, progress);
            (rec, res)
        }
        (EngineKind::Processes, Clock::Realtime) => {
            let (rec, res, _) = processes::run_realtime(sc, real, popts, progress);
            (rec, res)
        }
        (other, Clock::Realtime) => (
            RunRecord {
                counters: vec![Counters::default(); sc.graph.len()],
                ..Default::default()
            },
            Err(EngineError::Unsupported(format!(
                "realtime clocks need the processes engine, not {}",
                other.as_str()
            ))),
        ),
    }
}
