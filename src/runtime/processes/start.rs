//! How the nodes of a run start: spawned here behind a start gate (over
//! iceoryx2), or here and through the agents of other hosts (over zenoh),
//! then awaited until every one reports READY.

use super::Processes;
use super::fleet::{self, NodeProc};
use super::launch::{NodeLaunch, ProcessOptions, spawn_child};
use crate::protocol::EngineError;
use crate::protocol::NodeConfig;
use crate::protocol::codec::CoordinatorInput;
use crate::protocol::error::Cause;
use crate::transport::{IoxTransport, Transport};
use std::time::{Duration, Instant};

impl Processes {
    /// Over iceoryx2: spawn every node, then create the services.
    pub(super) fn start_iceoryx2(
        &mut self,
        topo: &crate::transport::RunTopology,
        configs: &[NodeConfig],
    ) -> Result<(), EngineError> {
        let p = self;
        let prog = p.nodes.relaunch.program.clone();
        let prog = &prog;
        // The nodes start first, each waiting at a gate (its stdin, one pipe
        // for all) until the services exist: spawned while the coordinator
        // holds few file descriptors and mappings (the close-on-exec of
        // every one of them is paid per spawn: O(N^2) per run otherwise),
        // and starting up while the services are created.
        let (gate, gate_writer) = std::io::pipe().map_err(|e| EngineError::StartGate {
            step: "creating its pipe".into(),
            source: Cause::new(e),
        })?;
        for cfg in configs {
            let launch = NodeLaunch {
                gate: true,
                ..p.launch_of(cfg, false)
            };
            let stdin = gate.try_clone().map_err(|e| EngineError::StartGate {
                step: format!("passing it to node {}", cfg.id),
                source: Cause::new(e),
            })?;
            p.nodes.children.push(Some(NodeProc::Local(spawn_child(
                prog,
                &launch,
                stdin.into(),
                None,
            )?)));
        }
        drop(gate);
        let mut tx = IoxTransport::coordinator(topo).map_err(EngineError::Transport)?;
        for (i, c) in p.nodes.children.iter().enumerate() {
            if let Some(pid) = c.as_ref().and_then(NodeProc::local_pid) {
                tx.authenticate_sender(i as u32, pid);
            }
        }
        tx.publish_senders().map_err(EngineError::Transport)?;
        p.tx = Some(Box::new(tx));
        // Open the gate: every node reads end-of-file and opens its ports.
        drop(gate_writer);
        Ok(())
    }

    /// Over zenoh: open the coordinator's router, wait for the agents of a
    /// placement, then start every node, here or through its agent.
    #[cfg(feature = "zenoh")]
    pub(super) fn start_zenoh(
        &mut self,
        topo: &crate::transport::RunTopology,
        z: &crate::transport::ZenohSettings,
        configs: &[NodeConfig],
        opts: &ProcessOptions,
    ) -> Result<(), EngineError> {
        let agents = opts
            .placement
            .as_ref()
            .map(|pl| pl.agents())
            .unwrap_or_default();
        let creds = crate::transport::credentials::RunCredentials::fresh(
            configs.len(),
            &agents,
            opts.fleet_key.as_ref(),
            &self.run_id,
        )
        .map_err(|e| {
            EngineError::Transport(crate::transport::TransportError::InvalidTopology(e))
        })?;
        let tx = crate::transport::zenoh::ZenohTransport::coordinator(topo, z, &creds)
            .map_err(EngineError::Transport)?;
        self.nodes.credentials = Some(creds);
        if let Some(pl) = &opts.placement {
            let fleet = fleet::RemoteFleet::open(tx.session(), &self.run_id, pl, configs.len())?;
            let agents = pl.agents();
            Processes::log(
                self,
                format_args!(
                    "waiting for the agents of {} on {}",
                    agents.join(", "),
                    z.listen.join(", ")
                ),
            );
            let missing = fleet.wait_for(&agents, opts.agent_wait);
            if !missing.is_empty() {
                return Err(EngineError::AgentsMissing {
                    missing,
                    waited: opts.agent_wait,
                    run_id: self.run_id.clone(),
                    listen: z.listen.join(", "),
                });
            }
            self.nodes.fleet = Some(fleet);
        }
        self.tx = Some(Box::new(tx));
        for cfg in configs {
            let launch = self.launch_of(cfg, false);
            let proc = self.start_node(&launch)?;
            self.nodes.children.push(Some(proc));
        }
        Ok(())
    }

    #[cfg(not(feature = "zenoh"))]
    pub(super) fn start_zenoh(
        &mut self,
        _topo: &crate::transport::RunTopology,
        _z: &crate::transport::ZenohSettings,
        _configs: &[NodeConfig],
        _opts: &ProcessOptions,
    ) -> Result<(), EngineError> {
        Err(EngineError::Transport(
            crate::transport::TransportError::ZenohUnavailable,
        ))
    }

    /// Start node `launch.node.id`: through its host's agent, or here.
    pub(super) fn start_node(&self, launch: &NodeLaunch) -> Result<NodeProc, EngineError> {
        let host = self
            .nodes
            .placement
            .as_ref()
            .and_then(|pl| pl.host_of(launch.node.id));
        let password = self
            .nodes
            .credentials
            .as_ref()
            .and_then(|c| c.node(launch.node.id));
        match (&self.nodes.fleet, host) {
            (Some(fleet), Some(h)) if h != fleet::LOCAL_HOST => fleet.spawn(launch, password),
            _ => Ok(NodeProc::Local(spawn_child(
                &self.nodes.relaunch.program,
                launch,
                std::process::Stdio::null(),
                password,
            )?)),
        }
    }

    /// Wait for READY from every node.
    pub(super) fn wait_ready(
        &mut self,
        start: Instant,
        timeout: Duration,
    ) -> Result<(), EngineError> {
        let p = self;
        let n = p.nodes.children.len();
        // Wait for READY from everyone alive: a node cut off during start-up
        // (a frame in another's name, a flood) is dead, not missing, whether
        // or not its READY came (any other death fails the poll).
        let mut ready = vec![false; n];
        let awaited = |p: &Processes, ready: &[bool], i: usize| !ready[i] && !p.nodes.dead[i];
        while (0..n).any(|i| awaited(p, &ready, i)) {
            if start.elapsed() > timeout {
                return Err(EngineError::Startup {
                    missing: (0..n)
                        .filter(|&i| awaited(p, &ready, i))
                        .map(|i| i as u32)
                        .collect(),
                    waited: timeout,
                });
            }
            for input in p.poll(Duration::from_millis(50), true)? {
                if let CoordinatorInput::Ready { node } = input
                    && let Some(r) = ready.get_mut(node as usize)
                {
                    *r = true;
                }
            }
        }
        p.startup_seconds = start.elapsed().as_secs_f64();
        Processes::log(
            p,
            format_args!("all {n} nodes ready after {:.3} s", p.startup_seconds),
        );
        Ok(())
    }

    /// What node `cfg.id` is told at start (`resume`: a restart from its
    /// checkpoint).
    pub(super) fn launch_of(&self, cfg: &NodeConfig, resume: bool) -> NodeLaunch {
        NodeLaunch {
            node: cfg.clone(),
            checkpoint: self
                .nodes
                .relaunch
                .checkpoints
                .as_ref()
                .filter(|_| cfg.checkpoint_every.is_some())
                .map(|(dir, _)| crate::engine::checkpoint::path(dir, cfg.id)),
            resume,
            ..self.nodes.relaunch.launch0.clone()
        }
    }
}
