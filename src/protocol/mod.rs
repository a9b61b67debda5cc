//! The I/O-free protocol of a run: the Douglas-Rachford core of one receiver
//! node ([`NodeCore`]), the coordinator that drives a run ([`Coordinator`],
//! built from a [`RunPlan`] that [`RunConfig::resolve`] admitted, recording a
//! [`RunRecord`]), and their messages as frames ([`codec`]).
//!
//! In the manner of stateright's `Actor` and quinn-proto, a [`NodeCore`] takes
//! one input (a coordinator command, a peer message or a clock tick) and
//! returns what to send. It never touches a socket, a clock or a thread. The
//! in-process engine and the `sonarnet-node` processes drive the very same
//! core, so both compute bit-identical states.
//!
//! The math (Mourya 2017 eq. 11 and Sec. II-B):
//! * prox step: `theta_i = prox_{gamma f_i}(u_i)`, reflected point `r_i = 2 theta_i - u_i`;
//! * consensus: `z_i = (a, r_i[2])` where `a` averages the position parts of
//!   the reflected points of the communicating nodes (the pair `{v, w}` in
//!   async mode, every node in sync mode, summed in node-id order);
//! * update: `u_i += z_i - theta_i`.
//!
//! Sync rounds gather at one node, [`SYNC_ROOT`] (node 0): every other node sends its
//! reflected point of round `k` to the root, which averages all `n` of them in node-id
//! order and broadcasts the mean ([`PeerMsg::Average`]). That is one message per node
//! and one broadcast per round (instead of every node broadcasting to every node),
//! and a waiting node is woken once per round. The root is a receiver like any other;
//! the coordinator never computes node states.

pub mod codec;
pub mod config;
pub mod coordinator;
pub mod error;
pub mod local;
mod messages;
pub mod plan;
pub mod record;
pub mod words;

pub use config::{Clock, Driver, EngineKind, Key, LONG_WALL_S, Refused, RunConfig, TransportKind};
pub use coordinator::{Action, Coordinator, Event, LOOKAHEAD, Timer};
pub use error::EngineError;
pub use messages::{Command, Counters, Input, NodeConfig, NodeMode, Output, PeerMsg, Report};
pub use plan::{ChannelPlan, RealtimePlan, RunPlan, Scheduler};
pub use record::RunRecord;

use crate::estimators::gossip::{dr_update, mean_position, pair_average};
use crate::estimators::prox::gtrs::ProxError;
use crate::model::coords::Coords;
use crate::model::rng::{SonarRng, Stream, stream_rng};
use local::LocalStep;
use rand::RngExt;
use std::collections::{BTreeMap, VecDeque};

/// The node that gathers the reflected points of every sync round and sends their
/// mean back to all nodes ([`PeerMsg::Average`]).
pub const SYNC_ROOT: u32 = 0;

#[derive(Debug, Clone)]
struct SyncState {
    sample: u32,
    round: u64,
    last_round: u64,
    /// Own theta and r of the current round, once computed.
    mine: Option<(Coords, Coords)>,
    /// Received reflected points, by round, by sender.
    received: BTreeMap<u64, Vec<Option<Coords>>>,
}

#[derive(Debug, Clone)]
struct AsyncState {
    sample: u32,
    steps: VecDeque<(u64, u32)>,
    /// Own theta and r of the head step, once computed.
    mine: Option<(Coords, Coords)>,
}

#[derive(Debug, Clone, Copy)]
struct Exchange {
    partner: u32,
    seq: u64,
    theta: Coords,
    r: Coords,
}

/// The protocol state machine of one receiver node.
#[derive(Debug, Clone)]
pub struct NodeCore {
    cfg: NodeConfig,
    problem: LocalStep,
    u: Coords,
    theta: Coords,
    sample: u32,
    counters: Counters,
    sync: Option<SyncState>,
    plan: Option<AsyncState>,
    /// Async-logical reflected points that arrived before this node reached
    /// that iteration, keyed by iteration.
    early: BTreeMap<u64, Coords>,
    /// Root: sync reflected points that arrived before the SyncRounds command.
    early_sync: BTreeMap<u64, Vec<Option<Coords>>>,
    /// Other nodes: consensus averages from the root not yet used, by round.
    averages: BTreeMap<u64, Coords>,
    exchange: Option<Exchange>,
    exchange_seq: u64,
    alive: Vec<u32>,
    rng: SonarRng,
    /// Sample, sync-rounds and plan commands that arrived while the node was still
    /// working on an earlier sample (the coordinator may send several samples ahead);
    /// run in order once that sample is done.
    queued: VecDeque<Command>,
    /// A sample has been received (`first_fix` starts from the first).
    started: bool,
    /// The last sync round or async-logical iteration this node is done
    /// with: what arrives for it or an earlier one is late
    /// ([`Counters::late`]).
    last_done: Option<u64>,
}

/// Most sample, sync-rounds and plan commands a busy node keeps queued. The
/// coordinator sends at most [`LOOKAHEAD`] samples ahead, two
/// commands each; past this bound a command is a flood, dropped and counted
/// in [`Counters::bad_frames`].
pub const MAX_QUEUED: usize = 64;

impl NodeCore {
    /// A node restarted from its checkpoint ([`Output::Checkpoint`]): `u` and
    /// `theta` as saved, no measurements yet (the coordinator sends the
    /// current sample's).
    pub fn restore(cfg: NodeConfig, u: Coords, theta: Coords) -> NodeCore {
        let mut n = NodeCore::new(cfg);
        n.u = u;
        n.theta = theta;
        // Its first sample must not overwrite the restored state.
        n.started = true;
        n
    }

