//! [`Transport`] over iceoryx2 0.10 shared memory (`ipc::Service`). The only module of
//! the crate that uses iceoryx2.
//!
//! # Namespace and service names
//!
//! Every run gets its own iceoryx2 *prefix* `iox2_sn<h>_`, where `<h>` is the 64-bit
//! FNV-1a hash of the run id in 16 hex digits (see [`resource_prefix`]). All files
//! iceoryx2 creates for the run start with that prefix: shared memory in `/dev/shm`,
//! and static service configs, node details, monitor locks and event sockets under
//! the iceoryx2 root directory, which sonarnet moves from the default `/tmp/iceoryx2`
//! to the tmpfs directory `/dev/shm/sonarnet-iceoryx2-<uid>/` (one per user, mode 0700; creating the ~40 small files
//! per endpoint on the disk file system made a 256-node run take ~30 s to set up
//! instead of ~1.4 s). Concurrent runs are therefore fully separated, and a run's
//! files can be listed ([`run_resources`]) and cleaned ([`cleanup_stale_resources`]).
//! Inside the namespace the services are:
//!
//! | service | pattern | publishers / notifiers | subscribers / listeners | max nodes | buffer |
//! |---|---|---|---|---|---|
//! | `sonarnet/<run>/node/<i>/inbox` | pub-sub of [`Frame`] | `1 + in_deg(i)` | 1 | `2 + in_deg(i)` | `inbox_buffer` |
//! | `sonarnet/<run>/node/<i>/wake` | event | `1 + in_deg(i)` | 1 | `2 + in_deg(i)` | - |
//! | `sonarnet/<run>/coordinator/inbox` | pub-sub | `N` | 1 | `N + 1` | `inbox_buffer` |
//! | `sonarnet/<run>/coordinator/wake` | event | `N` | 1 | `N + 1` | - |
//! | `sonarnet/<run>/coordinator/down` | event | 1 | `N` (listener `n<i>`) | `N + 1` | - |
//! | `sonarnet/<run>/broadcast/frames` (optional) | pub-sub | `N` | `N` | `N + 1` | `broadcast_buffer` |
//! | `sonarnet/<run>/broadcast/wake` (optional) | event | `N` | `N` | `N + 1` | - |
//!
//! `in_deg(i)` is the number of nodes listing `i` as a neighbour; the `+1`s are the
//! coordinator and the owner. The coordinator creates and holds every service but
//! the nodes' wake-up services: a node and its in-neighbours open those, whoever
//! comes first creating it. The coordinator wakes node `i` through `i`'s listener
//! on its one `down` service (iceoryx2's `notify_single_listener`), so it holds one
//! notifier for the run and no event service per node (9 descriptors per
//! node instead of 12). All pub-sub
//! services have history 0, one borrowed sample per subscriber, publishers loan one
//! sample at a time, and event ids go up to 1 (only id 0 is used). iceoryx2 nodes
//! are named `sonarnet/<run>/coordinator` and `sonarnet/<run>/node/<i>`.
//!
//! # No silent loss: overflow policy
//!
//! Safe overflow is **off** on every service (a full buffer never overwrites). The
//! buffer is per sender/receiver pair (an iceoryx2 connection).
//!
//! * Inbox sends use `BackpressureStrategy::DiscardData` and check the number of
//!   receivers the frame reached. If it reached none (buffer full, or the receiver's
//!   process has not opened its inbox yet), [`IoxTransport::send`] wakes the
//!   receiver, moves everything in its *own* inboxes into a private queue (returned
//!   by the next `recv`), sleeps with exponential back-off (yield, then 20 µs to 1 ms)
//!   and retries, until the topology's send timeout; then it returns
//!   [`TransportError::SendTimeout`]. Because a blocked sender keeps draining its own
//!   inbox, endpoints that send to each other cannot deadlock; only a receiver that
//!   stops calling `recv`/`send` (or was killed) makes senders time out. A receiver
//!   that took frames from this sender before and has since closed its inbox (its
//!   process exited cleanly or with an error) is [`TransportError::PeerGone`] at once.
//! * Broadcasts first wait (same back-off and draining) until all `N` members have
//!   subscribed, then publish with a backpressure handler that retries a full member
//!   buffer until the send timeout and then fails
//!   ([`TransportError::BroadcastTimeout`]); a frame reaching fewer than `N` members
//!   is [`TransportError::BroadcastIncomplete`]. While iceoryx2 retries inside the
//!   publish call the sender cannot drain its own broadcast buffer, so two members
//!   that each have more than `broadcast_buffer` unread broadcasts from the other
//!   both time out: size `broadcast_buffer` to the number of rounds a node may run
//!   ahead (2 for lock-step rounds). Before a broadcast that might block, pending
//!   broadcast wake-ups are flushed.
//!
//! # Exiting without losing the last frames
//!
//! A frame lives in the *sender's* shared memory until the receiver takes it. A
//! receiver maps a sender's memory the first time it looks at its inbox after the
//! sender came up; if the sender's process exits before that, its unread frames are
//! gone. [`Transport::shutdown`] therefore waits until every frame sent has left the
//! receivers' buffers (it can loan its whole sample pool; each publisher's pool is
//! sized exactly `subscribers * (buffer + 1) + 1`), and dropping the transport does
//! the same for at most [`DROP_LINGER`]. Frames to a receiver that has left are not
//! waited for.
//!
//! # Cleanup
//!
//! Dropping an [`IoxTransport`] removes its ports; iceoryx2 removes a service when
//! the last process holding it drops it. Each process also removes the run's global
//! management segment (`<prefix><hash>_node.<version>.global_mgmt` in `/dev/shm`, a
//! persistent node counter only needed while an iceoryx2 node is created) right after
//! creating its node. After a clean run nothing of the run is left (only the empty
//! per-user directories `/dev/shm/sonarnet-iceoryx2-<uid>/{nodes,services}` remain).
//!
//! iceoryx2's automatic dead-node scans (on node creation, node drop and service
//! open) are switched off: each costs O(N), O(N²) per run. Processes that die
//! without dropping their transport (SIGKILL, abort) therefore leave their files
//! until [`cleanup_stale_resources`] runs; the coordinator should call it when it
//! starts, and again after reaping the nodes of a run that ended abnormally. It
//! removes the resources of dead iceoryx2 nodes of every sonarnet run (iceoryx2's
//! file-lock monitors tell dead from alive) and leaves live runs alone. A node
//! program whose coordinator died calls [`cleanup_run`] for its own run after
//! dropping its transport, so the last node to leave removes what the
//! coordinator left and nothing waits for the next run.
//!
//! # Process behaviour
//!
//! iceoryx2 logging is set to `Error` (override with `IOX2_LOG_LEVEL`), and nodes and
//! wait sets are built with `SignalHandlingMode::Disabled`, so iceoryx2 installs no
//! SIGINT/SIGTERM handlers: Ctrl-C and `kill` keep their default effect.

