//! The control plane between the coordinator and the per-host agents
//! (`sonarnet agent`): opaque messages on `<prefix>/agent/<name>/cmd` and
//! `<prefix>/agent/<name>/ev`, and who is alive (liveliness tokens under
//! `<prefix>/alive/`). What the messages mean is the engine's
//! ([`crate::runtime::agent`]); this module only moves bytes.

use std::sync::Arc;
use std::time::Duration;

use crossbeam::channel::Receiver;
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::SampleKind;

use crate::transport::credentials::{Login, Secret, agent_password, agent_user};
use crate::transport::zenoh::config::Role;
use crate::transport::zenoh::declare_token;
use crate::transport::zenoh::open_session;
use crate::transport::zenoh::prefix;
use crate::transport::zenoh::publisher;
use crate::transport::zenoh::zerr;
use crate::transport::{TransportError, ZenohSettings};

/// A party of the run whose liveliness token appeared or vanished.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Member {
    /// Node `i`.
    Node(u32),
    /// The agent of this host name.
    Agent(String),
    /// The coordinator.
    Coordinator,
}

/// What the coordinator's side hears.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FleetEvent {
    /// A member came up (`true`) or went away (`false`).
    Presence(Member, bool),
    /// Agent `agent` said `payload`.
    Message {
        /// The agent's host name.
        agent: String,
        /// The message.
        payload: Vec<u8>,
    },
}

fn member_of(key: &str, prefix: &str) -> Option<Member> {
    let rest = key.strip_prefix(prefix)?.strip_prefix("/alive/")?;
    if rest == "coordinator" {
        return Some(Member::Coordinator);
    }
    if let Some(i) = rest.strip_prefix("node/") {
        return i.parse().ok().map(Member::Node);
    }
    rest.strip_prefix("agent/")
        .map(|a| Member::Agent(a.to_string()))
}

fn liveliness_subscriber(
    session: &zenoh::Session,
    prefix: &str,
    on: impl Fn(Member, bool) + Send + Sync + 'static,
) -> Result<Subscriber<()>, TransportError> {
    let key = format!("{prefix}/alive/**");
    let p = prefix.to_string();
    session
        .liveliness()
        .declare_subscriber(key.clone())
        .history(true)
        .callback(move |s| {
            if let Some(m) = member_of(s.key_expr().as_str(), &p) {
                on(m, s.kind() == SampleKind::Put);
            }
        })
        .wait()
        .map_err(zerr(format!("subscribing to liveliness {key}")))
}

/// The coordinator's side: sends commands to agents; every agent message and
/// every presence change goes to the callback given at [`FleetLink::open`]
/// (called on zenoh's threads).
pub struct FleetLink {
    session: zenoh::Session,
    prefix: String,
    _subs: Vec<Subscriber<()>>,
}

impl FleetLink {
    /// Listen to the run's agents and liveliness over the coordinator's own
    /// `session` (its transport's).
    pub fn open(
        session: &zenoh::Session,
        run_id: &str,
        on: impl Fn(FleetEvent) + Send + Sync + 'static,
    ) -> Result<Self, TransportError> {
        let prefix = prefix(run_id);
        let on = Arc::new(on);
        let on2 = Arc::clone(&on);
        let key = format!("{prefix}/agent/*/ev");
        let p = prefix.clone();
        let events = session
            .declare_subscriber(key.clone())
            .callback(move |s| {
                let k = s.key_expr().as_str();
                let agent = k
                    .strip_prefix(&p)
                    .and_then(|r| r.strip_prefix("/agent/"))
                    .and_then(|r| r.strip_suffix("/ev"));
                if let Some(agent) = agent {
                    on2(FleetEvent::Message {
                        agent: agent.to_string(),
                        payload: s.payload().to_bytes().into_owned(),
                    });
                }
            })
            .wait()
            .map_err(zerr(format!("subscribing to {key}")))?;
        let alive = liveliness_subscriber(session, &prefix, move |m, up| {
            on(FleetEvent::Presence(m, up))
        })?;
        Ok(FleetLink {
            session: session.clone(),
            prefix,
            _subs: vec![events, alive],
        })
    }

