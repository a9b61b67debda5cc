//! The underwater acoustic channel between the nodes, I/O-free:
//! how long a frame takes from one node to another, and whether it arrives.
//!
//! This module is the one implementation of the channel model; the
//! discrete-event engine ([`crate::engine::des`]) calls it.
//!
//! # The model
//! For a frame of `bits` bits sent by node `i` to node `j` at emulated time `t`:
//! * **transmission time** `bits / bit_rate`; `bits = header_bits + fields x
//!   value_bits` ([`AcousticCfg::frame_bits`]). A node's modem sends one frame
//!   at a time: a frame queued while the modem is busy starts when it is free;
//! * **propagation delay** `||r_i - r_j|| / sound_speed + extra_delay_s`, or
//!   the travel time along the straight path through a depth-dependent
//!   speed ([`crate::model::sound_speed`]);
//! * the frame **arrives** at `j` over `[t0 + delay, t0 + delay + bits / bit_rate)`,
//!   `t0` the start of its transmission;
//! * **time is exact**: every instant is an integer number of nanoseconds
//!   ([`Nanos`]), the discrete-event engine's own unit; the delay and the
//!   airtime are each rounded to the nearest nanosecond once, and every
//!   interval is half-open, so an arrival that ends at the instant a
//!   transmission starts does not overlap it, whatever order the two events
//!   are handled in;
//! * its **fate** is judged when its arrival ends, in this order:
//!   1. `blocked`: the link is blocked ([`LinkOverride::blocked`]);
//!   2. `half_duplex` (if on): `j` was transmitting during the arrival;
//!   3. `collision` (if on): another frame arrived at `j` during the arrival.
//!      Every frame a node transmits reaches every node it has a link to
//!      (acoustic modems broadcast physically), addressed or not, so a frame
//!      overheard by `j` collides with one addressed to `j`. Both are lost.
//!      Under `reception = { model = "sinr" }` every frame reaches every node
//!      instead, and the rule of [`crate::model::reception`] (the worst SINR
//!      over the arrival against a threshold, with capture) replaces this one;
//!   4. `loss`: an independent draw against the link's loss probability;
//!   5. else `delivered`.
//!
//! # Loss
//! * `none`; `bernoulli { p }`; a link's `loss_p` overrides either;
//! * `range`: Thorp's absorption (Thorp 1967, in the form of Stojanovic 2007,
//!   "On the relationship between capacity and distance in an underwater
//!   acoustic communication channel", eq. 3)
//!   `a(f) = 0.11 f^2 / (1 + f^2) + 44 f^2 / (4100 + f^2) + 2.75e-4 f^2 + 0.003`
//!   dB/km (f in kHz); transmission loss `TL = k 10 log10(d) + (d / 1000) a(f)`
//!   dB (d in m, k the spreading factor, Stojanovic eq. 1-2); the SNR
//!   `SL - TL - (NL + 10 log10 B)` (B in Hz); the BPSK bit error rate
//!   `1/2 erfc(sqrt(SNR B / R))` (SNR linear, R the bit rate); and the frame
//!   success `(1 - BER)^bits`. Francois and Garrison's or Schulkin and
//!   Marsh's absorption can stand for Thorp's, and Coates' noise spectrum, integrated over the band, for
//!   the flat `NL + 10 log10 B` ([`crate::model::acoustics`]).
//!
//! # Seeding
//! The fate draw of a frame comes from the run seed, through the stream
//! [`Stream::Channel`](crate::model::rng::Stream::Channel) keyed by the link and the frame's number on that link
//! ([`fate_draw`]), so the same frame has the same fate wherever it is decided,
//! whatever else happens meanwhile.

use crate::model::error::{KeyError, in_range};
use crate::model::xy::Pt;
use serde::{Deserialize, Serialize};

pub use crate::model::acoustics::thorp_db_per_km;
use crate::model::acoustics::{Absorption, Noise, Water};
use crate::model::mac::{Mac, Schedule, distance2_colours};
pub use crate::model::nanos::{Nanos, nanos, seconds};

mod medium;
use crate::model::reception::Reception;
use crate::model::sound_speed::SoundSpeedProfile;
pub use medium::{Fate, Frame, Medium, Reason, fate_draw};

