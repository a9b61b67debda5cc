//! The water between the nodes, I/O-free: what becomes of every frame one
//! node sends another, on the ideal or the acoustic channel.
//!
//! Every engine drives one [`Channel`] the same way. When a node sends, the
//! engine hands the frame to [`Channel::send`] or [`Channel::broadcast`], which
//! say when each copy's fate is due (an [`InFlight`] and its time). The
//! engine holds the copy in its own scheduler (the discrete-event engine's
//! queue in virtual time, the coordinator's relay on wall time for node
//! processes) and gives it back to [`Channel::arrive`] when that time has
//! come; `arrive` judges it and says whether it is delivered. The channel
//! decides every route, delay, loss and record, once:
//!
//! - **ideal**: a frame arrives at once unless a link fault blocks, drops
//!   (seeded draw) or delays it ([`IdealLinks`]); no records are kept;
//! - **acoustic** ([`Medium`]): a frame is judged when its arrival ends
//!   (propagation delay, half-duplex, collisions, the seeded loss draw, link
//!   faults) and recorded ([`MessageRecord`], a row of `messages.csv`); the
//!   sync root's Average is one transmission heard by every other node.
//!
//! A frame to a node that is down is lost as `node_down`; the engine says
//! which nodes are down when it gives a frame back.

use crate::model::channel::{Fate, Frame, Medium, Nanos, Reason, nanos, seconds};
use crate::model::drift::Drift;
use crate::model::fault::{FaultKind, IdealLinks};
use crate::model::mac::Mac;
use crate::model::rng::{Stream, link_draw};
use crate::model::xy::Pt;
use crate::protocol::{ChannelPlan, PeerMsg};
use crate::world::time::wait;
use std::collections::BTreeMap;
use std::time::Duration;

/// The acoustic channel's log of a run (`messages.csv` and the channel's
/// statistics in `metrics.json`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelLog {
    /// Every frame between two nodes, in the order judged.
    pub messages: Vec<MessageRecord>,
    /// The emulated time the run covered, seconds.
    pub emulated_seconds: f64,
    /// Discrete-event engine: events handled (node ticks, deliveries, frame
    /// judgements, coordinator timers and reports).
    pub events: Option<u64>,
    /// Processes engine: every delivered frame's realised error, forwarded
    /// minus planned end of arrival (emulated ms).
    pub delivery_errors_ms: Vec<f64>,
}

/// One frame between two nodes on the acoustic channel (a row of
/// `messages.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct MessageRecord {
    /// When its transmission started (emulated seconds; later than the
    /// node's send when its modem was still busy with an earlier frame).
    pub t_send: f64,
    /// When its arrival ended (delivered frames only).
    pub t_recv: Option<f64>,
    /// Sender.
    pub from: u32,
    /// Addressee.
    pub to: u32,
    /// Message kind ([`PeerMsg::kind`]).
    pub kind: &'static str,
    /// Bits on the channel.
    pub bits: u64,
    /// `None`: delivered (or still in flight); else why it was lost.
    pub lost: Option<Reason>,
    /// The run ended before its arrival did: never judged (`t_recv` and
    /// `lost` are `None`).
    pub in_flight: bool,
    /// Under the SINR reception rule, its worst SINR over the arrival, dB
    /// (`sinr_db` in `messages.csv`, written only under that rule).
    pub sinr_db: Option<f64>,
}

impl MessageRecord {
    /// Judge frame `f` carrying `msg` on `medium` (a frame to a dead node is
    /// lost as `node_down`): its record.
    fn judge(medium: &Medium, f: &Frame, msg: &PeerMsg, to_dead: bool) -> MessageRecord {
        let (fate, sinr_db) = medium.judged(f);
        let fate = match fate {
            Fate::Delivered if to_dead => Fate::Lost(Reason::NodeDown),
            fate => fate,
        };
        MessageRecord {
            t_send: seconds(f.t_start),
            t_recv: (fate == Fate::Delivered).then_some(seconds(f.arrive_end)),
            from: f.from,
            to: f.to,
            kind: msg.kind(),
            bits: f.bits,
            lost: match fate {
                Fate::Delivered => None,
                Fate::Lost(r) => Some(r),
            },
            in_flight: false,
            sinr_db,
        }
    }

