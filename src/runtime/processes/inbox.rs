//! What the coordinator of node processes receives from the nodes: frames
//! decoded into the coordinator's inputs, and the nodes that break the
//! protocol (frames that do not decode, floods, frames in another node's
//! name) counted, named and cut off.

use super::Processes;
use crate::protocol::EngineError;
use crate::protocol::codec::{CoordinatorInput, ReportDecoder};
use crate::protocol::coordinator::Event;
use crate::transport::wire::{Frame, IMPOSTOR};
use std::time::{Duration, Instant};

/// What came in from the nodes and is not yet handed to the coordinator.
pub(super) struct Inbox {
    pub(super) decoder: ReportDecoder,
    pub(super) frames: Vec<Frame>,
    pub(super) encoded: Vec<Frame>,
    /// Events for the coordinator not yet handed over.
    pub(super) events: Vec<Event>,
    /// Per node: frames from it that did not decode, dropped (the last
    /// slot: frames claiming a sender that is no node of the run).
    pub(super) bad: Vec<u64>,
    /// Per node: cut off for sending [`CUT_OFF_BAD_FRAMES`] bad frames, or
    /// a frame in another node's name.
    pub(super) cut: Vec<bool>,
    /// Per node: the node it claimed to be, when it sent a frame in another
    /// node's name ([`IMPOSTOR`]).
    pub(super) posed_as: Vec<Option<u32>>,
    /// Per node: frames received from it, and samples sent to it.
    pub(super) received: Vec<u64>,
    pub(super) samples: Vec<u64>,
    /// Frames a node may send per sample it was given (and one more
    /// sample's worth) before it is cut off as a flood.
    pub(super) flood_frames_per_sample: u64,
    /// The realtime clock's sample period in wall time, and when the
    /// nodes started ([`crate::engine::layout::budgets_earned`]).
    pub(super) budget_period: Option<Duration>,
    pub(super) started: Instant,
    /// Per node: cut off as a flood.
    pub(super) flooded: Vec<bool>,
}

/// "1 sample", "2 samples".
pub(super) fn samples_word(k: u64) -> String {
    format!("{k} sample{}", if k == 1 { "" } else { "s" })
}

impl Inbox {
    /// Whether `sent` frames are within node `i`'s allowance so far: a
    /// sample's budget for every sample it was given (on the realtime
    /// clock, for every sample period gone by, if more), and one more.
    pub(super) fn within_allowance(&self, i: usize, sent: u64) -> bool {
        let samples = self.samples.get(i).copied().unwrap_or(0);
        crate::engine::layout::within_budget(
            sent,
            self.flood_frames_per_sample,
            samples,
            self.budget_period,
            self.started,
        )
    }
}

/// Frames that do not decode after which the coordinator cuts a node off:
/// its process is killed and the run goes on as after a crash (the
/// realtime clock leaves a dead node out; a logical clock ends the run,
/// keeping what was completed).
pub const CUT_OFF_BAD_FRAMES: u64 = 64;

impl Processes {
    /// Kill every node that has sent [`CUT_OFF_BAD_FRAMES`] frames that
    /// do not decode, naming it; its death is then seen as a crash's.
    fn cut_off_garbage(&mut self) {
        for i in 0..self.inbox.cut.len() {
            if self.inbox.bad[i] >= CUT_OFF_BAD_FRAMES && !self.inbox.cut[i] && !self.nodes.dead[i]
            {
                self.inbox.cut[i] = true;
                eprintln!(
                    "error: node {i} sent {} frames that do not decode: cut off (its process \
                     is killed, and the run goes on as after a crash)",
                    self.inbox.bad[i]
                );
                self.signal(i as u32, libc::SIGKILL);
            }
        }
    }