/// Transmission loss `k 10 log10(d) + (d / 1000) a(f)` in dB over `d` metres,
/// with Thorp's absorption.
pub fn transmission_loss_db(d_m: f64, f_khz: f64, spreading: f64) -> f64 {
    spreading_loss_db(d_m, spreading) + d_m / 1000.0 * thorp_db_per_km(f_khz)
}

/// The spreading part of the transmission loss, `k 10 log10(d)` dB (`d` at
/// least 1 m).
pub fn spreading_loss_db(d_m: f64, spreading: f64) -> f64 {
    spreading * 10.0 * d_m.max(1.0).log10()
}

/// The BPSK bit error rate `1/2 erfc(sqrt(snr B / R))` at a linear SNR.
pub fn bpsk_ber(snr_linear: f64, bandwidth_hz: f64, bit_rate: f64) -> f64 {
    0.5 * libm::erfc((snr_linear.max(0.0) * bandwidth_hz / bit_rate).sqrt())
}

/// What decides a frame's random loss.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum LossCfg {
    /// No random loss.
    None {},
    /// Every frame is lost with probability `p` in [0, 1].
    Bernoulli {
        /// Loss probability.
        p: f64,
    },
    /// Loss from the link's length (module docs).
    Range {
        /// Carrier frequency, kHz, in [1e-3, 1000].
        #[serde(default = "default_carrier")]
        carrier_khz: f64,
        /// Bandwidth, kHz, in [1e-3, 1000].
        #[serde(default = "default_bandwidth")]
        bandwidth_khz: f64,
        /// Source level, dB re 1 uPa at 1 m, in [0, 300].
        #[serde(default = "default_source_level")]
        source_level_db: f64,
        /// Noise spectral level, dB re 1 uPa^2/Hz, in [-100, 200].
        #[serde(default = "default_noise_level")]
        noise_level_db: f64,
        /// Spreading factor `k`, in [1, 2] (1 cylindrical, 2 spherical).
        #[serde(default = "default_spreading")]
        spreading: f64,
        /// Absorption model: `"thorp"` (default), `"francois_garrison"` or
        /// `"marsh_schulkin"` (the last two in `water`, at the path's depth).
        #[serde(default, skip_serializing_if = "is_thorp")]
        absorption: Absorption,
        /// The water for `francois_garrison` and `marsh_schulkin`
        /// (temperature, salinity, pH, and a 2-D scenario's depth).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        water: Option<Water>,
        /// The ambient noise, instead of the flat `noise_level_db`:
        /// `{ model = "constant", level_db }` or `{ model = "coates",
        /// shipping, wind_mps }`, integrated over the band.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        noise: Option<Noise>,
    },
}

fn is_thorp(a: &Absorption) -> bool {
    *a == Absorption::Thorp
}

fn default_carrier() -> f64 {
    12.0
}
fn default_bandwidth() -> f64 {
    4.0
}
fn default_source_level() -> f64 {
    170.0
}
fn default_noise_level() -> f64 {
    50.0
}
fn default_spreading() -> f64 {
    1.5
}

/// Changes to one link, in both directions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkOverride {
    /// One end (node id).
    pub a: u32,
    /// The other end.
    pub b: u32,
    /// Loss probability of the link, in [0, 1], instead of the loss model.
    #[serde(default)]
    pub loss_p: Option<f64>,
    /// Extra one-way delay, seconds, in [0, 3600].
    #[serde(default)]
    pub extra_delay_s: f64,
    /// Nothing gets through.
    #[serde(default)]
    pub blocked: bool,
}