    /// A node in its initial state: `u = theta = init_u`, no measurements yet.
    pub fn new(cfg: NodeConfig) -> NodeCore {
        let rng = stream_rng(cfg.seed, Stream::NodeClock, cfg.id as u64);
        NodeCore {
            problem: LocalStep::new(&cfg),
            u: cfg.init_u,
            theta: cfg.init_u,
            sample: 0,
            counters: Counters::default(),
            sync: None,
            plan: None,
            early: BTreeMap::new(),
            early_sync: BTreeMap::new(),
            averages: BTreeMap::new(),
            exchange: None,
            exchange_seq: 0,
            alive: cfg.neighbours.clone(),
            rng,
            queued: VecDeque::new(),
            started: false,
            last_done: None,
            cfg,
        }
    }

    /// True while the node is running a sample's sync rounds or async plan.
    pub fn busy(&self) -> bool {
        self.sync.is_some() || self.plan.is_some()
    }

    /// Samples received and not started yet (the coordinator sends up to
    /// [`LOOKAHEAD`] ahead): while there is one,
    /// the node has work after the sample it is on.
    pub fn samples_queued(&self) -> usize {
        self.queued
            .iter()
            .filter(|c| matches!(c, Command::Sample { .. }))
            .count()
    }

    /// This node's id.
    pub fn id(&self) -> u32 {
        self.cfg.id
    }

    /// The run's dimension, 2 or 3 ([`NodeConfig::dim`]).
    pub fn dim(&self) -> usize {
        self.cfg.dim()
    }

    /// Current `theta`.
    pub fn theta(&self) -> Coords {
        self.theta
    }

    /// Current `u`.
    pub fn u(&self) -> Coords {
        self.u
    }

    /// Counters so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// A frame addressed to this node did not decode and was dropped (the
    /// node loop's decoder found it bad): counted in
    /// [`Counters::bad_frames`], reported with the other counters.
    pub fn note_bad_frame(&mut self) {
        self.counters.bad_frames += 1;
    }

    /// Neighbours still considered alive.
    pub fn live_neighbours(&self) -> &[u32] {
        &self.alive
    }

    /// Draw the time to the next realtime wake-up (seconds), exponential with
    /// rate `rate_hz`, from the node's own clock stream.
    pub fn draw_wait(&mut self, rate_hz: f64) -> f64 {
        let u: f64 = self.rng.random_range(f64::EPSILON..1.0);
        -u.ln() / rate_hz
    }

    fn prox_step(&mut self) -> Result<(Coords, Coords), ProxError> {
        let solver = self.cfg.solver.with_kappa(self.cfg.kappa);
        let theta = self.problem.prox(solver, &self.u, self.cfg.gamma)?;
        self.counters.prox_solves += 1;
        let r = theta.reflect(&self.u);
        Ok((theta, r))
    }

    fn failed(&self, e: ProxError) -> Output {
        Output::Report(Report::Failed {
            node: self.cfg.id,
            sample: self.sample,
            failure: e.kind(),
            reason: e.to_string(),
        })
    }

    fn sample_done(&self, sample: u32) -> Output {
        Output::Report(Report::SampleDone {
            node: self.cfg.id,
            sample,
            theta: self.theta,
            counters: self.counters,
        })
    }

    /// Handle one input; append what to send to `out`.
    ///
    /// `Sample`, `SyncRounds` and `AsyncPlan` commands that arrive while the node is
    /// [`busy`](Self::busy) with an earlier sample are queued and run, in order, as
    /// soon as that sample is done, so the coordinator may send samples ahead without
    /// changing any result.
    pub fn handle(&mut self, input: Input, out: &mut Vec<Output>) {
        match input {
            Input::Command(c) => {
                let sequenced = matches!(
                    c,
                    Command::Sample { .. } | Command::SyncRounds { .. } | Command::AsyncPlan { .. }
                );
                if sequenced && (self.busy() || !self.queued.is_empty()) {
                    if self.queued.len() < MAX_QUEUED {
                        self.queued.push_back(c);
                    } else {
                        // A flood of commands: dropped, and counted.
                        self.counters.bad_frames += 1;
                    }
                } else {
                    self.on_command(c, out);
                }
            }
            Input::Peer(m) => {
                // The sync root's broadcast comes back to it; that loopback
                // copy is not a message from a peer, and when it arrives
                // relative to the round's end is up to the transport.
                if m.from() != self.cfg.id {
                    self.counters.messages_in += 1;
                }
                self.on_peer(m, out)
            }
        }
        while !self.busy() {
            let Some(c) = self.queued.pop_front() else {
                break;
            };
            self.on_command(c, out);
        }
    }

    fn on_command(&mut self, c: Command, out: &mut Vec<Output>) {
        match c {
            Command::Sample {
                sample,
                mut meas,
                sigmas,
            } => {
                self.sample = sample;
                // A frame of the wire may name a transmitter this run does
                // not have, or carry a non-finite value: neither reaches the
                // cost.
                meas.retain_valid(self.cfg.transmitters.len());
                let sigmas = sigmas.valid();
                self.problem.build(&self.cfg, sample, &meas, &sigmas);
                if self.cfg.first_fix && !self.started {
                    self.u = self.problem.first_fix();
                    self.theta = self.u;
                }
                self.started = true;
                if let Some(m) = self.cfg.checkpoint_every
                    && m > 0
                    && sample % m == 0
                {
                    out.push(Output::Checkpoint {
                        sample,
                        u: self.u,
                        theta: self.theta,
                    });
                }
            }
            Command::SyncRounds {
                sample,
                first_round,
                rounds,
            } => {
                if rounds == 0 {
                    out.push(self.sample_done(sample));
                    return;
                }
                let mut st = SyncState {
                    sample,
                    round: first_round,
                    // A command's numbers come off the wire: no overflow.
                    last_round: first_round.saturating_add(u64::from(rounds) - 1),
                    mine: None,
                    received: BTreeMap::new(),
                };
                // Rounds whose messages arrived before this command.
                let later = self.early_sync.split_off(&first_round);
                st.received = later;
                self.sync = Some(st);
                self.sync_start_round(out);
            }
            Command::AsyncPlan { sample, steps } => {
                self.plan = Some(AsyncState {
                    sample,
                    steps: steps.into(),
                    mine: None,
                });
                self.async_advance(out);
            }
            Command::Tick => self.start_exchange(out),
            Command::ExchangeTimeout { seq } => {
                if matches!(self.exchange, Some(ex) if ex.seq == seq) {
                    self.exchange = None;
                    self.counters.timeouts += 1;
                }
            }
            Command::RoundTimeout { seq } => match self.cfg.mode {
                NodeMode::Sync => {
                    if self
                        .sync
                        .as_ref()
                        .is_some_and(|st| st.round == seq && st.mine.is_some())
                    {
                        self.sync_try_finish(true, out);
                    }
                }
                NodeMode::AsyncLogical => self.async_timeout(seq, out),
                NodeMode::Realtime => {}
            },
            Command::Snapshot { sample } => out.push(Output::Report(Report::Snapshot {
                node: self.cfg.id,
                sample,
                theta: self.theta,
                counters: self.counters,
            })),
            Command::NodeUp { node } => {
                if self.cfg.neighbours.contains(&node) && !self.alive.contains(&node) {
                    self.alive.push(node);
                    self.alive.sort_unstable();
                }
            }
            Command::NodeDown { node } => {
                self.alive.retain(|&w| w != node);
                if matches!(self.exchange, Some(ex) if ex.partner == node) {
                    self.exchange = None;
                    self.counters.declines += 1;
                }
            }
        }
    }

