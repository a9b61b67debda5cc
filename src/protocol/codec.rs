//! Encoding of protocol messages into fixed-size [`Frame`]s and back.
//!
//! I/O-free. A [`Command`] with a variable-length body (a sample's
//! measurements, an async plan) becomes several frames closed by an end
//! frame carrying the count; the [`NodeDecoder`] reassembles them. Frames
//! from one sender arrive in order (one publisher per sender and service),
//! which is all the reassembly needs.

use crate::model::coords::Coords;
use crate::model::measure::{NodeMeasurements, Sigmas};
use crate::protocol::{Command, Counters, PeerMsg, Report};
use crate::transport::wire::{COORDINATOR_ID, Frame};

mod coordinator;
pub use coordinator::{CoordinatorInput, ReportDecoder};

/// Frame kinds.
pub mod kind {
    /// Bistatic range: `aux` = transmitter, `data[0]` = value.
    pub const MEAS_BISTATIC: u32 = 1;
    /// DOA: `data[0]`.
    pub const MEAS_DOA: u32 = 2;
    /// One-way range: `data[0]`.
    pub const MEAS_RANGE: u32 = 3;
    /// End of a sample's measurements: `aux` = number of measurement frames.
    pub const SAMPLE_END: u32 = 4;
    /// Sync rounds: `seq` = first round, `aux` = rounds.
    pub const SYNC_ROUNDS: u32 = 5;
    /// Up to [`super::PLAN_STEPS_PER_FRAME`] async plan steps: `seq` =
    /// iteration and `aux` = partner of the first; each used `data` slot one
    /// more step, `(iteration - seq) * 2^32 + partner` as an exact integer
    /// ([`super::NO_STEP`] in the unused slots).
    pub const PLAN_STEP: u32 = 6;
    /// End of an async plan: `aux` = number of steps.
    pub const PLAN_END: u32 = 7;
    /// Snapshot request.
    pub const SNAPSHOT: u32 = 8;
    /// A node died: `aux` = node.
    pub const NODE_DOWN: u32 = 9;
    /// Stop and exit.
    pub const STOP: u32 = 10;
    /// Start free-running (realtime): `data[0]` = wake rate (Hz).
    pub const START_CLOCK: u32 = 11;
    /// Clock drift: `data[0]` = the factor of the node's waits and timers.
    pub const CLOCK_FACTOR: u32 = 14;
    /// Liveness check: `seq` = check number; answered at once with [`PONG`].
    pub const PING: u32 = 12;
    /// A node is up again (restarted): `aux` = node.
    pub const NODE_UP: u32 = 13;
    /// Measure hops: ping-pong `seq` times with neighbour `aux`
    /// ([`super::Control::ProbePeer`]).
    pub const PROBE_PEER: u32 = 15;
    /// Peer: a hop probe, `seq` = its number, answered at once with
    /// [`PROBE_BACK`] by the node's event loop.
    pub const PROBE: u32 = 25;
    /// Peer: the answer to [`PROBE`] `seq`.
    pub const PROBE_BACK: u32 = 26;
    /// Peer: reflected point, `seq`, `data[0..3]`.
    pub const REFLECT: u32 = 20;
    /// Peer: exchange request.
    pub const REQUEST: u32 = 21;
    /// Peer: exchange accepted.
    pub const ACCEPT: u32 = 22;
    /// Peer: exchange declined.
    pub const DECLINE: u32 = 23;
    /// Peer (sync, from the root): consensus average of round `seq`,
    /// `data[0..D]`.
    pub const AVERAGE: u32 = 24;
    /// Report: counters (`data` = prox_solves, messages_out, messages_in, declines, updates).
    pub const COUNTERS: u32 = 30;
    /// Report: sample done, `data[0..L]` = theta (`L` = 3 in 2-D, 4 in 3-D;
    /// after a COUNTERS frame).
    pub const SAMPLE_DONE: u32 = 31;
    /// Report: snapshot, `data[0..L]` = theta (after a COUNTERS frame).
    pub const SNAPSHOT_REPLY: u32 = 32;
    /// Report: iteration done, `seq`.
    pub const ITER_DONE: u32 = 33;
    /// Report: failure, `aux` = reason code.
    pub const FAILED: u32 = 34;
    /// Report: time spent (`data[0]` = busy seconds, `data[1]` = waiting seconds).
    pub const TIMING: u32 = 35;
    /// Report: the node process is up and its transport is open.
    pub const READY: u32 = 36;
    /// Report: the answer to a [`PING`], `seq` = its check number.
    pub const PONG: u32 = 37;
    /// Report: the lossy channel's counters and the bad frames dropped
    /// (`data` = timeouts, missing, late, bad frames), after a [`COUNTERS`]
    /// frame, sent only when one is not zero.
    pub const LOSS_COUNTERS: u32 = 38;
    /// Report (acoustic channel): the node discarded a frame as late;
    /// `aux` = its sender, `seq` = its sequence number, `sample` = its kind.
    pub const LATE: u32 = 39;
    /// Report: measured hops (seconds, half a ping-pong with a neighbour),
    /// `data[..aux]`, `seq` = the number of the first.
    pub const HOPS: u32 = 40;
}