mod cleanup;
mod open;
mod senders;
mod services;
pub use cleanup::{
    CleanupReport, cleanup_run, cleanup_stale_resources, resource_prefix, run_resources,
};
#[cfg(test)]
use cleanup::{PREFIX_LEN, parse_prefix};
use cleanup::{base_config, iox_path_to_std};
use cleanup::{config_for_prefix, init_logging, remove_global_mgmt_segment};
use services::{down_listener_node, endpoint_index, taken_by_receivers};

use std::time::{Duration, Instant};

use iceoryx2::port::SendError;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::{ListenerKey, Notifier, NotifierNotifyError};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use super::{Endpoint, RunTopology, Transport, TransportError};
use crate::transport::wire::Frame;

// SAFETY: `Frame` is `#[repr(C)]`, `Copy`, and made only of integers and floats:
// no pointers, references, handles or padding-dependent invariants, so the same
// bytes are valid in every process. Its type name (`sonarnet::transport::wire::Frame`) is
// identical in every process built from this crate.
unsafe impl ZeroCopySend for Frame {}

type Svc = ipc::Service;
type PubSub = publish_subscribe::PortFactory<Svc, Frame, ()>;
type EventSvc = event::PortFactory<Svc>;

/// Sleeps progressively longer between retries: a few yields, then 20 µs doubling to 1 ms.
struct Backoff(u32);

impl Backoff {
    fn wait(&mut self) {
        if self.0 < 3 {
            std::thread::yield_now();
        } else {
            let us = 20u64 << (self.0 - 3).min(6);
            std::thread::sleep(Duration::from_micros(us.min(1000)));
        }
        self.0 = self.0.saturating_add(1);
    }
}

/// How an endpoint wakes a destination after sending to it.
enum Wake {
    /// A notifier of the destination's own wake-up service (a node waking
    /// the coordinator or a neighbour).
    Own(Box<Notifier<Svc>>),
    /// The destination node's listener on the coordinator's down service
    /// (the coordinator waking a node), once found by its name.
    Down(Option<ListenerKey>),
}

/// A destination this endpoint may send to.
struct Peer {
    endpoint: Endpoint,
    publisher: Publisher<Svc, Frame, ()>,
    wake: Wake,
    pool: usize,
    /// Sent to since the last wake-up.
    pending: bool,
    /// Sent to since the last successful shutdown check.
    unconfirmed: bool,
    /// Index of the receiver's inbox service in `pubsub_services`.
    service: usize,
    /// A frame has reached the receiver (so an inbox without subscriber
    /// afterwards means it exited, not that it has not come up yet).
    connected: bool,
}