    fn on_peer(&mut self, m: PeerMsg, out: &mut Vec<Output>) {
        match m {
            PeerMsg::Reflect { from, seq, r } => match self.cfg.mode {
                NodeMode::Sync => {
                    let n = self.cfg.n_nodes as usize;
                    if from as usize >= n || self.cfg.id != SYNC_ROOT {
                        return;
                    }
                    let past = self.is_past(seq);
                    match &mut self.sync {
                        Some(st) if seq >= st.round && seq <= st.last_round => {
                            st.received.entry(seq).or_insert_with(|| vec![None; n])
                                [from as usize] = Some(r);
                            self.sync_try_finish(false, out);
                        }
                        // A round averaged at its timeout without it.
                        _ if past => self.counters.late += 1,
                        // A round of the next sample, sent by a faster node
                        // before this node got its SyncRounds command.
                        _ => {
                            self.early_sync.entry(seq).or_insert_with(|| vec![None; n])
                                [from as usize] = Some(r);
                        }
                    }
                }
                NodeMode::AsyncLogical | NodeMode::Realtime => {
                    if self.is_past(seq) {
                        // An iteration given up at its timeout.
                        self.counters.late += 1;
                    } else {
                        self.early.insert(seq, r);
                        self.async_advance(out);
                    }
                }
            },
            PeerMsg::Average { seq, a, .. } => {
                // The root ignores the loopback copy of its own broadcast.
                if self.cfg.mode == NodeMode::Sync && self.cfg.id != SYNC_ROOT {
                    if self.is_past(seq) {
                        // A round this node gave up at its timeout.
                        self.counters.late += 1;
                    } else {
                        self.averages.insert(seq, a);
                        self.sync_try_finish(false, out);
                    }
                }
            }
            PeerMsg::Request { from, seq, r } => {
                if self.exchange.is_some() {
                    self.counters.messages_out += 1;
                    out.push(Output::Peer {
                        to: from,
                        msg: PeerMsg::Decline {
                            from: self.cfg.id,
                            seq,
                        },
                    });
                    return;
                }
                match self.prox_step() {
                    Ok((theta, r_mine)) => {
                        let a = pair_average(&r, &r_mine);
                        self.theta = theta;
                        dr_update(&mut self.u, &theta, &r_mine, a);
                        self.counters.updates += 1;
                        self.counters.messages_out += 1;
                        out.push(Output::Peer {
                            to: from,
                            msg: PeerMsg::Accept {
                                from: self.cfg.id,
                                seq,
                                r: r_mine,
                            },
                        });
                    }
                    Err(e) => out.push(self.failed(e)),
                }
            }
            PeerMsg::Accept { from, seq, r } => {
                if let Some(ex) = self.exchange
                    && ex.partner == from
                    && ex.seq == seq
                {
                    let a = pair_average(&ex.r, &r);
                    self.theta = ex.theta;
                    dr_update(&mut self.u, &ex.theta, &ex.r, a);
                    self.counters.updates += 1;
                    self.exchange = None;
                } else {
                    // The exchange was given up (timeout, or the partner
                    // was reported down): a late answer is discarded.
                    self.counters.late += 1;
                }
            }
            PeerMsg::Decline { from, seq } => {
                if let Some(ex) = self.exchange
                    && ex.partner == from
                    && ex.seq == seq
                {
                    self.exchange = None;
                    self.counters.declines += 1;
                } else {
                    self.counters.late += 1;
                }
            }
        }
    }

    // ----- sync -----

    fn sync_start_round(&mut self, out: &mut Vec<Output>) {
        let Some(st) = &self.sync else { return };
        let round = st.round;
        let id = self.cfg.id;
        let n = self.cfg.n_nodes as usize;
        match self.prox_step() {
            Ok((theta, r)) => {
                if let Some(st) = &mut self.sync {
                    st.mine = Some((theta, r));
                    if id == SYNC_ROOT {
                        st.received.entry(round).or_insert_with(|| vec![None; n])[id as usize] =
                            Some(r);
                    }
                }
                if id != SYNC_ROOT {
                    self.counters.messages_out += 1;
                    out.push(Output::Peer {
                        to: SYNC_ROOT,
                        msg: PeerMsg::Reflect {
                            from: id,
                            seq: round,
                            r,
                        },
                    });
                }
                if let Some(t) = self.cfg.round_timeout_s {
                    // The root waits for the points; another node for the
                    // root's wait and the way back.
                    let after_s = if id == SYNC_ROOT { t } else { 2.0 * t };
                    out.push(Output::Timer {
                        after_s,
                        then: Command::RoundTimeout { seq: round },
                    });
                }
                self.sync_try_finish(false, out);
            }
            Err(e) => {
                self.sync = None;
                out.push(self.failed(e));
            }
        }
    }

