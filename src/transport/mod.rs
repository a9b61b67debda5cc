//! Frame transport between the coordinator and the node processes.
//!
//! The protocol logic is I/O-free; it hands fixed-size [`Frame`]s to a
//! [`Transport`] and gets frames back. Two implementations exist:
//!
//! * [`IoxTransport`]: shared-memory IPC over iceoryx2 0.10 (the only place in the
//!   crate that knows iceoryx2; see [`iox`] for service names, limits, overflow
//!   policy and cleanup).
//! * [`MemTransport`]: an in-process hub with the same semantics (unbounded queues,
//!   no backpressure), for unit tests and single-process engines.
//!
//! # Topology
//!
//! A run has `N` nodes (`Endpoint::Node(0..N)`) and one [`Endpoint::Coordinator`].
//! Who may send to whom is fixed by the [`RunTopology`]:
//!
//! * the coordinator may send to every node, every node may send to the coordinator;
//! * node `i` may send to node `j` iff `j` is in `neighbours[i]` (directed; give
//!   both directions for an undirected graph);
//! * with [`RunTopology::with_broadcast`], every node may publish to the broadcast
//!   group, and every node receives every broadcast frame, **including its own**
//!   (loopback). The coordinator is not a member of the group.
//!
//! # Semantics shared by both implementations
//!
//! * [`Transport::send`] queues a frame; it never wakes the receiver.
//!   [`Transport::flush`] wakes every endpoint sent to since the last flush (one
//!   notification each), so a burst of frames costs one wake-up.
//! * Frames from one sender to one receiver arrive in the order they were sent.
//!   There is no ordering between different senders, nor between a node's direct
//!   frames and its broadcast frames.
//! * Frames are never dropped silently: a frame is either delivered or the call
//!   returns an error.
//! * [`Transport::recv`] returns everything available now, and otherwise blocks on
//!   the wake-up notification(s) until something arrives or the timeout passes. It
//!   never busy-spins; [`IoxTransport::set_poll`] opts into a bounded poll of the
//!   shared-memory inboxes (yielding the CPU) before blocking.
//! * [`Transport::shutdown`] waits until the receivers have taken every frame sent;
//!   call it before a process exits (with iceoryx2 a frame lives in the sender's
//!   shared memory, and the last frames of an exiting process are otherwise lost if
//!   the receiver has not looked at its inbox since the sender came up).

use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crate::transport::wire::Frame;

pub mod credentials;
pub mod iox;
mod mem;
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh;

pub use iox::{CleanupReport, IoxTransport, cleanup_run, cleanup_stale_resources, run_resources};

/// Opens node `id`'s transport as its launch says: iceoryx2 (with `poll`,
/// see [`IoxTransport::set_poll`]) or zenoh.
pub fn open_node(
    choice: &TransportChoice,
    topology: &RunTopology,
    id: u32,
    poll: Duration,
) -> Result<Box<dyn Transport>, TransportError> {
    match choice {
        TransportChoice::Iceoryx2 => {
            let mut t = IoxTransport::node(topology, id)?;
            t.set_poll(poll);
            Ok(Box::new(t))
        }
        #[cfg(feature = "zenoh")]
        TransportChoice::Zenoh(z) => {
            let login =
                credentials::Login::node_from_env(id).map_err(|detail| TransportError::Zenoh {
                    op: format!("logging node {id} in"),
                    detail,
                })?;
            Ok(Box::new(zenoh::ZenohTransport::node(
                topology, id, z, &login,
            )?))
        }
        #[cfg(not(feature = "zenoh"))]
        TransportChoice::Zenoh(_) => Err(TransportError::ZenohUnavailable),
    }
}
pub use mem::{MemNetwork, MemTransport};

/// Which transport a multi-process run uses, and how to reach its peers.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TransportChoice {
    /// iceoryx2 shared memory: every node on the coordinator's host.
    #[default]
    Iceoryx2,
    /// zenoh over TCP ([`ZenohSettings`]): nodes on this host or on others.
    Zenoh(ZenohSettings),
}

