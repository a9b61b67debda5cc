//! The shared medium of one run (I/O-free): every transmission and every
//! arrival, and the fate of each frame by the rules of the channel model
//! (the parent module's docs).

use super::{AcousticCfg, Nanos, nanos};
use crate::model::mac::Schedule;
use crate::model::reception::{Reception, linear, worst_sinr_db};
use crate::model::rng::{Stream, link_draw};
use crate::model::xy::Pt;
use serde::{Deserialize, Serialize};

/// The uniform draw in `[0, 1)` that decides the random loss of frame number
/// `k` on the directed link `from -> to` of a run with seed `seed`.
pub fn fate_draw(seed: u64, from: u32, to: u32, k: u64) -> f64 {
    link_draw(seed, Stream::Channel, from, to, k)
}

/// Why a frame was lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// The random loss of the link.
    Loss,
    /// Another frame arrived at the receiver at the same time.
    Collision,
    /// The receiver was transmitting.
    HalfDuplex,
    /// The link is blocked.
    Blocked,
    /// The addressee was down (dead, or left out by the coordinator).
    NodeDown,
    /// It arrived after the wait it answers was over, and was discarded
    /// ([`crate::protocol::Counters::late`]).
    Late,
}

impl Reason {
    /// Every reason, in the order of the module docs.
    pub const ALL: [Reason; 6] = [
        Reason::Blocked,
        Reason::HalfDuplex,
        Reason::Collision,
        Reason::Loss,
        Reason::NodeDown,
        Reason::Late,
    ];

    /// The name written to `messages.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::Loss => "loss",
            Reason::Collision => "collision",
            Reason::HalfDuplex => "half_duplex",
            Reason::Blocked => "blocked",
            Reason::NodeDown => "node_down",
            Reason::Late => "late",
        }
    }
}

/// What became of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// It arrived whole.
    Delivered,
    /// It was lost, and why.
    Lost(Reason),
}

/// A frame on the medium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Its id on the medium (0, 1, ... in the order sent).
    pub id: u64,
    /// Sender.
    pub from: u32,
    /// Addressee.
    pub to: u32,
    /// Its number on the link `from -> to` (0, 1, ...).
    pub number: u64,
    /// Bits.
    pub bits: u64,
    /// When the sender asked to send it ([`Nanos`]).
    pub t_send: Nanos,
    /// When its transmission started (the modem was free).
    pub t_start: Nanos,
    /// When its arrival at the addressee starts.
    pub arrive_start: Nanos,
    /// When its arrival ends: the time its fate is judged ([`Medium::judge`]).
    pub arrive_end: Nanos,
}

/// The shared medium of one run: the nodes' positions and links, every
/// transmission and every arrival so far. I/O-free: times are passed in.
#[derive(Debug, Clone)]
pub struct Medium {
    cfg: AcousticCfg,
    seed: u64,
    pos: Vec<Pt>,
    /// `reach[i]`: the nodes that node `i`'s transmissions reach.
    reach: Vec<Vec<u32>>,
    /// Per node: when its modem is free again.
    free_at: Vec<Nanos>,
    /// The TDMA schedule, if any.
    schedule: Option<Schedule>,
    /// Per node: its transmissions `[start, end)`.
    sending: Vec<Vec<(Nanos, Nanos)>>,
    /// Per node: the arrivals at it `[start, end)`, the frame's id and its
    /// sender.
    arriving: Vec<Vec<(Nanos, Nanos, u64, u32)>>,
    /// Frames sent so far (the next frame's id).
    sent: u64,
    /// Frames sent per directed link.
    numbers: std::collections::HashMap<(u32, u32), u64>,
    /// The faults in force on the links (partitions, extra loss
    /// and delay), set by the engine as they start and end.
    pub link_faults: crate::model::fault::LinkFaults,
}

impl Medium {
    /// A medium for nodes at `pos`, where node `i` reaches the nodes
    /// `links[i]` (the gossip graph), with a validated `cfg` and the run seed.
    /// Under the SINR rule every node reaches every other, whatever `links`
    /// ([`AcousticCfg::physical_reach`]).
    pub fn new(cfg: AcousticCfg, seed: u64, pos: Vec<Pt>, links: &[Vec<u32>]) -> Medium {
        let n = pos.len();
        let reach = cfg.physical_reach(n, links);
        let schedule = cfg.schedule(&pos, links);
        Medium {
            schedule,
            cfg,
            seed,
            reach,
            free_at: vec![0; n],
            sending: vec![Vec::new(); n],
            arriving: vec![Vec::new(); n],
            sent: 0,
            pos,
            numbers: std::collections::HashMap::new(),
            link_faults: Default::default(),
        }
    }