    /// Kill every node that sent more frames than its allowance
    /// ([`Inbox::within_allowance`]), naming it; its death is then seen as a
    /// crash's.
    fn cut_off_floods(&mut self) {
        for i in 0..self.inbox.cut.len() {
            if !self.inbox.within_allowance(i, self.inbox.received[i])
                && !self.inbox.cut[i]
                && !self.nodes.dead[i]
            {
                self.inbox.cut[i] = true;
                self.inbox.flooded[i] = true;
                eprintln!(
                    "error: node {i} sent {} frames for {}, more than the {} a sample allows: \
                     cut off as a flood (its process is killed, and the run goes on as after a \
                     crash)",
                    self.inbox.received[i],
                    samples_word(self.inbox.samples[i]),
                    self.inbox.flood_frames_per_sample
                );
                self.signal(i as u32, libc::SIGKILL);
            }
        }
    }

    /// A frame from node `real`'s process named node `claimed` (or, with
    /// `real` no node of the run, came from a process the coordinator did
    /// not start): dropped; the impostor is named and cut off at once, as
    /// no honest node ever writes another's id.
    fn impostor(&mut self, real: u32, claimed: u32) {
        let n = self.inbox.bad.len() - 1;
        let slot = (real as usize).min(n);
        self.inbox.bad[slot] += 1;
        if slot == n {
            if self.inbox.bad[slot] == 1 {
                eprintln!(
                    "warning: a process that is no node of this run sent a frame in the name of \
                     node {claimed}: dropped"
                );
            }
            return;
        }
        if self.inbox.cut[slot] || self.nodes.dead[slot] {
            return;
        }
        self.inbox.cut[slot] = true;
        self.inbox.posed_as[slot] = Some(claimed);
        eprintln!(
            "error: node {real} sent a frame in the name of node {claimed}: cut off (its \
             process is killed, and the run goes on as after a crash)"
        );
        self.signal(real, libc::SIGKILL);
    }

    /// Receive and decode whatever arrives within `timeout`, keeping the
    /// latest timing of every node.
    pub(super) fn receive(
        &mut self,
        timeout: Duration,
    ) -> Result<Vec<CoordinatorInput>, EngineError> {
        self.inbox.frames.clear();
        let tx = self.tx.as_mut().ok_or(EngineError::TransportClosed)?;
        tx.recv(&mut self.inbox.frames, Some(timeout))
            .map_err(EngineError::Transport)?;
        let mut out = Vec::new();
        let mut bad = false;
        let mut posers = Vec::new();
        let mut flood = false;
        for f in &self.inbox.frames {
            if let Some(k) = self.inbox.received.get_mut(f.from as usize) {
                *k += 1;
                let sent = *k;
                flood |= !self.inbox.within_allowance(f.from as usize, sent);
            }
            if f.kind == IMPOSTOR {
                posers.push((f.from, f.aux));
                continue;
            }
            match self.inbox.decoder.feed(f) {
                Ok(Some(CoordinatorInput::Timing { node, timing })) => {
                    if let Some(t) = self.timing.get_mut(node as usize) {
                        *t = timing;
                    }
                }
                Ok(Some(CoordinatorInput::Channel { msg, to, t_send })) => {
                    if let Some(w) = &mut self.water {
                        w.submit(msg, to, t_send);
                    }
                }
                Ok(Some(CoordinatorInput::Late {
                    node, from, kind, ..
                })) => {
                    if let Some(w) = &mut self.water {
                        w.mark_late(node, from, kind);
                    }
                }
                Ok(Some(x)) => out.push(x),
                Ok(None) => {}
                Err(e) => {
                    // Counted and dropped; the first from each sender is
                    // named on standard error.
                    let n = self.inbox.bad.len() - 1;
                    let slot = (f.from as usize).min(n);
                    if self.inbox.bad[slot] == 0 {
                        let who = if slot < n {
                            format!("node {slot}")
                        } else {
                            format!("an unknown sender ({})", f.from)
                        };
                        eprintln!(
                            "warning: {who} sent a frame that does not decode ({e}): dropped"
                        );
                    }
                    self.inbox.bad[slot] += 1;
                    bad = true;
                }
            }
        }
        for (real, claimed) in posers {
            self.impostor(real, claimed);
        }
        if flood {
            self.cut_off_floods();
        }
        if bad {
            self.cut_off_garbage();
        }
        Ok(out)
    }
}
