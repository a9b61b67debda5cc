//! Liveness on logical clocks: a run whose reports stop pings every live
//! node, and ends naming the nodes that do not answer.

use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::coordinator::{Action, Coordinator, Timer};
use std::time::Duration;

/// A liveness check in progress (logical clocks).
pub(super) struct Check {
    pub(super) seq: u64,
    /// When the pings went out.
    pub(super) sent: Duration,
    pub(super) answered: Vec<bool>,
}

impl Coordinator<'_> {
    /// Logical clocks, [`Timer::Watchdog`]: if no report came in the last
    /// half stall timeout, ping every live node and expect the answers within
    /// the other half; else look again half a stall timeout after the last
    /// report.
    pub(super) fn watchdog(&mut self, now: Duration, out: &mut Vec<Action>) {
        let half = self.plan.stall_timeout / 2;
        if self.check.is_some() {
            return;
        }
        if now < self.last_report + half {
            out.push(Action::SetTimer {
                at: self.last_report + half,
                timer: Timer::Watchdog,
            });
            return;
        }
        self.checks += 1;
        let seq = self.checks;
        for i in (0..self.plan.n()).filter(|&i| !self.dead[i]) {
            out.push(Action::Send {
                node: i as u32,
                msg: Control::Ping(seq),
            });
        }
        out.push(Action::Flush);
        out.push(Action::SetTimer {
            at: now + half,
            timer: Timer::PingDeadline(seq),
        });
        self.check = Some(Check {
            seq,
            sent: now,
            answered: self.dead.clone(),
        });
    }

    /// Logical clocks, [`Timer::PingDeadline`]: a node that has not answered
    /// is not responding (stopped, or wedged), and the run ends naming it.
    /// If every node answered, the nodes are alive and merely slow (a long
    /// sample): the watchdog goes on.
    pub(super) fn ping_deadline(
        &mut self,
        now: Duration,
        seq: u64,
        out: &mut Vec<Action>,
    ) -> Result<(), EngineError> {
        let half = self.plan.stall_timeout / 2;
        let Some(c) = self.check.take_if(|c| c.seq == seq) else {
            // A report made this check moot (it cleared `check`). The chain
            // of watchdog timers went through this deadline, so it goes on
            // from the last report; a stale deadline of an older check does
            // not start a second chain.
            if seq == self.checks && self.check.is_none() {
                out.push(Action::SetTimer {
                    at: (self.last_report + half).max(now),
                    timer: Timer::Watchdog,
                });
            }
            return Ok(());
        };
        let silent: Vec<u32> = (0..self.plan.n())
            .filter(|&i| !c.answered[i])
            .map(|i| i as u32)
            .collect();
        if silent.is_empty() {
            out.push(Action::Log(format!(
                "no report for {:.1} s, but every node answers (sample {})",
                (now - self.last_report).as_secs_f64(),
                self.sample()
            )));
            out.push(Action::SetTimer {
                at: now + half,
                timer: Timer::Watchdog,
            });
            return Ok(());
        }
        for &node in &silent {
            out.push(Action::Abandon { node });
        }
        Err(EngineError::NotResponding {
            nodes: silent,
            sample: self.sample(),
            silent_for: now.saturating_sub(self.last_report.min(c.sent)),
        })
    }
}
