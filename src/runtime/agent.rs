//! The per-host agent of a run spread over machines (`sonarnet agent`, issue
//! 18), like an MPI launcher: it connects to the coordinator over zenoh,
//! starts the node processes the coordinator assigns to its host, tells the
//! coordinator how each one ends, and reaps every one of them.
//!
//! * Its nodes are its children: they ask for SIGTERM when the agent dies
//!   (`PR_SET_PDEATHSIG`), so an agent that is killed takes its nodes with it,
//!   and the coordinator, which sees the agent's liveliness token go, reports
//!   them dead.
//! * When the coordinator goes away (its token vanishes), the agent stops its
//!   nodes (SIGTERM, then SIGKILL after [`GRACE`]) and exits with an error.
//! * On SIGINT or SIGTERM it does the same and exits.
//! * A run is one coordinator: after [`AgentCommand::End`] (or the end of its
//!   nodes) the agent exits.

// Without zenoh the agent side is compiled but never used.
#![cfg_attr(not(feature = "zenoh"), allow(dead_code, unused_imports))]

use super::processes::fleet::{AgentCommand, AgentEvent};
use super::processes::{NodeLaunch, NodeProgram, spawn_child};
use crate::transport::{TransportChoice, ZenohSettings};

use std::collections::BTreeMap;
use std::process::Child;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long nodes get between SIGTERM and SIGKILL, and to end after
/// [`AgentCommand::End`].
pub const GRACE: Duration = Duration::from_secs(3);

/// An agent's settings (`sonarnet agent`).
#[derive(Debug, Clone)]
pub struct AgentOptions {
    /// The coordinator's endpoints, and the zenoh configuration file.
    pub zenoh: ZenohSettings,
    /// The run to join.
    pub run_id: String,
    /// The fleet's key, this agent's password
    /// ([`crate::transport::credentials`]).
    pub fleet_key: crate::transport::credentials::Secret,
    /// This host's name, as in the run's placement.
    pub host: String,
    /// The node program on this host.
    pub node_program: NodeProgram,
    /// How long to wait for the coordinator.
    pub wait: Duration,
    /// Log what the agent does to stderr.
    pub verbose: bool,
}

/// Why an agent stopped early.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// The zenoh link failed.
    #[error(transparent)]
    Transport(#[from] crate::transport::TransportError),
    /// No coordinator of the run appeared in time.
    #[error(
        "no coordinator of run {run_id} admitted this agent at {endpoints} within {waited:?} (is `sonarnet run` listening there, with this run id, this host in its placement, and the same --fleet-key?)"
    )]
    NoCoordinator {
        /// The run id.
        run_id: String,
        /// Where the agent looked.
        endpoints: String,
        /// How long it waited.
        waited: Duration,
    },
    /// The coordinator went away during the run.
    #[error("the coordinator of run {0} went away; this host's nodes were stopped")]
    CoordinatorGone(String),
}

/// How an agent's run ended without an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgentEnd {
    /// The coordinator ended the run.
    Ended,
    /// SIGINT or SIGTERM.
    Signalled,
}

struct Nodes {
    children: BTreeMap<u32, Child>,
}

impl Nodes {
    /// Reap what has ended; returns the events to report.
    fn reap(&mut self) -> Vec<AgentEvent> {
        let mut out = Vec::new();
        self.children.retain(|&node, c| match c.try_wait() {
            Ok(Some(s)) => {
                out.push(AgentEvent::Exited {
                    node,
                    how: super::processes::fleet::status_text(&s),
                });
                false
            }
            _ => true,
        });
        out
    }

    fn signal_all(&self, sig: i32) {
        for c in self.children.values() {
            // SAFETY: kill(2) on the pid of a child we own and have not reaped.
            unsafe {
                libc::kill(c.id() as i32, sig);
            }
        }
    }

    /// SIGTERM every node, SIGKILL after [`GRACE`], reap all.
    fn stop_all(&mut self) -> Vec<AgentEvent> {
        self.signal_all(libc::SIGTERM);
        self.reap_within(GRACE)
    }

    /// Reap until none is left or `grace` passed; then SIGKILL and reap the rest.
    fn reap_within(&mut self, grace: Duration) -> Vec<AgentEvent> {
        let deadline = Instant::now() + grace;
        let mut out = self.reap();
        while !self.children.is_empty() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
            out.extend(self.reap());
        }
        for (node, mut c) in std::mem::take(&mut self.children) {
            let _ = c.kill();
            let how = c
                .wait()
                .map(|s| super::processes::fleet::status_text(&s))
                .unwrap_or_else(|e| e.to_string());
            out.push(AgentEvent::Exited { node, how });
        }
        out
    }
}

