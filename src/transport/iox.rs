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
//! to the tmpfs directory `/dev/shm/sonarnet-iceoryx2/` (creating the ~40 small files
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
//! | `sonarnet/<run>/broadcast/frames` (optional) | pub-sub | `N` | `N` | `N + 1` | `broadcast_buffer` |
//! | `sonarnet/<run>/broadcast/wake` (optional) | event | `N` | `N` | `N + 1` | - |
//!
//! `in_deg(i)` is the number of nodes listing `i` as a neighbour; the `+1`s are the
//! coordinator (which creates and holds every service) and the owner. All pub-sub
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
//!   stops calling `recv`/`send` (or died) makes senders time out.
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
//! shared directories `/dev/shm/sonarnet-iceoryx2/{nodes,services}` remain).
//!
//! iceoryx2's automatic dead-node scans (on node creation, node drop and service
//! open) are switched off: each costs O(N), O(N²) per run. Processes that die
//! without dropping their transport (SIGKILL, abort) therefore leave their files
//! until [`cleanup_stale_resources`] runs; the coordinator should call it when it
//! starts, and again after reaping the nodes of a run that ended abnormally. It
//! removes the resources of dead iceoryx2 nodes of every sonarnet run (iceoryx2's
//! file-lock monitors tell dead from alive) and leaves live runs alone.
//!
//! # Process behaviour
//!
//! iceoryx2 logging is set to `Error` (override with `IOX2_LOG_LEVEL`), and nodes and
//! wait sets are built with `SignalHandlingMode::Disabled`, so iceoryx2 installs no
//! SIGINT/SIGTERM handlers: Ctrl-C and `kill` keep their default effect.

use std::path::{Path, PathBuf};
use std::sync::Once;
use std::time::{Duration, Instant};

use iceoryx2::config::Config;
use iceoryx2::node::NodeState;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{BackpressureAction, BackpressureInfo, LoanError, SendError};
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

/// Directory where POSIX shared memory objects appear (Linux).
const SHM_DIR: &str = "/dev/shm";
/// First part of every run prefix; followed by 16 hex digits and `_`.
const PREFIX_HEAD: &str = "iox2_sn";
const PREFIX_LEN: usize = PREFIX_HEAD.len() + 16 + 1;
const GLOBAL_MGMT_SUFFIX: &str = ".global_mgmt";
const MONITOR_SUFFIX: &str = ".node_monitor";

fn init_logging() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| set_log_level_from_env_or(LogLevel::Error));
}

fn fnv1a64(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The iceoryx2 file prefix of a run: `iox2_sn<16 hex digits of FNV-1a(run_id)>_`.
pub fn resource_prefix(run_id: &str) -> String {
    format!("{PREFIX_HEAD}{:016x}_", fnv1a64(run_id))
}

/// If `name` starts with a sonarnet run prefix, that prefix.
fn parse_prefix(name: &str) -> Option<&str> {
    let p = name.get(..PREFIX_LEN)?;
    let hex = &p[PREFIX_HEAD.len()..PREFIX_LEN - 1];
    (p.starts_with(PREFIX_HEAD) && p.ends_with('_') && hex.bytes().all(|b| b.is_ascii_hexdigit()))
        .then_some(p)
}

/// iceoryx2's root directory for sonarnet (static configs, node details, monitor
/// locks, event sockets): on tmpfs next to the shared memory, because creating the
/// ~40 small files per endpoint on a disk file system (the default `/tmp/iceoryx2`)
/// made a 256-node run take tens of seconds to set up instead of about one. Falls
/// back to the iceoryx2 default where `/dev/shm` does not exist.
const ROOT_DIR: &str = "/dev/shm/sonarnet-iceoryx2/";

/// The iceoryx2 configuration shared by all sonarnet processes (prefix not set).
fn base_config() -> Result<Config, TransportError> {
    let mut cfg = Config::default();
    if Path::new(SHM_DIR).is_dir() {
        let root = iceoryx2::prelude::Path::new(ROOT_DIR.as_bytes())
            .map_err(|e| TransportError::ipc(format!("using root {ROOT_DIR}"), e))?;
        cfg.global.set_root_path(&root);
    }
    Ok(cfg)
}

fn config_for_prefix(prefix: &str) -> Result<Config, TransportError> {
    let mut cfg = base_config()?;
    cfg.global.prefix = FileName::new(prefix.as_bytes())
        .map_err(|e| TransportError::ipc(format!("using prefix {prefix:?}"), e))?;
    // Dead-node scans on every node creation/drop and service open cost O(N) each,
    // O(N^2) per run; dead nodes are handled by `cleanup_stale_resources` instead.
    cfg.global.node.cleanup_dead_nodes_on_creation = false;
    cfg.global.node.cleanup_dead_nodes_on_destruction = false;
    cfg.global.service.cleanup_dead_nodes_on_open = false;
    Ok(cfg)
}

fn iox_path_to_std(p: &iceoryx2::prelude::Path) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(p.as_bytes()).into_owned())
}

