//! The acoustic channel of the processes engine: the
//! coordinator is the water.
//!
//! On the acoustic channel a node process does not send its gossip frames to
//! its peers: it hands each one to the coordinator, stamped with the emulated
//! time it was sent ([`crate::protocol::codec::encode_channel`]). The
//! coordinator puts it on the run's [`Channel`] (the world's one channel
//! model, as in the discrete-event engine), holds it until its arrival ends,
//! has the channel judge it then (half-duplex and collisions in emulated
//! time, the seeded loss draw, a dead addressee) and forwards it to its
//! addressee or drops it. A node
//! that discards a delivered frame as late says so
//! ([`crate::protocol::codec::encode_late`]), and its record is marked.
//!
//! Time: every process reads the same system-wide monotonic clock, so the
//! emulated time `(now - epoch) x time_scale` ([`ChannelClock`]) is one clock
//! for the coordinator and every node. A frame is judged [`JUDGE_GRACE`]
//! (wall) after its arrival ends, so that every frame sent before that end
//! has reached the coordinator; the OS does not wake anyone exactly on time,
//! so each delivery's realised error (forwarded minus planned arrival end,
//! emulated ms) is kept ([`Water::into_records`]).
//!
//! On the ideal channel a run with link faults (partitions, link loss,
//! extra delay) relays its gossip the same way ([`Water::ideal`]): the
//! channel forwards a frame at once or after its fault's delay. Only the
//! acoustic channel keeps records (`messages.csv`), as in the discrete-event
//! engine.
//!
//! [`Water`] adds to the channel only what wall time needs (the shared
//! clock, the grace, the realised errors). It is I/O-free: times are passed
//! in, and what to forward is returned.

use crate::protocol::PeerMsg;
use crate::protocol::plan::ChannelPlan;
use crate::world::medium::{Channel, InFlight, MessageRecord};
use crate::world::time::{at, wait};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Duration;

/// How long after a frame's arrival ends (wall time) it is judged.
pub const JUDGE_GRACE: Duration = Duration::from_millis(1);

/// The system-wide monotonic clock (`CLOCK_MONOTONIC`), nanoseconds: the same
/// for every process of the host.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec, which we own.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    if rc != 0 {
        return 0;
    }
    (ts.tv_sec as u64)
        .saturating_mul(1_000_000_000)
        .saturating_add(ts.tv_nsec as u64)
}

/// The emulated clock a run's processes share: emulated seconds since the
/// monotonic instant `epoch_ns`, at `time_scale` emulated seconds per wall
/// second.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelClock {
    /// Emulated seconds per wall-clock second (`channel.time_scale`).
    pub time_scale: f64,
    /// The monotonic instant of emulated time 0.
    pub epoch_ns: u64,
}

impl ChannelClock {
    /// A clock whose emulated time 0 is now.
    pub fn start(time_scale: f64) -> ChannelClock {
        ChannelClock {
            time_scale,
            epoch_ns: monotonic_ns(),
        }
    }

    /// Emulated seconds now.
    pub fn now_s(&self) -> f64 {
        monotonic_ns().saturating_sub(self.epoch_ns) as f64 * 1e-9 * self.time_scale
    }

    /// The wall time of `emulated_s` emulated seconds, clamped to `[0, 1 day]`.
    pub fn wall(&self, emulated_s: f64) -> Duration {
        wait(emulated_s / self.time_scale)
    }
}

/// The water between the node processes of one run.
#[derive(Debug)]
pub struct Water {
    channel: Channel,
    clock: ChannelClock,
    /// Frames on their way, by (due time, order).
    pending: BTreeMap<(Duration, u64), InFlight>,
    next: u64,
    /// Scratch: the copies of the frame being submitted.
    sends: Vec<(Duration, InFlight)>,
    dead: Vec<bool>,
    errors_ms: Vec<f64>,
    /// How far back (emulated seconds) beyond the channel's overlap horizon
    /// a judgement may still look: one second, plus the grace at any scale.
    margin_s: f64,
}

impl Water {
    /// The water of a run on `plan`'s channel with seed `seed`, on `clock`.
    pub fn new(plan: &ChannelPlan, seed: u64, clock: ChannelClock) -> Water {
        let margin_s = 1.0 + clock.time_scale * JUDGE_GRACE.as_secs_f64();
        Water::with(
            Channel::planned(plan, seed),
            plan.positions.len(),
            clock,
            margin_s,
        )
    }

    /// The relay of a run of `n` nodes with seed `seed` on the ideal channel
    /// under link faults, on `clock` (wall time: `time_scale` 1).
    pub fn ideal(n: usize, seed: u64, clock: ChannelClock) -> Water {
        Water::with(Channel::ideal(n, seed), n, clock, 0.0)
    }

