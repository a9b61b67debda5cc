//! Where the node processes run: children of the coordinator, or
//! children of a per-host agent (`sonarnet agent`) that the coordinator
//! drives over zenoh ([`crate::runtime::agent`]). [`NodeProc`] gives both
//! the few operations the engine needs of a process: has it exited (and how),
//! signal it, kill it, wait for it.

// Without zenoh the agent side is compiled but never used.
#![cfg_attr(not(feature = "zenoh"), allow(dead_code, unused_imports))]

use super::NodeLaunch;
use crate::protocol::EngineError;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::process::{Child, ExitStatus};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// What the coordinator tells an agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum AgentCommand {
    /// Start a node process with this launch description (the agent puts in
    /// its own endpoints and process id).
    Spawn {
        /// What the node is told.
        launch: Box<NodeLaunch>,
        /// The node's zenoh password for this run, which the agent hands to
        /// the node process in its environment
        /// ([`crate::transport::credentials::PASSWORD_ENV`]).
        #[serde(default)]
        password: Option<crate::transport::credentials::Secret>,
    },
    /// Send a signal to a node's process (faults: SIGSTOP, SIGCONT, SIGKILL).
    Signal {
        /// The node.
        node: u32,
        /// The signal number.
        signal: i32,
    },
    /// The run is over: reap the nodes (they were told to stop) and exit.
    End,
}

/// What an agent tells the coordinator.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "ev", rename_all = "snake_case", deny_unknown_fields)]
pub enum AgentEvent {
    /// A node process started.
    Spawned {
        /// The node.
        node: u32,
        /// Its process id on the agent's host.
        pid: u32,
    },
    /// A node process could not be started.
    Failed {
        /// The node.
        node: u32,
        /// Why.
        reason: String,
    },
    /// A node process ended.
    Exited {
        /// The node.
        node: u32,
        /// How (exit code or signal).
        how: String,
    },
    /// The agent is done.
    Ended,
}

pub use crate::scenario::deploy::{LOCAL_HOST, Placement};

/// What the coordinator knows of the agents and their nodes, updated by
/// zenoh's threads.
#[derive(Debug, Default)]
struct FleetState {
    /// Agents whose liveliness token is up now.
    up: BTreeSet<String>,
    /// Agents that were up and went away.
    gone: BTreeSet<String>,
    /// How each node's current process ended, not yet taken.
    exited: BTreeMap<u32, String>,
    /// Per node, its host.
    host_of: Vec<String>,
    /// Nodes whose process has not been reported ended.
    running: BTreeSet<u32>,
    /// The nodes' process ids on their hosts.
    pids: BTreeMap<u32, u32>,
    /// Agents that said they are done.
    ended: BTreeSet<String>,
    /// Nodes whose liveliness token went away, and when.
    token_gone: BTreeMap<u32, Instant>,
}

/// How long a node's vanished liveliness token waits for its agent's report
/// (which says how the process ended) before it counts as the death itself.
pub const TOKEN_GRACE: Duration = Duration::from_millis(200);

/// The state [`RemoteFleet`] shares with zenoh's threads.
#[derive(Debug, Default)]
struct FleetShared {
    state: Mutex<FleetState>,
    changed: Condvar,
}

impl FleetShared {
    fn lock(&self) -> MutexGuard<'_, FleetState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Apply one event (on zenoh's threads).
    #[cfg(feature = "zenoh")]
    fn on_event(&self, e: crate::transport::zenoh::fleet::FleetEvent) {
        use crate::transport::zenoh::fleet::{FleetEvent, Member};
        let mut st = self.lock();
        match e {
            FleetEvent::Presence(Member::Agent(a), true) => {
                st.gone.remove(&a);
                st.up.insert(a);
            }
            FleetEvent::Presence(Member::Agent(a), false) => {
                st.up.remove(&a);
                st.gone.insert(a.clone());
                let orphans: Vec<u32> = st
                    .running
                    .iter()
                    .copied()
                    .filter(|&i| st.host_of.get(i as usize) == Some(&a))
                    .collect();
                for i in orphans {
                    st.running.remove(&i);
                    st.exited
                        .insert(i, format!("its agent on host {a} went away"));
                }
            }
            FleetEvent::Presence(Member::Node(i), up) => {
                if up {
                    st.token_gone.remove(&i);
                } else {
                    st.token_gone.insert(i, Instant::now());
                }
            }
            FleetEvent::Presence(Member::Coordinator, _) => {}
            FleetEvent::Message { agent, payload } => {
                match serde_json::from_slice::<AgentEvent>(&payload) {
                    Ok(AgentEvent::Spawned { node, pid }) => {
                        st.pids.insert(node, pid);
                    }
                    Ok(AgentEvent::Exited { node, how })
                    | Ok(AgentEvent::Failed { node, reason: how }) => {
                        if st.running.remove(&node) {
                            st.exited.insert(node, format!("{how} (on host {agent})"));
                        }
                    }
                    Ok(AgentEvent::Ended) => {
                        st.ended.insert(agent);
                    }
                    Err(e) => {
                        eprintln!("warning: agent {agent} sent a message that does not parse: {e}")
                    }
                }
            }
        }
        drop(st);
        self.changed.notify_all();
    }
}