/// Removes the run's global management segment (in `/dev/shm`). iceoryx2 only uses
/// it while creating a node, to draw a per-machine node counter; node ids stay unique
/// without it (they also contain the pid and the creation time in nanoseconds).
fn remove_global_mgmt_segment(cfg: &Config) {
    // SAFETY: the function requires that no other process uses the segment's domain.
    // The domain is this run's prefix, whose processes use the segment only inside
    // `NodeBuilder::create`, which opens-or-creates it in a retry loop: removing it
    // concurrently at worst restarts the node counter, which cannot make node ids
    // collide (see above). The segment is removed by every process right after its
    // own node exists, so the last one to be created is also removed.
    let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<Svc>(cfg) };
}

/// Removes global management segments with `prefix` by listing `/dev/shm` (used by
/// the stale-resource cleanup, which does not know the exact name).
fn remove_global_mgmt_segments_by_scan(prefix: &str) -> usize {
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return 0;
    };
    let mut removed = 0;
    for entry in dir.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with(prefix)
            && name.ends_with(GLOBAL_MGMT_SUFFIX)
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

fn collect_files_with_prefix(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in rd.flatten() {
        let path = entry.path();
        let is_dir = entry.file_type().map(|t| t.is_dir()).unwrap_or(false);
        if entry.file_name().to_string_lossy().starts_with(prefix) {
            out.push(path.clone());
        }
        if is_dir {
            collect_files_with_prefix(&path, prefix, out);
        }
    }
}

/// All files and shared-memory objects that currently exist for run `run_id` (in
/// `/dev/shm`, including the iceoryx2 root below it). Empty after a clean run
/// or after [`cleanup_stale_resources`] removed a crashed one.
pub fn run_resources(run_id: &str) -> Vec<PathBuf> {
    let prefix = resource_prefix(run_id);
    let mut out = Vec::new();
    collect_files_with_prefix(Path::new(SHM_DIR), &prefix, &mut out);
    if let Ok(cfg) = base_config() {
        let root = iox_path_to_std(cfg.global.root_path());
        collect_files_with_prefix(&root, &prefix, &mut out);
    }
    out.sort();
    out.dedup();
    out
}

/// What [`cleanup_stale_resources`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// sonarnet run namespaces found on the machine.
    pub runs_scanned: usize,
    /// Runs that still have at least one live process (left alone).
    pub runs_alive: usize,
    /// Dead iceoryx2 nodes whose resources were removed.
    pub dead_nodes_removed: usize,
    /// Dead or undefined nodes that could not be cleaned (permissions, concurrent cleaner).
    pub cleanup_failures: usize,
    /// Orphaned global management segments removed.
    pub segments_removed: usize,
}