/// A node's membership in the broadcast group.
struct BroadcastPorts {
    publisher: Publisher<Svc, Frame, ()>,
    subscriber: Subscriber<Svc, Frame, ()>,
    notifier: Notifier<Svc>,
    listener: Listener<Svc>,
    service: PubSub,
    pool: usize,
    pending: bool,
    unconfirmed: bool,
}

/// One endpoint (coordinator or node) of a run, over iceoryx2 shared memory.
///
/// Create the coordinator's first ([`IoxTransport::coordinator`] creates the
/// services but the nodes' wake-ups), then the nodes' ([`IoxTransport::node`]
/// opens them). Not `Send`: use it
/// from the thread that created it.
pub struct IoxTransport {
    // Field order is drop order: the wait set goes before the listeners it watches,
    // ports before their services, services before the iceoryx2 node.
    waitset: WaitSet<Svc>,
    me: Endpoint,
    topology: RunTopology,
    /// `peer_index[endpoint index]` = position in `peers`, `usize::MAX` if not a peer.
    peer_index: Vec<usize>,
    peers: Vec<Peer>,
    /// Peers with `pending == true` (may contain stale entries; `flush` checks).
    pending: Vec<usize>,
    /// Frames drained while a send waited for a full receiver; returned first by `recv`.
    stash: Vec<Frame>,
    inbox: Subscriber<Svc, Frame, ()>,
    wake: Listener<Svc>,
    /// A node's listener on the coordinator's down service.
    down_listener: Option<Listener<Svc>>,
    /// The coordinator's notifier of the down service.
    down: Option<Notifier<Svc>>,
    bcast: Option<BroadcastPorts>,
    /// Bounded polling before blocking in `recv` (zero: block at once).
    poll: Duration,
    pubsub_services: Vec<PubSub>,
    event_services: Vec<EventSvc>,
    /// The node processes whose frames this endpoint authenticates
    /// ([`Transport::authenticate_sender`]); `None`: it does not.
    senders: Option<senders::Senders>,
    node: Node<Svc>,
}

impl std::fmt::Debug for IoxTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IoxTransport")
            .field("endpoint", &self.me)
            .field("run_id", &self.topology.run_id())
            .field("peers", &self.peers.len())
            .field("broadcast", &self.bcast.is_some())
            .finish()
    }
}

impl IoxTransport {
    /// Bounded polling: [`Transport::recv`] first checks the inboxes in shared memory
    /// (no system call), yielding the CPU between checks, for up to `poll` before it
    /// blocks on the wake-up events. Zero (the default) blocks at once.
    ///
    /// This trades CPU for latency while frames are expected within microseconds:
    /// a frame that arrives during the poll is taken without a wake-up, which on a
    /// virtual machine costs ~8 us on the same CPU and ~25 us across CPUs. An idle
    /// endpoint still blocks (after `poll`), so it never spins for longer.
    pub fn set_poll(&mut self, poll: Duration) {
        self.poll = poll;
    }

    /// Polls the inboxes for up to `self.poll` (see [`IoxTransport::set_poll`]);
    /// true if a frame is waiting.
    /// Polls for up to `self.poll` from `start` (the caller's clock read).
    fn poll_inboxes(&self, start: Instant) -> bool {
        if self.poll.is_zero() {
            return false;
        }
        loop {
            let waiting = self.inbox.has_samples().unwrap_or(true)
                || self
                    .bcast
                    .as_ref()
                    .is_some_and(|b| b.subscriber.has_samples().unwrap_or(true));
            if waiting {
                return true;
            }
            if start.elapsed() >= self.poll {
                return false;
            }
            std::thread::yield_now();
        }
    }

    /// The run topology this endpoint was built for.
    pub fn topology(&self) -> &RunTopology {
        &self.topology
    }

    /// Number of iceoryx2 services this endpoint holds open.
    pub fn open_services(&self) -> usize {
        self.pubsub_services.len() + self.event_services.len()
    }

    /// The iceoryx2 node name of this endpoint (for diagnostics).
    pub fn node_name(&self) -> String {
        self.node.name().to_string()
    }

    fn peer_slot(&self, to: Endpoint) -> Result<usize, TransportError> {
        self.topology.check_endpoint(to)?;
        match self.peer_index[endpoint_index(&self.topology, to)] {
            usize::MAX => Err(TransportError::NotAPeer { from: self.me, to }),
            k => Ok(k),
        }
    }

