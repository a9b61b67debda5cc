//! What a node process is told at start ([`NodeLaunch`]), where the node
//! program is ([`NodeProgram`]), and the engine's options.

use crate::protocol::NodeConfig;
use crate::transport::{RunTopology, TransportError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

use super::ChannelClock;

/// Everything a node process is told at start (passed as JSON in `--launch`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeLaunch {
    /// The run's IPC namespace.
    pub run_id: String,
    /// Directed neighbour lists of every node: the transport sizes its
    /// services from them (the node gossips only with its own list).
    pub topology: Vec<Vec<u32>>,
    /// Frames in flight per sender/receiver pair.
    pub inbox_buffer: usize,
    /// Broadcast group buffer (sync mode), if any.
    pub broadcast_buffer: Option<usize>,
    /// Send timeout (ms).
    pub send_timeout_ms: u64,
    /// The node's own configuration.
    pub node: NodeConfig,
    /// Log protocol events to stderr.
    pub verbose: bool,
    /// Bounded polling before blocking, in microseconds (0: block at once; see
    /// [`crate::transport::IoxTransport::set_poll`]).
    #[serde(default)]
    pub poll_us: u64,
    /// The acoustic channel's shared clock: gossip goes through the
    /// coordinator's water ([`crate::engine::water`]). `None`: the ideal channel.
    #[serde(default)]
    pub channel: Option<ChannelClock>,
    /// The node's checkpoint file ([`crate::engine::checkpoint`]), when it
    /// writes checkpoints (a `restart` fault with `state = "checkpoint"`).
    #[serde(default)]
    pub checkpoint: Option<PathBuf>,
    /// Resume from the checkpoint file (a restarted node).
    #[serde(default)]
    pub resume: bool,
    /// The coordinator's process id: the node's parent ([`guard_parent`]).
    #[serde(default)]
    pub coordinator_pid: Option<u32>,
    /// Wait at the start gate: read stdin to its end before opening the
    /// transport (the coordinator closes the gate's pipe once the run's
    /// services exist).
    #[serde(default)]
    pub gate: bool,
    /// The transport to open (iceoryx2, or zenoh with the coordinator's
    /// endpoints).
    #[serde(default)]
    pub transport: crate::transport::TransportChoice,
    /// Gossip frames a peer may send per sample
    /// ([`NodeLoop::peer_frames_per_sample`](crate::engine::node::NodeLoop)).
    #[serde(default = "unbounded")]
    pub peer_frames_per_sample: u64,
    /// The realtime clock's sample period in wall time, for that budget
    /// ([`NodeLoop::budget_period`](crate::engine::node::NodeLoop)).
    #[serde(default)]
    pub budget_period: Option<std::time::Duration>,
}

fn unbounded() -> u64 {
    u64::MAX
}

