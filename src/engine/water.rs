//! The acoustic channel of the processes engine: the
//! coordinator is the water.
//!
//! On the acoustic channel a node process does not send its gossip frames to
//! its peers: it hands each one to the coordinator, stamped with the emulated
//! time it was sent ([`crate::protocol::codec::encode_channel`]). The
//! coordinator puts it on the run's [`Medium`] (the one channel model, as in
//! the discrete-event engine), holds it until its arrival ends, judges it
//! then (half-duplex and collisions in emulated time, the seeded loss draw,
//! a dead addressee) and forwards it to its addressee or drops it. A node
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
//! extra delay) relays its gossip the same way ([`Water::ideal`]):
//! the coordinator applies [`IdealLinks`], the ideal channel's one
//! judgement, shared with the discrete-event engine, and forwards a frame at
//! once or after its fault's delay. Only the acoustic water keeps records
//! (`messages.csv`), as in the discrete-event engine.
//!
//! [`Water`] is I/O-free: times are passed in, and what to forward is
//! returned.

use crate::engine::MessageRecord;
use crate::engine::plan::ChannelPlan;
use crate::model::channel::{Frame, Medium, Reason};
use crate::model::fault::IdealLinks;
use crate::protocol::PeerMsg;
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
        const DAY: Duration = Duration::from_secs(86_400);
        Duration::try_from_secs_f64(emulated_s / self.time_scale).map_or(DAY, |d| d.min(DAY))
    }
}

/// What carries the frames.
#[derive(Debug)]
enum Carrier {
    /// The acoustic channel.
    Acoustic(Box<Medium>),
    /// The ideal channel under link faults, on a run with this seed.
    Ideal(IdealLinks, u64),
}

/// A frame on its way.
#[derive(Debug)]
enum Held {
    /// On the acoustic medium: judged when its arrival ends.
    Frame(Frame, PeerMsg),
    /// On the ideal channel, already judged to arrive: for its addressee.
    Ideal(u32, PeerMsg),
}

/// The water between the node processes of one run.
#[derive(Debug)]
pub struct Water {
    carrier: Carrier,
    clock: ChannelClock,
    /// Frames on their way, by (judgement time in emulated ns, order).
    pending: BTreeMap<(u64, u64), Held>,
    next: u64,
    dead: Vec<bool>,
    records: Vec<MessageRecord>,
    errors_ms: Vec<f64>,
    horizon_s: f64,
}

/// Emulated seconds as an ordered key (nanoseconds, saturating).
fn key(s: f64) -> u64 {
    (s.max(0.0) * 1e9).min(u64::MAX as f64) as u64
}

impl Water {
    /// The water of a run on `plan`'s channel with seed `seed`, on `clock`.
    pub fn new(plan: &ChannelPlan, seed: u64, clock: ChannelClock) -> Water {
        let medium = Medium::new(plan.cfg.clone(), seed, plan.positions.clone(), &plan.links);
        // Nothing judged from now on can overlap what ended this long ago
        // (plus the grace, at any scale).
        let horizon_s =
            plan.overlap_horizon_s() + 1.0 + clock.time_scale * JUDGE_GRACE.as_secs_f64();
        Water::with(
            Carrier::Acoustic(Box::new(medium)),
            plan.positions.len(),
            clock,
            horizon_s,
        )
    }

    /// The relay of a run of `n` nodes with seed `seed` on the ideal channel
    /// under link faults, on `clock` (wall time: `time_scale` 1).
    pub fn ideal(n: usize, seed: u64, clock: ChannelClock) -> Water {
        Water::with(Carrier::Ideal(IdealLinks::default(), seed), n, clock, 0.0)
    }

    fn with(carrier: Carrier, n: usize, clock: ChannelClock, horizon_s: f64) -> Water {
        Water {
            carrier,
            clock,
            pending: BTreeMap::new(),
            next: 0,
            dead: vec![false; n],
            records: Vec::new(),
            errors_ms: Vec::new(),
            horizon_s,
        }
    }

    /// How long after its arrival a frame is judged: [`JUDGE_GRACE`] on the
    /// acoustic channel; none on the ideal one, where a frame's fate is
    /// decided when it is sent.
    fn grace(&self) -> Duration {
        match self.carrier {
            Carrier::Acoustic(_) => JUDGE_GRACE,
            Carrier::Ideal(..) => Duration::ZERO,
        }
    }

    /// The run's emulated clock.
    pub fn clock(&self) -> ChannelClock {
        self.clock
    }