/// The acoustic channel's parameters; the ranges are checked by
/// [`AcousticCfg::validate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AcousticCfg {
    /// Speed of sound, m/s, in [1, 1e5].
    #[serde(default = "default_sound_speed")]
    pub sound_speed: f64,
    /// A depth-dependent speed instead of `sound_speed`: `{ model =
    /// "mackenzie", temperature_c, salinity_psu, depth_m }`
    /// ([`crate::model::sound_speed`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sound_speed_profile: Option<SoundSpeedProfile>,
    /// Modem bit rate, bit/s, in [1, 1e9].
    #[serde(default = "default_bit_rate")]
    pub bit_rate: f64,
    /// Bits of every frame's header, in [0, 1e6].
    #[serde(default = "default_header_bits")]
    pub header_bits: u32,
    /// Bits per value carried, in [1, 64] (32 models a modem that sends float32).
    #[serde(default = "default_value_bits")]
    pub value_bits: u32,
    /// A frame arriving while its receiver transmits is lost.
    #[serde(default = "default_true")]
    pub half_duplex: bool,
    /// Frames overlapping at a receiver are all lost.
    #[serde(default = "default_true")]
    pub collisions: bool,
    /// Random loss.
    #[serde(default = "default_loss")]
    pub loss: LossCfg,
    /// Per-link overrides.
    #[serde(default)]
    pub links: Vec<LinkOverride>,
    /// How overlapping frames are judged: `{ model = "graph" }` (the
    /// default) or `{ model = "sinr", threshold_db, detection_db }`
    /// ([`crate::model::reception`]).
    #[serde(default, skip_serializing_if = "Reception::is_graph")]
    pub reception: Reception,
    /// Medium access: `{ protocol = "aloha" }` (the default) or
    /// `{ protocol = "tdma", slot_s }` ([`crate::model::mac`]).
    #[serde(default, skip_serializing_if = "Mac::is_aloha")]
    pub mac: Mac,
    /// Emulated seconds per wall-clock second (processes engine), in [1e-3, 1e6].
    #[serde(default = "default_time_scale")]
    pub time_scale: f64,
    /// How long a realtime initiator waits for the answer to its Request
    /// (emulated seconds, in [1e-9, 86400]); default
    /// [`AcousticCfg::default_exchange_timeout`].
    #[serde(default)]
    pub exchange_timeout_s: Option<f64>,
    /// Logical clocks: how long the sync root waits for the reflected points
    /// of a round, and an async node for its partner's point (emulated
    /// seconds, in [1e-9, 86400]); default
    /// [`AcousticCfg::default_round_timeout`].
    #[serde(default)]
    pub round_timeout_s: Option<f64>,
}

/// `[channel]`: the network between the nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
// Read once per run from the scenario: the size of the acoustic variant
// costs nothing, a box would cost every match on it.
#[allow(clippy::large_enum_variant)]
pub enum ChannelCfg {
    /// Every message arrives at once and whole (the default). It takes no
    /// other key.
    Ideal {},
    /// The underwater acoustic channel of this module.
    Acoustic(AcousticCfg),
}

impl Default for ChannelCfg {
    fn default() -> Self {
        ChannelCfg::Ideal {}
    }
}

impl ChannelCfg {
    /// The acoustic parameters, if any.
    pub fn acoustic(&self) -> Option<&AcousticCfg> {
        match self {
            ChannelCfg::Ideal {} => None,
            ChannelCfg::Acoustic(a) => Some(a),
        }
    }
}

fn default_sound_speed() -> f64 {
    1500.0
}
fn default_bit_rate() -> f64 {
    1000.0
}
fn default_header_bits() -> u32 {
    48
}
fn default_value_bits() -> u32 {
    64
}
fn default_true() -> bool {
    true
}
fn default_time_scale() -> f64 {
    1.0
}
fn default_loss() -> LossCfg {
    LossCfg::None {}
}

impl Default for AcousticCfg {
    fn default() -> Self {
        AcousticCfg {
            sound_speed: default_sound_speed(),
            sound_speed_profile: None,
            bit_rate: default_bit_rate(),
            header_bits: default_header_bits(),
            value_bits: default_value_bits(),
            half_duplex: true,
            collisions: true,
            loss: LossCfg::None {},
            links: Vec::new(),
            reception: Reception::Graph {},
            mac: Mac::Aloha {},
            time_scale: 1.0,
            exchange_timeout_s: None,
            round_timeout_s: None,
        }
    }
}

