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
}

impl Default for ProcessOptions {
    fn default() -> Self {
        ProcessOptions {
            node_program: default_node_program(),
            verbose: false,
            startup_timeout: Duration::from_secs(60),
            poll_us: 0,
            checkpoint_dir: None,
        }
    }
}

/// Start one node process of `prog` with `launch`: in its own process group
/// (a terminal's Ctrl-C reaches only the coordinator), with SIGTERM if the
/// coordinator dies (`PR_SET_PDEATHSIG`), stdout to null, stderr inherited.
pub(super) fn spawn_child(
    prog: &NodeProgram,
    launch: &NodeLaunch,
) -> Result<std::process::Child, crate::engine::EngineError> {
    use crate::engine::EngineError;
    use std::os::unix::process::CommandExt;
    use std::process::{Command, Stdio};
    let id = launch.node.id;
    let json = serde_json::to_string(launch).map_err(|e| EngineError::Launch {
        node: id,
        reason: e.to_string(),
    })?;
    let mut cmd = Command::new(&prog.program);
    cmd.args(&prog.args)
        .arg("--launch")
        .arg(json)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit());
    cmd.process_group(0);
    // SAFETY: prctl is async-signal-safe; nothing else runs in the child
    // between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.spawn().map_err(|e| EngineError::Spawn {
        node: id,
        program: prog.program.clone(),
        reason: e.to_string(),
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
) -> Result<Option<(PathBuf, bool)>, crate::engine::EngineError> {
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
    std::fs::create_dir_all(&dir).map_err(|e| crate::engine::EngineError::Launch {
        node: 0,
        reason: format!(
            "cannot create the checkpoint directory {}: {e}",
            dir.display()
        ),
    })?;
    Ok(Some((dir, temp)))
}