/// Where a zenoh session listens or connects (`tcp/HOST:PORT` endpoints), and
/// the user's own zenoh configuration file to start from (TLS, access control).
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZenohSettings {
    /// Endpoints the coordinator listens on, e.g. `tcp/0.0.0.0:7447`.
    #[serde(default)]
    pub listen: Vec<String>,
    /// Endpoints nodes and agents connect to: the coordinator's.
    #[serde(default)]
    pub connect: Vec<String>,
    /// A zenoh configuration file (JSON5) read first; sonarnet then sets the
    /// mode, the endpoints, scouting and the lease over it.
    #[serde(default)]
    pub config_file: Option<std::path::PathBuf>,
}

impl ZenohSettings {
    /// What nodes on the coordinator's own host connect to: each listen
    /// endpoint, with an unspecified address (`0.0.0.0`, `[::]`) replaced by
    /// the loopback one; the configuration file is kept.
    pub fn for_local_nodes(&self) -> ZenohSettings {
        let connect = if self.connect.is_empty() {
            self.listen
                .iter()
                .map(|e| {
                    e.replace("/0.0.0.0:", "/127.0.0.1:")
                        .replace("/[::]:", "/[::1]:")
                })
                .collect()
        } else {
            self.connect.clone()
        };
        ZenohSettings {
            listen: Vec::new(),
            connect,
            config_file: self.config_file.clone(),
        }
    }

    /// A loopback TCP endpoint on a port the system has free now (the port
    /// is released before zenoh binds it: another program could take it in
    /// between, and zenoh's error then names the endpoint).
    pub fn free_loopback_endpoint() -> Result<String, TransportError> {
        let l = std::net::TcpListener::bind("127.0.0.1:0")
            .map_err(|e| TransportError::ipc("finding a free loopback port", e))?;
        let port = l
            .local_addr()
            .map_err(|e| TransportError::ipc("finding a free loopback port", e))?
            .port();
        Ok(format!("tcp/127.0.0.1:{port}"))
    }
}

/// A run id that also serves as the run's secret over zenoh: [`unique_run_id`]
/// followed by 64 bits from the operating system's random source
/// (`/dev/urandom`; not the run seed, which only drives the numbers). A party
/// that does not know it cannot join the run (the router admits only its
/// keys, [`zenoh::config`](crate::transport)).
pub fn secret_run_id() -> String {
    let mut b = [0u8; 8];
    let ok = std::fs::File::open("/dev/urandom")
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut b))
        .is_ok();
    let salt = if ok {
        u64::from_le_bytes(b)
    } else {
        // No random source: the clock's nanoseconds, hashed.
        let n = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos() as u64)
            .unwrap_or(0);
        n.wrapping_mul(0x9E37_79B9_7F4A_7C15)
    };
    format!("{}-{salt:016x}", unique_run_id())
}

/// One addressable party of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Endpoint {
    /// Sonar receiver process `i` (`0 <= i < N`).
    Node(u32),
    /// The coordinator process (`sonarnet run`).
    Coordinator,
}

impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Endpoint::Node(i) => write!(f, "node {i}"),
            Endpoint::Coordinator => write!(f, "coordinator"),
        }
    }
}

/// Why the per-user shared-memory directory is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RootProblem {
    /// It could not be created.
    #[error("cannot be created: {0}")]
    Create(std::io::ErrorKind),
    /// Its metadata could not be read.
    #[error("cannot be examined: {0}")]
    Stat(std::io::ErrorKind),
    /// A file or link of that name is in the way.
    #[error("is not a directory")]
    NotADirectory,
    /// Another user owns it.
    #[error(
        "belongs to uid {owner}, not to this user (uid {me}); sonarnet refuses to share iceoryx2 state with another user (remove the directory)"
    )]
    Foreign {
        /// Its owner.
        owner: u32,
        /// This user.
        me: u32,
    },
    /// Other users may enter it.
    #[error(
        "has mode {0:o}, open to other users; sonarnet needs 0700 (chmod 700 it, or remove it)"
    )]
    OpenMode(u32),
}