/// Removes the IPC resources of sonarnet runs whose processes died without cleaning
/// up (e.g. SIGKILL). Runs with a live process are left untouched. Call it when the
/// coordinator starts; it is cheap when there is nothing to do.
///
/// Uses iceoryx2's dead-node detection: `Node::list` reports nodes whose monitor lock
/// is no longer held as dead, and `try_remove_stale_resources` removes them from
/// their services (removing services nobody holds any more).
pub fn cleanup_stale_resources() -> Result<CleanupReport, TransportError> {
    init_logging();
    let base = base_config()?;
    let mut prefixes: Vec<String> = Vec::new();
    let mut note = |name: &str, suffix: &str| {
        if name.ends_with(suffix)
            && let Some(p) = parse_prefix(name)
            && !prefixes.iter().any(|q| q == p)
        {
            prefixes.push(p.to_string());
        }
    };
    if let Ok(rd) = std::fs::read_dir(iox_path_to_std(&base.global.node_dir())) {
        for e in rd.flatten() {
            note(&e.file_name().to_string_lossy(), MONITOR_SUFFIX);
        }
    }
    if let Ok(rd) = std::fs::read_dir(SHM_DIR) {
        for e in rd.flatten() {
            note(&e.file_name().to_string_lossy(), GLOBAL_MGMT_SUFFIX);
        }
    }

    let mut report = CleanupReport {
        runs_scanned: prefixes.len(),
        ..CleanupReport::default()
    };
    for prefix in &prefixes {
        let cfg = config_for_prefix(prefix)?;
        let mut alive = 0usize;
        Node::<Svc>::list(&cfg, |state| {
            match state {
                NodeState::Alive(_) => alive += 1,
                NodeState::Dead(view) => match view.try_remove_stale_resources() {
                    Ok(()) => report.dead_nodes_removed += 1,
                    Err(_) => report.cleanup_failures += 1,
                },
                NodeState::Inaccessible(_) => alive += 1,
                NodeState::Undefined(_) => report.cleanup_failures += 1,
            }
            CallbackProgression::Continue
        })
        .map_err(|e| TransportError::ipc(format!("listing iceoryx2 nodes of {prefix}"), e))?;
        if alive == 0 {
            report.segments_removed += remove_global_mgmt_segments_by_scan(prefix);
        } else {
            report.runs_alive += 1;
        }
    }
    Ok(report)
}

struct PubSubSpec {
    name: String,
    publishers: usize,
    subscribers: usize,
    nodes: usize,
    buffer: usize,
}

struct EventSpec {
    name: String,
    notifiers: usize,
    listeners: usize,
    nodes: usize,
}

fn node_inbox_spec(t: &RunTopology, i: u32) -> PubSubSpec {
    let d = t.in_neighbours(i).len();
    PubSubSpec {
        name: format!("sonarnet/{}/node/{i}/inbox", t.run_id()),
        publishers: 1 + d,
        subscribers: 1,
        nodes: 2 + d,
        buffer: t.inbox_buffer(),
    }
}

fn node_wake_spec(t: &RunTopology, i: u32) -> EventSpec {
    let d = t.in_neighbours(i).len();
    EventSpec {
        name: format!("sonarnet/{}/node/{i}/wake", t.run_id()),
        notifiers: 1 + d,
        listeners: 1,
        nodes: 2 + d,
    }
}

fn coordinator_inbox_spec(t: &RunTopology) -> PubSubSpec {
    PubSubSpec {
        name: format!("sonarnet/{}/coordinator/inbox", t.run_id()),
        publishers: t.n_nodes(),
        subscribers: 1,
        nodes: t.n_nodes() + 1,
        buffer: t.inbox_buffer(),
    }
}

fn coordinator_wake_spec(t: &RunTopology) -> EventSpec {
    EventSpec {
        name: format!("sonarnet/{}/coordinator/wake", t.run_id()),
        notifiers: t.n_nodes(),
        listeners: 1,
        nodes: t.n_nodes() + 1,
    }
}

fn broadcast_spec(t: &RunTopology) -> PubSubSpec {
    PubSubSpec {
        name: format!("sonarnet/{}/broadcast/frames", t.run_id()),
        publishers: t.n_nodes(),
        subscribers: t.n_nodes(),
        nodes: t.n_nodes() + 1,
        buffer: t.broadcast_buffer(),
    }
}