fn frame(kind: u32, from: u32, sample: u32, aux: u32, seq: u64, d: &[f64]) -> Frame {
    let mut data = [0.0; 5];
    data[..d.len()].copy_from_slice(d);
    Frame {
        kind,
        from,
        sample,
        aux,
        seq,
        data,
    }
}

/// Plan steps one [`kind::PLAN_STEP`] frame carries: `seq`/`aux`, and one per
/// `data` slot. Six per frame, not one: a node takes a sample's plan in a
/// sixth of the frames (50 steps: 9 frames, not 50), which both the
/// coordinator's sends and the node's reads between two gossip steps feel.
pub const PLAN_STEPS_PER_FRAME: usize = 6;
const _: () = assert!(PLAN_STEPS_PER_FRAME == 1 + std::mem::size_of::<[f64; 5]>() / 8);

/// An unused step slot of a [`kind::PLAN_STEP`] frame.
pub const NO_STEP: f64 = -1.0;

/// The partner's share of a packed step (`delta * STEP_SHIFT + partner`).
const STEP_SHIFT: u64 = 1 << 32;

/// Largest iteration offset a packed step carries: `delta * 2^32 + partner`
/// stays below 2^53, where every integer is an exact `f64`.
const MAX_STEP_DELTA: u64 = (1 << 21) - 1;

/// The first value above every packed step.
const PACKED_END: f64 = ((MAX_STEP_DELTA + 1) * STEP_SHIFT) as f64;

/// The steps of one async plan as [`kind::PLAN_STEP`] frames: a step starts
/// a new frame when the frame is full or its iteration is not within
/// [`MAX_STEP_DELTA`] after the frame's first (plans go up a few at a time).
fn encode_plan_steps(sample: u32, steps: &[(u64, u32)], out: &mut Vec<Frame>) {
    let co = COORDINATOR_ID;
    let mut rest = steps;
    while let Some((&(first, partner), tail)) = rest.split_first() {
        let mut data = [NO_STEP; 5];
        let mut used = 0;
        for (slot, &(it, p)) in data.iter_mut().zip(tail) {
            match it.checked_sub(first).filter(|d| *d <= MAX_STEP_DELTA) {
                Some(d) => *slot = (d * STEP_SHIFT + u64::from(p)) as f64,
                None => break,
            }
            used += 1;
        }
        out.push(Frame {
            kind: kind::PLAN_STEP,
            from: co,
            sample,
            aux: partner,
            seq: first,
            data,
        });
        rest = &tail[used..];
    }
}

/// The steps a [`kind::PLAN_STEP`] frame carries, appended to `steps`; a slot
/// that is neither [`NO_STEP`] nor a packed step is an error.
fn decode_plan_steps(f: &Frame, steps: &mut Vec<(u64, u32)>) -> Result<(), DecodeError> {
    steps.push((f.seq, f.aux));
    for (i, &v) in f.data.iter().enumerate() {
        let bad = || DecodeError::BadStep {
            slot: i,
            bits: v.to_bits(),
        };
        if v.is_finite() && v.is_sign_negative() {
            // `NO_STEP`: the frame's steps end here.
            return Ok(());
        }
        if !v.is_finite() || v >= PACKED_END || v.fract() != 0.0 {
            return Err(bad());
        }
        let packed = v as u64;
        let (delta, partner) = (packed / STEP_SHIFT, (packed % STEP_SHIFT) as u32);
        match f.seq.checked_add(delta) {
            Some(it) => steps.push((it, partner)),
            None => return Err(bad()),
        }
    }
    Ok(())
}

/// The first `n` numbers of a frame's payload (`n` = 2 to 4: a consensus
/// average or a lifted variable of the run's dimension).
fn coords(d: &[f64; 5], n: usize) -> Coords {
    Coords::from_fn(n, |i| d[i])
}

/// Extra coordinator-to-node commands that only exist between processes.
#[derive(Debug, Clone, PartialEq)]
pub enum Control {
    /// A protocol command.
    Command(Command),
    /// Realtime: start the node's Poisson clock at this rate (Hz).
    StartClock(f64),
    /// A `clock_drift` fault: multiply the node's waits and
    /// timers by this factor from now on (1: no drift).
    ClockFactor(f64),
    /// Exit cleanly.
    Stop,
    /// The coordinator's liveness check number `seq`: the node's event loop
    /// answers at once ([`encode_pong`]), whatever its protocol state.
    Ping(u64),
    /// Measure one hop between two node processes: ping-pong
    /// `count` times with neighbour `peer` ([`encode_probe`]), one probe
    /// at a time, and report each round trip halved ([`encode_hops`]).
    /// Answered by the node's event loop, not the protocol core.
    ProbePeer {
        /// The neighbour to ping.
        peer: u32,
        /// Ping-pongs.
        count: u32,
    },
}

