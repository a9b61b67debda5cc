//! Faults on node processes: the schedule of a run's faults in
//! wall time, and what each one does to a process, I/O-free. The processes
//! engine ([`super::processes`]) asks for the due faults and carries them out
//! with real signals: `pause` is SIGSTOP then SIGCONT, `crash` is SIGKILL
//! (the coordinator learns of it as of any death, when it reaps the child);
//! `restart` kills the node if it is alive and starts a new process for it,
//! fresh or from its checkpoint file ([`super::checkpoint`]), which rejoins
//! when it reports READY. `partition`, `link_loss` and `delay` act on the
//! water ([`super::water`]): the acoustic channel's, or on the ideal
//! channel a relay through the coordinator. `clock_drift` is a
//! [`crate::protocol::codec::Control::ClockFactor`] to the node.

use super::FaultRecord;
use crate::model::fault::{Fault, FaultKind};

/// What the engine must do for a fault event.
#[derive(Debug, Clone, PartialEq)]
pub enum FaultStep {
    /// SIGSTOP the node.
    Stop(u32),
    /// SIGCONT the node.
    Cont(u32),
    /// SIGKILL the node.
    Kill(u32),
    /// Fault `0` starts on the links (the water).
    LinkStart(usize, FaultKind),
    /// Fault `0` ends on the links.
    LinkEnd(usize),
    /// The node's clock runs with this factor on its waits and timers.
    Drift(u32, f64),
    /// Kill the node if it is alive, and start it again (`true`: from its
    /// checkpoint).
    Restart(u32, bool),
}

/// The faults of one run on node processes.
#[derive(Debug)]
pub struct FaultSchedule {
    faults: Vec<Fault>,
    /// `(emulated s, fault, start?)`, in time order.
    events: Vec<(f64, usize, bool)>,
    next: usize,
    period_s: f64,
    /// The record of every fault applied.
    pub records: Vec<FaultRecord>,
    /// Per node: paused now, and paused since the last completed sample.
    pub paused: Vec<bool>,
    was_paused: Vec<bool>,
    /// Per fault: its record.
    applied: Vec<Option<usize>>,
}

impl FaultSchedule {
    /// The schedule of `faults` over `n` nodes, with samples `period_s`
    /// emulated seconds long.
    pub fn new(faults: &[Fault], n: usize, period_s: f64) -> FaultSchedule {
        let mut events = Vec::new();
        for (id, f) in faults.iter().enumerate() {
            events.push((f.at_s, id, true));
            if let Some(u) = f.until_s {
                events.push((u, id, false));
            }
        }
        events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        FaultSchedule {
            faults: faults.to_vec(),
            events,
            next: 0,
            period_s,
            records: Vec::new(),
            paused: vec![false; n],
            was_paused: vec![false; n],
            applied: vec![None; faults.len()],
        }
    }

    /// Emulated seconds until the next fault event after `now_s`, if any.
    pub fn next_in(&self, now_s: f64) -> Option<f64> {
        self.events.get(self.next).map(|e| (e.0 - now_s).max(0.0))
    }