/// Errors of the transport layer.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TransportError {
    /// The [`RunTopology`] is malformed (bad run id, node id out of range, ...).
    #[error("invalid run topology: {0}")]
    InvalidTopology(String),
    /// The endpoint is not part of the run (node id `>= N`).
    #[error("{0} is not part of this run")]
    UnknownEndpoint(Endpoint),
    /// `to` is not reachable from `from` in the topology (not a neighbour, or self).
    #[error("{from} may not send to {to}: not an edge of the run topology")]
    NotAPeer {
        /// The sending endpoint.
        from: Endpoint,
        /// The requested destination.
        to: Endpoint,
    },
    /// [`Transport::broadcast`] on an endpoint that is not a broadcast member.
    #[error(
        "{0} is not a member of a broadcast group (enable it with RunTopology::with_broadcast)"
    )]
    BroadcastUnavailable(Endpoint),
    /// The receiver did not accept the frame within the send timeout: its buffer
    /// stayed full (it is not calling `recv`/`send`) or it never opened its inbox.
    #[error(
        "{from} could not deliver a frame to {to} within {waited:?}: the receiver's buffer stayed full or it never came up"
    )]
    SendTimeout {
        /// The sending endpoint.
        from: Endpoint,
        /// The destination.
        to: Endpoint,
        /// How long the sender waited.
        waited: Duration,
    },
    /// The receiver had taken frames from this sender before and has since
    /// closed its inbox: its process exited. Returned at once, where waiting
    /// for a full buffer would last the whole send timeout.
    #[error("{from} could not deliver a frame to {to}: {to} has closed its inbox (it exited)")]
    PeerGone {
        /// The sending endpoint.
        from: Endpoint,
        /// The destination that is gone.
        to: Endpoint,
    },
    /// A broadcast could not be delivered to every group member within the send
    /// timeout (a member's buffer stayed full, or not all members came up).
    #[error(
        "{from} could not deliver a broadcast frame to all {expected} group members within {waited:?} ({subscribers} subscribed)"
    )]
    BroadcastTimeout {
        /// The sending endpoint.
        from: Endpoint,
        /// Group members that were subscribed when the sender gave up.
        subscribers: usize,
        /// Group size (`N`).
        expected: usize,
        /// How long the sender waited.
        waited: Duration,
    },
    /// A broadcast reached fewer members than the group has (a member left).
    #[error("broadcast from {from} reached {delivered} of {expected} group members")]
    BroadcastIncomplete {
        /// The sending endpoint.
        from: Endpoint,
        /// Members the frame was delivered to.
        delivered: usize,
        /// Group size (`N`).
        expected: usize,
    },
    /// [`Transport::shutdown`] timed out with frames still unread by these receivers.
    #[error(
        "{from} shut down with frames still unread after {waited:?} by {pending:?}{}",
        if *broadcast { " and the broadcast group" } else { "" }
    )]
    ShutdownTimeout {
        /// The endpoint shutting down.
        from: Endpoint,
        /// Receivers that had not taken all frames.
        pending: Vec<Endpoint>,
        /// Whether broadcast frames were still unread by some member.
        broadcast: bool,
        /// How long it waited.
        waited: Duration,
    },
    /// A peer endpoint was closed (in-memory transport only).
    #[error("{0} has been closed")]
    Closed(Endpoint),
    /// The per-user iceoryx2 directory is not safe to use (another user's,
    /// or open to others).
    #[error("{}: {problem}", path.display())]
    UnsafeRoot {
        /// The directory.
        path: std::path::PathBuf,
        /// Why it is refused.
        problem: RootProblem,
    },
    /// This build has no zenoh transport (cargo feature `zenoh` off).
    #[error("this sonarnet was built without the zenoh transport (cargo feature `zenoh`)")]
    ZenohUnavailable,
    /// A zenoh operation failed.
    #[error("zenoh failure while {op}: {detail}")]
    Zenoh {
        /// What the transport was doing.
        op: String,
        /// The underlying error.
        detail: String,
    },
    /// An iceoryx2 (or OS) operation failed.
    #[error("IPC failure while {op}: {detail}")]
    Ipc {
        /// What the transport was doing.
        op: String,
        /// The underlying error.
        detail: String,
    },
}

impl TransportError {
    pub(crate) fn ipc(op: impl Into<String>, detail: impl fmt::Debug) -> Self {
        TransportError::Ipc {
            op: op.into(),
            detail: format!("{detail:?}"),
        }
    }
}

/// Moves [`Frame`]s between the endpoints of one run.
pub trait Transport {
    /// The endpoint this transport belongs to.
    fn endpoint(&self) -> Endpoint;