    /// Clears pending wake-up notifications (before reading data, so that a frame
    /// arriving in between still leaves a notification behind).
    fn consume_wakeups(&self) -> Result<(), TransportError> {
        self.wake
            .try_wait(|_| {})
            .map_err(|e| TransportError::ipc("reading wake-up events", e))?;
        if let Some(l) = &self.down_listener {
            l.try_wait(|_| {})
                .map_err(|e| TransportError::ipc("reading the coordinator's wake-up events", e))?;
        }
        if let Some(b) = &self.bcast {
            b.listener
                .try_wait(|_| {})
                .map_err(|e| TransportError::ipc("reading broadcast wake-up events", e))?;
        }
        Ok(())
    }

    /// Everything readable now in this endpoint's inbox and broadcast
    /// group, appended to `out`, authenticated when that is on (against the
    /// inbox, the first service).
    fn drain_into(&mut self, out: &mut Vec<Frame>) -> Result<(), TransportError> {
        let auth = match (self.senders.as_mut(), self.pubsub_services.first()) {
            (Some(s), Some(svc)) => Some((s, svc)),
            _ => None,
        };
        Self::drain_subscribers(&self.inbox, self.bcast.as_ref(), auth, out)
    }

    fn drain_subscribers(
        inbox: &Subscriber<Svc, Frame, ()>,
        bcast: Option<&BroadcastPorts>,
        auth: Option<(&mut senders::Senders, &PubSub)>,
        out: &mut Vec<Frame>,
    ) -> Result<(), TransportError> {
        let mut auth = auth;
        while let Some(sample) = inbox
            .receive()
            .map_err(|e| TransportError::ipc("receiving from inbox", e))?
        {
            let f = *sample.payload();
            out.push(match auth.as_mut() {
                Some((s, svc)) => s.stamp(svc, sample.header().publisher_id().value(), f),
                None => f,
            });
        }
        if let Some(b) = bcast {
            while let Some(sample) = b
                .subscriber
                .receive()
                .map_err(|e| TransportError::ipc("receiving from broadcast group", e))?
            {
                let f = *sample.payload();
                out.push(match auth.as_mut() {
                    Some((s, _)) => s.stamp(&b.service, sample.header().publisher_id().value(), f),
                    None => f,
                });
            }
        }
        Ok(())
    }

    /// Moves everything readable now into the private stash (used while waiting for
    /// a full receiver, so that we never hold up someone who is waiting for us).
    fn stash_incoming(&mut self) -> Result<(), TransportError> {
        let mut stash = std::mem::take(&mut self.stash);
        let r = self.drain_into(&mut stash);
        self.stash = stash;
        r
    }

    fn wait_broadcast_members(&mut self, start: Instant) -> Result<(), TransportError> {
        let n = self.topology.n_nodes();
        let mut backoff = Backoff(0);
        loop {
            let subscribers = match &self.bcast {
                Some(b) => b.service.dynamic_config().number_of_subscribers(),
                None => return Err(TransportError::BroadcastUnavailable(self.me)),
            };
            if subscribers >= n {
                return Ok(());
            }
            let waited = start.elapsed();
            if waited >= self.topology.send_timeout() {
                return Err(TransportError::BroadcastTimeout {
                    from: self.me,
                    subscribers,
                    expected: n,
                    waited,
                });
            }
            self.stash_incoming()?;
            backoff.wait();
        }
    }
}

impl IoxTransport {
    /// Endpoints (and the broadcast group) that still hold unread frames from us.
    fn unconfirmed_receivers(&mut self) -> Result<(Vec<Endpoint>, bool), TransportError> {
        let mut waiting = Vec::new();
        for p in self.peers.iter_mut().filter(|p| p.unconfirmed) {
            if taken_by_receivers(&p.publisher, p.pool)? {
                p.unconfirmed = false;
            } else {
                waiting.push(p.endpoint);
            }
        }
        let mut broadcast = false;
        if let Some(b) = self.bcast.as_mut().filter(|b| b.unconfirmed) {
            if taken_by_receivers(&b.publisher, b.pool)? {
                b.unconfirmed = false;
            } else {
                broadcast = true;
            }
        }
        Ok((waiting, broadcast))
    }
}