/// Encode a coordinator command into frames.
pub fn encode_control(c: &Control, out: &mut Vec<Frame>) {
    let co = COORDINATOR_ID;
    match c {
        Control::Command(Command::Sample {
            sample,
            meas,
            sigmas,
        }) => {
            let s = *sample;
            let mut n = 0;
            for &(m, v) in &meas.bistatic {
                out.push(frame(kind::MEAS_BISTATIC, co, s, m as u32, 0, &[v]));
                n += 1;
            }
            if let Some(v) = meas.doa {
                // aux = 1: an elevation follows the azimuth (3-D).
                match meas.elevation {
                    None => out.push(frame(kind::MEAS_DOA, co, s, 0, 0, &[v])),
                    Some(el) => out.push(frame(kind::MEAS_DOA, co, s, 1, 0, &[v, el])),
                }
                n += 1;
            }
            if let Some(v) = meas.range {
                out.push(frame(kind::MEAS_RANGE, co, s, 0, 0, &[v]));
                n += 1;
            }
            out.push(frame(
                kind::SAMPLE_END,
                co,
                s,
                n,
                0,
                &[sigmas.range, sigmas.doa, sigmas.elevation],
            ));
        }
        Control::Command(Command::SyncRounds {
            sample,
            first_round,
            rounds,
        }) => out.push(frame(
            kind::SYNC_ROUNDS,
            co,
            *sample,
            *rounds,
            *first_round,
            &[],
        )),
        Control::Command(Command::AsyncPlan { sample, steps }) => {
            encode_plan_steps(*sample, steps, out);
            out.push(frame(
                kind::PLAN_END,
                co,
                *sample,
                steps.len() as u32,
                0,
                &[],
            ));
        }
        Control::Command(Command::Snapshot { sample }) => {
            out.push(frame(kind::SNAPSHOT, co, *sample, 0, 0, &[]))
        }
        Control::Command(Command::NodeDown { node }) => {
            out.push(frame(kind::NODE_DOWN, co, 0, *node, 0, &[]))
        }
        Control::Command(Command::NodeUp { node }) => {
            out.push(frame(kind::NODE_UP, co, 0, *node, 0, &[]))
        }
        // Ticks are local to a node; never sent.
        // Node-local: a node's own clock and its own exchange timers.
        Control::Command(
            Command::Tick | Command::ExchangeTimeout { .. } | Command::RoundTimeout { .. },
        ) => {}
        Control::StartClock(rate) => out.push(frame(kind::START_CLOCK, co, 0, 0, 0, &[*rate])),
        Control::ClockFactor(f) => out.push(frame(kind::CLOCK_FACTOR, co, 0, 0, 0, &[*f])),
        Control::Stop => out.push(frame(kind::STOP, co, 0, 0, 0, &[])),
        Control::Ping(seq) => out.push(frame(kind::PING, co, 0, 0, *seq, &[])),
        Control::ProbePeer { peer, count } => out.push(frame(
            kind::PROBE_PEER,
            co,
            0,
            *peer,
            u64::from(*count),
            &[],
        )),
    }
}

/// Encode a peer message into one frame.
pub fn encode_peer(m: &PeerMsg) -> Frame {
    match *m {
        PeerMsg::Reflect { from, seq, r } => frame(kind::REFLECT, from, 0, 0, seq, r.as_slice()),
        PeerMsg::Request { from, seq, r } => frame(kind::REQUEST, from, 0, 0, seq, r.as_slice()),
        PeerMsg::Accept { from, seq, r } => frame(kind::ACCEPT, from, 0, 0, seq, r.as_slice()),
        PeerMsg::Decline { from, seq } => frame(kind::DECLINE, from, 0, 0, seq, &[]),
        PeerMsg::Average { from, seq, a } => frame(kind::AVERAGE, from, 0, 0, seq, a.as_slice()),
    }
}

/// The [`kind::COUNTERS`] frame, and the [`kind::LOSS_COUNTERS`] frame when
/// the lossy channel's counters are not all zero (so that runs on the ideal
/// channel send what they always sent).
fn counters_frames(node: u32, c: &Counters, out: &mut Vec<Frame>) {
    out.push(frame(
        kind::COUNTERS,
        node,
        0,
        0,
        0,
        &[
            c.prox_solves as f64,
            c.messages_out as f64,
            c.messages_in as f64,
            c.declines as f64,
            c.updates as f64,
        ],
    ));
    if c.timeouts > 0 || c.missing > 0 || c.late > 0 || c.bad_frames > 0 {
        out.push(frame(
            kind::LOSS_COUNTERS,
            node,
            0,
            0,
            0,
            &[
                c.timeouts as f64,
                c.missing as f64,
                c.late as f64,
                c.bad_frames as f64,
            ],
        ));
    }
}