    /// Queues a frame for `to`. Cheap; does not wake the receiver (see [`Transport::flush`]).
    ///
    /// If the receiver's buffer is full (or its inbox is not open yet) the call wakes
    /// the receiver, keeps draining this endpoint's own inbox into an internal queue
    /// (so two endpoints sending to each other cannot deadlock) and retries until the
    /// topology's send timeout, then fails with [`TransportError::SendTimeout`].
    fn send(&mut self, to: Endpoint, frame: &Frame) -> Result<(), TransportError>;

    /// Publishes a frame to the broadcast group: every node (including the sender)
    /// receives it. Does not wake anyone until [`Transport::flush`].
    fn broadcast(&mut self, frame: &Frame) -> Result<(), TransportError>;

    /// Wakes every endpoint sent to since the last flush (one notification each, plus
    /// one for the broadcast group if something was broadcast).
    fn flush(&mut self) -> Result<(), TransportError>;

    /// [`Transport::flush`], except that the wake-up owed to `lazy` may wait: the
    /// frames sent to it are readable at once, and it is woken at the next
    /// `flush`, or before this endpoint next blocks in [`Transport::recv`],
    /// whichever comes first. For frames the receiver needs only soon, not at
    /// once: a node's report of a sample while it has the next ones queued
    /// (on the polled spiral these reports woke the coordinator up
    /// to six times a sample, each wake-up taking a CPU from the gossip).
    /// By default the same as `flush`.
    fn flush_lazily(&mut self, lazy: Endpoint) -> Result<(), TransportError> {
        let _ = lazy;
        self.flush()
    }

    /// Appends all frames available now to `out`. If there are none, blocks on the
    /// wake-up notification(s) for up to `timeout` (`None` = forever). Returns the
    /// number of frames appended (`0` on timeout). Never busy-spins.
    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError>;

    /// Flushes, then waits until every frame this endpoint sent has been taken by its
    /// receiver (or the receiver has left), for at most `timeout`; frames arriving
    /// meanwhile stay available to `recv`. Call it before the process exits so that
    /// its last frames are not lost; fails with [`TransportError::ShutdownTimeout`]
    /// naming the receivers that did not read. The endpoint stays usable.
    fn shutdown(&mut self, timeout: Duration) -> Result<(), TransportError>;

    /// Stops waiting for receivers to take the frames already sent, except
    /// those sent to `keep`: [`Transport::shutdown`] and dropping then wait
    /// for `keep` alone. For the end of a run, when unread frames no longer
    /// matter: a node on STOP keeps the coordinator (which reads its last
    /// reports), and the coordinator, once every node is reaped, keeps none.
    /// Without it a frame left unread by a killed node held the sender for a
    /// whole [`DROP_LINGER`](crate::transport::iox::DROP_LINGER), so a run
    /// ended a second after the kill was noticed. Nothing by default (frames
    /// delivered at once need no wait).
    fn forget_unread(&mut self, _keep: Option<Endpoint>) {}

    /// Node `node` runs as the local process `pid`: a transport that can
    /// tell which process sent a frame hands one from any other process
    /// that names `node` to [`Transport::recv`] as an
    /// [`IMPOSTOR`](wire::IMPOSTOR) frame (iceoryx2 does; the coordinator
    /// calls it for every node process it starts). Nothing by default.
    fn authenticate_sender(&mut self, _node: u32, _pid: u32) {}