impl IoxTransport {
    /// Wakes the receiver of peer `slot`: through its own wake-up service,
    /// or (the coordinator waking a node) through that node's listener on
    /// the down service, looked up by name the first time and again when
    /// the node has restarted. A node whose listener is not there yet has
    /// no subscriber either, so nothing it could miss was delivered.
    fn wake_peer(&mut self, slot: usize) -> Result<(), TransportError> {
        let to = self.peers[slot].endpoint;
        let waking = |e| TransportError::ipc(format!("waking {to}"), e);
        let key = match &self.peers[slot].wake {
            Wake::Own(n) => return n.notify().map(|_| ()).map_err(waking),
            Wake::Down(key) => *key,
        };
        let Some(down) = &self.down else {
            return Ok(());
        };
        if let Some(k) = key {
            match down.notify_single_listener(&k) {
                Ok(()) => return Ok(()),
                Err(NotifierNotifyError::InvalidListenerKey) => {}
                Err(e) => return Err(waking(e)),
            }
        }
        // Find every node's listener (once per run, and after restarts).
        self.peers[slot].wake = Wake::Down(None);
        let (peers, index, topology) = (&mut self.peers, &self.peer_index, &self.topology);
        down.for_each_listener(|monofier, details| {
            if let Some(i) = down_listener_node(details.listener_name.as_str())
                && (i as usize) < topology.n_nodes()
                && let Some(&k) = index.get(i as usize)
                && let Some(p) = peers.get_mut(k)
            {
                p.wake = Wake::Down(Some(monofier.listener_key()));
            }
            CallbackProgression::Continue
        });
        match &self.peers[slot].wake {
            Wake::Down(Some(k)) => down.notify_single_listener(k).map_err(waking),
            _ => Ok(()),
        }
    }
}

impl IoxTransport {
    /// Wakes every endpoint sent to since it was last woken, but `lazy`
    /// (which stays owed its wake-up, see [`Transport::flush_lazily`]), and
    /// the broadcast group if something was broadcast.
    fn wake_pending(&mut self, lazy: Option<Endpoint>) -> Result<(), TransportError> {
        let mut pending = std::mem::take(&mut self.pending);
        let mut result = Ok(());
        pending.retain(|&slot| {
            if !self.peers[slot].pending {
                return false;
            }
            if Some(self.peers[slot].endpoint) == lazy {
                return true;
            }
            self.peers[slot].pending = false;
            if let Err(e) = self.wake_peer(slot) {
                result = Err(e);
            }
            false
        });
        self.pending = pending;
        if let Some(b) = self.bcast.as_mut()
            && b.pending
        {
            b.pending = false;
            if let Err(e) = b.notifier.notify() {
                result = Err(TransportError::ipc("waking the broadcast group", e));
            }
        }
        result
    }
}

/// How long dropping an [`IoxTransport`] waits for receivers to take frames sent to
/// them (see [`Transport::shutdown`]; call that to choose the time and see failures).
pub const DROP_LINGER: Duration = Duration::from_secs(1);

impl Drop for IoxTransport {
    fn drop(&mut self) {
        let unconfirmed = self.peers.iter().any(|p| p.unconfirmed)
            || self.bcast.as_ref().is_some_and(|b| b.unconfirmed);
        if unconfirmed {
            let _ = self.shutdown(DROP_LINGER);
        }
        if let Some(s) = &mut self.senders {
            s.withdraw();
        }
    }
}

impl Transport for IoxTransport {
    fn endpoint(&self) -> Endpoint {
        self.me
    }

    /// iceoryx2 keeps a frame in the sender's shared memory until the receiver takes
    /// it; a receiver that has not yet looked at its inbox since this sender came up
    /// would lose the frames when the sender's process exits. So this waits until
    /// every frame sent is out of the receivers' buffers (received, or the receiver
    /// has left), draining our own inbox meanwhile (frames stay available to `recv`).
    /// Dropping the transport does the same for at most [`DROP_LINGER`].
    fn shutdown(&mut self, timeout: Duration) -> Result<(), TransportError> {
        self.flush()?;
        let start = Instant::now();
        let mut backoff = Backoff(0);
        loop {
            let (pending, broadcast) = self.unconfirmed_receivers()?;
            if pending.is_empty() && !broadcast {
                return Ok(());
            }
            let waited = start.elapsed();
            if waited >= timeout {
                return Err(TransportError::ShutdownTimeout {
                    from: self.me,
                    pending,
                    broadcast,
                    waited,
                });
            }
            self.stash_incoming()?;
            backoff.wait();
        }
    }

    /// From the first call on, every frame in this endpoint's inbox is
    /// checked: the process that created its publisher (iceoryx2 records
    /// the process id in the publisher's node id) must be the node the
    /// frame names, else it comes back as an
    /// [`IMPOSTOR`](crate::transport::wire::IMPOSTOR) frame naming both.
    fn authenticate_sender(&mut self, node: u32, pid: u32) {
        let prefix = resource_prefix(self.topology.run_id());
        self.senders
            .get_or_insert_with(|| match senders::roster_path(&prefix) {
                Ok(path) => senders::Senders::writing(path, std::process::id()),
                Err(_) => senders::Senders::default(),
            })
            .set(node, pid);
    }

