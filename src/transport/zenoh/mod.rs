//! [`Transport`] over zenoh 1.x: the same frames as over
//! iceoryx2, between processes on one host or on many. The only module of the
//! crate that uses zenoh.
//!
//! # Key expressions
//!
//! Every key of a run starts with [`prefix`]`(run_id)` = `sonarnet/<run id>`, so
//! two runs on one network never cross. The coordinator's router admits only
//! the run's users, and each only on its own keys ([`config`]): a frame key
//! names its sender, which the router checks against the user, and the
//! receiving side checks every frame's `from` against the key (a frame
//! claiming another sender arrives as an
//! [`IMPOSTOR`](super::wire::IMPOSTOR) frame naming both, as
//! over iceoryx2).
//!
//! | key | what |
//! |---|---|
//! | `<prefix>/in/<to>/<from>` | frames for node `<to>` (`c`: the coordinator) from `<from>`: one put per sender and [`Transport::flush`], the frames' [`FRAME_BYTES`](super::wire::FRAME_BYTES)-byte forms back to back |
//! | `<prefix>/bcast/<from>` | the broadcast group (sync rounds) |
//! | `<prefix>/alive/node/<i>`, `<prefix>/alive/agent/<name>`, `<prefix>/alive/coordinator` | liveliness tokens: a party's death (its socket closes, or its lease of [`config::LEASE_MS`] runs out) is seen by the others |
//! | `<prefix>/barrier/<endpoint>` | the coordinator's queryable: a reply means every frame put before the query reached the coordinator's router ([`Transport::shutdown`]) |
//! | `<prefix>/agent/<name>/cmd`, `<prefix>/agent/<name>/ev` | an agent's commands and events ([`fleet`]) |
//!
//! # Semantics
//!
//! As the trait says, with these differences from shared memory:
//! * queues are unbounded on the receiving side (zenoh's reliable channel,
//!   with `CongestionControl::Block`, gives backpressure on the way), so a
//!   send never times out;
//! * a frame for an endpoint that is gone is dropped by the router (the
//!   coordinator learns of the death from the liveliness token);
//! * `--poll-us` does not apply: a receiver blocks on a channel fed by zenoh's
//!   own threads.

use std::collections::BTreeMap;
use std::time::Duration;

use crossbeam::channel::{Receiver, RecvTimeoutError, Sender};
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::Queryable;

use super::credentials::{Login, RunCredentials};
use super::wire::{COORDINATOR_ID, Frame};
use super::{Endpoint, RunTopology, Transport, TransportError, ZenohSettings};

pub mod config;
pub mod fleet;
mod refusals;

pub use config::Role;

/// The key prefix of run `run_id`.
pub fn prefix(run_id: &str) -> String {
    format!("sonarnet/{run_id}")
}

fn endpoint_key(e: Endpoint) -> String {
    match e {
        Endpoint::Node(i) => i.to_string(),
        Endpoint::Coordinator => "c".into(),
    }
}

/// The sender id a key's last chunk names (`c`: the coordinator).
fn sender_of(key: &str) -> Option<u32> {
    match key.rsplit('/').next()? {
        "c" => Some(COORDINATOR_ID),
        i => i.parse().ok(),
    }
}

pub(crate) fn zerr(op: impl Into<String>) -> impl FnOnce(zenoh::Error) -> TransportError {
    let op = op.into();
    move |e| TransportError::Zenoh {
        op,
        detail: e.to_string(),
    }
}

/// zenoh's own log, on standard error, when `RUST_LOG` asks for it
/// (the book, "Across hosts": `RUST_LOG=zenoh=debug`), as zenoh's
/// `try_init_log_from_env` would set it up but for the stream: standard
/// output carries the run's summary; and, always, a line for each peer the
/// router refuses at the handshake ([`refusals`]). Once per process; later
/// calls do nothing.
fn init_log() {
    use tracing_subscriber::Layer;
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    let fmt = tracing_subscriber::EnvFilter::try_from_default_env()
        .ok()
        .map(|filter| {
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
                .with_target(true)
                .with_filter(filter)
        });
    let _ = tracing_subscriber::registry()
        .with(fmt)
        .with(refusals::layer())
        .try_init();
}

