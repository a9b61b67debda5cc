//! Medium access on the acoustic channel: when a node's modem may start a
//! frame.
//!
//! * `aloha` (the default): as soon as the modem is free (pure ALOHA).
//! * `tdma`: in the node's own slot of a collision-free schedule. The slots
//!   come from a greedy distance-2 colouring of the physical reach graph
//!   (the gossip graph under the graph reception rule, every pair under the
//!   SINR rule), nodes taken in index order, each given the smallest colour
//!   not used within two hops: two nodes of one colour neither reach each
//!   other nor share a node they both reach. The cycle has one slot per
//!   colour, in colour order; a slot lasts `slot_s`, by default the airtime
//!   of the longest frame the protocol sends (`D + 1` values) plus the
//!   longest propagation delay between two nodes that reach each other (the
//!   guard). A transmission started at its slot's start then arrives at
//!   every node it reaches within that slot, so no two arrivals at a node
//!   overlap and no node receives while it transmits: under TDMA the
//!   `collision` and `half_duplex` losses cannot happen.
//!
//! * `csma`: carrier sense on the node's own receiver, non-persistent with a
//!   random backoff. A frame the protocol hands over is offered to the
//!   medium at that instant, after every transmission started before it is
//!   known (the engines hold it as a pending copy due at once). If the
//!   node's modem is busy, or an arrival it would detect is in progress at
//!   its receiver (under the graph rule any arrival, under the SINR rule one
//!   at least `detection_db` over the noise), it waits a backoff uniform in
//!   `[0, backoff_s)` (a seeded draw keyed by the node and its backoff count)
//!   and senses again; after `max_attempts` busy senses it sends regardless.
//!   Sensing cannot hear a transmission whose sound has not reached the node
//!   yet, so collisions remain possible; the default timeouts add four
//!   backoff windows.
//!
//! Gossip maps onto the slots frame by frame: a node sends at most one
//! frame per slot of its own; a frame the protocol hands over waits for the
//! node's next slot that starts at or after the modem is free. An exchange
//! (Request, Accept, Reflect) therefore spans slots of two nodes, and the
//! default timeouts of [`crate::model::channel::AcousticCfg`] add the wait
//! for a slot: two cycles for an exchange and for a round.
//!
//! With drifting receivers the default guard is taken from the positions the
//! medium starts with; give `slot_s` for the longest link the drift reaches.

use crate::model::error::{KeyError, in_range};
use crate::model::nanos::{Nanos, nanos, seconds};
use serde::{Deserialize, Serialize};

/// `[channel] mac`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "protocol", rename_all = "snake_case", deny_unknown_fields)]
pub enum Mac {
    /// Send when the modem is free (the default).
    Aloha {},
    /// Carrier sense (module docs).
    Csma {
        /// The backoff is uniform in `[0, backoff_s)`, seconds, in [1e-6,
        /// 3600] (default 1).
        #[serde(default = "default_backoff")]
        backoff_s: f64,
        /// Sensing attempts before the frame is sent regardless, in [1,
        /// 1000] (default 8).
        #[serde(default = "default_attempts")]
        max_attempts: u32,
    },
    /// The slotted schedule of the module docs.
    Tdma {
        /// Slot length, seconds, in [1e-6, 3600]; default the longest
        /// frame's airtime plus the longest delay between nodes in reach.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        slot_s: Option<f64>,
    },
}

fn default_backoff() -> f64 {
    1.0
}
fn default_attempts() -> u32 {
    8
}

impl Default for Mac {
    fn default() -> Self {
        Mac::Aloha {}
    }
}

impl Mac {
    /// Pure ALOHA (left out of a written scenario).
    pub fn is_aloha(&self) -> bool {
        matches!(self, Mac::Aloha {})
    }

    /// Checks the numbers.
    pub fn validate(&self) -> Result<(), KeyError> {
        match *self {
            Mac::Tdma { slot_s: Some(s) } => in_range("channel.mac.slot_s", s, 1e-6, 3600.0),
            Mac::Csma {
                backoff_s,
                max_attempts,
            } => {
                in_range("channel.mac.backoff_s", backoff_s, 1e-6, 3600.0)?;
                in_range(
                    "channel.mac.max_attempts",
                    f64::from(max_attempts),
                    1.0,
                    1000.0,
                )
            }
            _ => Ok(()),
        }
    }
}