impl AcousticCfg {
    /// Checks every number against its documented range, and the links
    /// against the node count `n`: a [`KeyError`] names the key.
    pub fn validate(&self, n: usize) -> Result<(), KeyError> {
        in_range("channel.sound_speed", self.sound_speed, 1.0, 1e5)?;
        in_range("channel.bit_rate", self.bit_rate, 1.0, 1e9)?;
        in_range("channel.header_bits", self.header_bits as f64, 0.0, 1e6)?;
        in_range("channel.value_bits", self.value_bits as f64, 1.0, 64.0)?;
        in_range("channel.time_scale", self.time_scale, 1e-3, 1e6)?;
        if let Some(t) = self.exchange_timeout_s {
            in_range("channel.exchange_timeout_s", t, 1e-9, 86_400.0)?;
        }
        if let Some(t) = self.round_timeout_s {
            in_range("channel.round_timeout_s", t, 1e-9, 86_400.0)?;
        }
        self.reception
            .validate(matches!(self.loss, LossCfg::Range { .. }))?;
        self.mac.validate()?;
        if let Some(p) = &self.sound_speed_profile {
            p.validate()?;
        }
        match self.loss {
            LossCfg::None {} => {}
            LossCfg::Bernoulli { p } => in_range("channel.loss.p", p, 0.0, 1.0)?,
            LossCfg::Range {
                carrier_khz,
                bandwidth_khz,
                source_level_db,
                noise_level_db,
                spreading,
                absorption,
                water,
                noise,
            } => {
                in_range("channel.loss.carrier_khz", carrier_khz, 1e-3, 1000.0)?;
                in_range("channel.loss.bandwidth_khz", bandwidth_khz, 1e-3, 1000.0)?;
                in_range("channel.loss.source_level_db", source_level_db, 0.0, 300.0)?;
                in_range("channel.loss.noise_level_db", noise_level_db, -100.0, 200.0)?;
                in_range("channel.loss.spreading", spreading, 1.0, 2.0)?;
                if let Some(w) = water {
                    w.validate("channel.loss.water")?;
                    if absorption == Absorption::Thorp {
                        return Err(KeyError::new(
                            "channel.loss.water",
                            "Thorp's absorption depends on the frequency only: give \
                             absorption = \"francois_garrison\" or \"marsh_schulkin\" \
                             to use the water",
                        ));
                    }
                }
                if let Some(n) = noise {
                    n.validate("channel.loss.noise")?;
                }
            }
        }
        for (k, l) in self.links.iter().enumerate() {
            let key = |f: &str| format!("channel.links[{k}].{f}");
            for (f, v) in [("a", l.a), ("b", l.b)] {
                if v as usize >= n {
                    return Err(KeyError::new(
                        key(f),
                        format!("node {v} does not exist ({n} nodes)"),
                    ));
                }
            }
            if l.a == l.b {
                return Err(KeyError::new(key("b"), "a link joins two different nodes"));
            }
            if let Some(p) = l.loss_p {
                in_range(&key("loss_p"), p, 0.0, 1.0)?;
            }
            in_range(&key("extra_delay_s"), l.extra_delay_s, 0.0, 3600.0)?;
        }
        Ok(())
    }

    /// Who hears whom: `links` (the gossip graph) under the graph reception
    /// rule, every other node under the SINR rule.
    pub fn physical_reach(&self, n: usize, links: &[Vec<u32>]) -> Vec<Vec<u32>> {
        let everyone = !self.reception.is_graph();
        (0..n)
            .map(|i| {
                let mut r: Vec<u32> = if everyone {
                    (0..n as u32).collect()
                } else {
                    links.get(i).map_or(&[][..], |l| &l[..]).to_vec()
                };
                r.retain(|&j| (j as usize) < n && j as usize != i);
                r.sort_unstable();
                r.dedup();
                r
            })
            .collect()
    }

    /// The longest one-way delay between nodes that reach each other,
    /// seconds.
    fn longest_delay(&self, pos: &[Pt], reach: &[Vec<u32>]) -> f64 {
        let mut max_delay = 0.0f64;
        for (i, out) in reach.iter().enumerate() {
            for &j in out {
                let (Some(a), Some(b)) = (pos.get(i), pos.get(j as usize)) else {
                    continue;
                };
                let extra = self.link(i as u32, j).map_or(0.0, |l| l.extra_delay_s);
                max_delay = max_delay.max(self.travel_time_s(a, b) + extra);
            }
        }
        max_delay
    }