/// The coordinator's view of the remote hosts of a run.
pub struct RemoteFleet {
    #[cfg(feature = "zenoh")]
    link: crate::transport::zenoh::fleet::FleetLink,
    shared: Arc<FleetShared>,
}

impl RemoteFleet {
    fn lock(&self) -> MutexGuard<'_, FleetState> {
        self.shared.lock()
    }

    /// Listen to the run's agents over the coordinator's zenoh session.
    #[cfg(feature = "zenoh")]
    pub fn open(
        session: &zenoh::Session,
        run_id: &str,
        placement: &Placement,
        n: usize,
    ) -> Result<Arc<RemoteFleet>, EngineError> {
        let shared = Arc::new(FleetShared::default());
        shared.lock().host_of = (0..n as u32)
            .map(|i| placement.host_of(i).unwrap_or(LOCAL_HOST).to_string())
            .collect();
        let s2 = Arc::clone(&shared);
        let link = crate::transport::zenoh::fleet::FleetLink::open(session, run_id, move |e| {
            s2.on_event(e)
        })
        .map_err(EngineError::Transport)?;
        Ok(Arc::new(RemoteFleet { link, shared }))
    }

    /// Wait up to `timeout` until every agent of `agents` is up; returns
    /// the ones still missing.
    pub fn wait_for(&self, agents: &[&str], timeout: Duration) -> Vec<String> {
        let deadline = Instant::now() + timeout;
        let mut st = self.lock();
        loop {
            let missing: Vec<String> = agents
                .iter()
                .filter(|a| !st.up.contains(**a))
                .map(|a| a.to_string())
                .collect();
            let left = deadline.saturating_duration_since(Instant::now());
            if missing.is_empty() || left.is_zero() {
                return missing;
            }
            st = self
                .shared
                .changed
                .wait_timeout(st, left.min(Duration::from_millis(100)))
                .map(|(g, _)| g)
                .unwrap_or_else(|e| e.into_inner().0);
        }
    }

    fn send(&self, agent: &str, cmd: &AgentCommand) -> Result<(), EngineError> {
        let bytes = serde_json::to_vec(cmd).map_err(|e| EngineError::Unsupported(e.to_string()))?;
        #[cfg(feature = "zenoh")]
        {
            self.link.send(agent, bytes).map_err(EngineError::Transport)
        }
        #[cfg(not(feature = "zenoh"))]
        {
            let _ = (agent, bytes);
            Err(EngineError::Transport(
                crate::transport::TransportError::ZenohUnavailable,
            ))
        }
    }

    /// Ask the agent of node `launch.node.id`'s host to start it, with its
    /// zenoh `password`.
    pub fn spawn(
        self: &Arc<Self>,
        launch: &NodeLaunch,
        password: Option<&crate::transport::credentials::Secret>,
    ) -> Result<NodeProc, EngineError> {
        let node = launch.node.id;
        let agent = {
            let mut st = self.lock();
            st.exited.remove(&node);
            st.token_gone.remove(&node);
            st.running.insert(node);
            st.host_of.get(node as usize).cloned().unwrap_or_default()
        };
        self.send(
            &agent,
            &AgentCommand::Spawn {
                launch: Box::new(launch.clone()),
                password: password.cloned(),
            },
        )?;
        Ok(NodeProc::Remote {
            node,
            agent,
            fleet: Arc::clone(self),
        })
    }

    /// Tell every agent that the run is over, and wait up to `timeout` for
    /// each to say it is done (or to go away).
    pub fn end(&self, timeout: Duration) {
        let agents: Vec<String> = self.lock().up.iter().cloned().collect();
        for a in &agents {
            let _ = self.send(a, &AgentCommand::End);
        }
        let deadline = Instant::now() + timeout;
        let mut st = self.lock();
        while agents
            .iter()
            .any(|a| !st.ended.contains(a) && st.up.contains(a))
            && Instant::now() < deadline
        {
            st = self
                .shared
                .changed
                .wait_timeout(st, Duration::from_millis(50))
                .map(|(g, _)| g)
                .unwrap_or_else(|e| e.into_inner().0);
        }
    }

    /// How node `node`'s process ended: its agent's report, or, when that
    /// does not come within [`TOKEN_GRACE`] of its liveliness token going
    /// away, the token's going.
    fn take_exit(&self, node: u32) -> Option<String> {
        let mut st = self.lock();
        if let Some(how) = st.exited.remove(&node) {
            st.token_gone.remove(&node);
            return Some(how);
        }
        let gone = st.token_gone.get(&node).copied()?;
        if gone.elapsed() < TOKEN_GRACE || !st.running.contains(&node) {
            return None;
        }
        st.running.remove(&node);
        st.token_gone.remove(&node);
        let host = st.host_of.get(node as usize).cloned().unwrap_or_default();
        Some(format!(
            "its zenoh session on host {host} closed (liveliness token gone)"
        ))
    }
}