fn broadcast_wake_spec(t: &RunTopology) -> EventSpec {
    EventSpec {
        name: format!("sonarnet/{}/broadcast/wake", t.run_id()),
        notifiers: t.n_nodes(),
        listeners: t.n_nodes(),
        nodes: t.n_nodes() + 1,
    }
}

fn service_name(name: &str) -> Result<ServiceName, TransportError> {
    ServiceName::new(name).map_err(|e| TransportError::ipc(format!("naming service {name}"), e))
}

/// Create (coordinator) or open (node) a pub-sub service with the spec's limits; on
/// open, iceoryx2 checks that the existing service supports at least these limits.
fn pubsub(node: &Node<Svc>, spec: &PubSubSpec, create: bool) -> Result<PubSub, TransportError> {
    let builder = node
        .service_builder(&service_name(&spec.name)?)
        .publish_subscribe::<Frame>()
        .enable_safe_overflow(false)
        .history_size(0)
        .subscriber_max_buffer_size(spec.buffer)
        .subscriber_max_borrowed_samples(1)
        .max_publishers(spec.publishers)
        .max_subscribers(spec.subscribers)
        .max_nodes(spec.nodes);
    if create {
        builder.create().map_err(|e| {
            TransportError::ipc(
                format!(
                    "creating service {} (stale run with the same id? see cleanup_stale_resources)",
                    spec.name
                ),
                e,
            )
        })
    } else {
        builder.open().map_err(|e| {
            TransportError::ipc(
                format!(
                    "opening service {} (has the coordinator created this run with the same topology?)",
                    spec.name
                ),
                e,
            )
        })
    }
}

fn event_service(
    node: &Node<Svc>,
    spec: &EventSpec,
    create: bool,
) -> Result<EventSvc, TransportError> {
    let builder = node
        .service_builder(&service_name(&spec.name)?)
        .event()
        .max_notifiers(spec.notifiers)
        .max_listeners(spec.listeners)
        .max_nodes(spec.nodes)
        .event_id_max_value(1);
    if create {
        builder
            .create()
            .map_err(|e| TransportError::ipc(format!("creating service {}", spec.name), e))
    } else {
        builder.open().map_err(|e| {
            TransportError::ipc(
                format!(
                    "opening service {} (has the coordinator created this run with the same topology?)",
                    spec.name
                ),
                e,
            )
        })
    }
}

/// Sample pool of a publisher: every subscriber's buffer plus its one borrowed
/// sample, plus the one sample `send_copy` loans. That is exactly what normal
/// operation can need; the publisher may also loan the whole pool at once, which is
/// how [`taken_by_receivers`] tells that no sent frame is still waiting anywhere.
fn pool_size(subscribers: usize, buffer: usize) -> usize {
    subscribers * (buffer + 1) + 1
}

fn inbox_publisher(
    svc: &PubSub,
    to: Endpoint,
    pool: usize,
) -> Result<Publisher<Svc, Frame, ()>, TransportError> {
    svc.publisher_builder()
        .max_loaned_samples(pool)
        .override_sample_preallocation(move |_| pool)
        .backpressure_strategy(BackpressureStrategy::DiscardData)
        .create()
        .map_err(|e| TransportError::ipc(format!("creating publisher to {to}"), e))
}

/// Whether every frame `publisher` sent has left the receivers' buffers (was
/// received, or its receiver is gone): true iff the whole sample pool can be loaned.
fn taken_by_receivers(
    publisher: &Publisher<Svc, Frame, ()>,
    pool: usize,
) -> Result<bool, TransportError> {
    publisher
        .update_connections()
        .map_err(|e| TransportError::ipc("updating connections", e))?;
    let mut loans = Vec::with_capacity(pool);
    while loans.len() < pool {
        match publisher.loan_uninit() {
            Ok(sample) => loans.push(sample),
            Err(LoanError::OutOfMemory) | Err(LoanError::ExceedsMaxLoans) => break,
            Err(e) => return Err(TransportError::ipc("probing the sample pool", e)),
        }
    }
    Ok(loans.len() == pool)
}

