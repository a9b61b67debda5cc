//! In-process implementation of [`Transport`] for unit tests and single-process use.
//!
//! Same topology rules, ordering and wake-up semantics as the iceoryx2 transport,
//! except that queues are unbounded (a send never waits), so no frame can be lost
//! and no send can time out. Sending to an endpoint whose [`MemTransport`] has been
//! dropped fails with [`TransportError::Closed`].

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::transport::Endpoint;
use crate::transport::RunTopology;
use crate::transport::Transport;
use crate::transport::TransportError;
use crate::transport::wire::Frame;

#[derive(Debug, Default)]
struct MailboxState {
    frames: VecDeque<Frame>,
    taken: bool,
    closed: bool,
}

#[derive(Debug, Default)]
struct Mailbox {
    state: Mutex<MailboxState>,
    wake: Condvar,
}

impl Mailbox {
    fn lock(&self) -> MutexGuard<'_, MailboxState> {
        // A panic while holding the lock cannot leave the queue inconsistent
        // (all updates are single push/drain calls), so poisoning is ignored.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[derive(Debug)]
struct Shared {
    topology: RunTopology,
    /// Index `i < N` is node `i`, index `N` is the coordinator.
    boxes: Vec<Mailbox>,
}

impl Shared {
    fn index(&self, e: Endpoint) -> usize {
        match e {
            Endpoint::Node(i) => i as usize,
            Endpoint::Coordinator => self.topology.n_nodes(),
        }
    }
}

/// The in-memory "network" of one run; hands out one [`MemTransport`] per endpoint.
#[derive(Debug, Clone)]
pub struct MemNetwork {
    shared: Arc<Shared>,
}

impl MemNetwork {
    /// A network for `topology` (the broadcast group exists iff the topology enables it).
    pub fn new(topology: &RunTopology) -> Self {
        let boxes = (0..=topology.n_nodes())
            .map(|_| Mailbox::default())
            .collect();
        MemNetwork {
            shared: Arc::new(Shared {
                topology: topology.clone(),
                boxes,
            }),
        }
    }

    /// The transport of endpoint `e`. Each endpoint can be taken once.
    pub fn endpoint(&self, e: Endpoint) -> Result<MemTransport, TransportError> {
        self.shared.topology.check_endpoint(e)?;
        let idx = self.shared.index(e);
        let mut st = self.shared.boxes[idx].lock();
        if st.taken {
            return Err(TransportError::InvalidTopology(format!(
                "{e} was already opened on this in-memory network"
            )));
        }
        st.taken = true;
        drop(st);
        Ok(MemTransport {
            me: e,
            own: idx,
            shared: Arc::clone(&self.shared),
            pending: Vec::new(),
            pending_flag: vec![false; self.shared.boxes.len()],
            pending_broadcast: false,
        })
    }
}

/// One endpoint of a [`MemNetwork`].
#[derive(Debug)]
pub struct MemTransport {
    me: Endpoint,
    own: usize,
    shared: Arc<Shared>,
    pending: Vec<usize>,
    pending_flag: Vec<bool>,
    pending_broadcast: bool,
}

impl MemTransport {
    fn push(&self, idx: usize, to: Endpoint, frame: &Frame) -> Result<(), TransportError> {
        let mut st = self.shared.boxes[idx].lock();
        if st.closed {
            return Err(TransportError::Closed(to));
        }
        st.frames.push_back(*frame);
        Ok(())
    }
}

impl Transport for MemTransport {
    fn endpoint(&self) -> Endpoint {
        self.me
    }

    fn send(&mut self, to: Endpoint, frame: &Frame) -> Result<(), TransportError> {
        self.shared.topology.check_endpoint(to)?;
        if !self.shared.topology.is_edge(self.me, to) {
            return Err(TransportError::NotAPeer { from: self.me, to });
        }
        let idx = self.shared.index(to);
        self.push(idx, to, frame)?;
        if !self.pending_flag[idx] {
            self.pending_flag[idx] = true;
            self.pending.push(idx);
        }
        Ok(())
    }

    fn broadcast(&mut self, frame: &Frame) -> Result<(), TransportError> {
        if !self.shared.topology.broadcast() || self.me == Endpoint::Coordinator {
            return Err(TransportError::BroadcastUnavailable(self.me));
        }
        let n = self.shared.topology.n_nodes();
        for j in 0..n {
            self.push(j, Endpoint::Node(j as u32), frame)?;
        }
        self.pending_broadcast = true;
        Ok(())
    }

    fn flush(&mut self) -> Result<(), TransportError> {
        for idx in self.pending.drain(..) {
            self.pending_flag[idx] = false;
            self.shared.boxes[idx].wake.notify_all();
        }
        if self.pending_broadcast {
            self.pending_broadcast = false;
            for b in &self.shared.boxes[..self.shared.topology.n_nodes()] {
                b.wake.notify_all();
            }
        }
        Ok(())
    }

    fn shutdown(&mut self, _timeout: Duration) -> Result<(), TransportError> {
        self.shutdown_impl()
    }

