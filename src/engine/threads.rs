//! Every node a thread of this process over the in-memory transport
//! ([`MemTransport`]): the node program's own loop ([`super::node::run_node`])
//! and the same frames, topology and coordinator as the processes engine,
//! without processes or shared memory. It gives the in-process numbers bit
//! for bit, and it is how a second [`crate::transport::Transport`] runs the
//! real node loop (`--engine threads`: logical clocks on the ideal channel).

use super::layout::{NetworkLayout, network_layout};
use super::node::{NodeError, NodeLoop, run_node};
use crate::engine::Network;
use crate::engine::Progress;
use crate::engine::outcome::RunOutcome;
use crate::model::synth::Feed;
use crate::protocol::EngineError;
use crate::protocol::codec::{self, Control, CoordinatorInput, ReportDecoder};
use crate::protocol::config::Driver;
use crate::protocol::coordinator::Event;
use crate::protocol::plan::RunPlan;
use crate::transport::wire::Frame;
use crate::transport::{Endpoint, MemNetwork, MemTransport, RunTopology, Transport};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// The coordinator's side of a threads run.
pub struct Threads {
    tx: MemTransport,
    decoder: ReportDecoder,
    frames: Vec<Frame>,
    encoded: Vec<Frame>,
    nodes: Vec<Option<JoinHandle<Result<(), NodeError>>>>,
    term: Arc<AtomicBool>,
    /// Per node (the last slot: a sender that is no node): frames that did
    /// not decode, dropped.
    bad: Vec<u64>,
}

impl Threads {
    /// Open the network and start one thread per node.
    fn start(net: NetworkLayout) -> Result<Threads, EngineError> {
        let topology = RunTopology::new("threads", net.neighbours, net.inbox)
            .and_then(|t| {
                if net.broadcast {
                    t.with_broadcast(4)
                } else {
                    Ok(t)
                }
            })
            .map_err(EngineError::Transport)?;
        let mem = MemNetwork::new(&topology);
        let tx = mem
            .endpoint(Endpoint::Coordinator)
            .map_err(EngineError::Transport)?;
        let term = Arc::new(AtomicBool::new(false));
        let dim = net.configs.first().map_or(2, |c| c.dim());
        let mut nodes = Vec::with_capacity(net.configs.len());
        for cfg in net.configs {
            let mut node_tx = mem
                .endpoint(Endpoint::Node(cfg.id))
                .map_err(EngineError::Transport)?;
            let term = Arc::clone(&term);
            nodes.push(Some(std::thread::spawn(move || {
                run_node(&mut node_tx, cfg, &NodeLoop::in_process(&term))
            })));
        }
        Ok(Threads {
            tx,
            decoder: ReportDecoder::new(dim),
            frames: Vec::new(),
            encoded: Vec::new(),
            bad: vec![0; nodes.len() + 1],
            nodes,
            term,
        })
    }

    /// Node threads that have ended (they only end on STOP or an error).
    fn check_nodes(&mut self, out: &mut Vec<Event>) {
        for (i, h) in self.nodes.iter_mut().enumerate() {
            if h.as_ref().is_some_and(JoinHandle::is_finished) {
                let how = match h.take().map(JoinHandle::join) {
                    Some(Ok(Ok(()))) => "it stopped".to_string(),
                    Some(Ok(Err(e))) => e.to_string(),
                    _ => "it panicked".to_string(),
                };
                out.push(Event::NodeDied {
                    node: i as u32,
                    how,
                });
            }
        }
    }

    /// Stop every node and join its thread (idempotent; also done on drop).
    fn shutdown(&mut self) {
        if self.nodes.iter().all(Option::is_none) {
            return;
        }
        self.encoded.clear();
        codec::encode_control(&Control::Stop, &mut self.encoded);
        for i in 0..self.nodes.len() {
            for f in &self.encoded {
                let _ = self.tx.send(Endpoint::Node(i as u32), f);
            }
        }
        let _ = self.tx.flush();
        self.term.store(true, Ordering::SeqCst);
        for h in self.nodes.iter_mut().filter_map(Option::take) {
            let _ = h.join();
        }
    }
}

impl Drop for Threads {
    fn drop(&mut self) {
        self.shutdown();
    }
}

impl Network for Threads {
    fn send(&mut self, node: u32, msg: &Control) -> Result<(), EngineError> {
        self.encoded.clear();
        codec::encode_control(msg, &mut self.encoded);
        for f in &self.encoded {
            self.tx
                .send(Endpoint::Node(node), f)
                .map_err(EngineError::Transport)?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        self.tx.flush().map_err(EngineError::Transport)
    }

    fn recv(&mut self, timeout: Option<Duration>, out: &mut Vec<Event>) -> Result<(), EngineError> {
        let deadline = timeout.map(|t| std::time::Instant::now() + t);
        loop {
            self.frames.clear();
            self.tx
                .recv(&mut self.frames, Some(Duration::from_millis(50)))
                .map_err(EngineError::Transport)?;
            for f in &self.frames {
                match self.decoder.feed(f) {
                    Ok(Some(CoordinatorInput::Report(r))) => out.push(Event::Report(r)),
                    Ok(Some(CoordinatorInput::Pong { node, seq })) => {
                        out.push(Event::Pong { node, seq })
                    }
                    Ok(_) => {}
                    Err(e) => {
                        // Counted and dropped, as the coordinator of node
                        // processes does; the first from each sender is named.
                        let slot = (f.from as usize).min(self.bad.len() - 1);
                        if self.bad[slot] == 0 {
                            eprintln!(
                                "warning: node {} sent a frame that does not decode ({e}): dropped",
                                f.from
                            );
                        }
                        self.bad[slot] += 1;
                    }
                }
            }
            if out.is_empty() {
                self.check_nodes(out);
            }
            if super::interrupt::requested() {
                out.push(Event::Interrupted);
            }
            if !out.is_empty() || deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                return Ok(());
            }
        }
    }
}

/// Run `plan` with logical clocks, every node a thread over [`MemTransport`].
pub fn run_threads(plan: &RunPlan, real: Feed<'_>, progress: Progress<'_>) -> RunOutcome {
    let mut net = match Threads::start(network_layout(plan)) {
        Ok(t) => t,
        Err(e) => return RunOutcome::failed(Driver::Threads, plan.n(), e),
    };
    let (rec, res) = super::drive(plan, real, &mut net, progress);
    net.shutdown();
    RunOutcome::new(Driver::Threads, rec, res)
}