    /// Seconds of sound from `a` to `b`: the distance over `sound_speed`, or
    /// along the straight path through `sound_speed_profile`.
    pub fn travel_time_s(&self, a: &Pt, b: &Pt) -> f64 {
        match &self.sound_speed_profile {
            None => a.distance(b) / self.sound_speed,
            Some(p) => p.travel_time_s(a, b),
        }
    }

    /// The shortest TDMA slot that keeps every frame in its slot at every
    /// node it reaches: the airtime of the longest frame (`dim + 1` values)
    /// plus the longest delay in reach, seconds.
    pub fn min_slot_s(&self, pos: &[Pt], links: &[Vec<u32>]) -> f64 {
        let reach = self.physical_reach(pos.len(), links);
        let dim = pos.first().map_or(2, Pt::dim) as u32;
        self.transmission_s(self.frame_bits(dim + 1)) + self.longest_delay(pos, &reach)
    }

    /// The TDMA schedule for nodes at `pos` linked by `links`; `None` under
    /// ALOHA.
    pub fn schedule(&self, pos: &[Pt], links: &[Vec<u32>]) -> Option<Schedule> {
        let Mac::Tdma { slot_s } = self.mac else {
            return None;
        };
        let reach = self.physical_reach(pos.len(), links);
        let slot = slot_s.unwrap_or_else(|| self.min_slot_s(pos, links));
        Some(Schedule::new(distance2_colours(&reach), slot))
    }

