//! Who really sent a frame: a frame's `from` is what its sender wrote, but
//! the shared-memory sample it came in names the publisher, and the
//! publisher's iceoryx2 node names the process that created it. The
//! coordinator knows the process id of every node it started, so a frame
//! from a process that is not the node it claims to be is caught here.

use super::PubSub;
use super::Svc;
use crate::transport::wire::{Frame, IMPOSTOR};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::PortFactory;
use std::collections::HashMap;

/// The node processes an endpoint accepts frames from, by process id.
#[derive(Debug, Default)]
pub(super) struct Senders {
    /// Process id -> node.
    pids: HashMap<i64, u32>,
    /// Publisher id -> the node its process is (only publishers found).
    known: HashMap<u128, u32>,
}

impl Senders {
    /// Node `node` runs as process `pid` (again, after a restart).
    pub(super) fn set(&mut self, node: u32, pid: u32) {
        self.pids.retain(|_, n| *n != node);
        self.pids.insert(i64::from(pid), node);
        self.known.retain(|_, n| *n != node);
    }

    /// The node whose process created the publisher `publisher` of the
    /// inbox `inbox`, if it is one of ours.
    fn node_of(&mut self, inbox: &PubSub, publisher: u128) -> Option<u32> {
        if let Some(n) = self.known.get(&publisher) {
            return Some(*n);
        }
        let mut found = None;
        inbox.dynamic_config().list_publishers(|p| {
            if p.publisher_id.value() == publisher {
                found = p
                    .node_id
                    .pid::<Svc>()
                    .ok()
                    .map(|pid| i64::from(pid.value()));
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
        let node = found.and_then(|pid| self.pids.get(&pid).copied())?;
        self.known.insert(publisher, node);
        Some(node)
    }

    /// `f` as it came from the publisher `publisher` of `inbox`: itself if
    /// that publisher's process is the node `f` names (or the coordinator,
    /// which does not check itself), else an [`IMPOSTOR`] frame naming the
    /// node the process is (`from`, `u32::MAX` for a process that is no
    /// node of the run) and the one it claimed (`aux`).
    pub(super) fn stamp(&mut self, inbox: &PubSub, publisher: u128, f: Frame) -> Frame {
        let real = self.node_of(inbox, publisher);
        if real == Some(f.from) {
            return f;
        }
        Frame {
            kind: IMPOSTOR,
            from: real.unwrap_or(u32::MAX),
            aux: f.from,
            ..f
        }
    }
}
