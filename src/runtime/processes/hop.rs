//! The one-hop latency between two node processes (`sonarnet bench`).

use super::Processes;
use super::launch::ProcessOptions;
use crate::engine::layout::network_layout;
use crate::protocol::EngineError;
use crate::protocol::codec::{Control, CoordinatorInput};
use crate::protocol::plan::RunPlan;
use std::time::{Duration, Instant};

/// Ping-pongs per edge before the measurement moves to the next edge.
pub const HOPS_PER_TURN: u32 = 20;

/// The one-hop latency between two node processes on this machine: spawn `plan`'s nodes, then have the nodes of each gossip edge in
/// turn ping-pong [`HOPS_PER_TURN`] times ([`Control::ProbePeer`]), until
/// `count` hops are measured. A probe is sent as soon as the last one's
/// answer is in, so both nodes block between probes (or poll, with
/// `opts.poll_us`) as they do between gossip steps, and the coordinator
/// stays out of the path. Taking the edges in turn mixes the CPU placements
/// the run's processes get (a wake-up on the same CPU costs a third of one
/// across CPUs here). Each round trip is two hops, a frame and a wake-up
/// each way, so half of it is one hop. Returns the hops in seconds, and the
/// run id of the measurement; fails if the graph has no edge.
pub fn measure_hop(
    plan: &RunPlan,
    opts: &ProcessOptions,
    count: usize,
) -> Result<(Vec<f64>, String), EngineError> {
    let layout = network_layout(plan);
    let edges: Vec<(u32, u32)> = layout
        .configs
        .iter()
        .flat_map(|c| c.neighbours.iter().map(move |&w| (c.id, w)))
        .filter(|&(v, w)| v < w)
        .collect();
    if edges.is_empty() {
        return Err(EngineError::Unsupported(
            "a hop is measured between two neighbours, and this graph has no edge".into(),
        ));
    }
    let run_id = crate::transport::unique_run_id();
    let mut p = Processes::spawn(run_id.clone(), layout, None, opts)?;
    let mut hops = Vec::with_capacity(count);
    for &(v, w) in edges.iter().cycle() {
        if hops.len() >= count {
            break;
        }
        let want = HOPS_PER_TURN.min((count - hops.len()) as u32);
        let t0 = Instant::now();
        p.control(
            v,
            &Control::ProbePeer {
                peer: w,
                count: want,
            },
        )?;
        p.flush_all()?;
        let mut got = 0;
        while got < want {
            if t0.elapsed() > Duration::from_secs(10) {
                return Err(EngineError::NotResponding {
                    nodes: vec![v, w],
                    sample: 0,
                    silent_for: t0.elapsed(),
                });
            }
            for x in p.poll(Duration::from_millis(100), false)? {
                if let CoordinatorInput::Hops { node, seconds, .. } = x
                    && node == v
                {
                    got += seconds.len() as u32;
                    hops.extend(seconds);
                }
            }
        }
    }
    p.shutdown();
    Ok((hops, run_id))
}