    /// Writes the run's roster of node processes for the nodes' own checks
    /// (`<iceoryx2 root>/<run prefix>.roster`), if it changed since it was
    /// last written.
    fn publish_senders(&mut self) -> Result<(), TransportError> {
        match self.senders.as_mut() {
            Some(s) => s
                .publish()
                .map_err(|e| TransportError::ipc("writing the run's roster of node processes", e)),
            None => Ok(()),
        }
    }

    fn forget_unread(&mut self, keep: Option<Endpoint>) {
        for p in self.peers.iter_mut().filter(|p| Some(p.endpoint) != keep) {
            p.unconfirmed = false;
        }
        if let Some(b) = self.bcast.as_mut() {
            b.unconfirmed = false;
        }
    }

    fn send(&mut self, to: Endpoint, frame: &Frame) -> Result<(), TransportError> {
        let slot = self.peer_slot(to)?;
        let mut started: Option<Instant> = None;
        let mut backoff = Backoff(0);
        loop {
            let delivered = self.peers[slot]
                .publisher
                .send_copy(*frame)
                .map_err(|e| TransportError::ipc(format!("sending to {to}"), e))?;
            if delivered > 0 {
                let peer = &mut self.peers[slot];
                peer.connected = true;
                peer.unconfirmed = true;
                if !peer.pending {
                    peer.pending = true;
                    self.pending.push(slot);
                }
                return Ok(());
            }
            // Not delivered: the receiver's buffer is full, it has no inbox yet,
            // or it had one and exited.
            let peer = &self.peers[slot];
            if peer.connected
                && self.pubsub_services[peer.service]
                    .dynamic_config()
                    .number_of_subscribers()
                    == 0
            {
                return Err(TransportError::PeerGone { from: self.me, to });
            }
            let start = match started {
                Some(s) => s,
                None => {
                    // Make sure the receiver knows there is something to drain.
                    self.wake_peer(slot)?;
                    *started.insert(Instant::now())
                }
            };
            self.stash_incoming()?;
            let waited = start.elapsed();
            if waited >= self.topology.send_timeout() {
                return Err(TransportError::SendTimeout {
                    from: self.me,
                    to,
                    waited,
                });
            }
            backoff.wait();
        }
    }

    fn broadcast(&mut self, frame: &Frame) -> Result<(), TransportError> {
        if self.bcast.is_none() {
            return Err(TransportError::BroadcastUnavailable(self.me));
        }
        let start = Instant::now();
        self.wait_broadcast_members(start)?;
        let n = self.topology.n_nodes();
        let me = self.me;
        let Some(b) = self.bcast.as_mut() else {
            return Err(TransportError::BroadcastUnavailable(me));
        };
        if b.pending {
            // Members may have to drain before this publish fits: wake them first.
            b.notifier
                .notify()
                .map_err(|e| TransportError::ipc("waking the broadcast group", e))?;
            b.pending = false;
        }
        match b.publisher.send_copy(*frame) {
            Ok(delivered) if delivered >= n => {
                b.pending = true;
                b.unconfirmed = true;
                Ok(())
            }
            Ok(delivered) => Err(TransportError::BroadcastIncomplete {
                from: me,
                delivered,
                expected: n,
            }),
            Err(SendError::UnableToDeliver) => Err(TransportError::BroadcastTimeout {
                from: me,
                subscribers: b.service.dynamic_config().number_of_subscribers(),
                expected: n,
                waited: start.elapsed(),
            }),
            Err(e) => Err(TransportError::ipc("broadcasting", e)),
        }
    }

    fn flush(&mut self) -> Result<(), TransportError> {
        self.wake_pending(None)
    }