/// Opens a session for run `run_id` in `role`.
pub(crate) fn open_session(
    settings: &ZenohSettings,
    role: Role<'_>,
    run_id: &str,
    connect_timeout: Duration,
) -> Result<zenoh::Session, TransportError> {
    init_log();
    let cfg = config::session_config(settings, role, run_id, connect_timeout)?;
    let what = match role {
        Role::Router(_) => format!("listening on {}", settings.listen.join(", ")),
        Role::Client(login) => format!(
            "connecting to {} as {} (is the run there, and are these its credentials?)",
            settings.connect.join(", "),
            login.map_or("nobody", |l| l.user.as_str())
        ),
    };
    cfg.open().map_err(zerr(what))
}

/// A reliable publisher on `key`: blocks rather than drops when congested,
/// data priority, no batching (sonarnet batches its own frames per flush).
pub(crate) fn publisher(
    session: &zenoh::Session,
    key: String,
) -> Result<Publisher<'static>, TransportError> {
    session
        .declare_publisher(key.clone())
        .congestion_control(CongestionControl::Block)
        .priority(Priority::Data)
        .express(true)
        .wait()
        .map_err(zerr(format!("declaring a publisher on {key}")))
}

/// How long a new publisher waits for zenoh to report a subscriber on its
/// key before its first put ([`await_match`]).
pub const MATCH_WAIT: Duration = Duration::from_secs(2);

/// Waits until zenoh reports a subscriber matching `publisher`, at most
/// `within`; returns whether one was seen.
///
/// A client learns of the router's subscribers asynchronously, after its
/// session opens: a put on a publisher declared before that news arrives is
/// dropped at the source, as nothing is known to want it. Over TCP on
/// loopback the news is nearly always first; over QUIC or a slow network
/// the first frames of a run were lost and the run stalled at sample 0.
/// Each publisher is declared once per destination, so this waits once.
/// After `within` the put goes ahead: the destination may be dead, which
/// liveliness reports.
pub fn await_match(publisher: &Publisher<'_>, within: Duration) -> bool {
    let matched = || {
        publisher
            .matching_status()
            .wait()
            .is_ok_and(|m| m.matching())
    };
    if matched() {
        return true;
    }
    let (tx, rx) = crossbeam::channel::bounded::<bool>(1);
    let listener = publisher
        .matching_listener()
        .callback(move |m| {
            let _ = tx.try_send(m.matching());
        })
        .wait();
    let Ok(_listener) = listener else {
        return false;
    };
    // The status may have changed between the check and the listener.
    if matched() {
        return true;
    }
    let deadline = std::time::Instant::now() + within;
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        match rx.recv_timeout(left) {
            Ok(true) => return true,
            Ok(false) => continue,
            Err(_) => return matched(),
        }
    }
}

/// A liveliness token on `key`: it vanishes for the others when this
/// session closes or its lease runs out.
pub(crate) fn declare_token(
    session: &zenoh::Session,
    key: String,
) -> Result<LivelinessToken, TransportError> {
    session
        .liveliness()
        .declare_token(key.clone())
        .wait()
        .map_err(zerr(format!("declaring the liveliness token {key}")))
}

/// A frame subscriber on `key` (whose last chunk is the sender) feeding
/// `tx`, every frame taken [as sent by](Frame::as_sent_by) that sender;
/// payloads that are not whole frames, or on a key naming no sender, are
/// dropped.
fn frame_subscriber(
    session: &zenoh::Session,
    key: String,
    tx: Sender<Frame>,
) -> Result<Subscriber<()>, TransportError> {
    session
        .declare_subscriber(key.clone())
        .callback(move |sample| {
            let Some(sender) = sender_of(sample.key_expr().as_str()) else {
                return;
            };
            let bytes = sample.payload().to_bytes();
            if let Some(frames) = Frame::from_bytes(&bytes) {
                for f in frames {
                    let _ = tx.send(f.as_sent_by(Some(sender)));
                }
            }
        })
        .wait()
        .map_err(zerr(format!("subscribing to {key}")))
}

