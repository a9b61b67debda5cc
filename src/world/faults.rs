//! The faults of a run, I/O-free: the schedule as a stream of timed steps,
//! the paused and dead state of every node as the faults leave it, and the
//! record of every fault applied (`faults.csv`).
//!
//! Every engine drives one [`FaultWorld`] the same way: it asks for the next
//! step due ([`FaultWorld::next_due`]), carries out each [`FaultStep`] in its
//! own medium (the discrete-event engine on its node cores, the processes
//! engine with real signals: `pause` is SIGSTOP then SIGCONT, `crash`
//! SIGKILL, `restart` a new process), and tells the world what it learns
//! ([`FaultWorld::died`], [`FaultWorld::abandoned`],
//! [`FaultWorld::restarted`], [`FaultWorld::sample_done`]). Which sample a
//! fault belongs to, when it counts as detected, and what a clock drift does
//! to a node's clock are decided here, once.

use crate::model::fault::{Fault, FaultKind};
use crate::world::time::at;
use std::time::Duration;

/// A fault as it was applied (a row of `faults.csv` before scoring).
#[derive(Debug, Clone, PartialEq)]
pub struct FaultRecord {
    /// The fault.
    pub fault: Fault,
    /// When it was applied (emulated s).
    pub t_s: f64,
    /// The sample in progress then.
    pub sample: u32,
    /// When the run noticed it (a crash, or a pause that outlasted the stall
    /// timeout), emulated s.
    pub detected_s: Option<f64>,
}

/// The faults of a run: every fault applied and the paused nodes per sample
/// (`faults.csv`, the `paused` column of `nodes.csv`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultLog {
    /// Every fault applied, in the order applied.
    pub applied: Vec<FaultRecord>,
    /// `paused[k][i]`: node `i` was paused at the end of sample `k`.
    pub paused: Vec<Vec<bool>>,
}

/// What an engine must do for one fault event.
#[derive(Debug, Clone, PartialEq)]
pub enum FaultStep {
    /// Stop the node (it keeps its state; what reaches it waits).
    Stop(u32),
    /// Let a stopped node go on.
    Cont(u32),
    /// Kill the node; the engine reports the death with [`FaultWorld::died`]
    /// when it learns of it.
    Kill(u32),
    /// Kill the node if it is alive and start it again (`true`: from its
    /// checkpoint); the engine calls [`FaultWorld::restarted`].
    Restart(u32, bool),
    /// Fault `0` starts on the links between nodes (the medium).
    LinkStart(usize, FaultKind),
    /// Fault `0` ends on the links.
    LinkEnd(usize),
    /// The node's waits and timers are multiplied by this factor from now on
    /// (`1 / (1 + ppm 1e-6)` while a clock drift lasts, 1 after it).
    Drift(u32, f64),
}

/// One node as the faults leave it.
#[derive(Debug, Clone, Copy, Default)]
struct NodeState {
    dead: bool,
    paused: bool,
    /// Paused at some time since the last completed sample.
    was_paused: bool,
}

/// The faults of one run: their schedule, the nodes' state and the records.
#[derive(Debug)]
pub struct FaultWorld {
    faults: Vec<Fault>,
    /// `(time, fault, start?)`, in time order (ties: the order of the faults,
    /// a start before its end).
    events: Vec<(Duration, usize, bool)>,
    next: usize,
    /// Sample period in emulated seconds (realtime clocks), else `None`.
    period_s: Option<f64>,
    nodes: Vec<NodeState>,
    records: Vec<FaultRecord>,
    /// Per fault: its record, once applied.
    applied: Vec<Option<usize>>,
    /// Per completed sample: the nodes paused at any time during it.
    masks: Vec<Vec<bool>>,
    /// The engine knows of a crash the moment it happens.
    crashes_seen_at_once: bool,
}