/// A greedy distance-2 colouring of the graph `reach` (symmetric or not:
/// both directions count): node `i`'s colour, and the number of colours.
pub fn distance2_colours(reach: &[Vec<u32>]) -> (Vec<u32>, u32) {
    let n = reach.len();
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, out) in reach.iter().enumerate() {
        for &j in out {
            let j = j as usize;
            if j < n && j != i {
                adj[i].push(j);
                adj[j].push(i);
            }
        }
    }
    let mut colour: Vec<Option<u32>> = vec![None; n];
    for i in 0..n {
        let mut used = vec![false; n + 1];
        for &j in &adj[i] {
            if let Some(c) = colour[j] {
                used[c as usize] = true;
            }
            for &k in &adj[j] {
                if k != i
                    && let Some(c) = colour[k]
                {
                    used[c as usize] = true;
                }
            }
        }
        colour[i] = Some(used.iter().position(|u| !u).unwrap_or(n) as u32);
    }
    let colours: Vec<u32> = colour.into_iter().map(|c| c.unwrap_or(0)).collect();
    let count = colours.iter().max().map_or(0, |m| m + 1);
    (colours, count)
}

/// A TDMA schedule in the medium's time.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    colour: Vec<u32>,
    slot: Nanos,
    cycle: Nanos,
}

impl Schedule {
    /// The schedule of `colours` (from [`distance2_colours`]) with slots of
    /// `slot_s` seconds.
    pub fn new(colours: (Vec<u32>, u32), slot_s: f64) -> Schedule {
        let slot = nanos(slot_s).max(1);
        Schedule {
            cycle: slot.saturating_mul(u64::from(colours.1.max(1))),
            colour: colours.0,
            slot,
        }
    }

    /// The cycle, seconds: the longest a frame waits for its slot.
    pub fn cycle_s(&self) -> f64 {
        seconds(self.cycle)
    }

    /// The start and end of node `i`'s first slot that starts at or after
    /// `t`.
    pub fn slot_at_or_after(&self, i: usize, t: Nanos) -> (Nanos, Nanos) {
        let offset = u64::from(self.colour.get(i).copied().unwrap_or(0)) * self.slot;
        let start = if t <= offset {
            offset
        } else {
            let k = (t - offset).div_ceil(self.cycle);
            offset.saturating_add(k.saturating_mul(self.cycle))
        };
        (start, start.saturating_add(self.slot))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_of_one_colour_are_at_least_three_hops_apart() {
        // A path 0-1-2-3-4-5: distance 2 needs three colours.
        let reach: Vec<Vec<u32>> = (0..6u32)
            .map(|i| {
                [i.wrapping_sub(1), i + 1]
                    .into_iter()
                    .filter(|&j| j < 6)
                    .collect()
            })
            .collect();
        let (c, count) = distance2_colours(&reach);
        assert_eq!(c, vec![0, 1, 2, 0, 1, 2]);
        assert_eq!(count, 3);
        // Every pair at one or two hops differs.
        for i in 0..6usize {
            for j in i + 1..6 {
                if j - i <= 2 {
                    assert_ne!(c[i], c[j], "{i} {j}");
                }
            }
        }
        // A complete graph: one colour each.
        let all: Vec<Vec<u32>> = (0..4u32)
            .map(|i| (0..4).filter(|&j| j != i).collect())
            .collect();
        assert_eq!(distance2_colours(&all), (vec![0, 1, 2, 3], 4));
    }

    #[test]
    fn a_frame_waits_for_its_nodes_next_slot() {
        // Slots of 1 s, three colours: node of colour 1 owns [1, 2), [4, 5), ...
        let s = Schedule::new((vec![0, 1, 2], 3), 1.0);
        let sec = 1_000_000_000;
        assert_eq!(s.slot_at_or_after(1, 0), (sec, 2 * sec));
        assert_eq!(s.slot_at_or_after(1, sec), (sec, 2 * sec));
        assert_eq!(s.slot_at_or_after(1, sec + 1), (4 * sec, 5 * sec));
        assert_eq!(s.slot_at_or_after(0, 3 * sec), (3 * sec, 4 * sec));
        assert!((s.cycle_s() - 3.0).abs() < 1e-12);
    }
}
