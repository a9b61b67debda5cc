//! Opening an endpoint: the coordinator's creates the run's services, a
//! node's opens them and registers its inbox; both end in one
//! [`IoxTransport`] with its wait set.

use super::services::{
    Access, broadcast_spec, broadcast_wake_spec, coordinator_inbox_spec, coordinator_wake_spec,
    down_listener, down_wake_spec, endpoint_index, event_service, inbox_publisher, listener,
    make_node, node_inbox_spec, node_wake_spec, notifier, pool_size, pubsub, subscriber,
};
use super::{BroadcastPorts, EventSvc, IoxTransport, Peer, PubSub, Svc, Wake};
use crate::transport::wire::Frame;
use crate::transport::{Endpoint, RunTopology, TransportError};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::*;
use std::time::Duration;

/// The receiving ports of an endpoint, handed to `IoxTransport::assemble`.
struct Receivers {
    inbox: Subscriber<Svc, Frame, ()>,
    wake: Listener<Svc>,
    down_listener: Option<Listener<Svc>>,
    down: Option<Notifier<Svc>>,
    bcast: Option<BroadcastPorts>,
}

impl IoxTransport {
    /// The coordinator's endpoint. Creates the services of the run (all but the
    /// nodes' own wake-ups) with limits sized from `topology` (see the
    /// [module docs](super)), so call it before starting the node processes. Fails if services of this run id already exist.
    pub fn coordinator(topology: &RunTopology) -> Result<Self, TransportError> {
        let t = topology;
        let node = make_node(
            t,
            &format!("sonarnet/{}/coordinator", t.run_id()),
            Endpoint::Coordinator,
        )?;
        let inbox_svc = pubsub(&node, &coordinator_inbox_spec(t), true)?;
        let wake_svc = event_service(&node, &coordinator_wake_spec(t), Access::Create)?;
        let wake = listener(&wake_svc, "coordinator")?;
        let inbox = subscriber(&inbox_svc, "coordinator")?;
        let down_svc = event_service(&node, &down_wake_spec(t), Access::Create)?;
        let down = notifier(&down_svc, "every node")?;
        let mut pubsub_services = vec![inbox_svc];
        let mut event_services = vec![wake_svc, down_svc];
        let pool = pool_size(1, t.inbox_buffer());
        let mut peers = Vec::with_capacity(t.n_nodes());
        for i in 0..t.n_nodes() as u32 {
            let to = Endpoint::Node(i);
            let s = pubsub(&node, &node_inbox_spec(t, i), true)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                wake: Wake::Down(None),
                pool,
                pending: false,
                unconfirmed: false,
                service: pubsub_services.len(),
                connected: false,
            });
            pubsub_services.push(s);
        }
        if t.broadcast() {
            pubsub_services.push(pubsub(&node, &broadcast_spec(t), true)?);
            event_services.push(event_service(
                &node,
                &broadcast_wake_spec(t),
                Access::Create,
            )?);
        }
        Self::assemble(
            t,
            Endpoint::Coordinator,
            node,
            peers,
            Receivers {
                inbox,
                wake,
                down_listener: None,
                down: Some(down),
                bcast: None,
            },
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
        let node = make_node(t, &format!("sonarnet/{}/node/{id}", t.run_id()), me)?;
        let inbox_svc = pubsub(&node, &node_inbox_spec(t, id), false)?;
        let wake_svc = event_service(&node, &node_wake_spec(t, id), Access::OpenOrCreate)?;
        let down_svc = event_service(&node, &down_wake_spec(t), Access::Open)?;
        // Listeners before subscriber: whoever sees our subscriber can also wake us.
        let wake = listener(&wake_svc, &me.to_string())?;
        let down_listener = down_listener(&down_svc, id)?;
        let inbox = subscriber(&inbox_svc, &me.to_string())?;
        let mut pubsub_services = vec![inbox_svc];
        let mut event_services = vec![wake_svc, down_svc];

        let bcast = if t.broadcast() {
            let service = pubsub(&node, &broadcast_spec(t), false)?;
            let ev = event_service(&node, &broadcast_wake_spec(t), Access::Open)?;
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
            let e = event_service(&node, &coordinator_wake_spec(t), Access::Open)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                wake: Wake::Own(Box::new(notifier(&e, "coordinator")?)),
                pool,
                pending: false,
                unconfirmed: false,
                service: pubsub_services.len(),
                connected: false,
            });
            pubsub_services.push(s);
            event_services.push(e);
        }
        for &j in t.neighbours(id) {
            let to = Endpoint::Node(j);
            let s = pubsub(&node, &node_inbox_spec(t, j), false)?;
            let e = event_service(&node, &node_wake_spec(t, j), Access::OpenOrCreate)?;
            peers.push(Peer {
                endpoint: to,
                publisher: inbox_publisher(&s, to, pool)?,
                wake: Wake::Own(Box::new(notifier(&e, &to.to_string())?)),
                pool,
                pending: false,
                unconfirmed: false,
                service: pubsub_services.len(),
                connected: false,
            });
            pubsub_services.push(s);
            event_services.push(e);
        }
        let mut this = Self::assemble(
            t,
            me,
            node,
            peers,
            Receivers {
                inbox,
                wake,
                down_listener: Some(down_listener),
                down: None,
                bcast,
            },
            pubsub_services,
            event_services,
        )?;
        // A run whose coordinator wrote a roster of its node processes:
        // every frame is checked against it (`senders`).
        let roster = super::senders::roster_path(&super::resource_prefix(t.run_id()))?;
        if roster.exists() {
            this.senders = Some(super::senders::Senders::from_roster(roster));
        }
        Ok(this)
    }

    fn assemble(
        t: &RunTopology,
        me: Endpoint,
        node: Node<Svc>,
        peers: Vec<Peer>,
        ports: Receivers,
        pubsub_services: Vec<PubSub>,
        event_services: Vec<EventSvc>,
    ) -> Result<Self, TransportError> {
        let Receivers {
            inbox,
            wake,
            down_listener,
            down,
            bcast,
        } = ports;
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
        if let Some(l) = &down_listener {
            let guard = waitset.attach_notification(l).map_err(|e| {
                TransportError::ipc("attaching the coordinator's wake-up listener", e)
            })?;
            std::mem::forget(guard);
        }
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
            down_listener,
            down,
            bcast,
            poll: Duration::ZERO,
            pubsub_services,
            event_services,
            senders: None,
            node,
        })
    }
}
