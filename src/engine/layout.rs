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
    /// The most frames an honest node sends the coordinator per sample it
    /// is given ([`flood_budget`]); beyond that it floods.
    pub flood_frames_per_sample: u64,
}

/// The most frames a node sends the coordinator per sample, with room to
/// spare: its reports (a few frames), a report per iteration when
/// iterations are traced, and on a channel the coordinator relays every
/// gossip frame it sends (an exchange or an iteration costs a node at most
/// three). On a logical clock `1024 + 8 x iterations_per_sample`; on the
/// realtime clock `1024 + 16 x (wakes per sample) x (1 + largest degree)`,
/// the node's own wakes and its neighbours' calls to it.
pub fn flood_budget(plan: &RunPlan) -> u64 {
    let max_deg = plan
        .nodes
        .iter()
        .map(|c| c.neighbours.len())
        .max()
        .unwrap_or(0) as u64;
    match (&plan.realtime, plan.clock) {
        (Some(rt), Clock::Realtime) => {
            let wakes = (rt.wake_rate_hz * rt.sample_period.as_secs_f64())
                .ceil()
                .clamp(1.0, 1e9) as u64;
            1024u64.saturating_add(16u64.saturating_mul(wakes).saturating_mul(1 + max_deg))
        }
        _ => 1024u64.saturating_add(8u64.saturating_mul(plan.iterations_per_sample as u64)),
    }
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
            flood_frames_per_sample: flood_budget(plan),
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
        flood_frames_per_sample: flood_budget(plan),
    }
}