/// Why a node process ends with an error (exit 1): its start, its
/// transport or its loop; the cause is kept as the source.
#[derive(Debug, thiserror::Error)]
pub enum NodeProcessError {
    /// `PR_SET_PDEATHSIG` failed.
    #[error("cannot ask for SIGTERM at the parent's death (PR_SET_PDEATHSIG)")]
    DeathSignal(#[source] std::io::Error),
    /// The coordinator died before the node started.
    #[error("the coordinator (pid {0}) is gone")]
    CoordinatorGone(u32),
    /// The SIGTERM/SIGINT flag could not be installed.
    #[error("cannot install the SIGTERM/SIGINT handlers")]
    Signals(#[source] std::io::Error),
    /// Reading stdin at the start gate failed.
    #[error("waiting at the start gate (stdin)")]
    Gate(#[source] std::io::Error),
    /// The transport could not be set up.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The node loop stopped on an error.
    #[error(transparent)]
    Node(#[from] crate::engine::node::NodeError),
}

/// In a node process with `launch.gate`: wait until the coordinator opens
/// the start gate (stdin reaches its end; also if the coordinator dies).
pub fn wait_at_gate(launch: &NodeLaunch) -> Result<(), NodeProcessError> {
    if !launch.gate {
        return Ok(());
    }
    let mut sink = Vec::new();
    std::io::Read::read_to_end(&mut std::io::stdin().lock(), &mut sink)
        .map(|_| ())
        .map_err(NodeProcessError::Gate)
}

/// In a node process: ask the kernel for SIGTERM when the parent dies
/// (`PR_SET_PDEATHSIG`), then check that the parent is still `coordinator`
/// (it may have died between the spawn and the request). Errors if it is
/// gone, so that the node exits at once.
pub fn guard_parent(coordinator: Option<u32>) -> Result<(), NodeProcessError> {
    // SAFETY: prctl(PR_SET_PDEATHSIG) only sets a flag on this process.
    if unsafe { libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) } != 0 {
        return Err(NodeProcessError::DeathSignal(
            std::io::Error::last_os_error(),
        ));
    }
    match coordinator {
        Some(pid) if std::os::unix::process::parent_id() != pid => {
            Err(NodeProcessError::CoordinatorGone(pid))
        }
        _ => Ok(()),
    }
}

impl NodeLaunch {
    /// The transport topology this launch describes.
    pub fn run_topology(&self) -> Result<RunTopology, TransportError> {
        let t = RunTopology::new(
            self.run_id.clone(),
            self.topology.clone(),
            self.inbox_buffer,
        )?
        .with_send_timeout(Duration::from_millis(self.send_timeout_ms));
        match self.broadcast_buffer {
            Some(b) => t.with_broadcast(b),
            None => Ok(t),
        }
    }
}

/// How to start a node process: a program and the arguments that come
/// before `--launch JSON`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeProgram {
    /// The executable.
    pub program: PathBuf,
    /// Leading arguments (`["__node"]` when `sonarnet` runs the node program itself).
    pub args: Vec<String>,
}

impl NodeProgram {
    /// The `sonarnet-node` binary at `path`.
    pub fn binary(path: impl Into<PathBuf>) -> Self {
        NodeProgram {
            program: path.into(),
            args: Vec::new(),
        }
    }
}

/// Where to find the node program: `$SONARNET_NODE_BIN`; else the
/// `sonarnet-node` binary next to the current executable (or one directory up,
/// for test binaries in `target/*/deps`); else, when the current executable
/// is `sonarnet` itself (e.g. after `cargo run`, which builds only that
/// binary), `sonarnet __node`, which runs the same node program compiled in.
pub fn default_node_program() -> NodeProgram {
    if let Some(p) = std::env::var_os("SONARNET_NODE_BIN") {
        return NodeProgram::binary(p);
    }
    let exe = std::env::current_exe().unwrap_or_default();
    let dir = exe.parent().map(Path::to_path_buf).unwrap_or_default();
    let here = dir.join("sonarnet-node");
    if here.exists() {
        return NodeProgram::binary(here);
    }
    if let Some(up) = dir.parent().map(|p| p.join("sonarnet-node"))
        && up.exists()
    {
        return NodeProgram::binary(up);
    }
    if exe.file_name().is_some_and(|n| n == "sonarnet") {
        return NodeProgram {
            program: exe,
            args: vec!["__node".into()],
        };
    }
    NodeProgram::binary(here)
}

/// Options of the multi-process engine.
#[derive(Debug, Clone)]
pub struct ProcessOptions {
    /// The node program.
    pub node_program: NodeProgram,
    /// Log with node ids.
    pub verbose: bool,
    /// How long to wait for all nodes to report READY.
    pub startup_timeout: Duration,
    /// Node processes poll their inboxes for up to this many microseconds before
    /// blocking (`--poll-us`; 0, the default, blocks at once). The coordinator
    /// always blocks.
    pub poll_us: u64,
    /// Where nodes that checkpoint write their files (`checkpoints/` of
    /// the results directory). `None`: a temporary directory, removed when
    /// the run ends.
    pub checkpoint_dir: Option<PathBuf>,
    /// The transport between the processes (`--transport`).
    pub transport: crate::transport::TransportChoice,
    /// Nodes on other hosts, started by their agents (`[deploy]`,
    /// `--place`; zenoh only). `None`: every node on this host.
    pub placement: Option<super::Placement>,
    /// How long to wait for the agents of a placement (`--agent-wait`).
    pub agent_wait: Duration,
    /// The run id; `None`: a fresh one ([`crate::transport::unique_run_id`],
    /// or [`crate::transport::secret_run_id`] over zenoh).
    pub run_id: Option<String>,
    /// The fleet's key, which the agents of a placement log in with
    /// (`--fleet-key`; [`crate::transport::credentials`]).
    pub fleet_key: Option<crate::transport::credentials::Secret>,
}

impl Default for ProcessOptions {
    fn default() -> Self {
        ProcessOptions {
            node_program: default_node_program(),
            verbose: false,
            startup_timeout: Duration::from_secs(60),
            poll_us: 0,
            checkpoint_dir: None,
            transport: crate::transport::TransportChoice::Iceoryx2,
            placement: None,
            agent_wait: Duration::from_secs(30),
            run_id: None,
            fleet_key: None,
        }
    }
}

/// Start one node process of `prog` with `launch` and `stdin` (the start
/// gate, [`NodeLaunch::gate`]): in its own process group (a terminal's
/// Ctrl-C reaches only the coordinator), stdout to null, stderr inherited.
/// The node asks for SIGTERM if the coordinator dies itself
/// ([`guard_parent`]). A zenoh `password` goes into the node's environment
/// ([`PASSWORD_ENV`](crate::transport::credentials::PASSWORD_ENV)), never
/// on its command line, which every user of the host can read.
pub(crate) fn spawn_child(
    prog: &NodeProgram,
    launch: &NodeLaunch,
    stdin: std::process::Stdio,
    password: Option<&crate::transport::credentials::Secret>,
) -> Result<std::process::Child, crate::protocol::EngineError> {
    use crate::protocol::EngineError;
    use crate::protocol::error::Cause;
    use std::os::unix::process::CommandExt;
    use std::process::{Command, Stdio};
    let id = launch.node.id;
    let json = serde_json::to_string(launch).map_err(|e| EngineError::Launch {
        node: id,
        source: Cause::new(e),
    })?;
    let mut cmd = Command::new(&prog.program);
    cmd.args(&prog.args)
        .arg("--launch")
        .arg(json)
        .stdin(stdin)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit());
    if let Some(p) = password {
        cmd.env(crate::transport::credentials::PASSWORD_ENV, p.expose());
    }
    // No `pre_exec`: without it the standard library starts the child with
    // posix_spawn (a vfork-like clone that shares the coordinator's memory
    // until exec), not fork, whose copy of the coordinator's page tables
    // grows with the shared memory it maps for the run: O(N) per spawn,
    // O(N^2) per run. The node program sets its own
    // PR_SET_PDEATHSIG and checks `coordinator_pid` ([`NodeLaunch`]).
    cmd.process_group(0);
    cmd.spawn().map_err(|e| EngineError::Spawn {
        node: id,
        program: prog.program.clone(),
        source: Cause::new(e),
    })
}

/// The name of a run's temporary checkpoint directory, before its run id
/// (in the system's temporary directory; removed by the coordinator when
/// the run ends, or by the last node out if the coordinator was killed).
pub const TEMP_CHECKPOINTS: &str = "sonarnet-checkpoints-";

/// The directory of the run's checkpoint files, if any node writes
/// checkpoints: `opts.checkpoint_dir`, else a temporary directory of this
/// run (`true`: remove it at the end). Created here.
pub(super) fn checkpoint_dir(
    configs: &[NodeConfig],
    run_id: &str,
    opts: &ProcessOptions,
) -> Result<Option<(PathBuf, bool)>, crate::protocol::EngineError> {
    if configs.iter().all(|c| c.checkpoint_every.is_none()) {
        return Ok(None);
    }
    let (dir, temp) = match &opts.checkpoint_dir {
        Some(d) => (d.clone(), false),
        None => (
            std::env::temp_dir().join(format!("{TEMP_CHECKPOINTS}{run_id}")),
            true,
        ),
    };
    std::fs::create_dir_all(&dir).map_err(|e| crate::protocol::EngineError::Checkpoints {
        dir: dir.clone(),
        source: crate::protocol::error::Cause::new(e),
    })?;
    Ok(Some((dir, temp)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node started by a coordinator that has since died exits at once
    /// instead of running as an orphan; with its coordinator alive, it runs.
    #[test]
    fn a_node_whose_coordinator_is_gone_refuses_to_start() {
        let parent = std::os::unix::process::parent_id();
        assert!(guard_parent(Some(parent)).is_ok());
        assert!(guard_parent(None).is_ok());
        let e = guard_parent(Some(parent.wrapping_add(7919))).unwrap_err();
        assert!(matches!(e, NodeProcessError::CoordinatorGone(_)), "{e}");
    }
}