/// Encode a report into frames.
pub fn encode_report(r: &Report, out: &mut Vec<Frame>) {
    match r {
        Report::SampleDone {
            node,
            sample,
            theta,
            counters,
        } => {
            counters_frames(*node, counters, out);
            out.push(frame(
                kind::SAMPLE_DONE,
                *node,
                *sample,
                0,
                0,
                theta.as_slice(),
            ));
        }
        Report::Snapshot {
            node,
            sample,
            theta,
            counters,
        } => {
            counters_frames(*node, counters, out);
            out.push(frame(
                kind::SNAPSHOT_REPLY,
                *node,
                *sample,
                0,
                0,
                theta.as_slice(),
            ));
        }
        Report::IterationDone {
            node,
            iteration,
            theta,
        } => out.push(frame(
            kind::ITER_DONE,
            *node,
            0,
            0,
            *iteration,
            theta.as_slice(),
        )),
        Report::Failed {
            node,
            sample,
            failure,
            ..
        } => out.push(frame(kind::FAILED, *node, *sample, failure.code(), 0, &[])),
    }
}

/// A decoded frame as a node sees it.
#[derive(Debug, Clone, PartialEq)]
pub enum NodeInput {
    /// From the coordinator.
    Control(Control),
    /// From a peer.
    Peer(PeerMsg),
    /// A hop probe from a peer ([`encode_probe`]).
    Probe {
        /// The sender.
        from: u32,
        /// The probe's number.
        seq: u64,
        /// Whether it is the answer to this node's own probe.
        back: bool,
    },
}

/// Why a frame stream could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// Unknown frame kind.
    #[error("unknown frame kind {0}")]
    UnknownKind(u32),
    /// A multi-frame message was incomplete.
    #[error("frame count mismatch in {what}: expected {expected}, got {got}")]
    Count {
        /// Which message.
        what: &'static str,
        /// Announced count.
        expected: u32,
        /// Frames received.
        got: u32,
    },
    /// A multi-frame message grew past its limit (a flood, or a frame
    /// stream that never ends it): what was gathered is dropped.
    #[error("{what}: more than {limit} frames or steps, dropped")]
    TooMany {
        /// Which message.
        what: &'static str,
        /// The limit.
        limit: usize,
    },
    /// A peer message carried a coordinate that is not finite: a broken
    /// or malicious sender's point must not reach the node's state.
    #[error("frame kind {kind} from {from} carries a value that is not finite")]
    NotFinite {
        /// The frame kind.
        kind: u32,
        /// The sender it claims.
        from: u32,
    },
    /// A slot of an async plan frame held no step.
    #[error("async plan frame: slot {slot} holds {}, not a step", f64::from_bits(*bits))]
    BadStep {
        /// The `data` slot.
        slot: usize,
        /// What it held (the `f64`'s bits).
        bits: u64,
    },
}

/// Most measurement frames of one sample a node gathers before its end:
/// a bistatic range per transmitter, a DOA and a one-way range.
pub const MAX_SAMPLE_FRAMES: u32 = crate::scenario::MAX_TRANSMITTERS as u32 + 2;

/// Most steps of one async plan a node gathers before its end (a node takes
/// part in at most every iteration of a sample): 16 bytes each.
pub const MAX_PLAN_STEPS: usize = crate::scenario::MAX_ITERATIONS_PER_SAMPLE;

/// Reassembles a node's incoming frames. What it gathers between a
/// multi-frame message's first frame and its end is bounded
/// ([`MAX_SAMPLE_FRAMES`], [`MAX_PLAN_STEPS`]).
#[derive(Debug)]
pub struct NodeDecoder {
    meas: NodeMeasurements,
    meas_n: u32,
    steps: Vec<(u64, u32)>,
    dim: usize,
}

impl NodeDecoder {
    /// The decoder of a node of a `dim`-dimensional run (2 or 3).
    pub fn new(dim: usize) -> NodeDecoder {
        NodeDecoder {
            meas: NodeMeasurements::default(),
            meas_n: 0,
            steps: Vec::new(),
            dim,
        }
    }

