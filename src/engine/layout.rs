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
    /// The most gossip frames a node takes from one peer per sample
    /// ([`peer_budget`]).
    pub peer_frames_per_sample: u64,
    /// On the realtime clock, the wall time of one sample period: the
    /// budgets also grow by one sample's worth per period gone by, so that
    /// gossip that goes on while no new sample comes (a stall) stays
    /// within them. `None` on a logical clock.
    pub budget_period: Option<std::time::Duration>,
}

/// [`NetworkLayout::budget_period`] of `plan`: the sample period over the
/// channel's time scale (1 without a channel).
pub fn budget_period(plan: &RunPlan) -> Option<std::time::Duration> {
    let rt = plan
        .realtime
        .as_ref()
        .filter(|_| plan.clock == Clock::Realtime)?;
    let scale = plan
        .channel
        .as_ref()
        .map_or(1.0, |c| c.cfg.time_scale)
        .max(1e-9);
    std::time::Duration::try_from_secs_f64(rt.sample_period.as_secs_f64() / scale).ok()
}

/// Whether `sent` frames are within `budget` per budget earned
/// ([`budgets_earned`]); the clock is read only when the samples given
/// alone do not cover them (it is asked once per frame).
pub fn within_budget(
    sent: u64,
    budget: u64,
    samples_given: u64,
    period: Option<std::time::Duration>,
    start: std::time::Instant,
) -> bool {
    sent <= budget.saturating_mul(samples_given.saturating_add(1))
        || sent <= budget.saturating_mul(budgets_earned(samples_given, period, start))
}

/// How many budgets a party has earned: one per sample given, or per
/// `period` gone by since `start` if more (the realtime clock), and one
/// more.
pub fn budgets_earned(
    samples_given: u64,
    period: Option<std::time::Duration>,
    start: std::time::Instant,
) -> u64 {
    let by_time = period.map_or(0, |p| {
        (start.elapsed().as_secs_f64() / p.as_secs_f64().max(1e-9)).min(1e12) as u64
    });
    samples_given.max(by_time).saturating_add(1)
}

/// The largest number of neighbours a node of `plan` has.
fn max_degree(plan: &RunPlan) -> u64 {
    plan.nodes
        .iter()
        .map(|c| c.neighbours.len())
        .max()
        .unwrap_or(0) as u64
}

/// The most gossip frames a node takes from one peer per sample:
/// [`flood_budget`] over `2 (1 + largest degree)`, so that a node that
/// answers every frame its peers may send still stays within its own
/// budget with the coordinator (which relays its answers on a channel);
/// at least 64.
pub fn peer_budget(plan: &RunPlan) -> u64 {
    let max_deg = max_degree(plan);
    (flood_budget(plan) / (2 * (1 + max_deg))).max(64)
}

/// The most frames a node sends the coordinator per sample, with room to
/// spare: its reports (a few frames), a report per iteration when
/// iterations are traced, and on a channel the coordinator relays every
/// gossip frame it sends (an exchange or an iteration costs a node at most
/// three). On a logical clock `1024 + 8 x iterations_per_sample`; on the
/// realtime clock `1024 + 16 x (wakes per sample) x (1 + largest degree)`,
/// the node's own wakes and its neighbours' calls to it.
pub fn flood_budget(plan: &RunPlan) -> u64 {
    let max_deg = max_degree(plan);
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
            peer_frames_per_sample: peer_budget(plan),
            budget_period: budget_period(plan),
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
        peer_frames_per_sample: peer_budget(plan),
        budget_period: budget_period(plan),
    }
}

#[cfg(test)]
mod tests {
    use super::budgets_earned;
    use std::time::{Duration, Instant};

    #[test]
    fn budgets_are_earned_per_sample_given_or_per_period_gone_by() {
        let now = Instant::now();
        assert_eq!(budgets_earned(0, None, now), 1);
        assert_eq!(budgets_earned(4, None, now), 5);
        // Ten periods of 1 ms gone by count more than two samples.
        let start = now
            .checked_sub(Duration::from_millis(10))
            .expect("an instant");
        let earned = budgets_earned(2, Some(Duration::from_millis(1)), start);
        assert!(earned >= 11, "{earned}");
        // Samples count when they are more.
        assert_eq!(budgets_earned(50, Some(Duration::from_secs(3600)), now), 51);
        // Within: budget x earned, the clock read only past the samples' share.
        assert!(super::within_budget(10, 5, 1, None, now));
        assert!(!super::within_budget(11, 5, 1, None, now));
        assert!(super::within_budget(
            11,
            5,
            1,
            Some(Duration::from_millis(1)),
            start
        ));
    }
}