    /// Send `payload` to the agent of host `agent`.
    pub fn send(&self, agent: &str, payload: Vec<u8>) -> Result<(), TransportError> {
        let key = format!("{}/agent/{agent}/cmd", self.prefix);
        self.session
            .put(key.clone(), payload)
            .congestion_control(CongestionControl::Block)
            .priority(Priority::Data)
            .express(true)
            .wait()
            .map_err(zerr(format!("sending to {key}")))
    }
}

/// An agent's side: its commands, its events, and whether the coordinator is
/// there.
pub struct AgentLink {
    session: zenoh::Session,
    cmds: Receiver<Vec<u8>>,
    coordinator: Receiver<bool>,
    events: Publisher<'static>,
    _subs: Vec<Subscriber<()>>,
    _token: LivelinessToken,
}

impl AgentLink {
    /// Connect to the coordinator of run `run_id` as the agent of host
    /// `name`, with the fleet's key, trying for up to `connect_timeout`.
    pub fn open(
        settings: &ZenohSettings,
        run_id: &str,
        name: &str,
        fleet_key: &Secret,
        connect_timeout: Duration,
    ) -> Result<Self, TransportError> {
        let password =
            agent_password(fleet_key, run_id, name).map_err(|detail| TransportError::Zenoh {
                op: "logging in".into(),
                detail,
            })?;
        let login = Login {
            user: agent_user(name),
            password,
        };
        let session = open_session(
            settings,
            Role::Client(Some(&login)),
            run_id,
            connect_timeout,
        )?;
        let prefix = prefix(run_id);
        let (ctx, cmds) = crossbeam::channel::unbounded();
        let key = format!("{prefix}/agent/{name}/cmd");
        let cmd_sub = session
            .declare_subscriber(key.clone())
            .callback(move |s| {
                let _ = ctx.send(s.payload().to_bytes().into_owned());
            })
            .wait()
            .map_err(zerr(format!("subscribing to {key}")))?;
        let (ltx, coordinator) = crossbeam::channel::unbounded();
        let alive = liveliness_subscriber(&session, &prefix, move |m, up| {
            if m == Member::Coordinator {
                let _ = ltx.send(up);
            }
        })?;
        let events = publisher(&session, format!("{prefix}/agent/{name}/ev"))?;
        // The coordinator subscribed before any agent could connect: wait
        // until this session knows it, so that the first event is not lost.
        super::await_match(&events, super::MATCH_WAIT);
        let token_key = format!("{prefix}/alive/agent/{name}");
        let token = declare_token(&session, token_key)?;
        Ok(AgentLink {
            session,
            cmds,
            coordinator,
            events,
            _subs: vec![cmd_sub, alive],
            _token: token,
        })
    }

    /// The next command, waiting at most `timeout`.
    pub fn recv(&self, timeout: Duration) -> Option<Vec<u8>> {
        self.cmds.recv_timeout(timeout).ok()
    }

    /// Changes of the coordinator's presence since the last call, oldest first.
    pub fn coordinator_changes(&self) -> Vec<bool> {
        self.coordinator.try_iter().collect()
    }

    /// Tell the coordinator `payload`.
    pub fn send(&self, payload: Vec<u8>) -> Result<(), TransportError> {
        self.events
            .put(payload)
            .wait()
            .map_err(zerr("sending an agent event"))
    }
}

impl Drop for AgentLink {
    fn drop(&mut self) {
        let _ = self.session.close().wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn liveliness_keys_name_their_member() {
        let p = prefix("r1");
        assert_eq!(
            member_of("sonarnet/r1/alive/node/12", &p),
            Some(Member::Node(12))
        );
        assert_eq!(
            member_of("sonarnet/r1/alive/agent/host-b", &p),
            Some(Member::Agent("host-b".into()))
        );
        assert_eq!(
            member_of("sonarnet/r1/alive/coordinator", &p),
            Some(Member::Coordinator)
        );
        assert_eq!(member_of("sonarnet/r2/alive/node/1", &p), None);
        assert_eq!(member_of("sonarnet/r1/alive/node/x", &p), None);
    }
}
