//! What a node knows and says: its [`NodeConfig`], the coordinator's
//! [`Command`]s, the gossip [`PeerMsg`]s between nodes, its [`Report`]s, and
//! the [`Input`]/[`Output`] of [`super::NodeCore`].

use crate::estimators::prox::LocalSolver;
use crate::estimators::prox::gtrs::ProxFailure;
use crate::model::coords::Coords;
use crate::model::drift::Drift;
use crate::model::measure::{NodeMeasurements, Sigmas};
use crate::model::xy::Pt;

/// Everything a node knows about the world: itself, its neighbours and the
/// transmitters. It never learns another node's measurements or state except
/// through the gossip messages below.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeConfig {
    /// This node's id.
    pub id: u32,
    /// Number of nodes in the network (sync averaging divides by it).
    pub n_nodes: u32,
    /// This receiver's position `r_v` (at sample 0 if it drifts); its
    /// dimension (2 or 3) is the run's.
    pub anchor: Pt,
    /// How this receiver drifts, if it does: the node builds each sample's
    /// cost at its position of that sample ([`Drift::position`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift: Option<Drift>,
    /// All transmitter positions `t_m`, of the anchor's dimension.
    pub transmitters: Vec<Pt>,
    /// Sorted neighbour ids.
    pub neighbours: Vec<u32>,
    /// DOA row weight.
    pub omega: f64,
    /// Prox step.
    pub gamma: f64,
    /// Local prox.
    pub solver: LocalSolver,
    /// Outlier budget of [`LocalSolver::GtrsL0`] (rows of this node's cost that may be
    /// separated as outliers; clamped per sample by
    /// [`crate::estimators::prox::l0::effective_kappa`]). Ignored by the other solvers.
    #[serde(default = "default_kappa")]
    pub kappa: usize,
    /// Initial `u` (and `theta`): one number more than the anchor has.
    pub init_u: Coords,
    /// Start instead from the node's own fix of the first sample it gets
    /// ([`crate::estimators::local::LocalProblem::first_fix`]).
    #[serde(default)]
    pub first_fix: bool,
    /// Divide each row of the local cost by its noise standard deviation
    /// (`algorithm.row_weights = "noise"`,
    /// [`crate::estimators::local::LocalProblem::build_weighted`]).
    #[serde(default)]
    pub noise_weights: bool,
    /// Run seed (the node's own clock RNG derives from it and `id`).
    pub seed: u64,
    /// How the run is clocked.
    pub mode: NodeMode,
    /// Logical clocks: report `theta` after every round or iteration
    /// (`--trace-iterations`, [`Report::IterationDone`]).
    #[serde(default)]
    pub trace_iterations: bool,
    /// Realtime over a lossy channel: an initiator gives its exchange up when
    /// no answer came within this many (emulated) seconds
    /// ([`Output::Timer`], [`Command::ExchangeTimeout`]). `None` (the ideal
    /// channel): it waits as long as it takes.
    #[serde(default)]
    pub exchange_timeout_s: Option<f64>,
    /// Logical clocks over a lossy channel ([`Command::RoundTimeout`]): the
    /// sync root averages the reflected points that arrived within this many
    /// (emulated) seconds of the start of its round; another node gives up on
    /// a round's Average twice this long after it sent its reflected point;
    /// an async-logical node gives up on its partner's reflected point this
    /// long after it sent its own. `None` (the ideal channel): every wait
    /// lasts as long as it takes.
    #[serde(default)]
    pub round_timeout_s: Option<f64>,
    /// Write a checkpoint of `u` and `theta` ([`Output::Checkpoint`]) when
    /// every `checkpoint_every`-th sample arrives (a node that may
    /// restart from its checkpoint). `None`: never.
    #[serde(default)]
    pub checkpoint_every: Option<u32>,
}

impl NodeConfig {
    /// The run's dimension, 2 or 3: the anchor's.
    pub fn dim(&self) -> usize {
        self.anchor.dim()
    }
}

fn default_kappa() -> usize {
    crate::estimators::prox::l0::DEFAULT_KAPPA
}

/// How a run is clocked, as far as a node is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NodeMode {
    /// Synchronous rounds; positions averaged over all nodes.
    Sync,
    /// Async pairwise iterations drawn by the coordinator (`--clock logical`).
    AsyncLogical,
    /// Free-running pairwise exchanges on each node's own Poisson clock.
    Realtime,
}

