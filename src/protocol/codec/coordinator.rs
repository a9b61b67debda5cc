//! The coordinator's side of the codec: the frames of every node decoded
//! into [`CoordinatorInput`]s.

use super::{DecodeError, Timing, coords, decode_peer, kind};
use crate::estimators::prox::gtrs::ProxFailure;
use crate::protocol::{Counters, PeerMsg, Report};
use crate::transport::wire::Frame;

/// A decoded frame as the coordinator sees it.
#[derive(Debug, Clone, PartialEq)]
pub enum CoordinatorInput {
    /// A protocol report.
    Report(Report),
    /// A node process is up.
    Ready {
        /// Node id.
        node: u32,
    },
    /// A node answered liveness check `seq` ([`Control::Ping`](super::Control::Ping)).
    Pong {
        /// Node id.
        node: u32,
        /// The check number.
        seq: u64,
    },
    /// Hops node `node` measured to a neighbour ([`Control::ProbePeer`](super::Control::ProbePeer)).
    Hops {
        /// Node id.
        node: u32,
        /// The number of the first.
        first: u64,
        /// Half round trips (s), at most five.
        seconds: Vec<f64>,
    },
    /// A node's time split.
    Timing {
        /// Node id.
        node: u32,
        /// The split.
        timing: Timing,
    },
    /// Acoustic channel: a node's gossip message for the water
    /// ([`encode_channel`](super::encode_channel)).
    Channel {
        /// The message (its sender is `msg.from()`).
        msg: PeerMsg,
        /// The addressee, [`TO_ALL`](super::TO_ALL) for every other node.
        to: u32,
        /// When the node sent it, emulated seconds.
        t_send: f64,
    },
    /// Acoustic channel: node `node` discarded a frame as late
    /// ([`encode_late`](super::encode_late)).
    Late {
        /// The node that discarded it.
        node: u32,
        /// Its sender.
        from: u32,
        /// Its kind ([`PeerMsg::kind`]).
        kind: &'static str,
        /// Its sequence number.
        seq: u64,
    },
}

/// Reassembles the reports of all nodes at the coordinator.
#[derive(Debug)]
pub struct ReportDecoder {
    counters: std::collections::HashMap<u32, Counters>,
    dim: usize,
}

impl ReportDecoder {
    /// The decoder of a `dim`-dimensional run's reports (2 or 3).
    pub fn new(dim: usize) -> ReportDecoder {
        ReportDecoder {
            counters: std::collections::HashMap::new(),
            dim,
        }
    }

    /// Feed one frame; returns a complete input when one is finished.
    pub fn feed(&mut self, f: &Frame) -> Result<Option<CoordinatorInput>, DecodeError> {
        use kind::{
            ACCEPT, AVERAGE, COUNTERS, DECLINE, FAILED, HOPS, ITER_DONE, LATE, LOSS_COUNTERS, PONG,
            READY, REFLECT, REQUEST, SAMPLE_DONE, SNAPSHOT_REPLY, TIMING,
        };
        let counters = |s: &Self| s.counters.get(&f.from).copied().unwrap_or_default();
        match f.kind {
            COUNTERS => {
                let d = &f.data;
                self.counters.insert(
                    f.from,
                    Counters {
                        prox_solves: d[0] as u64,
                        messages_out: d[1] as u64,
                        messages_in: d[2] as u64,
                        declines: d[3] as u64,
                        updates: d[4] as u64,
                        ..Counters::default()
                    },
                );
                Ok(None)
            }
            REFLECT | REQUEST | ACCEPT | DECLINE | AVERAGE => Ok(decode_peer(f, self.dim).map(
                |msg| CoordinatorInput::Channel {
                    msg,
                    to: f.aux,
                    t_send: f.data[4],
                },
            )),
            LATE => {
                let probe = Frame {
                    kind: f.sample,
                    ..*f
                };
                let Some(m) = decode_peer(&probe, self.dim) else {
                    return Err(DecodeError::UnknownKind(f.sample));
                };
                Ok(Some(CoordinatorInput::Late {
                    node: f.from,
                    from: f.aux,
                    kind: m.kind(),
                    seq: f.seq,
                }))
            }
            LOSS_COUNTERS => {
                let d = &f.data;
                let c = self.counters.entry(f.from).or_default();
                c.timeouts = d[0] as u64;
                c.missing = d[1] as u64;
                c.late = d[2] as u64;
                c.bad_frames = d[3] as u64;
                Ok(None)
            }
            SAMPLE_DONE => Ok(Some(CoordinatorInput::Report(Report::SampleDone {
                node: f.from,
                sample: f.sample,
                theta: coords(&f.data, self.dim + 1),
                counters: counters(self),
            }))),
            SNAPSHOT_REPLY => Ok(Some(CoordinatorInput::Report(Report::Snapshot {
                node: f.from,
                sample: f.sample,
                theta: coords(&f.data, self.dim + 1),
                counters: counters(self),
            }))),
            ITER_DONE => Ok(Some(CoordinatorInput::Report(Report::IterationDone {
                node: f.from,
                iteration: f.seq,
                theta: coords(&f.data, self.dim + 1),
            }))),
            FAILED => Ok(Some(CoordinatorInput::Report(Report::Failed {
                node: f.from,
                sample: f.sample,
                failure: ProxFailure::from_code(f.aux),
                reason: ProxFailure::from_code(f.aux).text().into(),
            }))),
            TIMING => Ok(Some(CoordinatorInput::Timing {
                node: f.from,
                timing: Timing {
                    busy_seconds: f.data[0],
                    wait_seconds: f.data[1],
                },
            })),
            READY => Ok(Some(CoordinatorInput::Ready { node: f.from })),
            PONG => Ok(Some(CoordinatorInput::Pong {
                node: f.from,
                seq: f.seq,
            })),
            HOPS => Ok(Some(CoordinatorInput::Hops {
                node: f.from,
                first: f.seq,
                seconds: f.data[..(f.aux as usize).min(5)].to_vec(),
            })),
            k => Err(DecodeError::UnknownKind(k)),
        }
    }
}