/// [`Transport`] of one endpoint over a zenoh session.
pub struct ZenohTransport {
    me: Endpoint,
    topo: RunTopology,
    prefix: String,
    session: zenoh::Session,
    rx: Receiver<Frame>,
    _subs: Vec<Subscriber<()>>,
    publishers: BTreeMap<Endpoint, Publisher<'static>>,
    bcast: Option<Publisher<'static>>,
    /// Frames queued per destination since the last flush.
    pending: BTreeMap<Endpoint, Vec<u8>>,
    pending_bcast: Vec<u8>,
    _token: LivelinessToken,
    _barrier: Option<Queryable<()>>,
}

impl ZenohTransport {
    /// The coordinator's endpoint: a router listening on `settings.listen`
    /// and admitting the users of `creds`, with the run's barrier and its
    /// liveliness token.
    pub fn coordinator(
        topology: &RunTopology,
        settings: &ZenohSettings,
        creds: &RunCredentials,
    ) -> Result<Self, TransportError> {
        let session = open_session(
            settings,
            Role::Router(creds),
            topology.run_id(),
            config::CONNECT_TIMEOUT,
        )?;
        Self::on(session, topology, Endpoint::Coordinator)
    }

    /// Node `id`'s endpoint: a client of `settings.connect`, logged in as
    /// `login`.
    pub fn node(
        topology: &RunTopology,
        id: u32,
        settings: &ZenohSettings,
        login: &Login,
    ) -> Result<Self, TransportError> {
        topology.check_endpoint(Endpoint::Node(id))?;
        let session = open_session(
            settings,
            Role::Client(Some(login)),
            topology.run_id(),
            config::CONNECT_TIMEOUT,
        )?;
        Self::on(session, topology, Endpoint::Node(id))
    }

    fn on(
        session: zenoh::Session,
        topology: &RunTopology,
        me: Endpoint,
    ) -> Result<Self, TransportError> {
        let prefix = prefix(topology.run_id());
        let (tx, rx) = crossbeam::channel::unbounded();
        let mut subs = vec![frame_subscriber(
            &session,
            format!("{prefix}/in/{}/*", endpoint_key(me)),
            tx.clone(),
        )?];
        let is_node = matches!(me, Endpoint::Node(_));
        if is_node && topology.broadcast() {
            subs.push(frame_subscriber(&session, format!("{prefix}/bcast/*"), tx)?);
        }
        let barrier = if is_node {
            None
        } else {
            let key = format!("{prefix}/barrier/**");
            Some(
                session
                    .declare_queryable(key.clone())
                    .callback(|q| {
                        let _ = q.reply(q.key_expr().clone(), Vec::<u8>::new()).wait();
                    })
                    .wait()
                    .map_err(zerr(format!("declaring {key}")))?,
            )
        };
        let alive = match me {
            Endpoint::Node(i) => format!("{prefix}/alive/node/{i}"),
            Endpoint::Coordinator => format!("{prefix}/alive/coordinator"),
        };
        // Declared last: whoever sees it may send at once.
        let token = declare_token(&session, alive)?;
        Ok(ZenohTransport {
            me,
            topo: topology.clone(),
            prefix,
            session,
            rx,
            _subs: subs,
            publishers: BTreeMap::new(),
            bcast: None,
            pending: BTreeMap::new(),
            pending_bcast: Vec::new(),
            _token: token,
            _barrier: barrier,
        })
    }