    /// One-way delay of the link `i -> j`, seconds.
    pub fn delay(&self, i: u32, j: u32) -> f64 {
        self.cfg
            .travel_time_s(&self.pos[i as usize], &self.pos[j as usize])
            + self.cfg.link(i, j).map_or(0.0, |l| l.extra_delay_s)
            + self.link_faults.delay(i, j)
    }

    /// [`Medium::delay`] rounded to the nanosecond: the delay the medium
    /// uses.
    pub fn delay_ns(&self, i: u32, j: u32) -> Nanos {
        nanos(self.delay(i, j))
    }

    /// Node `from` sends a frame of `bits` bits to `to` at time `t`: its
    /// modem transmits it when free, every node that hears `from` receives
    /// it, and its fate is judged at [`Frame::arrive_end`] by [`Medium::judge`].
    pub fn send(&mut self, t: Nanos, from: u32, to: u32, bits: u64) -> Frame {
        let (id, start, end) = self.transmit(t, from, &[to], bits);
        self.frame(id, from, to, bits, t, start, end)
    }

    /// The nodes are now at `pos` (receivers that drift, at the start of a
    /// sample): later transmissions take their delays, and later
    /// judgements their range loss, from these positions. Ignored unless
    /// there is one position per node.
    pub fn move_to(&mut self, pos: Vec<Pt>) {
        if pos.len() == self.pos.len() {
            self.pos = pos;
        }
    }

    /// How many nodes it joins.
    pub fn nodes(&self) -> usize {
        self.pos.len()
    }

    /// The run's dimension, 2 or 3: the positions'.
    pub fn dim(&self) -> usize {
        self.pos.first().map_or(2, Pt::dim)
    }

    /// The channel's configuration.
    pub fn cfg(&self) -> &AcousticCfg {
        &self.cfg
    }

    /// Node `from` sends one frame of `bits` bits to every node of `to` at
    /// time `t` (one transmission, as the sync root's Average): one [`Frame`]
    /// per addressee, in the order given, each judged on its own.
    pub fn broadcast(&mut self, t: Nanos, from: u32, to: &[u32], bits: u64) -> Vec<Frame> {
        let (id, start, end) = self.transmit(t, from, to, bits);
        to.iter()
            .map(|&j| self.frame(id, from, j, bits, t, start, end))
            .collect()
    }

    /// Puts one transmission on the medium: `(id, start, end)`.
    fn transmit(&mut self, t: Nanos, from: u32, to: &[u32], bits: u64) -> (u64, Nanos, Nanos) {
        let fi = from as usize;
        let id = self.sent;
        self.sent += 1;
        let start = t.max(self.free_at[fi]);
        let (start, end, free) = match &self.schedule {
            // One frame per slot of its own.
            Some(s) => {
                let (slot, slot_end) = s.slot_at_or_after(fi, start);
                (
                    slot,
                    slot.saturating_add(self.cfg.transmission_ns(bits)),
                    slot_end,
                )
            }
            None => {
                let end = start.saturating_add(self.cfg.transmission_ns(bits));
                (start, end, end)
            }
        };
        self.free_at[fi] = free;
        self.sending[fi].push((start, end));
        let mut listeners = self.reach[fi].clone();
        for &j in to {
            if !listeners.contains(&j) && j != from {
                listeners.push(j);
            }
        }
        for j in listeners {
            let d = self.delay_ns(from, j);
            self.arriving[j as usize].push((
                start.saturating_add(d),
                end.saturating_add(d),
                id,
                from,
            ));
        }
        (id, start, end)
    }

    /// The frame of transmission `id` addressed to `to` (numbered on its link).
    #[allow(clippy::too_many_arguments)]
    fn frame(
        &mut self,
        id: u64,
        from: u32,
        to: u32,
        bits: u64,
        t: Nanos,
        start: Nanos,
        end: Nanos,
    ) -> Frame {
        let number = self.numbers.entry((from, to)).or_insert(0);
        let k = *number;
        *number += 1;
        let d = self.delay_ns(from, to);
        Frame {
            id,
            from,
            to,
            number: k,
            bits,
            t_send: t,
            t_start: start,
            arrive_start: start.saturating_add(d),
            arrive_end: end.saturating_add(d),
        }
    }

    /// The fate of `f`, judged at `f.arrive_end` (every transmission that
    /// can overlap its arrival has been sent by then, when sends are made in
    /// time order).
    pub fn judge(&self, f: &Frame) -> Fate {
        self.judge_with(f, self.sinr_and_snr_db(f))
    }

    /// [`Medium::judge`] and, under the SINR rule, the frame's worst SINR
    /// (dB), computed once for both.
    pub fn judged(&self, f: &Frame) -> (Fate, Option<f64>) {
        let levels = self.sinr_and_snr_db(f);
        (self.judge_with(f, levels), levels.map(|(sinr, _)| sinr))
    }

