//! What the coordinator recorded of a run: every node's `theta` per sample,
//! the schedule, the counters, the deaths ([`RunRecord`]).

use crate::model::coords::Coords;
use crate::protocol::Counters;

/// What the coordinator recorded of a run, complete or not.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunRecord {
    /// `thetas[k][i]`: node `i`'s `theta` after sample `k` (only completed samples).
    pub thetas: Vec<Vec<Coords>>,
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
    /// `--trace-iterations`: `(iteration, sample, node, theta)` for every node
    /// updated by every iteration (sync: every node every round), in order.
    pub iteration_trace: Vec<(u64, u32, u32, Coords)>,
}

impl RunRecord {
    /// The record of a run that has not started: `n` nodes, nothing done.
    pub fn empty(n: usize) -> RunRecord {
        RunRecord {
            counters: vec![Counters::default(); n],
            ..Default::default()
        }
    }

    /// The nodes counted in `theta_bar` at sample `k`.
    pub fn alive_thetas(&self, k: usize) -> Vec<Coords> {
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