    /// The zenoh session (for [`fleet`], on the coordinator).
    pub(crate) fn session(&self) -> &zenoh::Session {
        &self.session
    }

    fn publisher(&self, key: String) -> Result<Publisher<'static>, TransportError> {
        publisher(&self.session, key)
    }
}

impl Transport for ZenohTransport {
    fn endpoint(&self) -> Endpoint {
        self.me
    }

    fn send(&mut self, to: Endpoint, frame: &Frame) -> Result<(), TransportError> {
        self.topo.check_endpoint(to)?;
        if !self.topo.is_edge(self.me, to) {
            return Err(TransportError::NotAPeer { from: self.me, to });
        }
        frame.put_bytes(self.pending.entry(to).or_default());
        Ok(())
    }

    fn broadcast(&mut self, frame: &Frame) -> Result<(), TransportError> {
        if !self.topo.broadcast() || self.me == Endpoint::Coordinator {
            return Err(TransportError::BroadcastUnavailable(self.me));
        }
        frame.put_bytes(&mut self.pending_bcast);
        Ok(())
    }

    fn flush(&mut self) -> Result<(), TransportError> {
        let pending = std::mem::take(&mut self.pending);
        for (to, bytes) in pending {
            if bytes.is_empty() {
                continue;
            }
            if !self.publishers.contains_key(&to) {
                let p = self.publisher(format!(
                    "{}/in/{}/{}",
                    self.prefix,
                    endpoint_key(to),
                    endpoint_key(self.me)
                ))?;
                await_match(&p, MATCH_WAIT);
                self.publishers.insert(to, p);
            }
            if let Some(p) = self.publishers.get(&to) {
                p.put(bytes)
                    .wait()
                    .map_err(zerr(format!("sending to {to}")))?;
            }
        }
        if !self.pending_bcast.is_empty() {
            if self.bcast.is_none() {
                let p =
                    self.publisher(format!("{}/bcast/{}", self.prefix, endpoint_key(self.me)))?;
                await_match(&p, MATCH_WAIT);
                self.bcast = Some(p);
            }
            let bytes = std::mem::take(&mut self.pending_bcast);
            if let Some(p) = &self.bcast {
                p.put(bytes).wait().map_err(zerr("broadcasting"))?;
            }
        }
        Ok(())
    }

    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError> {
        let before = out.len();
        out.extend(self.rx.try_iter());
        if out.len() == before {
            let first = match timeout {
                Some(t) => self.rx.recv_timeout(t),
                None => self.rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
            };
            match first {
                Ok(f) => out.push(f),
                Err(RecvTimeoutError::Timeout) => return Ok(0),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(TransportError::Closed(self.me));
                }
            }
            out.extend(self.rx.try_iter());
        }
        Ok(out.len() - before)
    }

    /// Flushes, then (on a node) asks the coordinator's barrier: its reply
    /// comes after every frame this node put before it, so the coordinator's
    /// router holds them and the node may exit.
    fn shutdown(&mut self, timeout: Duration) -> Result<(), TransportError> {
        self.flush()?;
        if self.me == Endpoint::Coordinator {
            return Ok(());
        }
        let key = format!("{}/barrier/{}", self.prefix, endpoint_key(self.me));
        let replies = self
            .session
            .get(key.clone())
            .congestion_control(CongestionControl::Block)
            .priority(Priority::Data)
            .express(true)
            .timeout(timeout)
            .wait()
            .map_err(zerr(format!("querying {key}")))?;
        match replies.recv_timeout(timeout) {
            Ok(Some(_)) => Ok(()),
            _ => Err(TransportError::ShutdownTimeout {
                from: self.me,
                pending: vec![Endpoint::Coordinator],
                broadcast: false,
                waited: timeout,
            }),
        }
    }
}

impl Drop for ZenohTransport {
    fn drop(&mut self) {
        let _ = self.flush();
        let _ = self.session.close().wait();
    }
}

#[cfg(test)]
mod tests;