    /// Feed one frame; returns a complete input when one is finished.
    pub fn feed(&mut self, f: &Frame) -> Result<Option<NodeInput>, DecodeError> {
        use kind::{
            ACCEPT, AVERAGE, CLOCK_FACTOR, DECLINE, MEAS_BISTATIC, MEAS_DOA, MEAS_RANGE, NODE_DOWN,
            NODE_UP, PING, PLAN_END, PLAN_STEP, PROBE, PROBE_BACK, PROBE_PEER, REFLECT, REQUEST,
            SAMPLE_END, SNAPSHOT, START_CLOCK, STOP, SYNC_ROUNDS,
        };
        let c = |c: Command| Ok(Some(NodeInput::Control(Control::Command(c))));
        if matches!(f.kind, MEAS_BISTATIC | MEAS_DOA | MEAS_RANGE)
            && self.meas_n >= MAX_SAMPLE_FRAMES
        {
            self.meas = NodeMeasurements::default();
            self.meas_n = 0;
            return Err(DecodeError::TooMany {
                what: "sample measurements",
                limit: MAX_SAMPLE_FRAMES as usize,
            });
        }
        if f.kind == PLAN_STEP && self.steps.len() >= MAX_PLAN_STEPS {
            self.steps = Vec::new();
            return Err(DecodeError::TooMany {
                what: "async plan",
                limit: MAX_PLAN_STEPS,
            });
        }
        match f.kind {
            MEAS_BISTATIC => {
                self.meas.bistatic.push((f.aux as usize, f.data[0]));
                self.meas_n += 1;
                Ok(None)
            }
            MEAS_DOA => {
                self.meas.doa = Some(f.data[0]);
                self.meas.elevation = (f.aux == 1).then_some(f.data[1]);
                self.meas_n += 1;
                Ok(None)
            }
            MEAS_RANGE => {
                self.meas.range = Some(f.data[0]);
                self.meas_n += 1;
                Ok(None)
            }
            SAMPLE_END => {
                let got = std::mem::take(&mut self.meas_n);
                let meas = std::mem::take(&mut self.meas);
                if got != f.aux {
                    return Err(DecodeError::Count {
                        what: "sample measurements",
                        expected: f.aux,
                        got,
                    });
                }
                c(Command::Sample {
                    sample: f.sample,
                    meas,
                    sigmas: Sigmas {
                        range: f.data[0],
                        doa: f.data[1],
                        elevation: f.data[2],
                    },
                })
            }
            SYNC_ROUNDS => c(Command::SyncRounds {
                sample: f.sample,
                first_round: f.seq,
                rounds: f.aux,
            }),
            PLAN_STEP => {
                decode_plan_steps(f, &mut self.steps)?;
                Ok(None)
            }
            PLAN_END => {
                let steps = std::mem::take(&mut self.steps);
                if steps.len() as u32 != f.aux {
                    return Err(DecodeError::Count {
                        what: "async plan",
                        expected: f.aux,
                        got: steps.len() as u32,
                    });
                }
                c(Command::AsyncPlan {
                    sample: f.sample,
                    steps,
                })
            }
            SNAPSHOT => c(Command::Snapshot { sample: f.sample }),
            NODE_DOWN => c(Command::NodeDown { node: f.aux }),
            NODE_UP => c(Command::NodeUp { node: f.aux }),
            STOP => Ok(Some(NodeInput::Control(Control::Stop))),
            PING => Ok(Some(NodeInput::Control(Control::Ping(f.seq)))),
            PROBE_PEER => Ok(Some(NodeInput::Control(Control::ProbePeer {
                peer: f.aux,
                count: u32::try_from(f.seq).unwrap_or(u32::MAX),
            }))),
            PROBE | PROBE_BACK => Ok(Some(NodeInput::Probe {
                from: f.from,
                seq: f.seq,
                back: f.kind == PROBE_BACK,
            })),
            START_CLOCK => Ok(Some(NodeInput::Control(Control::StartClock(f.data[0])))),
            CLOCK_FACTOR => Ok(Some(NodeInput::Control(Control::ClockFactor(f.data[0])))),
            REFLECT | REQUEST | ACCEPT | DECLINE | AVERAGE => {
                let used = match f.kind {
                    DECLINE => 0,
                    AVERAGE => self.dim,
                    _ => self.dim + 1,
                };
                if f.data[..used.min(f.data.len())]
                    .iter()
                    .any(|v| !v.is_finite())
                {
                    return Err(DecodeError::NotFinite {
                        kind: f.kind,
                        from: f.from,
                    });
                }
                Ok(decode_peer(f, self.dim).map(NodeInput::Peer))
            }
            k => Err(DecodeError::UnknownKind(k)),
        }
    }
}

/// The gossip message a peer frame of a `dim`-dimensional run carries
/// (`None` for another kind): a reflected point of `dim + 1` numbers, an
/// average of `dim`.
pub fn decode_peer(f: &Frame, dim: usize) -> Option<PeerMsg> {
    use kind::{ACCEPT, AVERAGE, DECLINE, REFLECT, REQUEST};
    let (from, seq) = (f.from, f.seq);
    Some(match f.kind {
        REFLECT => PeerMsg::Reflect {
            from,
            seq,
            r: coords(&f.data, dim + 1),
        },
        REQUEST => PeerMsg::Request {
            from,
            seq,
            r: coords(&f.data, dim + 1),
        },
        ACCEPT => PeerMsg::Accept {
            from,
            seq,
            r: coords(&f.data, dim + 1),
        },
        DECLINE => PeerMsg::Decline { from, seq },
        AVERAGE => PeerMsg::Average {
            from,
            seq,
            a: coords(&f.data, dim),
        },
        _ => return None,
    })
}