/// A node's process: a child of this process, or of an agent.
pub enum NodeProc {
    /// Started by the coordinator.
    Local(Child),
    /// Started by the agent of `agent`'s host.
    Remote {
        /// The node id.
        node: u32,
        /// Its host.
        agent: String,
        /// The run's agents.
        fleet: Arc<RemoteFleet>,
    },
}

/// How a process ended, in words (`exit code 3`, `killed by signal 9`).
pub fn status_text(s: &ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (s.code(), s.signal()) {
        (Some(143), _) => "exit code 143: stopped by SIGTERM or SIGINT".into(),
        (Some(c), _) => format!("exit code {c}"),
        (None, Some(sig)) => format!("killed by signal {sig}"),
        _ => "unknown status".into(),
    }
}

/// How long [`NodeProc::wait`] waits for an agent's report.
pub const REMOTE_WAIT: Duration = Duration::from_secs(5);

impl NodeProc {
    /// How the process ended, if it has (once: the status is taken).
    pub fn try_wait(&mut self) -> Option<String> {
        match self {
            NodeProc::Local(c) => c.try_wait().ok().flatten().map(|s| status_text(&s)),
            NodeProc::Remote { node, fleet, .. } => fleet.take_exit(*node),
        }
    }

    /// Send signal `sig` (SIGSTOP, SIGCONT, SIGKILL, ...).
    pub fn signal(&self, sig: i32) {
        match self {
            // SAFETY: kill(2) on the pid of a child we own and have not
            // reaped (it is held until reaped).
            NodeProc::Local(c) => unsafe {
                libc::kill(c.id() as i32, sig);
            },
            NodeProc::Remote { node, agent, fleet } => {
                let _ = fleet.send(
                    agent,
                    &AgentCommand::Signal {
                        node: *node,
                        signal: sig,
                    },
                );
            }
        }
    }

    /// SIGKILL.
    pub fn kill(&mut self) {
        match self {
            NodeProc::Local(c) => {
                let _ = c.kill();
            }
            r => r.signal(libc::SIGKILL),
        }
    }

    /// Wait until it has ended (a remote one: until its agent says so, or
    /// [`REMOTE_WAIT`]).
    pub fn wait(&mut self) {
        match self {
            NodeProc::Local(c) => {
                let _ = c.wait();
            }
            NodeProc::Remote { node, fleet, .. } => {
                let deadline = Instant::now() + REMOTE_WAIT;
                let mut st = fleet.lock();
                while st.running.contains(node) && Instant::now() < deadline {
                    st = fleet
                        .shared
                        .changed
                        .wait_timeout(st, Duration::from_millis(50))
                        .map(|(g, _)| g)
                        .unwrap_or_else(|e| e.into_inner().0);
                }
                st.running.remove(node);
                st.exited.remove(node);
            }
        }
    }

    /// The local process id (`None` for a remote node).
    pub fn local_pid(&self) -> Option<u32> {
        match self {
            NodeProc::Local(c) => Some(c.id()),
            NodeProc::Remote { .. } => None,
        }
    }
}