    /// A `slot_s` given for TDMA must hold the longest frame and delay
    /// ([`AcousticCfg::min_slot_s`]); the [`KeyError`] names the key.
    pub fn check_slot(&self, pos: &[Pt], links: &[Vec<u32>]) -> Result<(), KeyError> {
        if let Mac::Tdma { slot_s: Some(s) } = self.mac {
            let min = self.min_slot_s(pos, links);
            if s < min {
                return Err(KeyError::new(
                    "channel.mac.slot_s",
                    format!(
                        "is {s} s, shorter than the longest frame's airtime plus the longest \
                         delay between nodes in reach, {min} s: frames would spill into the \
                         next slot"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The longest round trip over `links`: twice the longest one-way delay
    /// between linked nodes plus twice the time to send a frame of `fields`
    /// values (a Request and its answer), seconds.
    pub fn round_trip(&self, pos: &[Pt], links: &[Vec<u32>], fields: u32) -> f64 {
        2.0 * self.longest_delay(pos, links) + 2.0 * self.transmission_s(self.frame_bits(fields))
    }

    /// The default realtime exchange timeout: the longest round trip
    /// ([`AcousticCfg::round_trip`]) plus one frame time of slack, seconds.
    /// Without the slack an answer sent at once over the longest link would
    /// arrive exactly at the timeout, and be late by any jitter (or by the
    /// order of two events at one virtual time), so that link would never
    /// complete an exchange.
    /// Under TDMA two cycles are added: the Request and the answer each wait
    /// for a slot.
    pub fn default_exchange_timeout(&self, pos: &[Pt], links: &[Vec<u32>], fields: u32) -> f64 {
        let base =
            self.round_trip(pos, links, fields) + self.transmission_s(self.frame_bits(fields));
        match (self.mac, self.schedule(pos, links)) {
            (_, Some(s)) => base + 2.0 * s.cycle_s(),
            (Mac::Csma { backoff_s, .. }, None) => base + 4.0 * backoff_s,
            _ => base,
        }
    }

    /// The exchange timeout in force (the key, or the default).
    pub fn exchange_timeout(&self, pos: &[Pt], links: &[Vec<u32>], fields: u32) -> f64 {
        self.exchange_timeout_s
            .unwrap_or_else(|| self.default_exchange_timeout(pos, links, fields))
    }

    /// The default logical round timeout over the links the mode uses
    /// (`links[i]`: the nodes `i` sends to), seconds. One wait is the longest
    /// round trip plus one frame time of slack, as for an exchange
    /// ([`AcousticCfg::default_exchange_timeout`]); that is the sync default.
    /// An async partner may still be busy with one earlier step with each of
    /// its other neighbours, so the async default is `max degree + 1` such
    /// waits.
    pub fn default_round_timeout(
        &self,
        pos: &[Pt],
        links: &[Vec<u32>],
        fields: u32,
        sync: bool,
    ) -> f64 {
        let one = self.default_exchange_timeout(pos, links, fields);
        if sync {
            one
        } else {
            let degree = links.iter().map(Vec::len).max().unwrap_or(0);
            (degree + 1) as f64 * one
        }
    }

    /// The logical round timeout in force (the key, or the default).
    pub fn round_timeout(&self, pos: &[Pt], links: &[Vec<u32>], fields: u32, sync: bool) -> f64 {
        self.round_timeout_s
            .unwrap_or_else(|| self.default_round_timeout(pos, links, fields, sync))
    }

    /// Bits of a frame carrying `fields` values.
    pub fn frame_bits(&self, fields: u32) -> u64 {
        u64::from(self.header_bits) + u64::from(fields) * u64::from(self.value_bits)
    }

    /// Seconds to send `bits` bits.
    pub fn transmission_s(&self, bits: u64) -> f64 {
        bits as f64 / self.bit_rate
    }

    /// [`AcousticCfg::transmission_s`] rounded to the nanosecond: the
    /// airtime the medium uses.
    pub fn transmission_ns(&self, bits: u64) -> Nanos {
        nanos(self.transmission_s(bits))
    }

    /// The override of the link `i - j`, if any (the last one given wins).
    fn link(&self, i: u32, j: u32) -> Option<&LinkOverride> {
        self.links
            .iter()
            .rev()
            .find(|l| (l.a, l.b) == (i, j) || (l.a, l.b) == (j, i))
    }

    /// The level at `b` of a transmission from `a`, `SL - TL(d)` dB, and the
    /// band noise `N` dB, when the loss model is `range` (the levels of the
    /// SINR rule and of the SNR of the bit-error draw).
    pub fn levels_db(&self, a: &Pt, b: &Pt) -> Option<(f64, f64)> {
        let LossCfg::Range {
            carrier_khz,
            bandwidth_khz,
            source_level_db,
            noise_level_db,
            spreading,
            absorption,
            water,
            noise,
        } = self.loss
        else {
            return None;
        };
        let d_m = a.distance(b);
        let water = water.unwrap_or_default();
        // The path's depth: the mean of its ends' in 3-D (z up).
        let depth = if a.dim() == 3 {
            ((-a[2]).max(0.0) + (-b[2]).max(0.0)) / 2.0
        } else {
            water.depth_m
        };
        let tl = spreading_loss_db(d_m, spreading)
            + d_m / 1000.0 * absorption.db_per_km(carrier_khz, &water, depth);
        let noise = noise
            .unwrap_or(Noise::Constant {
                level_db: noise_level_db,
            })
            .band_db(carrier_khz, bandwidth_khz);
        Some((source_level_db - tl, noise))
    }

    /// Probability that a frame of `bits` bits is lost at random (before
    /// half-duplex and collisions) on the link `i - j` between the positions
    /// `a` and `b`.
    pub fn loss_probability(&self, i: u32, j: u32, a: &Pt, b: &Pt, bits: u64) -> f64 {
        if let Some(p) = self.link(i, j).and_then(|l| l.loss_p) {
            return p;
        }
        match self.loss {
            LossCfg::None {} => 0.0,
            LossCfg::Bernoulli { p } => p,
            LossCfg::Range { bandwidth_khz, .. } => {
                let Some((level, noise)) = self.levels_db(a, b) else {
                    return 0.0;
                };
                let b_hz = bandwidth_khz * 1e3;
                let snr_db = level - noise;
                let ber = bpsk_ber(10f64.powf(snr_db / 10.0), b_hz, self.bit_rate);
                1.0 - (1.0 - ber).powf(bits as f64)
            }
        }
    }
}

#[cfg(test)]
#[path = "channel_tests.rs"]
mod tests;