/// `aux` of a channel frame addressed to every other node (the sync root's
/// Average).
pub const TO_ALL: u32 = u32::MAX;

/// A gossip message handed to the coordinator's acoustic channel
/// ([`crate::engine::water`]) instead of its addressee: the peer frame, with
/// `aux` = the addressee ([`TO_ALL`] for a broadcast) and `data[4]` = the
/// emulated time it was sent (no message uses `data[4]`).
pub fn encode_channel(m: &PeerMsg, to: u32, t_send: f64) -> Frame {
    let mut f = encode_peer(m);
    f.aux = to;
    f.data[4] = t_send;
    f
}

/// The [`kind::LATE`] report of node `node`, which discarded `m` as late.
pub fn encode_late(node: u32, m: &PeerMsg) -> Frame {
    let f = encode_peer(m);
    frame(kind::LATE, node, f.kind, f.from, f.seq, &[])
}

/// Per-node time split reported by node processes.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    /// Seconds spent computing (prox solves and protocol).
    pub busy_seconds: f64,
    /// Seconds spent blocked waiting for messages.
    pub wait_seconds: f64,
}

/// Encode a READY report.
pub fn encode_ready(node: u32) -> Frame {
    frame(kind::READY, node, 0, 0, 0, &[])
}

/// Encode the answer of node `node` to liveness check `seq`.
pub fn encode_pong(node: u32, seq: u64) -> Frame {
    frame(kind::PONG, node, 0, 0, seq, &[])
}

/// Encode hop probe `seq` of node `from` (`back`: the answer to one).
pub fn encode_probe(from: u32, seq: u64, back: bool) -> Frame {
    let k = if back { kind::PROBE_BACK } else { kind::PROBE };
    frame(k, from, 0, 0, seq, &[])
}

/// Encode node `node`'s measured hops (seconds), numbered from `first`,
/// five to a frame.
pub fn encode_hops(node: u32, first: u64, hops: &[f64], out: &mut Vec<Frame>) {
    for (i, c) in hops.chunks(5).enumerate() {
        let seq = first + 5 * i as u64;
        out.push(frame(kind::HOPS, node, 0, c.len() as u32, seq, c));
    }
}