/// Run the agent until the coordinator ends the run, `term` is set, or an
/// error. Every node it started is reaped before it returns.
#[cfg(feature = "zenoh")]
pub fn run_agent(opts: &AgentOptions, term: &AtomicBool) -> Result<AgentEnd, AgentError> {
    use crate::transport::zenoh::fleet::AgentLink;
    let start = Instant::now();
    let log = |m: &str| {
        if opts.verbose {
            crate::protocol::words::log_line(&format!("agent {}", opts.host), m);
        }
    };
    let no_coordinator = || AgentError::NoCoordinator {
        run_id: opts.run_id.clone(),
        endpoints: opts.zenoh.connect.join(", "),
        waited: opts.wait,
    };
    // The coordinator may not be listening yet: retry until `wait`, a
    // second at a time (so that a signal is heard).
    let link = loop {
        let left = opts.wait.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(no_coordinator());
        }
        match AgentLink::open(
            &opts.zenoh,
            &opts.run_id,
            &opts.host,
            &opts.fleet_key,
            left.min(Duration::from_secs(1)),
        ) {
            Ok(l) => break l,
            Err(e @ crate::transport::TransportError::InvalidTopology(_)) => return Err(e.into()),
            Err(_) if term.load(Ordering::Relaxed) => return Ok(AgentEnd::Signalled),
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    };
    log(&format!("connected to {}", opts.zenoh.connect.join(", ")));
    let send = |e: &AgentEvent| {
        if let Ok(b) = serde_json::to_vec(e) {
            let _ = link.send(b);
        }
    };
    let mut nodes = Nodes {
        children: BTreeMap::new(),
    };
    let mut seen = false;
    let mut ending: Option<Instant> = None;
    loop {
        if term.load(Ordering::Relaxed) {
            log("signalled: stopping this host's nodes");
            nodes.stop_all().iter().for_each(send);
            return Ok(AgentEnd::Signalled);
        }
        if let Some(bytes) = link.recv(Duration::from_millis(20)) {
            match serde_json::from_slice::<AgentCommand>(&bytes) {
                Ok(AgentCommand::Spawn { launch, password }) => {
                    let node = launch.node.id;
                    let launch = NodeLaunch {
                        transport: TransportChoice::Zenoh(opts.zenoh.clone()),
                        coordinator_pid: Some(std::process::id()),
                        gate: false,
                        ..*launch
                    };
                    match spawn_child(
                        &opts.node_program,
                        &launch,
                        std::process::Stdio::null(),
                        password.as_ref(),
                    ) {
                        Ok(c) => {
                            log(&format!("started node {node} (pid {})", c.id()));
                            send(&AgentEvent::Spawned { node, pid: c.id() });
                            nodes.children.insert(node, c);
                        }
                        Err(e) => send(&AgentEvent::Failed {
                            node,
                            reason: e.in_full(),
                        }),
                    }
                }
                Ok(AgentCommand::Signal { node, signal }) => {
                    if let Some(c) = nodes.children.get(&node) {
                        // SAFETY: kill(2) on the pid of a child we own and
                        // have not reaped.
                        unsafe {
                            libc::kill(c.id() as i32, signal);
                        }
                    }
                }
                Ok(AgentCommand::End) => {
                    log("the run is over");
                    ending = Some(Instant::now() + GRACE);
                }
                Err(e) => eprintln!("warning: a command that does not parse: {e}"),
            }
        }
        // After END the coordinator may close at any time: its going away
        // is then no error.
        for up in link.coordinator_changes() {
            if ending.is_some() {
                continue;
            }
            if up {
                seen = true;
            } else if seen {
                nodes.stop_all().iter().for_each(send);
                return Err(AgentError::CoordinatorGone(opts.run_id.clone()));
            }
        }
        if !seen && start.elapsed() >= opts.wait {
            return Err(no_coordinator());
        }
        nodes.reap().iter().for_each(send);
        if let Some(deadline) = ending
            && (nodes.children.is_empty() || Instant::now() >= deadline)
        {
            nodes.reap_within(Duration::ZERO).iter().for_each(send);
            send(&AgentEvent::Ended);
            return Ok(AgentEnd::Ended);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agent_messages_are_tagged_json_and_refuse_unknown_fields() {
        let e = AgentEvent::Exited {
            node: 3,
            how: "exit code 0".into(),
        };
        let j = serde_json::to_string(&e).unwrap();
        assert_eq!(j, r#"{"ev":"exited","node":3,"how":"exit code 0"}"#);
        assert_eq!(serde_json::from_str::<AgentEvent>(&j).unwrap(), e);
        let c: AgentCommand =
            serde_json::from_str(r#"{"cmd":"signal","node":1,"signal":19}"#).unwrap();
        assert_eq!(
            c,
            AgentCommand::Signal {
                node: 1,
                signal: 19
            }
        );
        assert!(
            serde_json::from_str::<AgentCommand>(r#"{"cmd":"signal","node":1,"signal":9,"x":1}"#)
                .is_err()
        );
    }
}
