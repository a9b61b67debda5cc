//! The [`RunPlan`]: everything an engine needs to run a scenario, built once.
//!
//! A plan is made from a [`Scenario`] and a [`Clock`] by [`RunPlan::new`]. It
//! holds the node configurations (what each node may know), the gossip graph,
//! the async schedule source, the mode, the clock and the one run seed. Every
//! engine and the [`Coordinator`](super::coordinator::Coordinator) read the
//! plan, never the scenario.

use super::Clock;
use super::EngineKind;
use crate::estimators::gossip::{self, Mode};
use crate::model::graph::Graph;
use crate::model::rng::{SonarRng, Stream, stream_rng};
use crate::model::xy::Pt;
use crate::protocol::EngineError;
use crate::protocol::config::RunConfig;
use crate::protocol::{NodeConfig, NodeMode, SYNC_ROOT};
use crate::scenario::{RowWeights, Scenario};
use rand::RngExt;
use std::time::Duration;

/// The free-running clock of a realtime run (`[realtime]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealtimePlan {
    /// Poisson wake-up rate of every node (Hz).
    pub wake_rate_hz: f64,
    /// Time between two samples.
    pub sample_period: Duration,
}

/// The default of [`RunPlan::stall_timeout`] (`--stall-timeout`).
pub const DEFAULT_STALL_TIMEOUT: Duration = Duration::from_secs(5);

/// The range of `--stall-timeout`, in seconds.
pub const STALL_TIMEOUT_RANGE_S: std::ops::RangeInclusive<f64> = 0.1..=3600.0;

/// One run of one scenario, as the engines see it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunPlan {
    /// The run seed: every random stream of the run derives from it
    /// ([`crate::model::rng::stream_rng`]).
    pub seed: u64,
    /// Sync rounds or async pairwise gossip.
    pub mode: Mode,
    /// The engine that runs it ([`RunConfig::resolve`]).
    pub engine: EngineKind,
    /// Logical (exact, sequenced by the coordinator) or realtime clocks.
    pub clock: Clock,
    /// Samples to run.
    pub samples: usize,
    /// DR iterations (sync: rounds) per sample.
    pub iterations_per_sample: usize,
    /// Collect every node's `theta` after every iteration.
    pub trace_iterations: bool,
    /// `nodes[i]`: node `i`'s configuration (`nodes[i].id == i`).
    pub nodes: Vec<NodeConfig>,
    /// The gossip graph (the async schedule and the liveness check use it).
    pub graph: Graph,
    /// A replayed async schedule, `(v, w)` per iteration, instead of drawing one.
    pub replay: Option<Vec<(usize, usize)>>,
    /// Number of transmitters (frames per measurement command).
    pub transmitters: usize,
    /// Realtime clock parameters (`Some` exactly when `clock` is realtime).
    pub realtime: Option<RealtimePlan>,
    /// The liveness watchdog (`--stall-timeout`, default
    /// [`DEFAULT_STALL_TIMEOUT`]). Logical clocks: when no report has come
    /// for half of it, every live node is pinged, and a node that does not
    /// answer within the other half ends the run
    /// ([`EngineError::NotResponding`]). Realtime: a node that has not
    /// answered a snapshot within it is left out like a dead node.
    pub stall_timeout: Duration,
    /// The acoustic channel between the nodes (`None`: ideal).
    pub channel: Option<ChannelPlan>,
    /// Faults (realtime clock), in emulated seconds.
    pub faults: Vec<crate::model::fault::Fault>,
}

/// The acoustic channel of a run ([`crate::model::channel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelPlan {
    /// Its parameters (validated).
    pub cfg: crate::model::channel::AcousticCfg,
    /// Node positions (the receivers) at sample 0, in the run's dimension.
    pub positions: Vec<Pt>,
    /// How the receivers drift (empty when none does): the medium moves
    /// them to their positions of each sample ([`crate::world::medium::Channel::at_sample`]).
    pub drift: Vec<Option<crate::model::drift::Drift>>,
    /// `links[i]`: the nodes that node `i`'s transmissions reach (its
    /// gossip neighbours).
    pub links: Vec<Vec<u32>>,
    /// The realtime exchange timeout in force, emulated seconds.
    pub exchange_timeout_s: f64,
    /// Logical clocks: the round timeout in force, emulated seconds
    /// ([`crate::protocol::NodeConfig::round_timeout_s`]).
    pub round_timeout_s: Option<f64>,
}

impl RunPlan {
    /// What runs this plan's nodes: its engine on its clock and channel.
    pub fn driver(&self) -> super::Driver {
        super::Driver::of(self.engine, self.clock, self.channel.is_some())
    }