    /// Tells the nodes what [`Transport::authenticate_sender`] was told, so
    /// that they check their peers' frames too (iceoryx2 writes the run's
    /// roster of node processes); call it before the nodes open their
    /// transports, and after each restart. Does nothing by default.
    fn publish_senders(&mut self) -> Result<(), TransportError> {
        Ok(())
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn endpoint(&self) -> Endpoint {
        (**self).endpoint()
    }
    fn send(&mut self, to: Endpoint, frame: &Frame) -> Result<(), TransportError> {
        (**self).send(to, frame)
    }
    fn broadcast(&mut self, frame: &Frame) -> Result<(), TransportError> {
        (**self).broadcast(frame)
    }
    fn flush(&mut self) -> Result<(), TransportError> {
        (**self).flush()
    }
    fn flush_lazily(&mut self, lazy: Endpoint) -> Result<(), TransportError> {
        (**self).flush_lazily(lazy)
    }
    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError> {
        (**self).recv(out, timeout)
    }
    fn shutdown(&mut self, timeout: Duration) -> Result<(), TransportError> {
        (**self).shutdown(timeout)
    }
    fn forget_unread(&mut self, keep: Option<Endpoint>) {
        (**self).forget_unread(keep)
    }
    fn publish_senders(&mut self) -> Result<(), TransportError> {
        (**self).publish_senders()
    }

    fn authenticate_sender(&mut self, node: u32, pid: u32) {
        (**self).authenticate_sender(node, pid)
    }
}

/// Default send timeout, see [`RunTopology::with_send_timeout`].
pub const DEFAULT_SEND_TIMEOUT: Duration = Duration::from_secs(30);

/// Longest accepted run id (characters).
pub const MAX_RUN_ID_LEN: usize = 64;

/// Everything both sides must agree on to set up the transport of one run.
///
/// The coordinator builds it, creates the services with
/// [`IoxTransport::coordinator`], and passes the same values to every node process
/// (which calls [`IoxTransport::node`]). Service limits are derived from it, so all
/// processes must use identical topologies.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunTopology {
    run_id: String,
    neighbours: Vec<Vec<u32>>,
    in_neighbours: Vec<Vec<u32>>,
    broadcast: bool,
    inbox_buffer: usize,
    broadcast_buffer: usize,
    send_timeout: Duration,
}

impl RunTopology {
    /// A run with `neighbours.len()` nodes; node `i` may send to every node in
    /// `neighbours[i]`.
    ///
    /// `run_id` names the run's IPC namespace: 1 to [`MAX_RUN_ID_LEN`] characters from
    /// `[A-Za-z0-9._-]`, unique among concurrently running (or crashed) runs, e.g. from
    /// [`unique_run_id`]. `inbox_buffer` is the number of frames that may be in flight
    /// from one sender to one receiver before the sender has to wait (per
    /// sender/receiver pair); it must be at least 1.
    pub fn new(
        run_id: impl Into<String>,
        neighbours: Vec<Vec<u32>>,
        inbox_buffer: usize,
    ) -> Result<Self, TransportError> {
        let run_id = run_id.into();
        validate_run_id(&run_id)?;
        let n = neighbours.len();
        if n == 0 {
            return Err(TransportError::InvalidTopology(
                "a run needs at least one node".into(),
            ));
        }
        if n >= u32::MAX as usize {
            return Err(TransportError::InvalidTopology(format!(
                "{n} nodes is too many"
            )));
        }
        if inbox_buffer == 0 {
            return Err(TransportError::InvalidTopology(
                "inbox_buffer must be at least 1".into(),
            ));
        }
        let mut in_neighbours = vec![Vec::new(); n];
        for (i, list) in neighbours.iter().enumerate() {
            for (k, &j) in list.iter().enumerate() {
                if j as usize >= n {
                    return Err(TransportError::InvalidTopology(format!(
                        "node {i} lists neighbour {j}, but there are only {n} nodes"
                    )));
                }
                if j as usize == i {
                    return Err(TransportError::InvalidTopology(format!(
                        "node {i} lists itself as a neighbour"
                    )));
                }
                if list[..k].contains(&j) {
                    return Err(TransportError::InvalidTopology(format!(
                        "node {i} lists neighbour {j} twice"
                    )));
                }
                in_neighbours[j as usize].push(i as u32);
            }
        }
        Ok(RunTopology {
            run_id,
            neighbours,
            in_neighbours,
            broadcast: false,
            inbox_buffer,
            broadcast_buffer: 0,
            send_timeout: DEFAULT_SEND_TIMEOUT,
        })
    }

    /// A ring of `n` nodes (`i` talks to `i-1` and `i+1` mod `n`); convenient for tests.
    pub fn ring(
        run_id: impl Into<String>,
        n: usize,
        inbox_buffer: usize,
    ) -> Result<Self, TransportError> {
        let neighbours = (0..n)
            .map(|i| {
                let mut v = Vec::new();
                if n > 1 {
                    v.push(((i + n - 1) % n) as u32);
                }
                if n > 2 {
                    v.push(((i + 1) % n) as u32);
                }
                v
            })
            .collect();
        Self::new(run_id, neighbours, inbox_buffer)
    }

