//! The in-process engine: every node's [`NodeCore`] in one thread, messages
//! routed through a FIFO queue. Exact and deterministic; the multi-process
//! engine is held to bit-for-bit agreement with it.

use crate::engine::Network;
use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::coordinator::Event;
use crate::protocol::{Input, NodeConfig, NodeCore, Output};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How many node inputs are handled between two looks at the interrupt flag.
const INTERRUPT_CHECK_EVERY: usize = 256;

/// All nodes in one thread.
pub struct InProcess {
    nodes: Vec<NodeCore>,
    queue: VecDeque<(u32, Input)>,
    outputs: Vec<Output>,
    /// Liveness checks to answer: every node here is alive by construction.
    pongs: Vec<(u32, u64)>,
    /// Set by SIGINT/SIGTERM ([`super::interrupt`]); `None`: never.
    interrupt: Option<Arc<AtomicBool>>,
}

impl InProcess {
    /// Build the nodes from their configurations (`configs[i].id == i`).
    pub fn new(configs: Vec<NodeConfig>) -> Self {
        InProcess {
            nodes: configs.into_iter().map(NodeCore::new).collect(),
            queue: VecDeque::new(),
            outputs: Vec::new(),
            pongs: Vec::new(),
            interrupt: None,
        }
    }

    /// Stop at the next batch of node work once `flag` is set (it becomes
    /// [`Event::Interrupted`]); [`super::run_inprocess`] passes the process's
    /// SIGINT/SIGTERM flag.
    pub fn with_interrupt(mut self, flag: Arc<AtomicBool>) -> Self {
        self.interrupt = Some(flag);
        self
    }

    fn interrupted(&self) -> bool {
        self.interrupt
            .as_ref()
            .is_some_and(|f| f.load(Ordering::SeqCst))
    }

    /// The node cores (for inspection).
    pub fn nodes(&self) -> &[NodeCore] {
        &self.nodes
    }
}

impl Network for InProcess {
    fn send(&mut self, node: u32, msg: &Control) -> Result<(), EngineError> {
        match msg {
            Control::Command(cmd) => self.queue.push_back((node, Input::Command(cmd.clone()))),
            Control::StartClock(_) | Control::ClockFactor(_) => {
                return Err(EngineError::Unsupported(
                    "the in-process engine runs logical clocks only".into(),
                ));
            }
            Control::ProbePeer { .. } => {
                return Err(EngineError::Unsupported(
                    "hops are measured between node processes only".into(),
                ));
            }
            Control::Stop => {}
            Control::Ping(seq) => self.pongs.push((node, *seq)),
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        Ok(())
    }

    fn recv(
        &mut self,
        _timeout: Option<Duration>,
        out: &mut Vec<Event>,
    ) -> Result<(), EngineError> {
        let n = self.nodes.len() as u32;
        let before = out.len();
        if self.interrupted() {
            out.push(Event::Interrupted);
            return Ok(());
        }
        let mut handled = 0usize;
        out.extend(
            self.pongs
                .drain(..)
                .map(|(node, seq)| Event::Pong { node, seq }),
        );
        while let Some((to, input)) = self.queue.pop_front() {
            handled += 1;
            if handled.is_multiple_of(INTERRUPT_CHECK_EVERY) && self.interrupted() {
                out.push(Event::Interrupted);
                return Ok(());
            }
            let Some(node) = self.nodes.get_mut(to as usize) else {
                return Err(EngineError::Stalled(format!(
                    "message to unknown node {to}"
                )));
            };
            node.handle(input, &mut self.outputs);
            for o in self.outputs.drain(..) {
                match o {
                    Output::Peer { to, msg } => self.queue.push_back((to, Input::Peer(msg))),
                    Output::Broadcast(msg) => {
                        for i in 0..n {
                            self.queue.push_back((i, Input::Peer(msg)));
                        }
                    }
                    Output::Report(r) => out.push(Event::Report(r)),
                    // Exchange timers belong to realtime clocks, which this
                    // engine does not run (the discrete-event engine does).
                    // Timers and checkpoints belong to lossy channels and
                    // faults, which run on the discrete-event engine.
                    Output::Timer { .. } | Output::Checkpoint { .. } => {}
                }
            }
        }
        if out.len() == before {
            return Err(EngineError::Stalled(
                "no node has anything to do and no report arrived".into(),
            ));
        }
        Ok(())
    }
}