    /// The record of frame `f` (a `kind` message) whose arrival had not
    /// ended when the run did.
    fn in_flight(f: &Frame, kind: &'static str) -> MessageRecord {
        MessageRecord {
            t_send: seconds(f.t_start),
            t_recv: None,
            from: f.from,
            to: f.to,
            kind,
            bits: f.bits,
            lost: None,
            in_flight: true,
            sinr_db: None,
        }
    }

    /// The fate written to `messages.csv`: `delivered`, `lost` or
    /// `in_flight`.
    pub fn fate(&self) -> &'static str {
        match (self.in_flight, self.lost) {
            (true, _) => "in_flight",
            (false, None) => "delivered",
            (false, Some(_)) => "lost",
        }
    }
}

/// What carries the frames.
#[derive(Debug)]
enum Carrier {
    Acoustic(Box<Medium>),
    Ideal(IdealLinks),
}

/// One copy of a frame on its way to one addressee: the engine holds it
/// until the time [`Channel::send`] gave, then hands it to
/// [`Channel::arrive`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InFlight {
    msg: PeerMsg,
    way: Way,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Way {
    /// On the acoustic medium: judged when its arrival ends.
    Acoustic(Frame),
    /// On the ideal channel, already judged to arrive: for this addressee.
    Ideal(u32),
    /// Under CSMA, not yet on the water: due when its sender senses the
    /// channel (again), addressed to `to` ([`ALL`]: every other node), from
    /// the sender's life `life` (a crash ends it and withdraws the frame).
    Pending {
        from: u32,
        to: u32,
        attempt: u32,
        life: u32,
    },
}

/// The addressee of a pending broadcast.
const ALL: u32 = u32::MAX;

impl InFlight {
    /// The addressee.
    pub fn to(&self) -> u32 {
        match &self.way {
            Way::Acoustic(f) => f.to,
            Way::Ideal(to) | Way::Pending { to, .. } => *to,
        }
    }

    /// On the acoustic channel: when its arrival ends (emulated seconds).
    pub fn arrive_end_s(&self) -> Option<f64> {
        match &self.way {
            Way::Acoustic(f) => Some(seconds(f.arrive_end)),
            Way::Ideal(_) | Way::Pending { .. } => None,
        }
    }
}

/// The channel of one run between its `n` nodes.
#[derive(Debug)]
pub struct Channel {
    carrier: Carrier,
    seed: u64,
    n: u32,
    records: Vec<MessageRecord>,
    /// Acoustic copies sent and not yet judged, by (transmission id,
    /// addressee): what is still in the water when the run ends.
    flying: BTreeMap<(u64, u32), (Frame, &'static str)>,
    /// Receivers that drift: their sample-0 positions and their drifts.
    drift: Option<(Vec<Pt>, Vec<Option<Drift>>)>,
    /// Per node: CSMA backoffs drawn so far.
    backoffs: Vec<u64>,
    /// Per node: how many times it died; a pending frame of an earlier
    /// life is withdrawn.
    lives: Vec<u32>,
}

impl Channel {
    /// The acoustic channel `plan` describes, on a run with seed `seed`:
    /// the one every engine judges frames on.
    pub fn planned(plan: &ChannelPlan, seed: u64) -> Channel {
        let medium = Medium::new(plan.cfg.clone(), seed, plan.positions.clone(), &plan.links);
        let mut ch = Channel::acoustic(medium, seed);
        if plan.drift.iter().any(Option::is_some) {
            ch.drift = Some((plan.positions.clone(), plan.drift.clone()));
        }
        ch
    }

    /// Sample `k` begins: drifting receivers move to their positions of that
    /// sample on the acoustic medium (nothing else changes). The engines
    /// call it as each sample completes ([`crate::engine::Actuator::sample_done`]).
    pub fn at_sample(&mut self, k: usize) {
        let (Some((start, drift)), Carrier::Acoustic(m)) = (&self.drift, &mut self.carrier) else {
            return;
        };
        let pos = start
            .iter()
            .enumerate()
            .map(|(i, p)| match drift.get(i) {
                Some(Some(d)) => d.position_pt(p, k),
                _ => *p,
            })
            .collect();
        m.move_to(pos);
    }