    /// Enables the broadcast group. `broadcast_buffer` is the number of broadcast
    /// frames one member may have in flight to another member (e.g. how many rounds
    /// a node may run ahead of the slowest member); at least 1.
    pub fn with_broadcast(mut self, broadcast_buffer: usize) -> Result<Self, TransportError> {
        if broadcast_buffer == 0 {
            return Err(TransportError::InvalidTopology(
                "broadcast_buffer must be at least 1".into(),
            ));
        }
        self.broadcast = true;
        self.broadcast_buffer = broadcast_buffer;
        Ok(self)
    }

    /// How long `send`/`broadcast` wait for a full receiver before failing
    /// (default [`DEFAULT_SEND_TIMEOUT`]). Also bounds how long a sender waits for a
    /// receiver process that has not opened its inbox yet.
    pub fn with_send_timeout(mut self, timeout: Duration) -> Self {
        self.send_timeout = timeout;
        self
    }

    /// The run id (IPC namespace).
    pub fn run_id(&self) -> &str {
        &self.run_id
    }

    /// Number of nodes `N`.
    pub fn n_nodes(&self) -> usize {
        self.neighbours.len()
    }

    /// Nodes that node `i` may send to (empty for an unknown id).
    pub fn neighbours(&self, i: u32) -> &[u32] {
        self.neighbours
            .get(i as usize)
            .map(Vec::as_slice)
            .unwrap_or(&[])
    }

    /// Nodes that may send to node `i` (empty for an unknown id).
    pub fn in_neighbours(&self, i: u32) -> &[u32] {
        self.in_neighbours
            .get(i as usize)
            .map(Vec::as_slice)
            .unwrap_or(&[])
    }

    /// Whether the broadcast group is enabled.
    pub fn broadcast(&self) -> bool {
        self.broadcast
    }

    /// Frames in flight per sender/receiver pair on an inbox.
    pub fn inbox_buffer(&self) -> usize {
        self.inbox_buffer
    }

    /// Frames in flight per member pair in the broadcast group (0 if disabled).
    pub fn broadcast_buffer(&self) -> usize {
        self.broadcast_buffer
    }

    /// The send timeout.
    pub fn send_timeout(&self) -> Duration {
        self.send_timeout
    }

    /// Whether `from` may send to `to` in this topology.
    pub fn is_edge(&self, from: Endpoint, to: Endpoint) -> bool {
        let n = self.n_nodes() as u32;
        match (from, to) {
            (Endpoint::Coordinator, Endpoint::Node(j)) => j < n,
            (Endpoint::Node(i), Endpoint::Coordinator) => i < n,
            (Endpoint::Node(i), Endpoint::Node(j)) => i < n && self.neighbours(i).contains(&j),
            (Endpoint::Coordinator, Endpoint::Coordinator) => false,
        }
    }

    pub(crate) fn check_endpoint(&self, e: Endpoint) -> Result<(), TransportError> {
        match e {
            Endpoint::Node(i) if i as usize >= self.n_nodes() => {
                Err(TransportError::UnknownEndpoint(e))
            }
            _ => Ok(()),
        }
    }
}

/// Checks a run id: 1 to [`MAX_RUN_ID_LEN`] characters from `[A-Za-z0-9._-]`.
pub fn validate_run_id(run_id: &str) -> Result<(), TransportError> {
    if run_id.is_empty() || run_id.len() > MAX_RUN_ID_LEN {
        return Err(TransportError::InvalidTopology(format!(
            "run id must have 1 to {MAX_RUN_ID_LEN} characters, got {}",
            run_id.len()
        )));
    }
    if let Some(c) = run_id
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')))
    {
        return Err(TransportError::InvalidTopology(format!(
            "run id {run_id:?} contains {c:?}; allowed are [A-Za-z0-9._-]"
        )));
    }
    Ok(())
}