/// A command from the coordinator.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// This node's own measurements of sample `sample`; replaces the local cost.
    Sample {
        /// Sample index.
        sample: u32,
        /// The node's measurements.
        meas: NodeMeasurements,
        /// The noise standard deviations of this sample (what a sonar's
        /// own error model gives; `row_weights = "noise"` divides the rows of
        /// the local cost by them).
        sigmas: Sigmas,
    },
    /// Sync mode: run `rounds` synchronous rounds numbered from `first_round`,
    /// then report [`Report::SampleDone`].
    SyncRounds {
        /// Sample index.
        sample: u32,
        /// Global number of the first round.
        first_round: u64,
        /// How many rounds.
        rounds: u32,
    },
    /// Async logical mode: this node's share of the sample's schedule, as
    /// `(global iteration, partner)` in increasing iteration order. The node
    /// executes them in order (a dataflow execution of the sequential
    /// schedule), then reports [`Report::SampleDone`].
    AsyncPlan {
        /// Sample index.
        sample: u32,
        /// `(iteration, partner)` pairs.
        steps: Vec<(u64, u32)>,
    },
    /// Realtime mode: the node's Poisson clock fired; pick a neighbour and
    /// start a pairwise exchange unless already inside one.
    Tick,
    /// Realtime mode: the timer of exchange `seq` ([`Output::Timer`]) is due;
    /// if that exchange is still open the initiator gives it up and keeps its
    /// state (its Request or the answer was lost; a late answer is discarded).
    ExchangeTimeout {
        /// The initiator's exchange counter.
        seq: u64,
    },
    /// Logical clocks over a lossy channel: the wait of sync round or async
    /// iteration `seq` ([`NodeConfig::round_timeout_s`]) is over. If the node
    /// is still waiting in it: the sync root averages the reflected points it
    /// has; another sync node, or an async node still without its partner's
    /// point, keeps its state for that round or iteration and goes on. What
    /// arrives for it later is discarded ([`Counters::late`]).
    RoundTimeout {
        /// The round or iteration.
        seq: u64,
    },
    /// Report the current `theta` as the estimate at sample `sample`.
    Snapshot {
        /// Sample index.
        sample: u32,
    },
    /// Node `node` is up again (restarted): a neighbour may pick it again.
    NodeUp {
        /// The node.
        node: u32,
    },
    /// Node `node` is gone: never pick it again and abandon any exchange with it.
    NodeDown {
        /// The dead node.
        node: u32,
    },
}

/// A gossip message between two nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PeerMsg {
    /// Sync round `seq` or async logical iteration `seq`: the sender's
    /// reflected point `r = 2 theta - u`.
    Reflect {
        /// Sender.
        from: u32,
        /// Round or iteration number.
        seq: u64,
        /// Reflected point.
        r: Coords,
    },
    /// Realtime: `from` asks for an exchange and sends its reflected point.
    Request {
        /// Initiator.
        from: u32,
        /// Initiator's exchange counter.
        seq: u64,
        /// Initiator's reflected point.
        r: Coords,
    },
    /// Realtime: the responder accepted and updated; here is its reflected point.
    Accept {
        /// Responder.
        from: u32,
        /// The initiator's exchange counter.
        seq: u64,
        /// Responder's reflected point.
        r: Coords,
    },
    /// Realtime: the responder is inside another exchange; the initiator keeps its state.
    Decline {
        /// Responder.
        from: u32,
        /// The initiator's exchange counter.
        seq: u64,
    },
    /// Sync round `seq`, from the root [`SYNC_ROOT`](super::SYNC_ROOT) to every node: the consensus
    /// average `a` of all nodes' reflected points.
    Average {
        /// The root.
        from: u32,
        /// Round.
        seq: u64,
        /// `mean_i r_i[0:2]`, summed in node-id order.
        a: Coords,
    },
}

impl PeerMsg {
    /// The sender.
    pub fn from(&self) -> u32 {
        match *self {
            PeerMsg::Reflect { from, .. }
            | PeerMsg::Request { from, .. }
            | PeerMsg::Accept { from, .. }
            | PeerMsg::Decline { from, .. }
            | PeerMsg::Average { from, .. } => from,
        }
    }