    /// The ideal channel between `n` nodes of a run with seed `seed`.
    pub fn ideal(n: usize, seed: u64) -> Channel {
        Channel::with(Carrier::Ideal(IdealLinks::default()), n, seed)
    }

    /// The acoustic channel `medium` (built with the run's seed `seed`).
    pub fn acoustic(medium: Medium, seed: u64) -> Channel {
        let n = medium.nodes();
        Channel::with(Carrier::Acoustic(Box::new(medium)), n, seed)
    }

    fn with(carrier: Carrier, n: usize, seed: u64) -> Channel {
        Channel {
            carrier,
            seed,
            n: u32::try_from(n).unwrap_or(u32::MAX),
            records: Vec::new(),
            flying: BTreeMap::new(),
            drift: None,
            backoffs: vec![0; n],
            lives: vec![0; n],
        }
    }

    /// Whether this is the acoustic channel (which keeps records).
    pub fn is_acoustic(&self) -> bool {
        matches!(self.carrier, Carrier::Acoustic(_))
    }

    /// How long after a transmission ended nothing judged later can overlap
    /// it, seconds: two airtimes of the largest frame (zero on the ideal
    /// channel, where nothing overlaps).
    pub fn overlap_horizon_s(&self) -> f64 {
        match &self.carrier {
            Carrier::Acoustic(m) => {
                2.0 * m
                    .cfg()
                    .transmission_s(m.cfg().frame_bits(PeerMsg::max_values(m.dim())))
            }
            Carrier::Ideal(_) => 0.0,
        }
    }

    /// Node `from` sends `msg` to node `to` at `now`: the copy on its way and
    /// when its fate is due, pushed to `out` (nothing when the channel
    /// already lost it, or for a node that is not in the run).
    pub fn send(
        &mut self,
        now: Duration,
        from: u32,
        to: u32,
        msg: PeerMsg,
        out: &mut Vec<(Duration, InFlight)>,
    ) {
        if from >= self.n || to >= self.n {
            return;
        }
        match &mut self.carrier {
            Carrier::Acoustic(m) if matches!(m.cfg().mac, Mac::Csma { .. }) => {
                let life = self.lives[from as usize];
                out.push((now, pending(msg, from, to, 0, life)));
            }
            Carrier::Acoustic(m) => {
                let bits = m.cfg().frame_bits(msg.values());
                let f = m.send(nanos_of(now), from, to, bits);
                self.flying.insert((f.id, f.to), (f, msg.kind()));
                out.push(acoustic(f, msg));
            }
            Carrier::Ideal(links) => {
                if let Some(d) = links.send(self.seed, from, to) {
                    out.push((now + wait(d), ideal(to, msg)));
                }
            }
        }
    }

    /// Node `from` sends `msg` to every other node at `now` (one
    /// transmission on the acoustic channel): the copies on their way, in
    /// the order of the addressees, pushed to `out`. The sender's own copy is
    /// not on the channel.
    pub fn broadcast(
        &mut self,
        now: Duration,
        from: u32,
        msg: PeerMsg,
        out: &mut Vec<(Duration, InFlight)>,
    ) {
        if from >= self.n {
            return;
        }
        match &mut self.carrier {
            Carrier::Acoustic(m) if matches!(m.cfg().mac, Mac::Csma { .. }) => {
                let life = self.lives[from as usize];
                out.push((now, pending(msg, from, ALL, 0, life)));
            }
            Carrier::Acoustic(m) => {
                let others: Vec<u32> = (0..self.n).filter(|&j| j != from).collect();
                let bits = m.cfg().frame_bits(msg.values());
                for f in m.broadcast(nanos_of(now), from, &others, bits) {
                    self.flying.insert((f.id, f.to), (f, msg.kind()));
                    out.push(acoustic(f, msg));
                }
            }
            Carrier::Ideal(_) => {
                for j in (0..self.n).filter(|&j| j != from) {
                    self.send(now, from, j, msg, out);
                }
            }
        }
    }