    fn flush_lazily(&mut self, lazy: Endpoint) -> Result<(), TransportError> {
        self.wake_pending(Some(lazy))
    }

    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError> {
        let before = out.len();
        // Taken when a first look finds nothing: a frame already there costs
        // no clock read.
        let mut deadline: Option<Option<Instant>> = None;
        loop {
            // Frames first (shared memory, no system call): while frames keep coming,
            // the wake-up notifications are only read (system calls) right before
            // blocking, once per wait instead of once per call.
            out.append(&mut self.stash);
            self.drain_into(out)?;
            if out.len() > before {
                return Ok(out.len() - before);
            }
            let now = Instant::now();
            let deadline =
                *deadline.get_or_insert_with(|| timeout.and_then(|t| now.checked_add(t)));
            let forever = deadline.is_none();
            if self.poll_inboxes(now) {
                continue;
            }
            // Never block owing a wake-up (one left by `flush_lazily`).
            if !self.pending.is_empty() {
                self.flush()?;
            }
            // Clear the notifications, then look again: a frame sent after the
            // look still leaves a notification behind, so the wait below wakes up.
            self.consume_wakeups()?;
            self.drain_into(out)?;
            if out.len() > before {
                return Ok(out.len() - before);
            }
            let result = if forever {
                self.waitset
                    .wait_and_process_once(|_| CallbackProgression::Continue)
            } else {
                let now = Instant::now();
                let remaining = match deadline {
                    Some(d) if d > now => d - now,
                    _ => return Ok(0),
                };
                self.waitset.wait_and_process_once_with_timeout(
                    |_| CallbackProgression::Continue,
                    remaining,
                )
            };
            result.map_err(|e| TransportError::ipc("waiting for a wake-up", e))?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn frame(from: u32, seq: u64) -> Frame {
        Frame {
            kind: 7,
            from,
            seq,
            ..Frame::default()
        }
    }

    #[test]
    fn run_prefix_is_a_short_hex_hash_that_parses_back() {
        let p = resource_prefix("some-run");
        assert_eq!(p.len(), PREFIX_LEN);
        assert_eq!(
            parse_prefix(&format!("{p}abc.node_monitor")),
            Some(p.as_str())
        );
        assert_ne!(p, resource_prefix("some-run2"));
        assert_eq!(parse_prefix("iox2_node.0_10_0.global_mgmt"), None);
        assert_eq!(parse_prefix("iox2_snzzzzzzzzzzzzzzzz_x"), None);
    }

    #[test]
    fn single_process_round_trip_wakes_the_receiver_and_leaves_nothing_behind() {
        let topo = RunTopology::ring(super::super::unique_run_id(), 2, 2)
            .unwrap()
            .with_send_timeout(Duration::from_millis(300));
        {
            let mut c = IoxTransport::coordinator(&topo).unwrap();
            let mut n0 = IoxTransport::node(&topo, 0).unwrap();
            let mut n1 = IoxTransport::node(&topo, 1).unwrap();
            assert!(!run_resources(topo.run_id()).is_empty());
            let to1 = Endpoint::Node(1);
            c.send(to1, &frame(u32::MAX, 0)).unwrap();
            c.send(to1, &frame(u32::MAX, 1)).unwrap();
            // the coordinator->node 1 buffer (2) is full and node 1 is not reading
            let t0 = Instant::now();
            let err = c.send(to1, &frame(u32::MAX, 2)).unwrap_err();
            assert!(matches!(err, TransportError::SendTimeout { .. }), "{err}");
            assert!(t0.elapsed() >= Duration::from_millis(300));
            // the buffer is per sender: node 0 can still reach node 1
            n0.send(to1, &frame(0, 9)).unwrap();
            n0.flush().unwrap();
            let mut out = Vec::new();
            while out.len() < 3 {
                n1.recv(&mut out, Some(Duration::from_secs(10))).unwrap();
            }
            let from_c: Vec<u64> = out
                .iter()
                .filter(|f| f.from == u32::MAX)
                .map(|f| f.seq)
                .collect();
            assert_eq!(from_c, vec![0, 1]);
            assert!(out.contains(&frame(0, 9)));
            c.send(to1, &frame(u32::MAX, 2)).unwrap();
            // node 1 does not read: shutdown names it
            match c.shutdown(Duration::from_millis(100)) {
                Err(TransportError::ShutdownTimeout {
                    pending, broadcast, ..
                }) => {
                    assert_eq!(pending, vec![to1]);
                    assert!(!broadcast);
                }
                other => panic!("expected a shutdown timeout, got {other:?}"),
            }
            out.clear();
            assert_eq!(n1.recv(&mut out, Some(Duration::from_secs(10))).unwrap(), 1);
            assert_eq!(out, vec![frame(u32::MAX, 2)]);
            c.shutdown(Duration::from_secs(10)).unwrap();
            n0.shutdown(Duration::from_secs(10)).unwrap();

            n1.send(Endpoint::Coordinator, &frame(1, 1)).unwrap();
            n1.flush().unwrap();
            let mut back = Vec::new();
            assert_eq!(c.recv(&mut back, Some(Duration::from_secs(10))).unwrap(), 1);
            assert_eq!(back, vec![frame(1, 1)]);
            assert!(matches!(
                n0.send(Endpoint::Node(0), &frame(0, 0)),
                Err(TransportError::NotAPeer { .. })
            ));
            assert!(matches!(
                c.send(Endpoint::Node(2), &frame(0, 0)),
                Err(TransportError::UnknownEndpoint(_))
            ));
            assert!(matches!(
                n0.broadcast(&frame(0, 0)),
                Err(TransportError::BroadcastUnavailable(_))
            ));
        }
        assert_eq!(run_resources(topo.run_id()), Vec::<PathBuf>::new());
    }

    /// A lazily flushed frame is readable at once, its wake-up
    /// stays owed, and the sender gives it before it blocks (or at its next
    /// plain flush), so a receiver that waits for it is never stranded.
    #[test]
    fn a_wake_up_left_by_a_lazy_flush_is_given_before_the_sender_blocks() {
        let topo = RunTopology::ring(super::super::unique_run_id(), 2, 4).unwrap();
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut n0 = IoxTransport::node(&topo, 0).unwrap();
        let _n1 = IoxTransport::node(&topo, 1).unwrap();
        let owed = |t: &IoxTransport| t.peers.iter().any(|p| p.pending);
        n0.send(Endpoint::Coordinator, &frame(0, 1)).unwrap();
        n0.send(Endpoint::Node(1), &frame(0, 2)).unwrap();
        n0.flush_lazily(Endpoint::Coordinator).unwrap();
        let coordinator = n0.peer_slot(Endpoint::Coordinator).unwrap();
        let node1 = n0.peer_slot(Endpoint::Node(1)).unwrap();
        assert!(
            n0.peers[coordinator].pending,
            "the coordinator's wake-up waits"
        );
        assert!(!n0.peers[node1].pending, "node 1 was woken");
        // A second lazy flush still owes it; a plain one gives it.
        n0.flush_lazily(Endpoint::Coordinator).unwrap();
        assert!(owed(&n0));
        n0.flush().unwrap();
        assert!(!owed(&n0));
        // Owed again, then given when the sender blocks (nothing to read).
        n0.send(Endpoint::Coordinator, &frame(0, 3)).unwrap();
        n0.flush_lazily(Endpoint::Coordinator).unwrap();
        assert!(owed(&n0));
        let mut out = Vec::new();
        assert_eq!(
            n0.recv(&mut out, Some(Duration::from_millis(5))).unwrap(),
            0
        );
        assert!(!owed(&n0), "woken before blocking");
        while out.len() < 2 {
            assert!(c.recv(&mut out, Some(Duration::from_secs(10))).unwrap() > 0);
        }
        assert_eq!(out, vec![frame(0, 1), frame(0, 3)]);
    }

    #[test]
    fn a_send_to_a_receiver_that_closed_its_inbox_fails_with_peer_gone_not_a_timeout() {
        let topo = RunTopology::ring(super::super::unique_run_id(), 2, 2)
            .unwrap()
            .with_send_timeout(Duration::from_secs(30));
        {
            let mut c = IoxTransport::coordinator(&topo).unwrap();
            let mut n0 = IoxTransport::node(&topo, 0).unwrap();
            let mut n1 = IoxTransport::node(&topo, 1).unwrap();
            let to1 = Endpoint::Node(1);
            n0.send(to1, &frame(0, 1)).unwrap();
            n0.flush().unwrap();
            let mut out = Vec::new();
            n1.recv(&mut out, Some(Duration::from_secs(10))).unwrap();
            assert_eq!(out, vec![frame(0, 1)]);
            // Node 1 exits (its inbox closes, as when its process ends).
            drop(n1);
            let err = n0.send(to1, &frame(0, 2)).unwrap_err();
            assert!(
                matches!(err, TransportError::PeerGone { to, .. } if to == to1),
                "{err}"
            );
            // The coordinator never sent to node 1: for it the inbox might
            // not be up yet, so it would wait (not tried here: 30 s).
            c.shutdown(Duration::from_secs(10)).unwrap();
            n0.shutdown(Duration::from_secs(10)).unwrap();
        }
        assert_eq!(run_resources(topo.run_id()), Vec::<PathBuf>::new());
    }

    #[test]
    fn a_node_cannot_join_a_run_that_was_not_created() {
        let topo = RunTopology::ring(super::super::unique_run_id(), 2, 2).unwrap();
        let err = IoxTransport::node(&topo, 0).unwrap_err();
        assert!(matches!(err, TransportError::Ipc { .. }), "{err}");
        assert_eq!(run_resources(topo.run_id()), Vec::<PathBuf>::new());
    }

    #[test]
    fn a_node_with_a_larger_topology_than_the_coordinator_is_refused() {
        let id = super::super::unique_run_id();
        let small = RunTopology::ring(id.clone(), 3, 2).unwrap();
        let big = RunTopology::ring(id.clone(), 3, 8).unwrap();
        {
            let _c = IoxTransport::coordinator(&small).unwrap();
            let err = IoxTransport::node(&big, 0).unwrap_err();
            assert!(err.to_string().contains("inbox"), "{err}");
        }
        assert_eq!(run_resources(&id), Vec::<PathBuf>::new());
    }
}