    /// The kind, as written to `messages.csv`.
    pub fn kind(&self) -> &'static str {
        match self {
            PeerMsg::Reflect { .. } => "reflect",
            PeerMsg::Request { .. } => "request",
            PeerMsg::Accept { .. } => "accept",
            PeerMsg::Decline { .. } => "decline",
            PeerMsg::Average { .. } => "average",
        }
    }

    /// The most values a message of a `dim`-dimensional run carries
    /// ([`PeerMsg::values`]): a reflected point, `dim + 1`.
    pub fn max_values(dim: usize) -> u32 {
        dim as u32 + 1
    }

    /// The values a message carries over an acoustic modem, the `fields` of
    /// [`AcousticCfg::frame_bits`](crate::model::channel::AcousticCfg::frame_bits):
    /// a reflected point `r = (x, y, d)` is 3 (Reflect, Request, Accept; 4
    /// in 3-D, `(x, y, z, d)`), a consensus average `(x, y)` 2 (Average; 3 in
    /// 3-D), a Decline none. The sender, the addressee, the kind and the
    /// sequence number are the frame header (`header_bits`).
    pub fn values(&self) -> u32 {
        match self {
            PeerMsg::Reflect { r, .. } | PeerMsg::Request { r, .. } | PeerMsg::Accept { r, .. } => {
                r.len() as u32
            }
            PeerMsg::Average { a, .. } => a.len() as u32,
            PeerMsg::Decline { .. } => 0,
        }
    }
}

/// Per-node counters, reported to the coordinator.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Counters {
    /// Prox solves.
    pub prox_solves: u64,
    /// Gossip messages sent.
    pub messages_out: u64,
    /// Gossip messages received from other nodes (the sync root's own
    /// broadcast, looped back, is not counted).
    pub messages_in: u64,
    /// Declined exchanges (realtime; as initiator).
    pub declines: u64,
    /// Completed DR updates of this node's `u`.
    pub updates: u64,
    /// Waits given up at their timeout on a lossy channel: realtime
    /// exchanges (as initiator), sync rounds without the root's Average,
    /// async-logical iterations without the partner's point. Left out of
    /// `metrics.json` when zero, so runs on the ideal channel write what they
    /// always wrote.
    #[serde(skip_serializing_if = "is_zero")]
    pub timeouts: u64,
    /// Sync root over a lossy channel: reflected points missing from the
    /// rounds it averaged at their timeout. Left out when zero.
    #[serde(skip_serializing_if = "is_zero")]
    pub missing: u64,
    /// Messages that arrived after the wait they answer was over, and were
    /// discarded. Left out when zero.
    #[serde(skip_serializing_if = "is_zero")]
    pub late: u64,
    /// Frames that did not decode (garbage, a truncated or out-of-range
    /// field, a flood past a reassembly limit), counted and dropped: the
    /// node goes on. Left out when zero.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bad_frames: u64,
}

fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// A report to the coordinator.
#[derive(Debug, Clone, PartialEq)]
pub enum Report {
    /// The node finished its work for `sample`; `theta` is its estimate.
    SampleDone {
        /// Node id.
        node: u32,
        /// Sample index.
        sample: u32,
        /// Current `theta`.
        theta: Coords,
        /// Counters so far.
        counters: Counters,
    },
    /// Logical clocks, only with [`NodeConfig::trace_iterations`]: the node
    /// completed its part of iteration (sync: round) `iteration`. Without the
    /// trace nothing reads it, and a frame per step to the coordinator would
    /// cost a node process as much as the step's own arithmetic.
    IterationDone {
        /// Node id.
        node: u32,
        /// Global iteration (sync: round).
        iteration: u64,
        /// The node's `theta` after the iteration.
        theta: Coords,
    },
    /// Answer to [`Command::Snapshot`].
    Snapshot {
        /// Node id.
        node: u32,
        /// Sample index.
        sample: u32,
        /// Current `theta`.
        theta: Coords,
        /// Counters so far.
        counters: Counters,
    },
    /// The node could not compute (a prox failed); the run must stop.
    Failed {
        /// Node id.
        node: u32,
        /// Sample index.
        sample: u32,
        /// What kind of failure (what crosses the wire).
        failure: ProxFailure,
        /// Why, in words (over the wire, the kind's [`ProxFailure::text`]).
        reason: String,
    },
}

/// Something the node wants sent.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// To one peer.
    Peer {
        /// Destination node.
        to: u32,
        /// The message.
        msg: PeerMsg,
    },
    /// To every node, including the sender (sync rounds).
    Broadcast(PeerMsg),
    /// To the coordinator.
    Report(Report),
    /// Save this checkpoint of the node's state (atomically; the last one
    /// wins), taken when sample `sample` arrived.
    Checkpoint {
        /// The sample.
        sample: u32,
        /// `u`.
        u: Coords,
        /// `theta`.
        theta: Coords,
    },
    /// Over a lossy channel: hand the node `then` (a
    /// [`Command::ExchangeTimeout`] or a [`Command::RoundTimeout`]) after
    /// `after_s` seconds.
    Timer {
        /// When, from now (emulated seconds).
        after_s: f64,
        /// The command to deliver.
        then: Command,
    },
}

/// An input to the core.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// From the coordinator.
    Command(Command),
    /// From a peer.
    Peer(PeerMsg),
}