    /// What the engines call when a copy they hold is due at `now`: a copy
    /// in the water is judged ([`Channel::arrive`]); a CSMA frame pending its
    /// sender's carrier sense is sensed for, and either put on the water or
    /// given another backoff, the copies pushed to `out` as
    /// [`Channel::send`] does. A pending frame whose sender died since it was
    /// sent ([`Channel::sender_died`]) is withdrawn: it never reaches the
    /// water (and `messages.csv`), as a crashed modem sends nothing.
    pub fn due(
        &mut self,
        f: InFlight,
        to_dead: bool,
        now: Duration,
        out: &mut Vec<(Duration, InFlight)>,
    ) -> Option<(u32, PeerMsg)> {
        let Way::Pending {
            from,
            to,
            attempt,
            life,
        } = f.way
        else {
            return self.arrive(f, to_dead);
        };
        if self.lives.get(from as usize) != Some(&life) {
            return None;
        }
        let Carrier::Acoustic(m) = &mut self.carrier else {
            return None;
        };
        let Mac::Csma {
            backoff_s,
            max_attempts,
        } = m.cfg().mac
        else {
            return None;
        };
        let t = nanos_of(now);
        if m.senses_busy(from, t) && attempt + 1 < max_attempts {
            let k = &mut self.backoffs[from as usize];
            let draw = link_draw(self.seed, Stream::Mac, from, 0, *k);
            *k += 1;
            out.push((
                now + wait(draw * backoff_s),
                pending(f.msg, from, to, attempt + 1, life),
            ));
            return None;
        }
        let bits = m.cfg().frame_bits(f.msg.values());
        let frames = if to == ALL {
            let others: Vec<u32> = (0..self.n).filter(|&j| j != from).collect();
            m.broadcast(t, from, &others, bits)
        } else {
            vec![m.send(t, from, to, bits)]
        };
        for fr in frames {
            self.flying.insert((fr.id, fr.to), (fr, f.msg.kind()));
            out.push(acoustic(fr, f.msg));
        }
        None
    }

    /// Node `node` died (a crash, a cut-off, the old life of a restart):
    /// what it still had pending its carrier sense is withdrawn. Frames
    /// already on the water travel on.
    pub fn sender_died(&mut self, node: u32) {
        if let Some(l) = self.lives.get_mut(node as usize) {
            *l = l.wrapping_add(1);
        }
    }

    /// The copy `f` is due, and its addressee is down (`to_dead`) or not:
    /// judged (and recorded on the acoustic channel). `Some((to, msg))` if
    /// it is delivered.
    pub fn arrive(&mut self, f: InFlight, to_dead: bool) -> Option<(u32, PeerMsg)> {
        let InFlight { msg, way } = f;
        match (way, &self.carrier) {
            (Way::Acoustic(frame), Carrier::Acoustic(m)) => {
                self.flying.remove(&(frame.id, frame.to));
                let rec = MessageRecord::judge(m, &frame, &msg, to_dead);
                let delivered = rec.lost.is_none();
                self.records.push(rec);
                delivered.then_some((frame.to, msg))
            }
            (Way::Ideal(to), _) => (!to_dead).then_some((to, msg)),
            (Way::Acoustic(_), Carrier::Ideal(_)) | (Way::Pending { .. }, _) => None,
        }
    }

    /// Node `node` discarded a delivered frame `kind` from `from` as late
    /// (the wait it answered was over): the record of the latest such frame
    /// is marked `late`.
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
    pub fn link_fault_start(&mut self, id: usize, kind: &FaultKind) {
        match &mut self.carrier {
            Carrier::Acoustic(m) => m.link_faults.start(id, kind),
            Carrier::Ideal(l) => l.faults.start(id, kind),
        }
    }