    /// The plan of `sc` (with its own seed `sc.seed`) as `cfg` asks (a
    /// [`Clock`] alone: in-process on that clock). A combination that
    /// cannot run is [`EngineError::Refused`] ([`RunConfig::resolve`]).
    pub fn new<const D: usize>(
        sc: &Scenario<D>,
        cfg: impl Into<RunConfig>,
    ) -> Result<RunPlan, EngineError> {
        let (engine, clock) = cfg.into().resolve(sc)?;
        let mode = sc.algorithm.mode;
        let (node_mode, realtime) = match clock {
            Clock::Logical => (logical_mode(mode), None),
            Clock::Realtime => {
                let Some(rt) = &sc.realtime else {
                    return Err(EngineError::Unsupported(
                        "--clock realtime needs a [realtime] table in the scenario".into(),
                    ));
                };
                let sample_period = Duration::try_from_secs_f64(rt.sample_period_ms / 1000.0)
                    .map_err(|_| {
                        EngineError::Unsupported(format!(
                            "realtime.sample_period_ms = {} is not a duration",
                            rt.sample_period_ms
                        ))
                    })?;
                let rt = RealtimePlan {
                    wake_rate_hz: rt.wake_rate_hz,
                    sample_period,
                };
                (NodeMode::Realtime, Some(rt))
            }
        };
        let gammas = prox_steps_of(sc);
        let mut nodes: Vec<NodeConfig> = (0..sc.graph.len())
            .map(|i| node_config(sc, i, node_mode, gammas[i]))
            .collect();
        // The scheduled faults, then the nemesis's, drawn from the run seed.
        let mut faults = sc.faults.clone();
        if let (Some(nem), Some(rt)) = (&sc.nemesis, &realtime) {
            let horizon = sc.samples as f64 * rt.sample_period.as_secs_f64();
            faults.extend(nem.draw(sc.seed, horizon, sc.graph.len(), sc.graph.edges()));
        }
        let checkpointed: Vec<(u32, u32)> = faults
            .iter()
            .filter_map(|f| match f.kind {
                crate::model::fault::FaultKind::Restart {
                    node,
                    checkpoint: true,
                    every,
                } => Some((node, every)),
                _ => None,
            })
            .collect();
        for (node, every) in checkpointed {
            if let Some(c) = nodes.get_mut(node as usize) {
                c.checkpoint_every = Some(c.checkpoint_every.map_or(every, |e| e.min(every)));
            }
        }
        // On the ideal channel a fault can swallow a Request (partition, link
        // loss) or hold it (pause): the initiator gives it up after two mean
        // wake-up intervals.
        if !faults.is_empty()
            && sc.channel.acoustic().is_none()
            && let Some(rt) = &realtime
        {
            for c in &mut nodes {
                c.exchange_timeout_s = Some(2.0 / rt.wake_rate_hz);
            }
        }
        let channel = match sc.channel.acoustic() {
            None => None,
            Some(cfg) => {
                let positions: Vec<Pt> = sc.geometry.receivers.iter().map(Pt::of).collect();
                let links: Vec<Vec<u32>> = nodes.iter().map(|c| c.neighbours.clone()).collect();
                // A Request and its Accept carry a reflected point each.
                let fields = crate::protocol::PeerMsg::max_values(D);
                // The timeouts hold for the longest links of the run: those
                // of sample 0, or with drifting receivers of the samples
                // where the distances are largest.
                let snapshots: Vec<Vec<Pt>> = sc
                    .geometry
                    .extreme_samples(sc.samples)
                    .into_iter()
                    .map(|k| sc.geometry.at(k).receivers.iter().map(Pt::of).collect())
                    .collect();
                let longest =
                    |f: &dyn Fn(&[Pt]) -> f64| snapshots.iter().map(|p| f(p)).fold(0.0, f64::max);
                let timeout = longest(&|p| cfg.exchange_timeout(p, &links, fields));
                // Sync rounds talk to and from the root; async steps along
                // the gossip links.
                let used: Vec<Vec<u32>> = match node_mode {
                    NodeMode::Sync => (0..nodes.len() as u32)
                        .map(|i| match i {
                            SYNC_ROOT => (1..nodes.len() as u32).collect(),
                            _ => vec![SYNC_ROOT],
                        })
                        .collect(),
                    _ => links.clone(),
                };
                let round = (node_mode != NodeMode::Realtime).then(|| {
                    longest(&|p| cfg.round_timeout(p, &used, fields, node_mode == NodeMode::Sync))
                });
                for c in &mut nodes {
                    c.exchange_timeout_s = Some(timeout);
                    c.round_timeout_s = round;
                }
                Some(ChannelPlan {
                    cfg: cfg.clone(),
                    positions,
                    drift: sc.geometry.drift.clone(),
                    links,
                    exchange_timeout_s: timeout,
                    round_timeout_s: round,
                })
            }
        };
        Ok(RunPlan {
            seed: sc.seed,
            mode,
            engine,
            clock,
            samples: sc.samples,
            iterations_per_sample: sc.algorithm.iterations_per_sample,
            trace_iterations: sc.trace_iterations,
            nodes,
            graph: sc.graph.clone(),
            replay: sc.algorithm.schedule.as_ref().map(|(_, s)| s.clone()),
            transmitters: sc.geometry.transmitters.len(),
            realtime,
            stall_timeout: DEFAULT_STALL_TIMEOUT,
            channel,
            faults,
        })
    }