    fn with(channel: Channel, n: usize, clock: ChannelClock, margin_s: f64) -> Water {
        Water {
            channel,
            clock,
            pending: BTreeMap::new(),
            next: 0,
            sends: Vec::new(),
            dead: vec![false; n],
            errors_ms: Vec::new(),
            margin_s,
        }
    }

    /// How long after its arrival a frame is judged: [`JUDGE_GRACE`] on the
    /// acoustic channel; none on the ideal one, where a frame's fate is
    /// decided when it is sent.
    fn grace(&self) -> Duration {
        if self.channel.is_acoustic() {
            JUDGE_GRACE
        } else {
            Duration::ZERO
        }
    }

    /// The run's emulated clock.
    pub fn clock(&self) -> ChannelClock {
        self.clock
    }

    /// Node `from`'s frame `msg` to `to` ([`crate::protocol::codec::TO_ALL`]:
    /// every other node), sent at emulated time `t_send`: on the channel.
    pub fn submit(&mut self, msg: PeerMsg, to: u32, t_send: f64) {
        if !t_send.is_finite() {
            return;
        }
        let now = at(t_send);
        if to == crate::protocol::codec::TO_ALL {
            self.channel
                .broadcast(now, msg.from(), msg, &mut self.sends);
        } else {
            self.channel.send(now, msg.from(), to, msg, &mut self.sends);
        }
        for (due, f) in self.sends.drain(..) {
            self.pending.insert((due, self.next), f);
            self.next += 1;
        }
    }

    /// The wall time from now until the next judgement is due, if any frame
    /// is on its way.
    pub fn next_due(&self) -> Option<Duration> {
        let (&(due, _), _) = self.pending.first_key_value()?;
        let wait_s = due.as_secs_f64() - self.clock.now_s();
        Some(self.clock.wall(wait_s.max(0.0)) + self.grace())
    }