    /// Fault `id` ends.
    pub fn link_fault_end(&mut self, id: usize) {
        match &mut self.carrier {
            Carrier::Acoustic(m) => m.link_faults.end(id),
            Carrier::Ideal(l) => l.faults.end(id),
        }
    }

    /// Forget the transmissions and arrivals that ended before
    /// `now_s - overlap_horizon_s - margin_s` (emulated seconds): nothing
    /// judged from `now_s` on can overlap them. Keeps memory bounded.
    pub fn forget(&mut self, now_s: f64, margin_s: f64) {
        let horizon = self.overlap_horizon_s();
        if let Carrier::Acoustic(m) = &mut self.carrier {
            m.forget_before(nanos(now_s - (horizon + margin_s)));
        }
    }

    /// Every frame judged so far, in the order judged, then every frame
    /// still in the water, marked in flight, in the order sent (acoustic
    /// channel; none on the ideal one).
    pub fn into_records(self) -> Vec<MessageRecord> {
        let mut records = self.records;
        records.extend(
            self.flying
                .values()
                .map(|(f, kind)| MessageRecord::in_flight(f, kind)),
        );
        records
    }
}

/// A virtual time as [`Nanos`] (saturating after about 584 years).
fn nanos_of(t: Duration) -> Nanos {
    u64::try_from(t.as_nanos()).unwrap_or(u64::MAX)
}

fn acoustic(f: Frame, msg: PeerMsg) -> (Duration, InFlight) {
    (
        Duration::from_nanos(f.arrive_end),
        InFlight {
            msg,
            way: Way::Acoustic(f),
        },
    )
}

fn pending(msg: PeerMsg, from: u32, to: u32, attempt: u32, life: u32) -> InFlight {
    InFlight {
        msg,
        way: Way::Pending {
            from,
            to,
            attempt,
            life,
        },
    }
}

fn ideal(to: u32, msg: PeerMsg) -> InFlight {
    InFlight {
        msg,
        way: Way::Ideal(to),
    }
}

#[cfg(test)]
mod tests {
    use super::{Channel, InFlight};
    use crate::model::channel::{AcousticCfg, Medium, Reason};
    use crate::model::coords::Coords;
    use crate::model::fault::FaultKind;
    use crate::model::xy::Pt;
    use crate::protocol::PeerMsg;
    use crate::world::time::at;
    use approx::assert_relative_eq;
    use std::time::Duration;

    fn reflect(from: u32, seq: u64) -> PeerMsg {
        PeerMsg::Reflect {
            from,
            seq,
            r: Coords::from([1.0, 2.0, 3.0]),
        }
    }

    /// Three nodes: 1500 m (1 s) from node 0 to node 1, 3000 m to node 2,
    /// every node in reach of node 0.
    fn acoustic() -> Channel {
        let pos = vec![Pt::xy(0.0, 0.0), Pt::xy(1500.0, 0.0), Pt::xy(0.0, 3000.0)];
        let links = vec![vec![1, 2], vec![0], vec![0]];
        Channel::acoustic(Medium::new(AcousticCfg::default(), 7, pos, &links), 7)
    }

    fn sent(
        ch: &mut Channel,
        now: f64,
        from: u32,
        to: u32,
        msg: PeerMsg,
    ) -> Vec<(Duration, InFlight)> {
        let mut out = Vec::new();
        ch.send(at(now), from, to, msg, &mut out);
        out
    }