impl FaultWorld {
    /// The faults of a run of `n` nodes whose samples are `period_s` emulated
    /// seconds long (`None` or 0: logical clocks, the sample of a fault is
    /// the one the coordinator is on).
    pub fn new(faults: &[Fault], n: usize, period_s: Option<f64>) -> FaultWorld {
        let mut events = Vec::with_capacity(2 * faults.len());
        for (id, f) in faults.iter().enumerate() {
            events.push((at(f.at_s), id, true));
            if let Some(u) = f.until_s {
                events.push((at(u), id, false));
            }
        }
        // Stable: a fault's start stays before its end at the same time.
        events.sort_by_key(|e| (e.0, e.1));
        FaultWorld {
            faults: faults.to_vec(),
            events,
            next: 0,
            period_s: period_s.filter(|p| *p > 0.0),
            nodes: vec![NodeState::default(); n],
            records: Vec::new(),
            applied: vec![None; faults.len()],
            masks: Vec::new(),
            crashes_seen_at_once: false,
        }
    }

    /// The engine learns of a crash the moment it happens (virtual time),
    /// not when it reaps a process: a crash is detected when applied.
    pub fn with_crashes_seen_at_once(mut self) -> FaultWorld {
        self.crashes_seen_at_once = true;
        self
    }

    /// Whether the run has faults at all.
    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    /// When the next fault event is due, if any.
    pub fn next_at(&self) -> Option<Duration> {
        self.events.get(self.next).map(|e| e.0)
    }

    /// The steps of the next fault event if it is due at `now` (one event:
    /// an engine carries out its consequences before the next), recorded.
    /// `sample` is the sample the coordinator is on, used on logical clocks.
    pub fn next_due(&mut self, now: Duration, sample: u32) -> Option<Vec<FaultStep>> {
        let &(t, id, start) = self.events.get(self.next).filter(|e| e.0 <= now)?;
        self.next += 1;
        let kind = self.faults[id].kind.clone();
        if start {
            self.record(id, t.as_secs_f64(), sample);
        }
        let mut out = Vec::new();
        match (kind, start) {
            (FaultKind::Pause { node }, true) => {
                if let Some(s) = self.live_mut(node) {
                    s.paused = true;
                    s.was_paused = true;
                    out.push(FaultStep::Stop(node));
                }
            }
            (FaultKind::Pause { node }, false) => {
                if let Some(s) = self.nodes.get_mut(node as usize).filter(|s| s.paused) {
                    s.paused = false;
                    out.push(FaultStep::Cont(node));
                }
            }
            (FaultKind::Crash { node }, true) => out.push(FaultStep::Kill(node)),
            (
                FaultKind::Restart {
                    node, checkpoint, ..
                },
                true,
            ) => out.push(FaultStep::Restart(node, checkpoint)),
            (FaultKind::ClockDrift { node, ppm }, true) => {
                out.push(FaultStep::Drift(node, 1.0 / (1.0 + ppm * 1e-6)));
            }
            (FaultKind::ClockDrift { node, .. }, false) => out.push(FaultStep::Drift(node, 1.0)),
            (
                k @ (FaultKind::Partition { .. }
                | FaultKind::LinkLoss { .. }
                | FaultKind::Delay { .. }),
                true,
            ) => out.push(FaultStep::LinkStart(id, k)),
            (
                FaultKind::Partition { .. } | FaultKind::LinkLoss { .. } | FaultKind::Delay { .. },
                false,
            ) => out.push(FaultStep::LinkEnd(id)),
            (FaultKind::Crash { .. } | FaultKind::Restart { .. }, false) => {}
        }
        Some(out)
    }

    /// Record fault `id` as applied at `t` emulated seconds.
    fn record(&mut self, id: usize, t: f64, sample: u32) {
        // Sample k's measurements arrive at k periods: a fault at that time
        // belongs to sample k, whatever the order of the events at it.
        let sample = match self.period_s {
            Some(p) => (t / p + 1e-9).floor() as u32,
            None => sample,
        };
        // The run restarts the node itself: it knows at once.
        let known = match self.faults[id].kind {
            FaultKind::Restart { .. } => true,
            FaultKind::Crash { .. } => self.crashes_seen_at_once,
            _ => false,
        };
        self.applied[id] = Some(self.records.len());
        self.records.push(FaultRecord {
            fault: self.faults[id].clone(),
            t_s: t,
            sample,
            detected_s: known.then_some(t),
        });
    }