    /// The same plan with the liveness watchdog at `t`
    /// ([`RunPlan::stall_timeout`]); `t` must lie in
    /// [`STALL_TIMEOUT_RANGE_S`] (the CLI checks it where it enters).
    pub fn with_stall_timeout(mut self, t: Duration) -> Result<RunPlan, EngineError> {
        if !STALL_TIMEOUT_RANGE_S.contains(&t.as_secs_f64()) {
            return Err(EngineError::Unsupported(format!(
                "stall timeout {} s is outside [{}, {}] s",
                t.as_secs_f64(),
                STALL_TIMEOUT_RANGE_S.start(),
                STALL_TIMEOUT_RANGE_S.end()
            )));
        }
        self.stall_timeout = t;
        Ok(self)
    }

    /// Number of nodes.
    pub fn n(&self) -> usize {
        self.nodes.len()
    }

    /// The run's dimension, 2 or 3 (its nodes').
    pub fn dim(&self) -> usize {
        self.nodes.first().map_or(2, NodeConfig::dim)
    }

    /// A fresh async scheduler for this plan.
    pub fn scheduler(&self) -> Scheduler<'_> {
        Scheduler::new(self)
    }
}

/// Each node's prox step: `gamma`, or with `prox_scaling =
/// "inverse_probability"` `gamma / p_v` (Mourya 2017 eq. 5), where `p_v` is the
/// probability that node `v` computes in an iteration: 1 in sync mode, the
/// empirical frequency over the whole file for a replayed schedule, and
/// otherwise that of the drawn schedule (`v` uniform, then a uniform
/// neighbour; the realtime clock draws the same, every node waking at one
/// rate and calling a uniform neighbour), [`gossip::computing_probabilities`].
fn prox_steps_of<const D: usize>(sc: &Scenario<D>) -> Vec<f64> {
    let a = &sc.algorithm;
    let n = sc.graph.len();
    let p = match (a.mode, &a.schedule) {
        (Mode::Sync, _) => None,
        (Mode::Async, Some((_, s))) => Some(gossip::empirical_probabilities(s, n)),
        (Mode::Async, None) => Some(gossip::computing_probabilities(&sc.graph)),
    };
    gossip::prox_steps(a.gamma, a.prox_scaling, p.as_deref(), n)
}

/// The configuration of node `id` in `sc` (what the node is allowed to know).
fn node_config<const D: usize>(
    sc: &Scenario<D>,
    id: usize,
    mode: NodeMode,
    gamma: f64,
) -> NodeConfig {
    NodeConfig {
        id: id as u32,
        n_nodes: sc.graph.len() as u32,
        anchor: Pt::of(&sc.geometry.receivers[id]),
        drift: sc.geometry.drift.get(id).cloned().flatten(),
        transmitters: sc.geometry.transmitters.iter().map(Pt::of).collect(),
        neighbours: sc.graph.neighbours(id).iter().map(|&w| w as u32).collect(),
        omega: sc.measurements.omega,
        gamma,
        solver: sc.algorithm.local_solver,
        kappa: sc.algorithm.kappa,
        init_u: sc.algorithm.init_u_coords(id, D),
        first_fix: sc.algorithm.init == crate::scenario::InitMode::FirstFix,
        noise_weights: sc.algorithm.row_weights == RowWeights::Noise,
        seed: sc.seed,
        mode,
        trace_iterations: sc.trace_iterations,
        exchange_timeout_s: None,
        round_timeout_s: None,
        checkpoint_every: None,
    }
}

/// The node mode of a logical-clock run.
fn logical_mode(mode: Mode) -> NodeMode {
    match mode {
        Mode::Sync => NodeMode::Sync,
        Mode::Async => NodeMode::AsyncLogical,
    }
}

/// Draws the async schedule: `v` uniform over nodes, `w` uniform over `v`'s
/// neighbours (Mourya 2017 Sec. II-B), from the run's schedule stream; or replays
/// the plan's schedule.
pub struct Scheduler<'a> {
    plan: &'a RunPlan,
    rng: SonarRng,
    next: usize,
}

impl<'a> Scheduler<'a> {
    /// A scheduler for `plan`, on the schedule stream of the plan's seed.
    pub fn new(plan: &'a RunPlan) -> Self {
        Scheduler {
            plan,
            rng: stream_rng(plan.seed, Stream::Schedule, 0),
            next: 0,
        }
    }

    /// The edge of the next iteration.
    pub fn next_pair(&mut self) -> (usize, usize) {
        let it = self.next;
        self.next += 1;
        if let Some(s) = &self.plan.replay {
            return s[it];
        }
        let g = &self.plan.graph;
        let v = self.rng.random_range(0..g.len());
        let nb = g.neighbours(v);
        let w = nb[self.rng.random_range(0..nb.len())];
        (v, w)
    }
}
