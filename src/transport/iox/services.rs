//! The iceoryx2 services of a run (inboxes, wake-up events, the broadcast group), sized
//! from the run topology, and their ports.

use super::BackpressureStrategy;
use super::Node;
use super::NodeBuilder;
use super::NodeName;
use super::PortName;
use super::ServiceName;
use super::SignalHandlingMode;
use super::config_for_prefix;
use super::init_logging;
use super::remove_global_mgmt_segment;
use super::resource_prefix;
use crate::transport::Endpoint;
use crate::transport::RunTopology;
use crate::transport::TransportError;
use crate::transport::iox::Backoff;
use crate::transport::iox::EventSvc;
use crate::transport::iox::PubSub;
use crate::transport::iox::Svc;
use crate::transport::wire::Frame;
use iceoryx2::port::LoanError;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;

/// The index of endpoint `e` among the run's endpoints (nodes, then the coordinator).
pub(super) fn endpoint_index(t: &RunTopology, e: Endpoint) -> usize {
    match e {
        Endpoint::Node(i) => i as usize,
        Endpoint::Coordinator => t.n_nodes(),
    }
}

/// How many expired connections a subscriber of endpoint `me` keeps: a
/// subscriber keeps the unread frames of senders that have exited in its
/// "expired connections", and beyond this many (iceoryx2's default is 128)
/// drops them with only a log warning. One slot per possible sender rules
/// that out: every endpoint for the coordinator's inbox and the broadcast
/// group; for a node's own inbox its senders (coordinator and
/// in-neighbours) twice over, for the exited incarnations of restarted
/// ones, plus slack. Sized per endpoint, not N for everyone: iceoryx2
/// allocates and clears these slots when the subscriber is created, which
/// made every node O(N) and start-up O(N^2).
pub(super) fn expired_connections(t: &RunTopology, me: Endpoint) -> usize {
    match me {
        Endpoint::Node(i) if !t.broadcast() => 2 * (1 + t.in_neighbours(i).len()) + 8,
        _ => t.n_nodes() + 1,
    }
}

