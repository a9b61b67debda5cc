//! Why a run stopped early ([`EngineError`]): the coordinator's own reasons
//! (a node failed, died or went silent, an interrupt, a stall) and those of
//! the engine that ran it (the transport, starting the node processes, the
//! machine's resources).

use crate::protocol::config::Refused;
use std::sync::Arc;
use std::time::Duration;

/// The error underneath an [`EngineError`] (an I/O or encoding error),
/// kept as its `source()`: shared, so that the error stays `Clone`, and
/// compared by its message.
#[derive(Debug, Clone)]
pub struct Cause(Arc<dyn std::error::Error + Send + Sync>);

impl Cause {
    /// `e` as a cause.
    pub fn new(e: impl std::error::Error + Send + Sync + 'static) -> Cause {
        Cause(Arc::new(e))
    }
}

impl PartialEq for Cause {
    fn eq(&self, other: &Cause) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

impl std::fmt::Display for Cause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for Cause {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// A node could not compute its prox.
    #[error("node {node} failed at sample {sample}: {reason}")]
    NodeFailed {
        /// Node id.
        node: u32,
        /// Sample.
        sample: u32,
        /// Reason.
        reason: String,
    },
    /// A node process died.
    #[error("node {node} died ({how}) at sample {sample}")]
    NodeDied {
        /// Node id.
        node: u32,
        /// Sample.
        sample: u32,
        /// Exit status or signal.
        how: String,
    },
    /// Nodes did not answer a liveness check (logical clocks): stopped
    /// (`kill -STOP`), or wedged.
    #[error(
        "{} not responding (stopped?) at sample {sample}: no report for {:.1} s and no answer to a liveness check",
        names(nodes),
        silent_for.as_secs_f64()
    )]
    NotResponding {
        /// The silent nodes.
        nodes: Vec<u32>,
        /// The oldest sample not complete.
        sample: u32,
        /// How long nothing had come from any node.
        silent_for: Duration,
    },
    /// The run was interrupted (SIGINT/SIGTERM).
    #[error("interrupted at sample {sample}")]
    Interrupted {
        /// Sample.
        sample: u32,
    },
    /// The transport failed (its error is part of this message, not a
    /// separate cause, so that it is printed once).
    #[error("transport: {0}")]
    Transport(crate::transport::TransportError),
    /// The coordinator's transport was already closed.
    #[error("the coordinator's transport is closed")]
    TransportClosed,
    /// The node program does not exist.
    #[error(
        "node program {} not found (build it with `cargo build --release`, or set SONARNET_NODE_BIN)",
        path.display()
    )]
    NodeProgramMissing {
        /// Where it was looked for.
        path: std::path::PathBuf,
    },
    /// A node process could not be started.
    #[error("cannot start {} for node {node}", program.display())]
    Spawn {
        /// The node.
        node: u32,
        /// The program.
        program: std::path::PathBuf,
        /// The operating system's error.
        #[source]
        source: Cause,
    },
    /// A node's launch configuration could not be encoded.
    #[error("cannot encode the launch configuration of node {node}")]
    Launch {
        /// The node.
        node: u32,
        /// The encoder's error.
        #[source]
        source: Cause,
    },
    /// The start gate of the node processes could not be set up
    /// ([`crate::runtime::processes::wait_at_gate`]) at step `step`.
    #[error("cannot set up the start gate of the node processes: {step}")]
    StartGate {
        /// What was being done (`creating its pipe`, `passing it to node 3`).
        step: String,
        /// The operating system's error.
        #[source]
        source: Cause,
    },
    /// The directory of the nodes' checkpoint files could not be created.
    #[error("cannot create the checkpoint directory {}", dir.display())]
    Checkpoints {
        /// The directory.
        dir: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: Cause,
    },
    /// The agents of some hosts of a placement did not connect in time.
    #[error(
        "no agent connected for host(s) {} within {waited:?}: start `sonarnet agent --connect tcp/<this host>:<port> --run-id {run_id} --host <name>` there (the coordinator listens on {listen})",
        missing.join(", ")
    )]
    AgentsMissing {
        /// The hosts without an agent.
        missing: Vec<String>,
        /// How long the coordinator waited.
        waited: Duration,
        /// The run id the agents must give.
        run_id: String,
        /// The coordinator's endpoints.
        listen: String,
    },
    /// A node to restart from its checkpoint file has a file that does not
    /// read (the file, and where and why it does not): bad input, exit 2.
    #[error("node {node} cannot restart from its checkpoint: {reason}")]
    Checkpoint {
        /// The node.
        node: u32,
        /// The file, and the line and column or the reason.
        reason: String,
    },
    /// Nodes did not report READY in time.
    #[error("nodes {missing:?} did not come up within {waited:?}")]
    Startup {
        /// The nodes that never reported.
        missing: Vec<u32>,
        /// How long the coordinator waited.
        waited: Duration,
    },
    /// This machine cannot hold the run ([`crate::runtime::preflight`]): the key most to
    /// blame and the reason with the numbers. Found before anything starts.
    #[error(transparent)]
    Resources(crate::model::error::KeyError),
    /// The engine cannot run this combination (e.g. realtime clocks in-process).
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// The run cannot be what it was asked to be ([`RunConfig::resolve`](crate::protocol::RunConfig::resolve)).
    #[error("{0}")]
    Refused(#[from] Refused),
    /// Internal inconsistency (a bug): the protocol stalled.
    #[error("protocol stalled: {0}")]
    Stalled(String),
}

impl EngineError {
    /// This error and its causes in one line, `: ` between them (the form of
    /// `metrics.json`, `run.json` and the logs; the command line prints the
    /// causes on lines of their own).
    pub fn in_full(&self) -> String {
        let mut out = self.to_string();
        let mut src = std::error::Error::source(self);
        while let Some(s) = src {
            out.push_str(": ");
            out.push_str(&s.to_string());
            src = s.source();
        }
        out
    }
}

/// `node 3 is` / `nodes 3, 4 are`.
fn names(nodes: &[u32]) -> String {
    let list: Vec<String> = nodes.iter().map(u32::to_string).collect();
    match nodes.len() {
        1 => format!("node {} is", list[0]),
        _ => format!("nodes {} are", list.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::{Cause, EngineError};
    use std::error::Error;

    #[test]
    fn an_engine_error_keeps_its_cause_as_its_source_and_says_it_in_full() {
        let e = EngineError::Spawn {
            node: 3,
            program: "/x/sonarnet-node".into(),
            source: Cause::new(std::io::Error::from(std::io::ErrorKind::NotFound)),
        };
        assert_eq!(e.to_string(), "cannot start /x/sonarnet-node for node 3");
        let cause = e.source().expect("a source");
        assert_eq!(cause.to_string(), "entity not found");
        assert_eq!(
            e.in_full(),
            "cannot start /x/sonarnet-node for node 3: entity not found"
        );
        // Clone and equality still hold (by the cause's message).
        assert_eq!(e.clone(), e);
        let without = EngineError::Interrupted { sample: 4 };
        assert_eq!(without.in_full(), without.to_string());
    }
}