    #[test]
    fn the_ideal_channel_delivers_at_once_unless_a_link_fault_blocks_or_delays_and_keeps_no_records()
     {
        let mut ch = Channel::ideal(3, 7);
        assert!(!ch.is_acoustic());
        assert_relative_eq!(ch.overlap_horizon_s(), 0.0);
        let out = sent(&mut ch, 1.0, 0, 1, reflect(0, 1));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].0, at(1.0), "at once");
        assert_eq!(ch.arrive(out[0].1, false), Some((1, reflect(0, 1))));
        ch.link_fault_start(
            0,
            &FaultKind::Partition {
                groups: vec![vec![0], vec![1, 2]],
            },
        );
        ch.link_fault_start(
            1,
            &FaultKind::Delay {
                a: 1,
                b: 2,
                extra_s: 0.5,
            },
        );
        assert!(
            sent(&mut ch, 2.0, 0, 1, reflect(0, 2)).is_empty(),
            "blocked"
        );
        let out = sent(&mut ch, 2.0, 1, 2, reflect(1, 3));
        assert_eq!(out[0].0, at(2.5), "delayed");
        ch.link_fault_end(0);
        ch.link_fault_end(1);
        let out = sent(&mut ch, 3.0, 0, 1, reflect(0, 4));
        assert_eq!(ch.arrive(out[0].1, true), None, "the addressee is down");
        assert!(
            sent(&mut ch, 3.0, 0, 9, reflect(0, 5)).is_empty(),
            "no such node"
        );
        assert!(ch.into_records().is_empty());
    }

    #[test]
    fn a_frame_not_yet_arrived_when_the_run_ends_is_recorded_in_flight_after_the_judged_ones() {
        let mut ch = acoustic();
        let first = sent(&mut ch, 1.0, 0, 1, reflect(0, 1));
        let second = sent(&mut ch, 2.0, 0, 2, reflect(0, 2));
        assert!(ch.arrive(first[0].1, false).is_some());
        assert_eq!(second.len(), 1);
        let recs = ch.into_records();
        assert_eq!(recs.len(), 2);
        assert_eq!((recs[0].fate(), recs[0].to), ("delivered", 1));
        assert_eq!((recs[1].fate(), recs[1].to), ("in_flight", 2));
        assert!(recs[1].in_flight && recs[1].t_recv.is_none() && recs[1].lost.is_none());
        assert_relative_eq!(recs[1].t_send, 2.0);
    }

    #[test]
    fn an_acoustic_frame_is_due_when_its_arrival_ends_and_is_judged_and_recorded_then() {
        let mut ch = acoustic();
        // 1 s of propagation, 0.24 s on the air.
        let out = sent(&mut ch, 10.0, 0, 1, reflect(0, 1));
        assert_eq!(out.len(), 1);
        let end = out[0].1.arrive_end_s().expect("an acoustic frame");
        assert_relative_eq!(end, 10.0 + 1.0 + 0.24, epsilon = 1e-12);
        assert_eq!(out[0].0, at(end));
        assert_eq!(out[0].1.to(), 1);
        assert_eq!(ch.arrive(out[0].1, false), Some((1, reflect(0, 1))));
        let out = sent(&mut ch, 20.0, 0, 2, reflect(0, 2));
        assert_eq!(ch.arrive(out[0].1, true), None);
        ch.mark_late(1, 0, "reflect");
        let recs = ch.into_records();
        assert_eq!(recs.len(), 2);
        assert_eq!((recs[0].from, recs[0].to, recs[0].kind), (0, 1, "reflect"));
        assert_relative_eq!(recs[0].t_send, 10.0);
        assert_eq!(recs[0].lost, Some(Reason::Late), "marked late");
        assert_eq!(recs[0].t_recv, None);
        assert_eq!(recs[1].lost, Some(Reason::NodeDown));
    }

    #[test]
    fn a_broadcast_is_one_transmission_heard_by_every_other_node_in_order() {
        let mut ch = acoustic();
        let mut out = Vec::new();
        ch.broadcast(at(1.0), 0, reflect(0, 1), &mut out);
        let to: Vec<u32> = out.iter().map(|(_, f)| f.to()).collect();
        assert_eq!(to, vec![1, 2]);
        // Node 2 is twice as far: its copy arrives one second later.
        let ends: Vec<f64> = out.iter().filter_map(|(_, f)| f.arrive_end_s()).collect();
        assert_relative_eq!(ends[1] - ends[0], 1.0, epsilon = 1e-9);
        let mut ideal = Channel::ideal(3, 7);
        let mut out = Vec::new();
        ideal.broadcast(at(1.0), 1, reflect(1, 1), &mut out);
        let to: Vec<u32> = out.iter().map(|(_, f)| f.to()).collect();
        assert_eq!(to, vec![0, 2]);
        assert!(out.iter().all(|(t, _)| *t == at(1.0)));
    }

    #[test]
    fn the_overlap_horizon_is_two_airtimes_of_the_largest_frame() {
        let ch = acoustic();
        let cfg = AcousticCfg::default();
        let airtime = cfg.transmission_s(cfg.frame_bits(PeerMsg::max_values(2)));
        assert_relative_eq!(ch.overlap_horizon_s(), 2.0 * airtime);
    }

    #[test]
    fn under_csma_a_node_that_hears_an_arrival_backs_off_and_an_idle_one_sends_at_once() {
        let cfg = AcousticCfg {
            mac: crate::model::mac::Mac::Csma {
                backoff_s: 0.5,
                max_attempts: 8,
            },
            ..AcousticCfg::default()
        };
        let pos = vec![Pt::xy(0.0, 0.0), Pt::xy(1500.0, 0.0), Pt::xy(0.0, 3000.0)];
        let links = vec![vec![1, 2], vec![0], vec![0]];
        let mut ch = Channel::acoustic(Medium::new(cfg, 7, pos, &links), 7);
        // Node 0 sends to 1 at 0 s: pending, sensed at once, on the water.
        let first = sent(&mut ch, 0.0, 0, 1, reflect(0, 1));
        assert_eq!(first.len(), 1);
        assert_eq!(first[0].0, at(0.0), "due at once for its carrier sense");
        let mut out = Vec::new();
        assert!(ch.due(first[0].1, false, at(0.0), &mut out).is_none());
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].1.arrive_end_s(), Some(1.0 + 0.24), "sent at 0 s");
        // Node 1 hears it over [1, 1.24) s: at 1.1 s it backs off.
        let second = sent(&mut ch, 1.1, 1, 0, reflect(1, 2));
        let mut out2 = Vec::new();
        assert!(ch.due(second[0].1, false, at(1.1), &mut out2).is_none());
        assert_eq!(out2.len(), 1);
        assert_eq!(out2[0].1.arrive_end_s(), None, "still pending");
        assert!(
            out2[0].0 > at(1.1) && out2[0].0 < at(1.6),
            "{:?}",
            out2[0].0
        );
        // At 1.3 s the channel at node 1 is idle: it sends at once.
        let mut out3 = Vec::new();
        assert!(ch.due(out2[0].1, false, at(1.3), &mut out3).is_none());
        assert_eq!(out3[0].1.arrive_end_s(), Some(1.3 + 1.0 + 0.24));
        // The first copy arrives whole.
        assert_eq!(ch.arrive(out[0].1, false), Some((1, reflect(0, 1))));
    }

    #[test]
    fn under_csma_a_frame_pending_its_senders_carrier_sense_is_withdrawn_when_the_sender_dies() {
        let cfg = AcousticCfg {
            mac: crate::model::mac::Mac::Csma {
                backoff_s: 0.5,
                max_attempts: 8,
            },
            ..AcousticCfg::default()
        };
        let pos = vec![Pt::xy(0.0, 0.0), Pt::xy(1500.0, 0.0)];
        let links = vec![vec![1], vec![0]];
        let mut ch = Channel::acoustic(Medium::new(cfg, 7, pos, &links), 7);
        let before = sent(&mut ch, 0.0, 0, 1, reflect(0, 1));
        ch.sender_died(0);
        let mut out = Vec::new();
        assert!(ch.due(before[0].1, false, at(0.0), &mut out).is_none());
        assert!(out.is_empty(), "withdrawn: {out:?}");
        // The next life (a restart) sends as before; its addressee's death
        // does not withdraw it.
        let after = sent(&mut ch, 1.0, 0, 1, reflect(0, 2));
        ch.sender_died(1);
        assert!(ch.due(after[0].1, false, at(1.0), &mut out).is_none());
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].1.arrive_end_s(), Some(1.0 + 1.0 + 0.24));
        // Only the frame of the new life is in the water (in flight).
        let recs = ch.into_records();
        assert_eq!(recs.len(), 1);
        assert_eq!(recs[0].t_send.to_bits(), 1f64.to_bits());
    }
}