/// The iceoryx2 node `name` of this run (its namespace and limits) for
/// endpoint `me`.
pub(super) fn make_node(
    t: &RunTopology,
    name: &str,
    me: Endpoint,
) -> Result<Node<Svc>, TransportError> {
    init_logging();
    let prefix = resource_prefix(t.run_id());
    let mut cfg = config_for_prefix(&prefix)?;
    cfg.defaults
        .publish_subscribe
        .subscriber_expired_connection_buffer = expired_connections(t, me);
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

pub(super) struct PubSubSpec {
    pub(super) name: String,
    pub(super) publishers: usize,
    pub(super) subscribers: usize,
    pub(super) nodes: usize,
    pub(super) buffer: usize,
}

pub(super) struct EventSpec {
    pub(super) name: String,
    pub(super) notifiers: usize,
    pub(super) listeners: usize,
    pub(super) nodes: usize,
}

pub(super) fn node_inbox_spec(t: &RunTopology, i: u32) -> PubSubSpec {
    let d = t.in_neighbours(i).len();
    PubSubSpec {
        name: format!("sonarnet/{}/node/{i}/inbox", t.run_id()),
        publishers: 1 + d,
        subscribers: 1,
        nodes: 2 + d,
        buffer: t.inbox_buffer(),
    }
}

pub(super) fn node_wake_spec(t: &RunTopology, i: u32) -> EventSpec {
    let d = t.in_neighbours(i).len();
    EventSpec {
        name: format!("sonarnet/{}/node/{i}/wake", t.run_id()),
        notifiers: 1 + d,
        listeners: 1,
        nodes: 2 + d,
    }
}

/// The coordinator's one wake-up service for every node: one notifier (the
/// coordinator), one listener per node, named [`down_listener_name`]. The
/// coordinator wakes node `i` alone (`notify_single_listener`), so it holds
/// one notifier for the whole run instead of one event service, notifier,
/// port tag and management segment per node (4 descriptors per
/// node fewer, which brings 2048 nodes under a 20 000-descriptor limit).
pub(super) fn down_wake_spec(t: &RunTopology) -> EventSpec {
    EventSpec {
        name: format!("sonarnet/{}/coordinator/down", t.run_id()),
        notifiers: 1,
        listeners: t.n_nodes(),
        nodes: t.n_nodes() + 1,
    }
}

/// The name of node `i`'s listener on the coordinator's down service.
pub(super) fn down_listener_name(i: u32) -> String {
    format!("n{i}")
}

/// The node whose down listener is called `name`.
pub(super) fn down_listener_node(name: &str) -> Option<u32> {
    name.strip_prefix('n')?.parse().ok()
}

pub(super) fn coordinator_inbox_spec(t: &RunTopology) -> PubSubSpec {
    PubSubSpec {
        name: format!("sonarnet/{}/coordinator/inbox", t.run_id()),
        publishers: t.n_nodes(),
        subscribers: 1,
        nodes: t.n_nodes() + 1,
        buffer: t.inbox_buffer(),
    }
}

pub(super) fn coordinator_wake_spec(t: &RunTopology) -> EventSpec {
    EventSpec {
        name: format!("sonarnet/{}/coordinator/wake", t.run_id()),
        notifiers: t.n_nodes(),
        listeners: 1,
        nodes: t.n_nodes() + 1,
    }
}

pub(super) fn broadcast_spec(t: &RunTopology) -> PubSubSpec {
    PubSubSpec {
        name: format!("sonarnet/{}/broadcast/frames", t.run_id()),
        publishers: t.n_nodes(),
        subscribers: t.n_nodes(),
        nodes: t.n_nodes() + 1,
        buffer: t.broadcast_buffer(),
    }
}

pub(super) fn broadcast_wake_spec(t: &RunTopology) -> EventSpec {
    EventSpec {
        name: format!("sonarnet/{}/broadcast/wake", t.run_id()),
        notifiers: t.n_nodes(),
        listeners: t.n_nodes(),
        nodes: t.n_nodes() + 1,
    }
}

pub(super) fn service_name(name: &str) -> Result<ServiceName, TransportError> {
    ServiceName::new(name).map_err(|e| TransportError::ipc(format!("naming service {name}"), e))
}

/// Create (coordinator) or open (node) a pub-sub service with the spec's limits; on
/// open, iceoryx2 checks that the existing service supports at least these limits.
pub(super) fn pubsub(
    node: &Node<Svc>,
    spec: &PubSubSpec,
    create: bool,
) -> Result<PubSub, TransportError> {
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

/// How an endpoint comes by an event service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Access {
    /// The coordinator creates it before any node starts.
    Create,
    /// A node opens what the coordinator created.
    Open,
    /// Whoever of the nodes using it comes first creates it (a node's own
    /// wake-up service: the node and its in-neighbours; the coordinator
    /// holds none of them).
    OpenOrCreate,
}

pub(super) fn event_service(
    node: &Node<Svc>,
    spec: &EventSpec,
    access: Access,
) -> Result<EventSvc, TransportError> {
    let builder = || -> Result<_, TransportError> {
        Ok(node
            .service_builder(&service_name(&spec.name)?)
            .event()
            .max_notifiers(spec.notifiers)
            .max_listeners(spec.listeners)
            .max_nodes(spec.nodes)
            .event_id_max_value(1))
    };
    match access {
        Access::Create => builder()?
            .create()
            .map_err(|e| TransportError::ipc(format!("creating service {}", spec.name), e)),
        Access::Open => builder()?.open().map_err(|e| {
            TransportError::ipc(
                format!(
                    "opening service {} (has the coordinator created this run with the same topology?)",
                    spec.name
                ),
                e,
            )
        }),
        Access::OpenOrCreate => {
            // Two nodes may race to create it; the loser's attempt fails
            // while the winner is still writing it. A few retries settle it.
            let mut backoff = Backoff(0);
            loop {
                match builder()?.open_or_create() {
                    Ok(s) => return Ok(s),
                    Err(_) if backoff.0 < 12 => backoff.wait(),
                    Err(e) => {
                        return Err(TransportError::ipc(
                            format!("opening or creating service {}", spec.name),
                            e,
                        ));
                    }
                }
            }
        }
    }
}

/// Sample pool of a publisher: every subscriber's buffer plus its one borrowed
/// sample, plus the one sample `send_copy` loans. That is exactly what normal
/// operation can need; the publisher may also loan the whole pool at once, which is
/// how [`taken_by_receivers`] tells that no sent frame is still waiting anywhere.
pub(super) fn pool_size(subscribers: usize, buffer: usize) -> usize {
    subscribers * (buffer + 1) + 1
}

pub(super) fn inbox_publisher(
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
pub(super) fn taken_by_receivers(
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

pub(super) fn notifier(svc: &EventSvc, to: &str) -> Result<Notifier<Svc>, TransportError> {
    svc.notifier_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating notifier for {to}"), e))
}

pub(super) fn listener(svc: &EventSvc, what: &str) -> Result<Listener<Svc>, TransportError> {
    svc.listener_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating listener for {what}"), e))
}

/// Node `i`'s listener on the coordinator's down service, named so that the
/// coordinator can find it ([`down_listener_name`]).
pub(super) fn down_listener(svc: &EventSvc, i: u32) -> Result<Listener<Svc>, TransportError> {
    let name = down_listener_name(i);
    let port = PortName::new(&name)
        .map_err(|e| TransportError::ipc(format!("naming listener {name}"), e))?;
    svc.listener_builder().name(&port).create().map_err(|e| {
        TransportError::ipc(
            format!("creating the coordinator's wake-up listener of node {i}"),
            e,
        )
    })
}

pub(super) fn subscriber(
    svc: &PubSub,
    what: &str,
) -> Result<Subscriber<Svc, Frame, ()>, TransportError> {
    svc.subscriber_builder()
        .create()
        .map_err(|e| TransportError::ipc(format!("creating subscriber for {what}"), e))
}