/// Encode a timing report.
pub fn encode_timing(node: u32, t: &Timing) -> Frame {
    frame(
        kind::TIMING,
        node,
        0,
        0,
        0,
        &[t.busy_seconds, t.wait_seconds],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_survive_a_round_trip_through_frames() {
        let cmds = vec![
            Control::Command(Command::Sample {
                sample: 3,
                sigmas: Sigmas {
                    elevation: 0.0,
                    range: 5.0,
                    doa: 0.25,
                },
                meas: NodeMeasurements {
                    elevation: None,
                    bistatic: vec![(0, 1234.5), (1, 0.1 + 0.2)],
                    doa: Some(-2.5),
                    range: Some(7.0),
                },
            }),
            Control::Command(Command::Sample {
                sample: 4,
                sigmas: Sigmas {
                    elevation: 0.0625,
                    range: 5.0,
                    doa: 0.25,
                },
                meas: NodeMeasurements {
                    elevation: Some(-0.125),
                    bistatic: vec![(1, 99.0)],
                    doa: Some(1.5),
                    range: None,
                },
            }),
            Control::Command(Command::SyncRounds {
                sample: 3,
                first_round: 150,
                rounds: 50,
            }),
            Control::Command(Command::AsyncPlan {
                sample: 4,
                steps: vec![(200, 1), (205, 3)],
            }),
            Control::Command(Command::AsyncPlan {
                sample: 5,
                steps: vec![],
            }),
            Control::Command(Command::Snapshot { sample: 9 }),
            Control::Command(Command::NodeDown { node: 2 }),
            Control::StartClock(250.0),
            Control::Stop,
            Control::Ping(7),
            Control::ProbePeer { peer: 3, count: 80 },
        ];
        let mut frames = Vec::new();
        for c in &cmds {
            encode_control(c, &mut frames);
        }
        let mut dec = NodeDecoder::new(2);
        let got: Vec<Control> = frames
            .iter()
            .filter_map(|f| match dec.feed(f).unwrap() {
                Some(NodeInput::Control(c)) => Some(c),
                _ => None,
            })
            .collect();
        assert_eq!(got, cmds);
    }

    fn plan_frames(steps: &[(u64, u32)]) -> Vec<Frame> {
        let mut frames = Vec::new();
        encode_control(
            &Control::Command(Command::AsyncPlan {
                sample: 2,
                steps: steps.to_vec(),
            }),
            &mut frames,
        );
        frames
    }

    #[test]
    fn an_async_plan_travels_six_steps_to_a_frame_and_any_plan_comes_back_whole() {
        // 13 steps close together: frames of 6, 6 and 1, then the end frame.
        let close: Vec<(u64, u32)> = (0..13).map(|j| (100 + 3 * j, (j % 4) as u32)).collect();
        // Steps that cannot share a frame: a jump past the packable offset,
        // an iteration that goes back, the largest partner and iteration.
        let far = vec![
            (5, 7),
            (5 + MAX_STEP_DELTA, u32::MAX),
            (6 + 2 * MAX_STEP_DELTA, 1),
            (3, 0),
            (u64::MAX, u32::MAX),
        ];
        for (steps, frames) in [(close, 3), (far, 4), (vec![(9, 1)], 1), (vec![], 0)] {
            let f = plan_frames(&steps);
            assert_eq!(f.len(), frames + 1, "{steps:?}");
            let mut dec = NodeDecoder::new(2);
            let got: Vec<_> = f.iter().filter_map(|f| dec.feed(f).unwrap()).collect();
            assert_eq!(
                got,
                vec![NodeInput::Control(Control::Command(Command::AsyncPlan {
                    sample: 2,
                    steps,
                }))]
            );
        }
    }

    #[test]
    fn a_plan_frame_slot_that_holds_no_step_is_a_decode_error_naming_the_slot() {
        for bad in [0.5, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300] {
            let mut f = plan_frames(&[(10, 1), (11, 2), (12, 3)]);
            f[0].data[1] = bad;
            let mut dec = NodeDecoder::new(2);
            let e = dec.feed(&f[0]).unwrap_err();
            assert_eq!(
                e,
                DecodeError::BadStep {
                    slot: 1,
                    bits: bad.to_bits()
                }
            );
            assert!(e.to_string().contains("slot 1"), "{e}");
        }
    }

    #[test]
    fn a_3d_run_carries_four_numbers_per_point_and_three_per_average() {
        let r = Coords::from([1.0 / 3.0, -2e-300, -150.25, 5e10]);
        for m in [
            PeerMsg::Reflect { from: 1, seq: 7, r },
            PeerMsg::Accept { from: 3, seq: 1, r },
            PeerMsg::Average {
                from: 0,
                seq: 12,
                a: Coords::from([-1.5, 2.25, -300.0]),
            },
        ] {
            assert_eq!(
                m.values() as usize,
                if m.kind() == "average" { 3 } else { 4 }
            );
            let f = encode_peer(&m);
            assert_eq!(
                NodeDecoder::new(3).feed(&f).unwrap(),
                Some(NodeInput::Peer(m))
            );
        }
        let mut frames = Vec::new();
        let done = Report::SampleDone {
            node: 2,
            sample: 4,
            theta: r,
            counters: Counters::default(),
        };
        encode_report(&done, &mut frames);
        let mut dec = ReportDecoder::new(3);
        let got: Vec<_> = frames.iter().filter_map(|f| dec.feed(f).unwrap()).collect();
        assert_eq!(got, vec![CoordinatorInput::Report(done)]);
    }

    #[test]
    fn peer_messages_and_reports_survive_a_round_trip() {
        let r = Coords::from([1.0 / 3.0, -2e-300, 5e10]);
        for m in [
            PeerMsg::Reflect {
                from: 1,
                seq: 77,
                r,
            },
            PeerMsg::Request { from: 2, seq: 1, r },
            PeerMsg::Accept { from: 3, seq: 1, r },
            PeerMsg::Decline { from: 4, seq: 9 },
            PeerMsg::Average {
                from: 0,
                seq: 12,
                a: Coords::from([-1.5, 2.25]),
            },
        ] {
            let f = encode_peer(&m);
            assert_eq!(
                NodeDecoder::new(2).feed(&f).unwrap(),
                Some(NodeInput::Peer(m))
            );
        }
        let counters = Counters {
            prox_solves: 10,
            messages_out: 11,
            messages_in: 12,
            declines: 1,
            updates: 9,
            timeouts: 3,
            missing: 2,
            late: 1,
            bad_frames: 4,
        };
        let reports = vec![
            Report::SampleDone {
                node: 2,
                sample: 5,
                theta: r,
                counters,
            },
            Report::Snapshot {
                node: 2,
                sample: 6,
                theta: r,
                counters,
            },
            Report::IterationDone {
                node: 1,
                iteration: 99,
                theta: r,
            },
        ];
        let mut frames = Vec::new();
        for rep in &reports {
            encode_report(rep, &mut frames);
        }
        let mut dec = ReportDecoder::new(2);
        let got: Vec<Report> = frames
            .iter()
            .filter_map(|f| match dec.feed(f).unwrap() {
                Some(CoordinatorInput::Report(r)) => Some(r),
                _ => None,
            })
            .collect();
        assert_eq!(got, reports);
        assert_eq!(
            dec.feed(&encode_pong(4, u64::MAX)).unwrap(),
            Some(CoordinatorInput::Pong {
                node: 4,
                seq: u64::MAX
            })
        );
    }

    #[test]
    fn a_failure_crosses_the_wire_as_its_kind_whatever_its_words() {
        use crate::estimators::prox::gtrs::{ProxError, ProxFailure};
        // Words that name another kind (a text guess would call the first
        // one a bad gamma) do not change the kind that arrives.
        let errors = [
            ProxError::Degenerate("gamma too large for the cone".into()),
            ProxError::BadGamma(f64::NAN),
            ProxError::NonFinite("prox input u"),
        ];
        for e in errors {
            let sent = Report::Failed {
                node: 3,
                sample: 7,
                failure: e.kind(),
                reason: e.to_string(),
            };
            let mut frames = Vec::new();
            encode_report(&sent, &mut frames);
            let got = ReportDecoder::new(2).feed(&frames[0]).unwrap();
            assert_eq!(
                got,
                Some(CoordinatorInput::Report(Report::Failed {
                    node: 3,
                    sample: 7,
                    failure: e.kind(),
                    reason: e.kind().text().into(),
                })),
                "{e}"
            );
        }
        for k in ProxFailure::ALL {
            assert_eq!(ProxFailure::from_code(k.code()), k);
        }
    }

    #[test]
    fn hop_probes_and_measured_hops_survive_a_round_trip() {
        for back in [false, true] {
            assert_eq!(
                NodeDecoder::new(2)
                    .feed(&encode_probe(2, 41, back))
                    .unwrap(),
                Some(NodeInput::Probe {
                    from: 2,
                    seq: 41,
                    back
                })
            );
        }
        let hops: Vec<f64> = (0..12).map(|i| 1e-6 * (i as f64 + 0.5)).collect();
        let mut frames = Vec::new();
        encode_hops(5, 100, &hops, &mut frames);
        assert_eq!(frames.len(), 3);
        let mut dec = ReportDecoder::new(2);
        let mut got = Vec::new();
        for f in &frames {
            match dec.feed(f).unwrap() {
                Some(CoordinatorInput::Hops {
                    node: 5,
                    first,
                    seconds,
                }) => {
                    assert_eq!(first, 100 + got.len() as u64);
                    got.extend(seconds);
                }
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(got, hops);
    }

    #[test]
    fn a_truncated_sample_is_reported_as_a_count_mismatch() {
        let mut frames = Vec::new();
        encode_control(
            &Control::Command(Command::Sample {
                sample: 0,
                sigmas: Sigmas {
                    elevation: 0.0,
                    range: 1.0,
                    doa: 0.1,
                },
                meas: NodeMeasurements {
                    elevation: None,
                    bistatic: vec![(0, 1.0), (1, 2.0)],
                    doa: None,
                    range: None,
                },
            }),
            &mut frames,
        );
        frames.remove(0);
        let mut dec = NodeDecoder::new(2);
        assert!(dec.feed(&frames[0]).unwrap().is_none());
        assert!(matches!(
            dec.feed(&frames[1]),
            Err(DecodeError::Count { .. })
        ));
    }

    #[test]
    fn a_flood_of_measurement_or_plan_frames_is_cut_at_its_limit_and_the_next_message_decodes() {
        let meas = frame(kind::MEAS_BISTATIC, COORDINATOR_ID, 0, 0, 0, &[1.0]);
        let mut dec = NodeDecoder::new(2);
        for _ in 0..MAX_SAMPLE_FRAMES {
            assert!(dec.feed(&meas).unwrap().is_none());
        }
        assert!(matches!(
            dec.feed(&meas),
            Err(DecodeError::TooMany {
                what: "sample measurements",
                ..
            })
        ));
        // Whatever was gathered is gone: a whole plan then decodes.
        let steps = vec![(7, 1), (9, 0)];
        let mut got = None;
        for f in plan_frames(&steps) {
            got = dec.feed(&f).unwrap();
        }
        assert_eq!(
            got,
            Some(NodeInput::Control(Control::Command(Command::AsyncPlan {
                sample: 2,
                steps
            })))
        );
        // A plan that never ends stops growing at MAX_PLAN_STEPS.
        let step = plan_frames(&[(1, 1)])[0];
        let mut dec = NodeDecoder::new(2);
        let mut fed = 0usize;
        let err = loop {
            match dec.feed(&step) {
                Ok(_) => fed += 1,
                Err(e) => break e,
            }
            assert!(fed <= MAX_PLAN_STEPS, "no limit");
        };
        assert!(matches!(
            err,
            DecodeError::TooMany {
                what: "async plan",
                ..
            }
        ));
        assert!(dec.steps.capacity() <= 2 * MAX_PLAN_STEPS + 16);
        assert!(dec.steps.is_empty());
    }
}