    /// Finish every sync round whose average is known: the root when it holds all
    /// `n` reflected points of the round (it then broadcasts their mean), every other
    /// node when the root's average has arrived. With `timed_out`, the current
    /// round's wait is over ([`Command::RoundTimeout`]): the root averages the
    /// points it has; another node without the Average keeps its state.
    fn sync_try_finish(&mut self, mut timed_out: bool, out: &mut Vec<Output>) {
        loop {
            let id = self.cfg.id;
            let n = self.cfg.n_nodes as usize;
            let Some(st) = &mut self.sync else { return };
            let Some((theta, r)) = st.mine else { return };
            let a = if id == SYNC_ROOT {
                let have = st
                    .received
                    .get(&st.round)
                    .map_or(0, |v| v.iter().flatten().count());
                if have < n && !timed_out {
                    return;
                }
                self.counters.missing += n.saturating_sub(have) as u64;
                let rs = st.received.remove(&st.round).unwrap_or_default();
                let a = mean_position(rs.iter().flatten());
                if self.cfg.n_nodes > 1 {
                    self.counters.messages_out += 1;
                    out.push(Output::Broadcast(PeerMsg::Average {
                        from: id,
                        seq: st.round,
                        a,
                    }));
                }
                Some(a)
            } else {
                match self.averages.remove(&st.round) {
                    Some(a) => Some(a),
                    None if timed_out => {
                        self.counters.timeouts += 1;
                        None
                    }
                    None => return,
                }
            };
            timed_out = false;
            if let Some(a) = a {
                dr_update(&mut self.u, &theta, &r, a);
                self.theta = theta;
                self.counters.updates += 1;
            }
            self.last_done = Some(st.round);
            if self.cfg.trace_iterations {
                out.push(Output::Report(Report::IterationDone {
                    node: self.cfg.id,
                    iteration: st.round,
                    theta: self.theta,
                }));
            }
            if st.round == st.last_round {
                let sample = st.sample;
                self.sync = None;
                out.push(self.sample_done(sample));
                return;
            }
            st.round += 1;
            st.mine = None;
            self.sync_start_round(out);
        }
    }

    /// True if round or iteration `seq` is one this node is done with.
    fn is_past(&self, seq: u64) -> bool {
        self.last_done.is_some_and(|d| seq <= d)
    }

    // ----- async logical -----

    fn async_advance(&mut self, out: &mut Vec<Output>) {
        loop {
            let Some(st) = &mut self.plan else { return };
            let Some(&(iter, partner)) = st.steps.front() else {
                let sample = st.sample;
                self.plan = None;
                out.push(self.sample_done(sample));
                return;
            };
            if st.mine.is_none() {
                match self.prox_step() {
                    Ok((theta, r)) => {
                        if let Some(st) = &mut self.plan {
                            st.mine = Some((theta, r));
                        }
                        self.counters.messages_out += 1;
                        out.push(Output::Peer {
                            to: partner,
                            msg: PeerMsg::Reflect {
                                from: self.cfg.id,
                                seq: iter,
                                r,
                            },
                        });
                        if let Some(after_s) = self.cfg.round_timeout_s {
                            out.push(Output::Timer {
                                after_s,
                                then: Command::RoundTimeout { seq: iter },
                            });
                        }
                    }
                    Err(e) => {
                        self.plan = None;
                        out.push(self.failed(e));
                        return;
                    }
                }
            }
            let Some(r_other) = self.early.remove(&iter) else {
                return;
            };
            let Some(st) = &mut self.plan else { return };
            let Some((theta, r)) = st.mine.take() else {
                return;
            };
            st.steps.pop_front();
            let a = pair_average(&r, &r_other);
            dr_update(&mut self.u, &theta, &r, a);
            self.theta = theta;
            self.counters.updates += 1;
            self.last_done = Some(iter);
            if self.cfg.trace_iterations {
                out.push(Output::Report(Report::IterationDone {
                    node: self.cfg.id,
                    iteration: iter,
                    theta,
                }));
            }
        }
    }

    /// Async logical, [`Command::RoundTimeout`]: if the node still waits for
    /// its partner's point of iteration `seq`, it keeps its state, and goes on.
    fn async_timeout(&mut self, seq: u64, out: &mut Vec<Output>) {
        let Some(st) = &mut self.plan else { return };
        if st.mine.is_none() || st.steps.front().is_none_or(|&(it, _)| it != seq) {
            return;
        }
        st.steps.pop_front();
        st.mine = None;
        self.counters.timeouts += 1;
        self.last_done = Some(seq);
        if self.cfg.trace_iterations {
            out.push(Output::Report(Report::IterationDone {
                node: self.cfg.id,
                iteration: seq,
                theta: self.theta,
            }));
        }
        self.async_advance(out);
    }

    // ----- realtime -----