    fn live_mut(&mut self, node: u32) -> Option<&mut NodeState> {
        self.nodes.get_mut(node as usize).filter(|s| !s.dead)
    }

    /// Mark the records of the applied faults of `node` whose kind `hit`
    /// accepts as detected at `now_s` (once).
    fn detect(&mut self, node: u32, now_s: f64, hit: fn(&FaultKind, u32) -> bool) {
        for (id, f) in self.faults.iter().enumerate() {
            if let Some(r) = self.applied[id]
                && hit(&f.kind, node)
                && self.records[r].detected_s.is_none()
            {
                self.records[r].detected_s = Some(now_s);
            }
        }
    }

    /// The run learnt at `now_s` that node `node` died (a crash, or the old
    /// incarnation of a restart): it is dead and not paused; a crash that
    /// killed it is detected now.
    pub fn died(&mut self, node: u32, now_s: f64) {
        if let Some(s) = self.nodes.get_mut(node as usize) {
            s.dead = true;
            s.paused = false;
        }
        self.detect(
            node,
            now_s,
            |k, n| matches!(k, FaultKind::Crash { node } if *node == n),
        );
    }

    /// The coordinator gave up on node `node` at `now_s` (it stayed silent
    /// past the stall timeout): it is dead; a pause or crash that caused it
    /// is detected now.
    pub fn abandoned(&mut self, node: u32, now_s: f64) {
        if let Some(s) = self.nodes.get_mut(node as usize) {
            s.dead = true;
        }
        self.detect(
            node,
            now_s,
            |k, n| matches!(k, FaultKind::Crash { node } | FaultKind::Pause { node } if *node == n),
        );
    }

    /// Node `node` runs again (a restart): alive. (An engine learns of the
    /// old incarnation's death first, [`FaultWorld::died`], which unpauses
    /// it; a node abandoned while paused stays paused until its pause ends.)
    pub fn restarted(&mut self, node: u32) {
        if let Some(s) = self.nodes.get_mut(node as usize) {
            s.dead = false;
        }
    }

    /// The run ends with node `node` let go: it is not paused any more.
    pub fn released(&mut self, node: u32) {
        if let Some(s) = self.nodes.get_mut(node as usize) {
            s.paused = false;
        }
    }

    /// Whether node `node` is paused now.
    pub fn is_paused(&self, node: u32) -> bool {
        self.nodes.get(node as usize).is_some_and(|s| s.paused)
    }

    /// How many completed samples have been recorded.
    pub fn samples_done(&self) -> usize {
        self.masks.len()
    }

    /// `samples` samples are complete: the nodes paused at any time during
    /// the newest ones are recorded.
    pub fn sample_done(&mut self, samples: usize) {
        if self.faults.is_empty() {
            return;
        }
        let mask: Vec<bool> = self
            .nodes
            .iter_mut()
            .map(|s| std::mem::replace(&mut s.was_paused, s.paused))
            .collect();
        self.masks.resize(samples, mask);
    }