fn notifier(svc: &EventSvc, to: &str) -> Result<Notifier<Svc>, TransportError> {
    svc.notifier_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating notifier for {to}"), e))
}

fn listener(svc: &EventSvc, what: &str) -> Result<Listener<Svc>, TransportError> {
    svc.listener_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating listener for {what}"), e))
}

fn subscriber(svc: &PubSub, what: &str) -> Result<Subscriber<Svc, Frame, ()>, TransportError> {
    svc.subscriber_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating subscriber for {what}"), e))
}

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

/// A destination this endpoint may send to.
struct Peer {
    endpoint: Endpoint,
    publisher: Publisher<Svc, Frame, ()>,
    notifier: Notifier<Svc>,
    pool: usize,
    /// Sent to since the last wake-up.
    pending: bool,
    /// Sent to since the last successful shutdown check.
    unconfirmed: bool,
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
/// Create the coordinator's first ([`IoxTransport::coordinator`] creates all
/// services), then the nodes' ([`IoxTransport::node`] opens them). Not `Send`: use it
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
    bcast: Option<BroadcastPorts>,
    /// Bounded polling before blocking in `recv` (zero: block at once).
    poll: Duration,
    pubsub_services: Vec<PubSub>,
    event_services: Vec<EventSvc>,
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

fn endpoint_index(t: &RunTopology, e: Endpoint) -> usize {
    match e {
        Endpoint::Node(i) => i as usize,
        Endpoint::Coordinator => t.n_nodes(),
    }
}

fn make_node(t: &RunTopology, name: &str) -> Result<Node<Svc>, TransportError> {
    init_logging();
    let prefix = resource_prefix(t.run_id());
    let mut cfg = config_for_prefix(&prefix)?;
    // A subscriber keeps the unread frames of senders that have exited in its
    // "expired connections"; beyond this many (default 128) it drops them with only a
    // log warning. One slot per possible sender (all nodes + coordinator) rules it out.
    cfg.defaults
        .publish_subscribe
        .subscriber_expired_connection_buffer = t.n_nodes() + 1;
    let node_name =
        NodeName::new(name).map_err(|e| TransportError::ipc(format!("naming node {name}"), e))?;
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(&cfg)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Svc>()
        .map_err(|e| TransportError::ipc(format!("creating iceoryx2 node {name}"), e))?;
    remove_global_mgmt_segment(&cfg);
    Ok(node)
}

impl IoxTransport {
    /// The coordinator's endpoint. Creates every service of the run with limits sized
    /// from `topology` (see the [module docs](self)), so call it before starting the
    /// node processes. Fails if services of this run id already exist.
    pub fn coordinator(topology: &RunTopology) -> Result<Self, TransportError> {
        let t = topology;
        let node = make_node(t, &format!("sonarnet/{}/coordinator", t.run_id()))?;
        let inbox_svc = pubsub(&node, &coordinator_inbox_spec(t), true)?;
        let wake_svc = event_service(&node, &coordinator_wake_spec(t), true)?;
        let wake = listener(&wake_svc, "coordinator")?;
        let inbox = subscriber(&inbox_svc, "coordinator")?;
        let mut pubsub_services = vec![inbox_svc];
        let mut event_services = vec![wake_svc];
        let pool = pool_size(1, t.inbox_buffer());
        let mut peers = Vec::with_capacity(t.n_nodes());
        for i in 0..t.n_nodes() as u32 {
            let to = Endpoint::Node(i);
            let s = pubsub(&node, &node_inbox_spec(t, i), true)?;
            let e = event_service(&node, &node_wake_spec(t, i), true)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                notifier: notifier(&e, &to.to_string())?,
                pool,
                pending: false,
                unconfirmed: false,
            });
            pubsub_services.push(s);
            event_services.push(e);
        }
        if t.broadcast() {
            pubsub_services.push(pubsub(&node, &broadcast_spec(t), true)?);
            event_services.push(event_service(&node, &broadcast_wake_spec(t), true)?);
        }
        Self::assemble(
            t,
            Endpoint::Coordinator,
            node,
            peers,
            inbox,
            wake,
            None,
            pubsub_services,
            event_services,
        )
    }

    /// The endpoint of node `id`. Opens the services created by
    /// [`IoxTransport::coordinator`] (checking that they support this topology's
    /// limits) and registers this node's inbox; other endpoints' sends to this node
    /// wait until that has happened.
    pub fn node(topology: &RunTopology, id: u32) -> Result<Self, TransportError> {
        let t = topology;
        let me = Endpoint::Node(id);
        t.check_endpoint(me)?;
        let node = make_node(t, &format!("sonarnet/{}/node/{id}", t.run_id()))?;
        let inbox_svc = pubsub(&node, &node_inbox_spec(t, id), false)?;
        let wake_svc = event_service(&node, &node_wake_spec(t, id), false)?;
        // Listener before subscriber: whoever sees our subscriber can also wake us.
        let wake = listener(&wake_svc, &me.to_string())?;
        let inbox = subscriber(&inbox_svc, &me.to_string())?;
        let mut pubsub_services = vec![inbox_svc];
        let mut event_services = vec![wake_svc];

        let bcast = if t.broadcast() {
            let service = pubsub(&node, &broadcast_spec(t), false)?;
            let ev = event_service(&node, &broadcast_wake_spec(t), false)?;
            let listener = listener(&ev, "broadcast group")?;
            let subscriber = subscriber(&service, "broadcast group")?;
            let timeout = t.send_timeout();
            let pool = pool_size(t.n_nodes(), t.broadcast_buffer());
            let publisher = service
                .publisher_builder()
                .max_loaned_samples(pool)
                .override_sample_preallocation(move |_| pool)
                .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
                .set_backpressure_handler(move |info: &BackpressureInfo| {
                    if info.elapsed_time < timeout {
                        BackpressureAction::Retry
                    } else {
                        BackpressureAction::DiscardDataAndFail
                    }
                })
                .create()
                .map_err(|e| TransportError::ipc("creating broadcast publisher", e))?;
            let notifier = notifier(&ev, "broadcast group")?;
            event_services.push(ev);
            Some(BroadcastPorts {
                publisher,
                subscriber,
                notifier,
                listener,
                service,
                pool,
                pending: false,
                unconfirmed: false,
            })
        } else {
            None
        };

        let pool = pool_size(1, t.inbox_buffer());
        let mut peers = Vec::with_capacity(t.neighbours(id).len() + 1);
        {
            let to = Endpoint::Coordinator;
            let s = pubsub(&node, &coordinator_inbox_spec(t), false)?;
            let e = event_service(&node, &coordinator_wake_spec(t), false)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                notifier: notifier(&e, "coordinator")?,
                pool,
                pending: false,
                unconfirmed: false,
            });
            pubsub_services.push(s);
            event_services.push(e);
        }
        for &j in t.neighbours(id) {
            let to = Endpoint::Node(j);
            let s = pubsub(&node, &node_inbox_spec(t, j), false)?;
            let e = event_service(&node, &node_wake_spec(t, j), false)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                notifier: notifier(&e, &to.to_string())?,
                pool,
                pending: false,
                unconfirmed: false,
            });
            pubsub_services.push(s);
            event_services.push(e);
        }
        Self::assemble(
            t,
            me,
            node,
            peers,
            inbox,
            wake,
            bcast,
            pubsub_services,
            event_services,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        t: &RunTopology,
        me: Endpoint,
        node: Node<Svc>,
        peers: Vec<Peer>,
        inbox: Subscriber<Svc, Frame, ()>,
        wake: Listener<Svc>,
        bcast: Option<BroadcastPorts>,
        pubsub_services: Vec<PubSub>,
        event_services: Vec<EventSvc>,
    ) -> Result<Self, TransportError> {
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<Svc>()
            .map_err(|e| TransportError::ipc("creating wait set", e))?;
        // The guards only borrow the listeners to register their file descriptors with
        // the wait set's epoll instance; forgetting them keeps the registration for the
        // wait set's lifetime (it is dropped before the listeners, see field order).
        // Nothing else is leaked: the registration is released with the wait set.
        let guard = waitset
            .attach_notification(&wake)
            .map_err(|e| TransportError::ipc("attaching wake-up listener", e))?;
        std::mem::forget(guard);
        if let Some(b) = &bcast {
            let guard = waitset
                .attach_notification(&b.listener)
                .map_err(|e| TransportError::ipc("attaching broadcast listener", e))?;
            std::mem::forget(guard);
        }
        let mut peer_index = vec![usize::MAX; t.n_nodes() + 1];
        for (k, p) in peers.iter().enumerate() {
            peer_index[endpoint_index(t, p.endpoint)] = k;
        }
        Ok(IoxTransport {
            waitset,
            me,
            topology: t.clone(),
            peer_index,
            peers,
            pending: Vec::new(),
            stash: Vec::new(),
            inbox,
            wake,
            bcast,
            poll: Duration::ZERO,
            pubsub_services,
            event_services,
            node,
        })
    }

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
    fn poll_inboxes(&self) -> bool {
        if self.poll.is_zero() {
            return false;
        }
        let start = Instant::now();
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
        if let Some(b) = &self.bcast {
            b.listener
                .try_wait(|_| {})
                .map_err(|e| TransportError::ipc("reading broadcast wake-up events", e))?;
        }
        Ok(())
    }

    fn drain_subscribers(
        inbox: &Subscriber<Svc, Frame, ()>,
        bcast: Option<&BroadcastPorts>,
        out: &mut Vec<Frame>,
    ) -> Result<(), TransportError> {
        while let Some(sample) = inbox
            .receive()
            .map_err(|e| TransportError::ipc("receiving from inbox", e))?
        {
            out.push(*sample.payload());
        }
        if let Some(b) = bcast {
            while let Some(sample) = b
                .subscriber
                .receive()
                .map_err(|e| TransportError::ipc("receiving from broadcast group", e))?
            {
                out.push(*sample.payload());
            }
        }
        Ok(())
    }

    /// Moves everything readable now into the private stash (used while waiting for
    /// a full receiver, so that we never hold up someone who is waiting for us).
    fn stash_incoming(&mut self) -> Result<(), TransportError> {
        Self::drain_subscribers(&self.inbox, self.bcast.as_ref(), &mut self.stash)
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
                peer.unconfirmed = true;
                if !peer.pending {
                    peer.pending = true;
                    self.pending.push(slot);
                }
                return Ok(());
            }
            // Not delivered: the receiver's buffer is full or it has no inbox yet.
            let start = match started {
                Some(s) => s,
                None => {
                    // Make sure the receiver knows there is something to drain.
                    self.peers[slot]
                        .notifier
                        .notify()
                        .map_err(|e| TransportError::ipc(format!("waking {to}"), e))?;
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
        let mut pending = std::mem::take(&mut self.pending);
        let mut result = Ok(());
        for &slot in &pending {
            let peer = &mut self.peers[slot];
            if peer.pending {
                peer.pending = false;
                if let Err(e) = peer.notifier.notify() {
                    result = Err(TransportError::ipc(format!("waking {}", peer.endpoint), e));
                }
            }
        }
        pending.clear();
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

    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError> {
        let before = out.len();
        let deadline = timeout.and_then(|t| Instant::now().checked_add(t));
        let forever = timeout.is_none() || deadline.is_none();
        loop {
            // Frames first (shared memory, no system call): while frames keep coming,
            // the wake-up notifications are only read (system calls) right before
            // blocking, once per wait instead of once per call.
            out.append(&mut self.stash);
            Self::drain_subscribers(&self.inbox, self.bcast.as_ref(), out)?;
            if out.len() > before {
                return Ok(out.len() - before);
            }
            if self.poll_inboxes() {
                continue;
            }
            // Clear the notifications, then look again: a frame sent after the
            // look still leaves a notification behind, so the wait below wakes up.
            self.consume_wakeups()?;
            Self::drain_subscribers(&self.inbox, self.bcast.as_ref(), out)?;
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