    fn recv(
        &mut self,
        out: &mut Vec<Frame>,
        timeout: Option<Duration>,
    ) -> Result<usize, TransportError> {
        let deadline = timeout.map(|t| Instant::now() + t);
        let mailbox = &self.shared.boxes[self.own];
        let mut st = mailbox.lock();
        loop {
            if !st.frames.is_empty() {
                let n = st.frames.len();
                out.extend(st.frames.drain(..));
                return Ok(n);
            }
            st = match deadline {
                None => mailbox.wake.wait(st).unwrap_or_else(|e| e.into_inner()),
                Some(d) => {
                    let now = Instant::now();
                    if now >= d {
                        return Ok(0);
                    }
                    mailbox
                        .wake
                        .wait_timeout(st, d - now)
                        .unwrap_or_else(|e| e.into_inner())
                        .0
                }
            };
        }
    }
}

impl MemTransport {
    /// Frames live in the shared hub, so they survive the sender: nothing to wait for.
    fn shutdown_impl(&mut self) -> Result<(), TransportError> {
        self.flush()
    }
}

impl Drop for MemTransport {
    fn drop(&mut self) {
        self.shared.boxes[self.own].lock().closed = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(from: u32, seq: u64) -> Frame {
        Frame {
            kind: 1,
            from,
            seq,
            ..Frame::default()
        }
    }

    #[test]
    fn frames_arrive_in_order_per_sender_and_only_along_edges() {
        let topo = RunTopology::ring("mem", 3, 1).unwrap();
        let net = MemNetwork::new(&topo);
        let mut c = net.endpoint(Endpoint::Coordinator).unwrap();
        let mut n0 = net.endpoint(Endpoint::Node(0)).unwrap();
        let mut n1 = net.endpoint(Endpoint::Node(1)).unwrap();
        assert!(net.endpoint(Endpoint::Node(0)).is_err(), "taken twice");
        assert_eq!(
            net.endpoint(Endpoint::Node(3)).err(),
            Some(TransportError::UnknownEndpoint(Endpoint::Node(3)))
        );
        for s in 0..10 {
            n0.send(Endpoint::Node(1), &frame(0, s)).unwrap();
            c.send(Endpoint::Node(1), &frame(u32::MAX, s)).unwrap();
        }
        n0.flush().unwrap();
        c.flush().unwrap();
        let mut out = Vec::new();
        assert_eq!(n1.recv(&mut out, Some(Duration::ZERO)).unwrap(), 20);
        for sender in [0, u32::MAX] {
            let seqs: Vec<u64> = out
                .iter()
                .filter(|f| f.from == sender)
                .map(|f| f.seq)
                .collect();
            assert_eq!(seqs, (0..10).collect::<Vec<_>>());
        }
        assert!(matches!(
            c.send(Endpoint::Coordinator, &frame(0, 0)),
            Err(TransportError::NotAPeer { .. })
        ));
        assert!(matches!(
            c.broadcast(&frame(0, 0)),
            Err(TransportError::BroadcastUnavailable(_))
        ));
    }

    #[test]
    fn recv_blocks_until_a_flush_from_another_thread() {
        let topo = RunTopology::ring("mem", 2, 1).unwrap();
        let net = MemNetwork::new(&topo);
        let mut n0 = net.endpoint(Endpoint::Node(0)).unwrap();
        let mut n1 = net.endpoint(Endpoint::Node(1)).unwrap();
        let h = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            n1.send(Endpoint::Node(0), &frame(1, 7)).unwrap();
            n1.flush().unwrap();
            n1
        });
        let mut out = Vec::new();
        let got = n0.recv(&mut out, Some(Duration::from_secs(10))).unwrap();
        assert_eq!(got, 1);
        assert_eq!(out[0].seq, 7);
        let _n1 = h.join().unwrap();
        assert_eq!(n0.recv(&mut out, Some(Duration::ZERO)).unwrap(), 0);
    }

    #[test]
    fn broadcast_reaches_every_node_including_the_sender() {
        let topo = RunTopology::ring("mem", 3, 1)
            .unwrap()
            .with_broadcast(1)
            .unwrap();
        let net = MemNetwork::new(&topo);
        let mut nodes: Vec<MemTransport> = (0..3)
            .map(|i| net.endpoint(Endpoint::Node(i)).unwrap())
            .collect();
        for (i, n) in nodes.iter_mut().enumerate() {
            n.broadcast(&frame(i as u32, 0)).unwrap();
            n.flush().unwrap();
        }
        for n in &mut nodes {
            let mut out = Vec::new();
            n.recv(&mut out, Some(Duration::ZERO)).unwrap();
            let mut from: Vec<u32> = out.iter().map(|f| f.from).collect();
            from.sort_unstable();
            assert_eq!(from, vec![0, 1, 2]);
        }
    }

    #[test]
    fn sending_to_a_dropped_endpoint_is_an_error_not_a_silent_loss() {
        let topo = RunTopology::ring("mem", 2, 1).unwrap();
        let net = MemNetwork::new(&topo);
        let mut c = net.endpoint(Endpoint::Coordinator).unwrap();
        drop(net.endpoint(Endpoint::Node(1)).unwrap());
        assert_eq!(
            c.send(Endpoint::Node(1), &frame(0, 0)),
            Err(TransportError::Closed(Endpoint::Node(1)))
        );
    }
}
