//! How a run's nodes sit on a transport: who may send to whom and how many
//! frames an inbox holds, for every engine that frames the protocol over a
//! [`crate::transport::Transport`] (processes, threads), and for the
//! resource check before a run ([`crate::runtime::preflight`]).

use crate::estimators::gossip::Mode;
use crate::protocol::NodeConfig;
use crate::protocol::codec;
use crate::protocol::{Clock, RunPlan};

/// The nodes and transport topology of a run, for every engine that frames
/// the protocol over a [`Transport`](crate::transport::Transport) (processes, threads).
pub struct NetworkLayout {
    /// Node configurations, `configs[i].id == i`.
    pub configs: Vec<NodeConfig>,
    /// Who may send to whom: the gossip graph, plus every node to the sync root.
    pub neighbours: Vec<Vec<u32>>,
    /// Frames an inbox holds.
    pub inbox: usize,
    /// Sync runs answer rounds over the broadcast group.
    pub broadcast: bool,
}

/// The layout of `plan`'s nodes over a transport.
pub fn network_layout(plan: &RunPlan) -> NetworkLayout {
    let configs = plan.nodes.clone();
    let mut neighbours: Vec<Vec<u32>> = configs.iter().map(|c| c.neighbours.clone()).collect();
    let m = plan.transmitters;
    if plan.clock == Clock::Realtime {
        let max_deg = neighbours.iter().map(Vec::len).max().unwrap_or(1);
        return NetworkLayout {
            configs,
            neighbours,
            inbox: 4 * max_deg + m + 64,
            broadcast: false,
        };
    }
    let broadcast = plan.mode == Mode::Sync;
    if broadcast {
        // Sync rounds gather at the root (protocol::SYNC_ROOT), which answers over
        // the broadcast group.
        let root = crate::protocol::SYNC_ROOT;
        for (i, nb) in neighbours.iter_mut().enumerate() {
            if i as u32 != root && !nb.contains(&root) {
                nb.push(root);
            }
        }
    }
    // Room for every frame of LOOKAHEAD samples in flight (a node in every iteration
    // gets a sample's plan in one frame per six steps, `codec::PLAN_STEPS_PER_FRAME`;
    // one frame per iteration for sync, the root's share of a round's points, and
    // when iterations are traced, a node's reports of a sample to the coordinator;
    // plus the measurements), so that the coordinator never waits for a full inbox.
    let per_sample = match plan.mode {
        Mode::Async if !plan.trace_iterations => plan
            .iterations_per_sample
            .div_ceil(codec::PLAN_STEPS_PER_FRAME),
        _ => plan.iterations_per_sample,
    };
    let inbox = crate::protocol::LOOKAHEAD * (per_sample + m + 4) + 16;
    NetworkLayout {
        configs,
        neighbours,
        inbox,
        broadcast,
    }
}