    fn start_exchange(&mut self, out: &mut Vec<Output>) {
        if self.exchange.is_some() || self.alive.is_empty() {
            return;
        }
        let partner = self.alive[self.rng.random_range(0..self.alive.len())];
        match self.prox_step() {
            Ok((theta, r)) => {
                self.exchange_seq += 1;
                self.exchange = Some(Exchange {
                    partner,
                    seq: self.exchange_seq,
                    theta,
                    r,
                });
                self.counters.messages_out += 1;
                out.push(Output::Peer {
                    to: partner,
                    msg: PeerMsg::Request {
                        from: self.cfg.id,
                        seq: self.exchange_seq,
                        r,
                    },
                });
                if let Some(after_s) = self.cfg.exchange_timeout_s {
                    out.push(Output::Timer {
                        after_s,
                        then: Command::ExchangeTimeout {
                            seq: self.exchange_seq,
                        },
                    });
                }
            }
            Err(e) => out.push(self.failed(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::local::LocalProblem;
    use crate::estimators::prox::LocalSolver;
    use crate::model::measure::{NodeMeasurements, Sigmas};
    use crate::model::xy::Pt;

    fn config(solver: LocalSolver, kappa: usize) -> NodeConfig {
        NodeConfig {
            drift: None,
            id: 1,
            n_nodes: 3,
            anchor: Pt::xy(1.0, 2.0),
            transmitters: vec![Pt::xy(0.0, 0.0)],
            neighbours: vec![0, 2],
            omega: 1.0,
            gamma: 1e-3,
            solver,
            kappa,
            init_u: Coords::zeros(3),
            first_fix: false,
            noise_weights: false,
            seed: 7,
            mode: NodeMode::Sync,
            trace_iterations: false,
            exchange_timeout_s: None,
            round_timeout_s: None,
            checkpoint_every: None,
        }
    }

    fn meas(rho: f64) -> NodeMeasurements {
        NodeMeasurements {
            elevation: None,
            bistatic: vec![(0, rho)],
            doa: Some(0.3),
            range: None,
        }
    }

    /// Sample `k`'s command: one bistatic range `10 + k` and a DOA.
    fn sample(k: u32) -> Input {
        Input::Command(Command::Sample {
            sample: k,
            meas: meas(10.0 + k as f64),
            sigmas: Sigmas {
                elevation: 0.0,
                range: 5.0,
                doa: 0.5,
            },
        })
    }

    /// Two async nodes, each with a one-step plan per sample against the other.
    fn plan(sample: u32) -> Command {
        Command::AsyncPlan {
            sample,
            steps: vec![(sample as u64, 0)],
        }
    }

    #[test]
    fn samples_sent_ahead_wait_until_the_current_sample_is_done_and_give_the_same_state() {
        let mut cfg = config(LocalSolver::Gtrs, 1);
        cfg.mode = NodeMode::AsyncLogical;
        let partner_r = |k: u64| Coords::from([3.0 + k as f64, 4.0, 5.0]);
        let reflect = |k: u64| {
            Input::Peer(PeerMsg::Reflect {
                from: 0,
                seq: k,
                r: partner_r(k),
            })
        };
        // One sample at a time.
        let mut step = NodeCore::new(cfg.clone());
        let mut out = Vec::new();
        for k in 0..2u32 {
            step.handle(sample(k), &mut out);
            step.handle(Input::Command(plan(k)), &mut out);
            step.handle(reflect(k as u64), &mut out);
            assert!(!step.busy());
        }
        // Both samples sent before the first is done.
        let mut ahead = NodeCore::new(cfg);
        let mut out2 = Vec::new();
        ahead.handle(sample(0), &mut out2);
        ahead.handle(Input::Command(plan(0)), &mut out2);
        ahead.handle(sample(1), &mut out2);
        ahead.handle(Input::Command(plan(1)), &mut out2);
        assert!(ahead.busy(), "sample 0 waits for its partner");
        assert_eq!(ahead.samples_queued(), 1, "sample 1 waits in the queue");
        // Only sample 0's reflected point went out so far.
        let sent: Vec<u64> = out2
            .iter()
            .filter_map(|o| match o {
                Output::Peer {
                    msg: PeerMsg::Reflect { seq, .. },
                    ..
                } => Some(*seq),
                _ => None,
            })
            .collect();
        assert_eq!(sent, vec![0]);
        ahead.handle(reflect(0), &mut out2);
        assert!(ahead.busy(), "sample 1 started at once");
        assert_eq!(ahead.samples_queued(), 0, "nothing after sample 1");
        ahead.handle(reflect(1), &mut out2);
        assert!(!ahead.busy());
        assert_eq!(ahead.u(), step.u());
        assert_eq!(ahead.theta(), step.theta());
        assert_eq!(out2, out, "same outputs in the same order");
    }

    #[test]
    fn a_busy_node_queues_at_most_its_bound_and_counts_the_flood_past_it() {
        let mut cfg = config(LocalSolver::Gtrs, 1);
        cfg.mode = NodeMode::AsyncLogical;
        let mut node = NodeCore::new(cfg);
        let mut out = Vec::new();
        node.handle(sample(0), &mut out);
        node.handle(Input::Command(plan(0)), &mut out);
        assert!(node.busy(), "sample 0 waits for its partner");
        for k in 1..=100u32 {
            node.handle(sample(k), &mut out);
        }
        assert_eq!(node.samples_queued(), MAX_QUEUED);
        assert_eq!(node.counters().bad_frames, 100 - MAX_QUEUED as u64);
    }

    #[test]
    fn an_async_node_reports_each_iteration_only_when_the_trace_is_on() {
        let iteration_reports = |trace: bool| {
            let mut cfg = config(LocalSolver::Gtrs, 1);
            cfg.mode = NodeMode::AsyncLogical;
            cfg.trace_iterations = trace;
            let mut node = NodeCore::new(cfg);
            let mut out = Vec::new();
            node.handle(sample(0), &mut out);
            node.handle(
                Input::Command(Command::AsyncPlan {
                    sample: 0,
                    steps: vec![(0, 0), (1, 2)],
                }),
                &mut out,
            );
            for (seq, from) in [(0, 0), (1, 2)] {
                let r = Coords::from([3.0, 4.0, 5.0]);
                node.handle(Input::Peer(PeerMsg::Reflect { from, seq, r }), &mut out);
            }
            assert!(!node.busy(), "both steps done");
            assert!(
                out.iter()
                    .any(|o| matches!(o, Output::Report(Report::SampleDone { .. })))
            );
            out.iter()
                .filter_map(|o| match o {
                    Output::Report(Report::IterationDone { iteration, .. }) => Some(*iteration),
                    _ => None,
                })
                .collect::<Vec<u64>>()
        };
        assert_eq!(iteration_reports(false), Vec::<u64>::new());
        assert_eq!(iteration_reports(true), vec![0, 1]);
    }

    #[test]
    fn a_first_fix_node_starts_from_its_first_sample_and_only_that_one() {
        let mut cfg = config(LocalSolver::Gtrs, 1);
        cfg.first_fix = true;
        cfg.init_u = Coords::from([7.0, 7.0, 7.0]);
        let mut node = NodeCore::new(cfg.clone());
        assert_eq!(node.u(), cfg.init_u);
        let mut out = Vec::new();
        node.handle(sample(0), &mut out);
        let tx: Vec<_> = cfg.transmitters.iter().map(|t| t.point::<2>()).collect();
        let want = LocalProblem::<2, 3>::build(cfg.anchor.point(), &tx, cfg.omega, &meas(10.0))
            .first_fix(&tx);
        let want = Coords::of(&want);
        assert_eq!(node.u(), want);
        assert_eq!(node.theta(), want);
        node.handle(sample(1), &mut out);
        assert_eq!(node.u(), want, "a later sample does not restart the node");
        assert!(out.is_empty());
    }

    #[test]
    fn sync_rounds_numbered_at_the_end_of_u64_end_there_without_overflow() {
        let mut node = NodeCore::new(config(LocalSolver::Relaxed, 1));
        let mut out = Vec::new();
        node.handle(
            Input::Command(Command::SyncRounds {
                sample: 0,
                first_round: u64::MAX - 1,
                rounds: 5,
            }),
            &mut out,
        );
        let st = node.sync.as_ref().expect("in sync rounds");
        assert_eq!((st.round, st.last_round), (u64::MAX - 1, u64::MAX));
    }

    #[test]
    fn a_sync_round_is_one_message_per_node_to_the_root_and_one_broadcast_of_the_mean() {
        let n = 3u32;
        let mut nodes: Vec<NodeCore> = (0..n)
            .map(|id| {
                let mut cfg = config(LocalSolver::Relaxed, 1);
                cfg.id = id;
                cfg.anchor = Pt::xy(id as f64, 2.0 * id as f64);
                NodeCore::new(cfg)
            })
            .collect();
        let mut outs: Vec<Vec<Output>> = vec![Vec::new(); n as usize];
        for (i, node) in nodes.iter_mut().enumerate() {
            let mut o = Vec::new();
            node.handle(
                Input::Command(Command::Sample {
                    sample: 0,
                    meas: meas(10.0 + i as f64),
                    sigmas: Sigmas {
                        elevation: 0.0,
                        range: 5.0,
                        doa: 0.5,
                    },
                }),
                &mut o,
            );
            node.handle(
                Input::Command(Command::SyncRounds {
                    sample: 0,
                    first_round: 0,
                    rounds: 1,
                }),
                &mut o,
            );
            outs[i] = o;
        }
        // Non-roots: one Reflect to the root; the root waits.
        let mut reflects = Vec::new();
        for (i, o) in outs.iter().enumerate().skip(1) {
            assert_eq!(o.len(), 1, "node {i}: {o:?}");
            match &o[0] {
                Output::Peer {
                    to: SYNC_ROOT,
                    msg: m @ PeerMsg::Reflect { .. },
                } => reflects.push(*m),
                other => panic!("node {i} sent {other:?}"),
            }
        }
        assert!(outs[0].is_empty() && nodes[0].busy());
        let root_r = nodes[0].sync.as_ref().and_then(|s| s.mine).unwrap().1;
        let mut rs = vec![root_r];
        rs.extend(reflects.iter().map(|m| match m {
            PeerMsg::Reflect { r, .. } => *r,
            _ => unreachable!(),
        }));
        let mut root_out = Vec::new();
        for m in reflects {
            nodes[0].handle(Input::Peer(m), &mut root_out);
        }
        let avg = match root_out.as_slice() {
            [
                Output::Broadcast(m @ PeerMsg::Average { seq: 0, .. }),
                Output::Report(_),
            ] => *m,
            other => panic!("root sent {other:?}"),
        };
        let PeerMsg::Average { a, .. } = avg else {
            unreachable!()
        };
        // The mean of all three reflected points, in node-id order, bit for bit.
        assert_eq!(a, mean_position(rs.iter()));
        for node in nodes.iter_mut().skip(1) {
            let mut o = Vec::new();
            node.handle(Input::Peer(avg), &mut o);
            assert!(!node.busy());
            assert!(
                matches!(o.as_slice(), [Output::Report(Report::SampleDone { .. })]),
                "{o:?}"
            );
        }
        // The root ignores the loopback of its own broadcast, and does not
        // count it as a message received: its counters are the same whether
        // the loopback arrives before or after its report.
        let before = nodes[0].counters;
        assert_eq!(before.messages_in, u64::from(n - 1));
        let mut o = Vec::new();
        nodes[0].handle(Input::Peer(avg), &mut o);
        assert!(o.is_empty());
        assert_eq!(nodes[0].counters, before);
        for node in &nodes[1..] {
            assert_eq!(node.counters.messages_in, 1, "the average");
            assert_eq!(node.counters.messages_out, 1, "the reflected point");
        }
    }

    /// Realtime over a lossy channel: a Request comes with its timer; at the
    /// timeout the exchange is given up with the state unchanged and counted,
    /// a late Accept is discarded, and the next Tick starts a new exchange.
    /// Without a timeout (the ideal channel) no timer is asked for.
    #[test]
    fn a_realtime_exchange_whose_answer_is_lost_is_given_up_at_its_timeout() {
        let mut cfg = config(LocalSolver::Gtrs, 1);
        cfg.mode = NodeMode::Realtime;
        cfg.exchange_timeout_s = Some(3.5);
        let mut node = NodeCore::new(cfg.clone());
        let mut o = Vec::new();
        node.handle(sample(0), &mut o);
        o.clear();
        node.handle(Input::Command(Command::Tick), &mut o);
        let (seq, to) = match o.as_slice() {
            [
                Output::Peer {
                    to,
                    msg: PeerMsg::Request { seq, .. },
                },
                Output::Timer {
                    after_s,
                    then: Command::ExchangeTimeout { seq: t },
                },
            ] if seq == t && (*after_s - 3.5).abs() < 1e-15 => (*seq, *to),
            other => panic!("{other:?}"),
        };
        let (u, theta) = (node.u, node.theta);
        // While the exchange is open, another Tick starts nothing.
        o.clear();
        node.handle(Input::Command(Command::Tick), &mut o);
        assert!(o.is_empty(), "{o:?}");
        // A stale timer does nothing; the right one closes the exchange.
        node.handle(
            Input::Command(Command::ExchangeTimeout { seq: seq + 7 }),
            &mut o,
        );
        assert_eq!(node.counters.timeouts, 0);
        node.handle(Input::Command(Command::ExchangeTimeout { seq }), &mut o);
        assert_eq!(node.counters.timeouts, 1);
        assert_eq!((node.u, node.theta), (u, theta), "state unchanged");
        // The late Accept is discarded.
        node.handle(
            Input::Peer(PeerMsg::Accept {
                from: to,
                seq,
                r: Coords::from([1.0, 2.0, 3.0]),
            }),
            &mut o,
        );
        assert!(o.is_empty());
        assert_eq!((node.u, node.theta, node.counters.updates), (u, theta, 0));
        assert_eq!(node.counters.late, 1);
        // The next Tick starts a new exchange.
        node.handle(Input::Command(Command::Tick), &mut o);
        assert!(
            matches!(o.first(), Some(Output::Peer { msg: PeerMsg::Request { seq: s, .. }, .. }) if *s == seq + 1)
        );
        // On the ideal channel no timer is asked for.
        cfg.exchange_timeout_s = None;
        let mut ideal = NodeCore::new(cfg);
        let mut o = Vec::new();
        ideal.handle(sample(0), &mut o);
        o.clear();
        ideal.handle(Input::Command(Command::Tick), &mut o);
        assert_eq!(o.len(), 1, "{o:?}");
    }

    /// A sync network of `n` nodes with a round timeout, each given sample 0
    /// and `rounds` rounds; returns the nodes and their first outputs.
    fn lossy_sync(n: u32, rounds: u32) -> (Vec<NodeCore>, Vec<Vec<Output>>) {
        let mut nodes = Vec::new();
        let mut outs = Vec::new();
        for id in 0..n {
            let mut cfg = config(LocalSolver::Relaxed, 1);
            cfg.id = id;
            cfg.n_nodes = n;
            cfg.anchor = Pt::xy(id as f64, 2.0 * id as f64);
            cfg.round_timeout_s = Some(2.0);
            let mut node = NodeCore::new(cfg);
            let mut o = Vec::new();
            node.handle(sample(id), &mut o);
            node.handle(
                Input::Command(Command::SyncRounds {
                    sample: 0,
                    first_round: 0,
                    rounds,
                }),
                &mut o,
            );
            nodes.push(node);
            outs.push(o);
        }
        (nodes, outs)
    }

    fn timer_of(o: &[Output]) -> Option<(f64, Command)> {
        o.iter().find_map(|x| match x {
            Output::Timer { after_s, then } => Some((*after_s, then.clone())),
            _ => None,
        })
    }

    /// Sync over a lossy channel: the root waits `round_timeout` for the
    /// points, the others twice as long for the Average. At its timeout the
    /// root averages the points it has (its own and node 1's; node 2's is
    /// missing), a node without the Average keeps its state, and the points
    /// and Averages of a round given up arrive late and are discarded.
    #[test]
    fn a_sync_round_with_a_lost_point_is_averaged_at_its_timeout_without_it() {
        let (mut nodes, outs) = lossy_sync(3, 2);
        assert_eq!(
            timer_of(&outs[0]),
            Some((2.0, Command::RoundTimeout { seq: 0 }))
        );
        assert_eq!(
            timer_of(&outs[1]),
            Some((4.0, Command::RoundTimeout { seq: 0 }))
        );
        let reflect = |o: &[Output]| {
            o.iter()
                .find_map(|x| match x {
                    Output::Peer { msg, .. } => Some(*msg),
                    _ => None,
                })
                .unwrap()
        };
        let (r1, r2) = (reflect(&outs[1]), reflect(&outs[2]));
        let own = nodes[0].sync.as_ref().and_then(|s| s.mine).unwrap().1;
        let mut o = Vec::new();
        nodes[0].handle(Input::Peer(r1), &mut o);
        assert!(o.is_empty(), "the root waits for node 2: {o:?}");
        // A stale timer does nothing; the round's timer averages.
        nodes[0].handle(Input::Command(Command::RoundTimeout { seq: 5 }), &mut o);
        assert!(o.is_empty());
        nodes[0].handle(Input::Command(Command::RoundTimeout { seq: 0 }), &mut o);
        let PeerMsg::Reflect { r: p1, .. } = r1 else {
            unreachable!()
        };
        let avg = match o.first() {
            Some(Output::Broadcast(m @ PeerMsg::Average { seq: 0, a, .. })) => {
                assert_eq!(*a, mean_position([own, p1].iter()));
                *m
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(nodes[0].counters.missing, 1);
        assert_eq!(nodes[0].counters.updates, 1);
        // Node 2's point of round 0 comes late: discarded.
        nodes[0].handle(Input::Peer(r2), &mut o);
        assert_eq!(nodes[0].counters.late, 1);
        // Node 1 gets the Average; node 2 misses it and keeps its state.
        let mut o1 = Vec::new();
        nodes[1].handle(Input::Peer(avg), &mut o1);
        assert_eq!(nodes[1].counters.updates, 1);
        let (u2, theta2) = (nodes[2].u, nodes[2].theta);
        let mut o2 = Vec::new();
        nodes[2].handle(Input::Command(Command::RoundTimeout { seq: 0 }), &mut o2);
        assert_eq!((nodes[2].u, nodes[2].theta), (u2, theta2));
        assert_eq!(nodes[2].counters.timeouts, 1);
        assert_eq!(nodes[2].counters.updates, 0);
        // ... and goes on to round 1; the round-0 Average, late, is discarded.
        assert!(matches!(
            timer_of(&o2),
            Some((_, Command::RoundTimeout { seq: 1 }))
        ));
        nodes[2].handle(Input::Peer(avg), &mut o2);
        assert_eq!(nodes[2].counters.late, 1);
        assert_eq!(nodes[2].counters.updates, 0);
    }

    /// Async logical over a lossy channel: a node whose partner's point did
    /// not come within the timeout keeps its state, reports the iteration,
    /// and goes on; the point, when it comes, is late and discarded.
    #[test]
    fn an_async_step_whose_partner_point_is_lost_keeps_the_state_and_goes_on() {
        let mut cfg = config(LocalSolver::Relaxed, 1);
        cfg.mode = NodeMode::AsyncLogical;
        cfg.round_timeout_s = Some(1.5);
        cfg.trace_iterations = true;
        let mut node = NodeCore::new(cfg);
        let mut o = Vec::new();
        node.handle(sample(0), &mut o);
        node.handle(
            Input::Command(Command::AsyncPlan {
                sample: 0,
                steps: vec![(4, 0), (9, 2)],
            }),
            &mut o,
        );
        assert_eq!(timer_of(&o), Some((1.5, Command::RoundTimeout { seq: 4 })));
        let (u, theta) = (node.u, node.theta);
        o.clear();
        node.handle(Input::Command(Command::RoundTimeout { seq: 4 }), &mut o);
        assert_eq!((node.u, node.theta), (u, theta));
        assert_eq!(node.counters.timeouts, 1);
        assert!(o.iter().any(|x| matches!(
            x,
            Output::Report(Report::IterationDone { iteration: 4, .. })
        )));
        // The next step's point went out, with its timer.
        assert!(o.iter().any(|x| matches!(
            x,
            Output::Peer {
                to: 2,
                msg: PeerMsg::Reflect { seq: 9, .. }
            }
        )));
        assert_eq!(timer_of(&o), Some((1.5, Command::RoundTimeout { seq: 9 })));
        // Node 0's point of iteration 4 arrives late: discarded.
        let late = PeerMsg::Reflect {
            from: 0,
            seq: 4,
            r: Coords::from([1.0, 1.0, 1.0]),
        };
        o.clear();
        node.handle(Input::Peer(late), &mut o);
        assert!(o.is_empty());
        assert_eq!((node.counters.late, node.counters.updates), (1, 0));
        // Node 2's point of iteration 9 in time: the update and the sample's end.
        let ok = PeerMsg::Reflect {
            from: 2,
            seq: 9,
            r: Coords::from([1.0, 1.0, 1.0]),
        };
        node.handle(Input::Peer(ok), &mut o);
        assert_eq!(node.counters.updates, 1);
        assert!(
            o.iter()
                .any(|x| matches!(x, Output::Report(Report::SampleDone { .. })))
        );
    }

    /// A node that checkpoints writes `u` and `theta` when every
    /// `checkpoint_every`-th sample arrives; restored from a checkpoint it
    /// resumes exactly at it (its next sample does not reset it); a fresh
    /// node starts at `init_u`. NodeUp puts a neighbour back in its list.
    #[test]
    fn a_node_restarted_from_its_checkpoint_resumes_exactly_at_its_saved_state() {
        let mut cfg = config(LocalSolver::Gtrs, 1);
        cfg.mode = NodeMode::Realtime;
        cfg.checkpoint_every = Some(2);
        cfg.first_fix = true;
        let mut node = NodeCore::new(cfg.clone());
        let mut o = Vec::new();
        node.handle(sample(0), &mut o);
        node.handle(Input::Command(Command::Tick), &mut o);
        let ck = |o: &[Output]| {
            o.iter()
                .filter_map(|x| match x {
                    Output::Checkpoint { sample, u, theta } => Some((*sample, *u, *theta)),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(ck(&o).len(), 1, "sample 0 is checkpointed");
        o.clear();
        node.handle(sample(1), &mut o);
        assert!(ck(&o).is_empty(), "sample 1 is not");
        node.u = Coords::from([3.0, -4.0, 5.0]);
        node.theta = Coords::from([1.0, 2.0, 3.0]);
        node.handle(sample(2), &mut o);
        let saved = ck(&o);
        assert_eq!(saved, vec![(2, node.u, node.theta)]);
        let (_, u, theta) = saved[0];
        let mut back = NodeCore::restore(cfg.clone(), u, theta);
        let mut o = Vec::new();
        back.handle(sample(3), &mut o);
        assert_eq!(
            (back.u, back.theta),
            (u, theta),
            "first_fix does not reset it"
        );
        let fresh = NodeCore::new(cfg.clone());
        assert_eq!((fresh.u, fresh.theta), (cfg.init_u, cfg.init_u));
        back.handle(Input::Command(Command::NodeDown { node: 2 }), &mut o);
        assert_eq!(back.live_neighbours(), &[0]);
        back.handle(Input::Command(Command::NodeUp { node: 2 }), &mut o);
        back.handle(Input::Command(Command::NodeUp { node: 7 }), &mut o);
        assert_eq!(back.live_neighbours(), &[0, 2], "7 is no neighbour");
    }

    #[test]
    fn the_node_config_json_carries_the_solver_and_kappa_and_defaults_kappa_to_one() {
        let cfg = config(LocalSolver::GtrsL0, 2);
        let json = serde_json::to_string(&cfg).unwrap();
        assert!(json.contains("\"solver\":\"gtrs_l0\""), "{json}");
        assert!(json.contains("\"kappa\":2"), "{json}");
        assert_eq!(serde_json::from_str::<NodeConfig>(&json).unwrap(), cfg);
        // A launch written without the key (older coordinator) gets the default.
        let old = json.replace(",\"kappa\":2", "");
        assert!(!old.contains("kappa"));
        let back: NodeConfig = serde_json::from_str(&old).unwrap();
        assert_eq!(back.kappa, crate::estimators::prox::l0::DEFAULT_KAPPA);
    }
}