    /// The records of every fault applied, in order, and the paused masks of
    /// the first `samples` completed samples.
    pub fn into_log(self, samples: usize) -> FaultLog {
        let mut paused = self.masks;
        paused.truncate(samples);
        FaultLog {
            applied: self.records,
            paused,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{FaultLog, FaultStep, FaultWorld};
    use crate::model::fault::FaultSpec;
    use crate::world::time::at;
    use std::time::Duration;

    fn world(specs: &[&str], n: usize, period: f64) -> FaultWorld {
        let faults: Vec<_> = specs
            .iter()
            .map(|s| {
                FaultSpec::parse_flag(s)
                    .expect("a valid flag")
                    .resolve(n, period)
                    .expect("resolves")
            })
            .collect();
        FaultWorld::new(&faults, n, Some(period))
    }

    fn due(w: &mut FaultWorld, t: f64) -> Vec<FaultStep> {
        let mut out = Vec::new();
        while let Some(steps) = w.next_due(at(t), 0) {
            out.extend(steps);
        }
        out
    }

    #[test]
    fn the_schedule_stops_continues_kills_and_restarts_on_time_and_records_each_fault() {
        let mut w = world(
            &[
                "pause:node=1,at_s=1,for_s=2",
                "crash:node=2,at_sample=4",
                "restart:node=0,at_s=9",
            ],
            3,
            0.5,
        );
        assert_eq!(w.next_at(), Some(Duration::from_secs(1)));
        assert!(due(&mut w, 0.9).is_empty());
        assert_eq!(due(&mut w, 1.0), vec![FaultStep::Stop(1)]);
        assert!(w.is_paused(1));
        w.sample_done(1);
        assert_eq!(
            due(&mut w, 3.0),
            vec![FaultStep::Kill(2), FaultStep::Cont(1)]
        );
        w.died(2, 2.1);
        w.sample_done(2);
        w.sample_done(3);
        // The coordinator restarts the node itself: detected at once.
        assert_eq!(due(&mut w, 9.0), vec![FaultStep::Restart(0, false)]);
        assert_eq!(w.next_at(), None);
        let FaultLog {
            applied: records,
            paused: masks,
        } = w.into_log(3);
        assert_eq!(records.len(), 3);
        assert_eq!(records[1].sample, 4);
        assert_eq!(records[1].detected_s, Some(2.1));
        assert_eq!(records[0].detected_s, None);
        assert_eq!(records[2].detected_s, Some(9.0));
        assert_eq!(
            masks,
            vec![
                vec![false, true, false],
                vec![false, true, false],
                vec![false; 3]
            ],
            "paused during the first two samples"
        );
    }

    #[test]
    fn a_dead_node_is_not_paused_and_an_abandoned_pause_is_detected() {
        let mut w = world(
            &[
                "crash:node=0,at_s=1",
                "pause:node=0,at_s=2,for_s=1",
                "pause:node=1,at_s=2,for_s=5",
            ],
            2,
            1.0,
        );
        assert_eq!(due(&mut w, 1.0), vec![FaultStep::Kill(0)]);
        w.died(0, 1.0);
        assert_eq!(due(&mut w, 2.0), vec![FaultStep::Stop(1)], "node 0 is dead");
        w.abandoned(1, 4.5);
        assert_eq!(
            due(&mut w, 3.0),
            Vec::<FaultStep>::new(),
            "no end for a pause never begun"
        );
        let records = w.into_log(0).applied;
        assert_eq!(records[0].detected_s, Some(1.0));
        assert_eq!(records[1].detected_s, None);
        assert_eq!(records[2].detected_s, Some(4.5));
    }

    #[test]
    fn a_clock_drift_scales_waits_while_it_lasts() {
        let mut w = world(&["clock_drift:node=1,ppm=1000,at_s=1,for_s=1"], 2, 1.0);
        assert_eq!(due(&mut w, 1.0), vec![FaultStep::Drift(1, 1.0 / 1.001)]);
        assert_eq!(due(&mut w, 2.0), vec![FaultStep::Drift(1, 1.0)]);
    }

    #[test]
    fn a_logical_clock_run_records_the_sample_the_coordinator_is_on() {
        let f = FaultSpec::parse_flag("crash:node=0,at_s=5")
            .expect("flag")
            .resolve(2, 0.0)
            .expect("resolves");
        let mut w = FaultWorld::new(&[f], 2, None);
        assert!(w.next_due(at(5.0), 7).is_some());
        assert_eq!(w.into_log(0).applied[0].sample, 7);
    }
}