    /// Node `from`'s frame `msg` to `to` ([`crate::protocol::codec::TO_ALL`]:
    /// every other node), sent at emulated time `t_send`: on the medium.
    pub fn submit(&mut self, msg: PeerMsg, to: u32, t_send: f64) {
        let n = self.dead.len() as u32;
        let from = msg.from();
        if from >= n || (to >= n && to != crate::protocol::codec::TO_ALL) || !t_send.is_finite() {
            return;
        }
        // A unicast frame, the common case, allocates nothing here.
        let all: Vec<u32>;
        let to: &[u32] = if to == crate::protocol::codec::TO_ALL {
            all = (0..n).filter(|&j| j != from).collect();
            &all
        } else {
            std::slice::from_ref(&to)
        };
        match &mut self.carrier {
            Carrier::Acoustic(medium) => {
                let bits = medium.cfg().frame_bits(msg.values());
                let mut hold = |f: Frame| {
                    self.pending
                        .insert((key(f.arrive_end), self.next), Held::Frame(f, msg));
                    self.next += 1;
                };
                match to {
                    [one] => hold(medium.send(t_send, from, *one, bits)),
                    all => medium
                        .broadcast(t_send, from, all, bits)
                        .into_iter()
                        .for_each(hold),
                }
            }
            Carrier::Ideal(links, seed) => {
                for &j in to {
                    if let Some(d) = links.send(*seed, from, j) {
                        self.pending
                            .insert((key(t_send + d), self.next), Held::Ideal(j, msg));
                        self.next += 1;
                    }
                }
            }
        }
    }

    /// The wall time from now until the next judgement is due, if any frame
    /// is on its way.
    pub fn next_due(&self) -> Option<Duration> {
        let (&(ns, _), _) = self.pending.first_key_value()?;
        let wait_s = ns as f64 * 1e-9 - self.clock.now_s();
        Some(self.clock.wall(wait_s.max(0.0)) + self.grace())
    }

    /// Judges every frame whose arrival ended at least [`JUDGE_GRACE`] before
    /// `now_s` (emulated), records it, and appends the delivered ones to
    /// `out` as `(addressee, message)`.
    pub fn judge_due(&mut self, now_s: f64, out: &mut Vec<(u32, PeerMsg)>) {
        let grace_s = self.clock.time_scale * self.grace().as_secs_f64();
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0 as f64 * 1e-9 + grace_s > now_s {
                break;
            }
            let (f, msg) = match entry.remove() {
                Held::Frame(f, msg) => (f, msg),
                Held::Ideal(to, msg) => {
                    if !self.dead[to as usize] {
                        out.push((to, msg));
                    }
                    continue;
                }
            };
            let Carrier::Acoustic(medium) = &mut self.carrier else {
                continue;
            };
            let rec = MessageRecord::judge(medium, &f, &msg, self.dead[f.to as usize]);
            let delivered = rec.lost.is_none();
            self.records.push(rec);
            if delivered {
                self.errors_ms.push((now_s - f.arrive_end) * 1e3);
                out.push((f.to, msg));
            }
        }
        if let Carrier::Acoustic(medium) = &mut self.carrier {
            medium.forget_before(now_s - self.horizon_s);
        }
    }

    /// Node `node` discarded a frame `kind` from `from` as late: its record
    /// (the latest such frame delivered) is marked.
    pub fn mark_late(&mut self, node: u32, from: u32, kind: &str) {
        if let Some(r) = self
            .records
            .iter_mut()
            .rev()
            .take(1 << 16)
            .find(|r| r.to == node && r.from == from && r.kind == kind && r.lost.is_none())
        {
            r.lost = Some(Reason::Late);
            r.t_recv = None;
        }
    }

    /// Fault `id` (a partition, link loss or delay) starts on the links.
    pub fn link_fault_start(&mut self, id: usize, kind: &crate::model::fault::FaultKind) {
        match &mut self.carrier {
            Carrier::Acoustic(m) => m.link_faults.start(id, kind),
            Carrier::Ideal(l, _) => l.faults.start(id, kind),
        }
    }

    /// Fault `id` ends.
    pub fn link_fault_end(&mut self, id: usize) {
        match &mut self.carrier {
            Carrier::Acoustic(m) => m.link_faults.end(id),
            Carrier::Ideal(l, _) => l.faults.end(id),
        }
    }

    /// Node `node` is up again (restarted): frames to it are delivered.
    pub fn set_alive(&mut self, node: u32) {
        if let Some(d) = self.dead.get_mut(node as usize) {
            *d = false;
        }
    }

    /// Whether this is the acoustic channel (which keeps records).
    pub fn is_acoustic(&self) -> bool {
        matches!(self.carrier, Carrier::Acoustic(_))
    }

    /// Node `node` is dead (or left out): frames to it are lost as `node_down`.
    pub fn set_dead(&mut self, node: u32) {
        if let Some(d) = self.dead.get_mut(node as usize) {
            *d = true;
        }
    }

    /// Every frame judged so far, in the order judged, with its times moved
    /// `offset_s` earlier, and the realised delivery errors (emulated ms).
    pub fn into_records(self, offset_s: f64) -> (Vec<MessageRecord>, Vec<f64>) {
        let mut recs = self.records;
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
    use crate::model::channel::AcousticCfg;
    use crate::model::geometry::{Vec2, Vec3};

    fn plan() -> ChannelPlan {
        ChannelPlan {
            cfg: AcousticCfg::default(),
            positions: vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1500.0, 0.0),
                Vec2::new(0.0, 3000.0),
            ],
            links: vec![vec![1, 2], vec![0], vec![0]],
            exchange_timeout_s: 5.0,
            round_timeout_s: None,
        }
    }

    fn reflect(from: u32, seq: u64) -> PeerMsg {
        PeerMsg::Reflect {
            from,
            seq,
            r: Vec3::new(1.0, 2.0, 3.0),
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