/// A run id that is unique on this machine: process id, wall-clock nanoseconds and a
/// per-process counter, in hex (e.g. `"1a2b-17f3c0d2e4a5b6c7-0"`).
///
/// Not random and not seed-dependent: it only names the IPC namespace.
pub fn unique_run_id() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let count = COUNTER.fetch_add(1, Ordering::Relaxed);
    format!("{:x}-{nanos:x}-{count:x}", std::process::id())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_topology_has_two_neighbours_each_and_symmetric_in_neighbours() {
        let t = RunTopology::ring("r", 5, 4).unwrap();
        assert_eq!(t.n_nodes(), 5);
        for i in 0..5u32 {
            let mut out = t.neighbours(i).to_vec();
            out.sort_unstable();
            let mut inn = t.in_neighbours(i).to_vec();
            inn.sort_unstable();
            assert_eq!(out, inn, "ring is symmetric at node {i}");
            assert_eq!(out.len(), 2);
            assert!(out.contains(&((i + 1) % 5)) && out.contains(&((i + 4) % 5)));
        }
        let two = RunTopology::ring("r", 2, 1).unwrap();
        assert_eq!(two.neighbours(0), &[1]);
        assert_eq!(two.neighbours(1), &[0]);
        assert!(
            RunTopology::ring("r", 1, 1)
                .unwrap()
                .neighbours(0)
                .is_empty()
        );
    }

    #[test]
    fn malformed_topologies_are_rejected_with_a_reason() {
        let bad = |r: Result<RunTopology, TransportError>| {
            matches!(r, Err(TransportError::InvalidTopology(_)))
        };
        assert!(bad(RunTopology::new("ok", vec![], 1)));
        assert!(bad(RunTopology::new("ok", vec![vec![1]], 1)));
        assert!(bad(RunTopology::new("ok", vec![vec![0]], 1)));
        assert!(bad(RunTopology::new("ok", vec![vec![1, 1], vec![]], 1)));
        assert!(bad(RunTopology::new("ok", vec![vec![]], 0)));
        assert!(bad(RunTopology::new("", vec![vec![]], 1)));
        assert!(bad(RunTopology::new("a/b", vec![vec![]], 1)));
        assert!(bad(RunTopology::new("x".repeat(65), vec![vec![]], 1)));
        assert!(bad(RunTopology::new("ok", vec![vec![]], 1)
            .unwrap()
            .with_broadcast(0)));
        assert!(RunTopology::new("A.b_c-9", vec![vec![]], 1).is_ok());
    }

    #[test]
    fn edges_follow_the_directed_neighbour_lists() {
        let t = RunTopology::new("r", vec![vec![1], vec![], vec![0]], 1).unwrap();
        assert!(t.is_edge(Endpoint::Node(0), Endpoint::Node(1)));
        assert!(!t.is_edge(Endpoint::Node(1), Endpoint::Node(0)));
        assert!(t.is_edge(Endpoint::Node(2), Endpoint::Node(0)));
        assert_eq!(t.in_neighbours(0), &[2]);
        assert!(t.is_edge(Endpoint::Coordinator, Endpoint::Node(2)));
        assert!(!t.is_edge(Endpoint::Coordinator, Endpoint::Node(3)));
        assert!(t.is_edge(Endpoint::Node(1), Endpoint::Coordinator));
        assert!(!t.is_edge(Endpoint::Coordinator, Endpoint::Coordinator));
    }

    #[test]
    fn local_nodes_connect_to_the_loopback_form_of_the_listen_endpoint() {
        let z = ZenohSettings {
            listen: vec!["tcp/0.0.0.0:7447".into(), "tcp/[::]:7448".into()],
            connect: vec![],
            config_file: None,
        };
        let l = z.for_local_nodes();
        assert_eq!(l.connect, vec!["tcp/127.0.0.1:7447", "tcp/[::1]:7448"]);
        assert!(l.listen.is_empty());
        let e = ZenohSettings::free_loopback_endpoint().unwrap();
        assert!(e.starts_with("tcp/127.0.0.1:"), "{e}");
    }

    #[test]
    fn secret_run_ids_are_valid_and_carry_64_random_bits() {
        let a = secret_run_id();
        let b = secret_run_id();
        assert_ne!(a[a.len() - 16..], b[b.len() - 16..]);
        assert!(
            validate_run_id(&a).is_ok() && a.len() <= MAX_RUN_ID_LEN,
            "{a}"
        );
    }

    #[test]
    fn unique_run_ids_differ_and_are_valid() {
        let a = unique_run_id();
        let b = unique_run_id();
        assert_ne!(a, b);
        assert!(validate_run_id(&a).is_ok(), "{a}");
    }
}