    /// The steps of every fault event due at `now_s` (emulated), recorded.
    pub fn due(&mut self, now_s: f64) -> Vec<FaultStep> {
        let mut out = Vec::new();
        while let Some(&(t, id, start)) = self.events.get(self.next) {
            if t > now_s {
                break;
            }
            self.next += 1;
            let kind = self.faults[id].kind.clone();
            if start {
                // In nanoseconds, as the discrete-event engine records it.
                let t = super::des::at(t).as_secs_f64();
                let sample = if self.period_s > 0.0 {
                    (t / self.period_s + 1e-9).floor() as u32
                } else {
                    0
                };
                self.applied[id] = Some(self.records.len());
                self.records.push(FaultRecord {
                    fault: self.faults[id].clone(),
                    t_s: t,
                    sample,
                    // The coordinator restarts the node itself: it knows at once.
                    detected_s: matches!(kind, FaultKind::Restart { .. }).then_some(t),
                });
            }
            match (kind, start) {
                (FaultKind::Pause { node }, true) => {
                    if let Some(p) = self.paused.get_mut(node as usize) {
                        *p = true;
                        self.was_paused[node as usize] = true;
                    }
                    out.push(FaultStep::Stop(node));
                }
                (FaultKind::Pause { node }, false) => {
                    if let Some(p) = self.paused.get_mut(node as usize) {
                        *p = false;
                    }
                    out.push(FaultStep::Cont(node));
                }
                (FaultKind::Crash { node }, true) => out.push(FaultStep::Kill(node)),
                (
                    FaultKind::Restart {
                        node, checkpoint, ..
                    },
                    true,
                ) => out.push(FaultStep::Restart(node, checkpoint)),
                (FaultKind::ClockDrift { node, ppm }, true) => {
                    out.push(FaultStep::Drift(node, 1.0 / (1.0 + ppm * 1e-6)))
                }
                (FaultKind::ClockDrift { node, .. }, false) => {
                    out.push(FaultStep::Drift(node, 1.0))
                }
                (
                    k @ (FaultKind::Partition { .. }
                    | FaultKind::LinkLoss { .. }
                    | FaultKind::Delay { .. }),
                    true,
                ) => out.push(FaultStep::LinkStart(id, k)),
                (
                    FaultKind::Partition { .. }
                    | FaultKind::LinkLoss { .. }
                    | FaultKind::Delay { .. },
                    false,
                ) => out.push(FaultStep::LinkEnd(id)),
                _ => {}
            }
        }
        out
    }

    /// The coordinator noticed node `node` at `now_s`: it died (a crash), or
    /// it was abandoned while paused. The fault that did it is detected.
    pub fn noticed(&mut self, node: u32, now_s: f64) {
        for (id, f) in self.faults.iter().enumerate() {
            let hit = matches!(f.kind, FaultKind::Crash { node: v } | FaultKind::Pause { node: v } if v == node);
            if let (true, Some(r)) = (hit, self.applied[id])
                && self.records[r].detected_s.is_none()
            {
                self.records[r].detected_s = Some(now_s);
            }
        }
        self.unpause(node);
    }

    /// Node `node` runs again without its pause ending on schedule (it was
    /// restarted, or the run ends): it is no longer paused.
    pub fn unpause(&mut self, node: u32) {
        if let Some(p) = self.paused.get_mut(node as usize) {
            *p = false;
        }
    }

    /// A sample completed: which nodes were paused during it.
    pub fn sample_mask(&mut self) -> Vec<bool> {
        self.was_paused
            .iter_mut()
            .zip(&self.paused)
            .map(|(w, p)| std::mem::replace(w, *p))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fault::FaultSpec;

    #[test]
    fn the_schedule_stops_continues_kills_and_restarts_on_time_and_records_each_fault() {
        let f = |s: &str| FaultSpec::parse_flag(s).unwrap().resolve(3, 0.5).unwrap();
        let faults = [
            f("pause:node=1,at_s=1,for_s=2"),
            f("crash:node=2,at_sample=4"),
            f("restart:node=0,at_s=9"),
        ];
        let mut s = FaultSchedule::new(&faults, 3, 0.5);
        assert_eq!(s.next_in(0.0), Some(1.0));
        assert!(s.due(0.9).is_empty());
        assert_eq!(s.due(1.0), vec![FaultStep::Stop(1)]);
        assert_eq!(s.sample_mask(), vec![false, true, false]);
        assert_eq!(s.due(3.0), vec![FaultStep::Kill(2), FaultStep::Cont(1)]);
        assert_eq!(s.records.len(), 2);
        assert_eq!(s.records[1].sample, 4);
        s.noticed(2, 2.1);
        assert_eq!(s.records[1].detected_s, Some(2.1));
        assert_eq!(s.records[0].detected_s, None);
        assert_eq!(
            s.sample_mask(),
            vec![false, true, false],
            "paused during it"
        );
        assert_eq!(s.sample_mask(), vec![false; 3]);
        // The coordinator restarts the node itself: detected at once.
        assert_eq!(s.due(9.0), vec![FaultStep::Restart(0, false)]);
        assert_eq!(s.records[2].detected_s, Some(9.0));
        assert_eq!(s.next_in(9.0), None);
    }
}