    /// Judges every frame due at least the grace before `now_s` (emulated),
    /// and appends the delivered ones to `out` as `(addressee, message)`.
    pub fn judge_due(&mut self, now_s: f64, out: &mut Vec<(u32, PeerMsg)>) {
        let grace_s = self.clock.time_scale * self.grace().as_secs_f64();
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0.as_secs_f64() + grace_s > now_s {
                break;
            }
            let (due, _) = *entry.key();
            let f = entry.remove();
            let arrive_end = f.arrive_end_s();
            let dead = self.dead.get(f.to() as usize).copied().unwrap_or(true);
            // A CSMA frame senses at its own due time (every frame sent
            // before it has reached the coordinator by now, the grace later).
            let delivered = self.channel.due(f, dead, due, &mut self.sends);
            for (due, f) in self.sends.drain(..) {
                self.pending.insert((due, self.next), f);
                self.next += 1;
            }
            if let Some(delivered) = delivered {
                if let Some(end) = arrive_end {
                    self.errors_ms.push((now_s - end) * 1e3);
                }
                out.push(delivered);
            }
        }
        self.channel.forget(now_s, self.margin_s);
    }

    /// Node `node` discarded a frame `kind` from `from` as late: its record
    /// (the latest such frame delivered) is marked.
    /// Sample `k` begins: drifting receivers move ([`Channel::at_sample`]).
    pub fn at_sample(&mut self, k: usize) {
        self.channel.at_sample(k);
    }

    pub fn mark_late(&mut self, node: u32, from: u32, kind: &str) {
        self.channel.mark_late(node, from, kind);
    }

    /// Fault `id` (a partition, link loss or delay) starts on the links.
    pub fn link_fault_start(&mut self, id: usize, kind: &crate::model::fault::FaultKind) {
        self.channel.link_fault_start(id, kind);
    }

    /// Fault `id` ends.
    pub fn link_fault_end(&mut self, id: usize) {
        self.channel.link_fault_end(id);
    }

    /// Node `node` is up again (restarted): frames to it are delivered.
    pub fn set_alive(&mut self, node: u32) {
        if let Some(d) = self.dead.get_mut(node as usize) {
            *d = false;
        }
    }

    /// Whether this is the acoustic channel (which keeps records).
    pub fn is_acoustic(&self) -> bool {
        self.channel.is_acoustic()
    }

    /// Node `node` is dead (or left out): frames to it are lost as
    /// `node_down`, and what it still had pending its carrier sense is
    /// withdrawn ([`Channel::sender_died`]).
    pub fn set_dead(&mut self, node: u32) {
        if let Some(d) = self.dead.get_mut(node as usize) {
            if !*d {
                self.channel.sender_died(node);
            }
            *d = true;
        }
    }

    /// Every frame judged so far, in the order judged, with its times moved
    /// `offset_s` earlier, and the realised delivery errors (emulated ms).
    pub fn into_records(self, offset_s: f64) -> (Vec<MessageRecord>, Vec<f64>) {
        let mut recs = self.channel.into_records();
        for r in &mut recs {
            r.t_send -= offset_s;
            if let Some(t) = &mut r.t_recv {
                *t -= offset_s;
            }
        }
        (recs, self.errors_ms)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::channel::{AcousticCfg, Reason};
    use crate::model::coords::Coords;
    use crate::model::xy::Pt;

    fn plan() -> ChannelPlan {
        ChannelPlan {
            drift: Vec::new(),
            cfg: AcousticCfg::default(),
            positions: vec![Pt::xy(0.0, 0.0), Pt::xy(1500.0, 0.0), Pt::xy(0.0, 3000.0)],
            links: vec![vec![1, 2], vec![0], vec![0]],
            exchange_timeout_s: 5.0,
            round_timeout_s: None,
        }
    }

    fn reflect(from: u32, seq: u64) -> PeerMsg {
        PeerMsg::Reflect {
            from,
            seq,
            r: Coords::from([1.0, 2.0, 3.0]),
        }
    }

    /// A frame is forwarded only once its arrival has ended (delay plus
    /// transmission time), with its realised error; a frame to a dead node
    /// is lost as `node_down`; a late mark moves a delivered record to
    /// `late`; the times move by the offset.
    #[test]
    fn the_water_holds_each_frame_until_its_arrival_ends_then_judges_it() {
        let clock = ChannelClock {
            time_scale: 1.0,
            epoch_ns: 0,
        };
        let mut w = Water::new(&plan(), 7, clock);
        w.submit(reflect(0, 1), 1, 10.0);
        // 1 s of propagation, 0.24 s on the air.
        let end = 10.0 + 1.0 + 0.24;
        let mut out = Vec::new();
        w.judge_due(end - 1e-3, &mut out);
        assert!(out.is_empty());
        w.judge_due(end + 0.01, &mut out);
        assert_eq!(out, vec![(1, reflect(0, 1))]);
        w.set_dead(2);
        w.submit(reflect(0, 2), 2, 20.0);
        w.judge_due(30.0, &mut out);
        assert_eq!(out.len(), 1);
        w.mark_late(1, 0, "reflect");
        let (recs, errs) = w.into_records(5.0);
        assert_eq!(recs.len(), 2);
        assert_eq!(recs[0].lost, Some(Reason::Late));
        assert_eq!(recs[0].t_recv, None);
        assert!((recs[0].t_send - 5.0).abs() < 1e-12);
        assert_eq!(recs[1].lost, Some(Reason::NodeDown));
        assert_eq!(errs.len(), 1);
        assert!((errs[0] - 10.0).abs() < 1e-6, "{errs:?}");
    }

    /// On the ideal channel the relay forwards a frame at once with no
    /// fault in force, drops it across a partition, holds it for a delay
    /// fault, drops frames to a dead node, and keeps no records.
    #[test]
    fn the_ideal_relay_applies_link_faults_and_keeps_no_records() {
        use crate::model::fault::FaultKind;
        let clock = ChannelClock {
            time_scale: 1.0,
            epoch_ns: 0,
        };
        let mut w = Water::ideal(3, 7, clock);
        assert!(!w.is_acoustic());
        let mut out = Vec::new();
        w.submit(reflect(0, 1), 1, 1.0);
        w.judge_due(1.0, &mut out);
        assert_eq!(out, vec![(1, reflect(0, 1))], "at once");
        w.link_fault_start(
            0,
            &FaultKind::Partition {
                groups: vec![vec![0], vec![1, 2]],
            },
        );
        w.link_fault_start(
            1,
            &FaultKind::Delay {
                a: 1,
                b: 2,
                extra_s: 0.5,
            },
        );
        w.submit(reflect(0, 2), 1, 2.0);
        w.submit(reflect(1, 3), 2, 2.0);
        w.judge_due(2.4, &mut out);
        assert_eq!(out.len(), 1, "blocked, and the delayed one not yet due");
        w.judge_due(2.5, &mut out);
        assert_eq!(out[1], (2, reflect(1, 3)));
        w.link_fault_end(0);
        w.link_fault_end(1);
        w.set_dead(1);
        w.submit(reflect(0, 4), 1, 3.0);
        w.judge_due(3.0, &mut out);
        assert_eq!(out.len(), 2, "the dead node gets nothing");
        w.set_alive(1);
        w.submit(reflect(0, 5), 1, 3.0);
        w.judge_due(3.0, &mut out);
        assert_eq!(out[2], (1, reflect(0, 5)));
        let (recs, errs) = w.into_records(0.0);
        assert!(recs.is_empty() && errs.is_empty());
    }

    #[test]
    fn the_shared_clock_runs_at_its_scale() {
        let c = ChannelClock::start(10.0);
        assert!(c.now_s() >= 0.0);
        assert_eq!(c.wall(5.0), Duration::from_millis(500));
        assert_eq!(c.wall(f64::INFINITY), Duration::from_secs(86_400));
    }
}