    /// The judgement, given the frame's worst SINR and its SNR (dB) under
    /// the SINR rule.
    fn judge_with(&self, f: &Frame, levels: Option<(f64, f64)>) -> Fate {
        if self.cfg.link(f.from, f.to).is_some_and(|l| l.blocked)
            || self.link_faults.blocked(f.from, f.to)
        {
            return Fate::Lost(Reason::Blocked);
        }
        let (a, b) = (f.arrive_start, f.arrive_end);
        // Half-open intervals in integer nanoseconds: an arrival that ends
        // at the instant another transmission or arrival starts does not
        // overlap it.
        let overlaps = |s: Nanos, e: Nanos| s < b && a < e;
        let to = f.to as usize;
        if self.cfg.half_duplex && self.sending[to].iter().any(|&(s, e)| overlaps(s, e)) {
            return Fate::Lost(Reason::HalfDuplex);
        }
        if let Reception::Sinr { threshold_db, .. } = self.cfg.reception {
            if let Some((sinr, snr)) = levels
                && sinr < threshold_db
            {
                return Fate::Lost(if snr >= threshold_db {
                    Reason::Collision
                } else {
                    Reason::Loss
                });
            }
        } else if self.cfg.collisions {
            let others = self.arriving[to]
                .iter()
                .any(|&(s, e, id, _)| id != f.id && overlaps(s, e));
            if others {
                return Fate::Lost(Reason::Collision);
            }
        }
        let p = self.cfg.loss_probability(
            f.from,
            f.to,
            &self.pos[f.from as usize],
            &self.pos[to],
            f.bits,
        );
        if fate_draw(self.seed, f.from, f.to, f.number) < p {
            return Fate::Lost(Reason::Loss);
        }
        let extra = self.link_faults.loss(f.from, f.to);
        if extra > 0.0 && crate::model::fault::fault_draw(self.seed, f.from, f.to, f.number) < extra
        {
            return Fate::Lost(Reason::Loss);
        }
        Fate::Delivered
    }

    /// Carrier sense at node `i` at instant `t`: its modem is busy, or an
    /// arrival it detects is in progress at its receiver (any under the graph
    /// rule; under the SINR rule one at least `detection_db` over the noise).
    pub fn senses_busy(&self, i: u32, t: Nanos) -> bool {
        let iu = i as usize;
        if self.free_at.get(iu).is_some_and(|&f| f > t) {
            return true;
        }
        let Some(at) = self.pos.get(iu) else {
            return false;
        };
        self.arriving.get(iu).is_some_and(|v| {
            v.iter().any(|&(s, e, _, k)| {
                s <= t
                    && t < e
                    && match self.cfg.reception {
                        Reception::Graph {} => true,
                        Reception::Sinr { detection_db, .. } => self
                            .cfg
                            .levels_db(&self.pos[k as usize], at)
                            .is_some_and(|(l, n)| l - n >= detection_db),
                    }
            })
        })
    }

    /// Under the SINR rule, the worst SINR of `f` over its arrival, dB
    /// ([`crate::model::reception`]); `None` under the graph rule.
    pub fn sinr_db(&self, f: &Frame) -> Option<f64> {
        self.sinr_and_snr_db(f).map(|(sinr, _)| sinr)
    }

    /// The worst SINR of `f` and its SNR against the noise alone, dB.
    fn sinr_and_snr_db(&self, f: &Frame) -> Option<(f64, f64)> {
        let Reception::Sinr { detection_db, .. } = self.cfg.reception else {
            return None;
        };
        let to = f.to as usize;
        let at = &self.pos[to];
        let (signal_db, noise_db) = self.cfg.levels_db(&self.pos[f.from as usize], at)?;
        let interferers: Vec<(Nanos, Nanos, f64)> = self.arriving[to]
            .iter()
            .filter(|&&(s, e, id, _)| id != f.id && s < f.arrive_end && f.arrive_start < e)
            .filter_map(|&(s, e, _, k)| {
                let (level, _) = self.cfg.levels_db(&self.pos[k as usize], at)?;
                (level - noise_db >= detection_db).then(|| (s, e, linear(level)))
            })
            .collect();
        let sinr = worst_sinr_db(
            linear(signal_db),
            linear(noise_db),
            f.arrive_start,
            f.arrive_end,
            &interferers,
        );
        Some((sinr, signal_db - noise_db))
    }

    /// Forgets transmissions and arrivals that ended before `t` (nothing
    /// judged at `t` or later can overlap them), so that a long run keeps
    /// bounded memory.
    pub fn forget_before(&mut self, t: Nanos) {
        for v in &mut self.sending {
            v.retain(|&(_, e)| e >= t);
        }
        for v in &mut self.arriving {
            v.retain(|&(_, e, _, _)| e >= t);
        }
    }
}
