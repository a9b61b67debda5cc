//! Faults on node processes: the coordinator carries out the steps of the
//! run's [`FaultWorld`] with real signals and new processes.

use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::coordinator::Event;
use crate::protocol::plan::RunPlan;
use crate::runtime::processes::Processes;
use crate::world::faults::FaultStep;
use crate::world::faults::FaultWorld;
use std::time::Instant;

impl Processes {
    /// Apply `plan`'s faults from now on (the run's emulated time 0).
    pub fn arm_faults(&mut self, plan: &RunPlan) {
        if plan.faults.is_empty() {
            return;
        }
        let period = plan.realtime.map(|rt| rt.sample_period.as_secs_f64());
        let scale = plan.channel.as_ref().map_or(1.0, |c| c.cfg.time_scale);
        let sched = FaultWorld::new(&plan.faults, self.nodes.children.len(), period);
        self.faults = Some((sched, Instant::now(), scale));
    }

    /// The emulated seconds of the fault clock now.
    pub(super) fn fault_now(&self) -> Option<f64> {
        self.faults
            .as_ref()
            .map(|(_, t0, scale)| t0.elapsed().as_secs_f64() * scale)
    }

    /// Carry out every fault event that is due, with real signals; fails
    /// only on a checkpoint file that does not read ([`Self::restart`]).
    pub(super) fn apply_faults(&mut self) -> Result<(), EngineError> {
        let Some(now) = self.fault_now() else {
            return Ok(());
        };
        let Some((sched, _, _)) = self.faults.as_mut() else {
            return Ok(());
        };
        let mut steps = Vec::new();
        let sample = sched.samples_done() as u32;
        while let Some(due) = sched.next_due(crate::world::time::at(now), sample) {
            steps.extend(due);
        }
        for step in steps {
            match step {
                FaultStep::Stop(n) => self.signal(n, libc::SIGSTOP),
                FaultStep::Cont(n) => {
                    self.signal(n, libc::SIGCONT);
                    if let Err(e) = self.release(n) {
                        eprintln!(
                            "warning: node {n} continued, but what was held for it could not be sent: {e}"
                        );
                    }
                }
                FaultStep::Kill(n) => {
                    if let Some(Some(child)) = self.nodes.children.get_mut(n as usize) {
                        child.kill();
                    }
                }
                FaultStep::LinkStart(id, kind) => {
                    if let Some(w) = &mut self.water {
                        w.link_fault_start(id, &kind);
                    }
                }
                FaultStep::LinkEnd(id) => {
                    if let Some(w) = &mut self.water {
                        w.link_fault_end(id);
                    }
                }
                FaultStep::Restart(n, checkpoint) => self.restart(n, checkpoint)?,
                FaultStep::Drift(n, factor) => {
                    let _ = self.control(n, &Control::ClockFactor(factor));
                    let _ = self.flush_all();
                }
            }
        }
        Ok(())
    }

    /// A `restart` fault: SIGKILL and reap node `node` if it is alive (the
    /// coordinator is told it died), remove what the dead process left in
    /// shared memory, and start a new process for it (from its checkpoint
    /// file when `checkpoint`). It rejoins when it reports READY
    /// ([`Processes::ready`]). A node that cannot be started stays dead, and
    /// the run says why. A checkpoint file that is there but does not read
    /// (corrupted, another node's, the wrong dimension) fails the run, naming
    /// the file and where it breaks, before the node is started: the node
    /// would otherwise have to start fresh, which is not the run asked for.
    fn restart(&mut self, node: u32, checkpoint: bool) -> Result<(), EngineError> {
        let i = node as usize;
        if i >= self.nodes.children.len() {
            return Ok(());
        }
        if let Some(mut child) = self.nodes.children[i].take() {
            child.kill();
            child.wait();
        }
        // Its old incarnation is gone: not paused any more.
        if let Some(now) = self.fault_now()
            && let Some((s, _, _)) = self.faults.as_mut()
        {
            s.died(node, now);
        }
        self.held[i].clear();
        if !self.nodes.dead[i] {
            self.nodes.dead[i] = true;
            if let Some(w) = &mut self.water {
                w.set_dead(node);
            }
            self.inbox.events.push(Event::NodeDied {
                node,
                how: "restarted (fault)".into(),
            });
        }
        // The dead incarnation's ports go, so that the new one fits in the
        // services' limits; live processes are left alone.
        if let Err(e) = crate::transport::cleanup_run(&self.run_id) {
            eprintln!("warning: node {node} restart: cleaning up its old ports: {e}");
        }
        let launch = self.launch_of(&self.nodes.relaunch.configs[i], checkpoint);
        if let (true, Some(path)) = (launch.resume, &launch.checkpoint) {
            let dim = self.nodes.relaunch.configs[i].dim();
            crate::engine::checkpoint::Checkpoint::read(path, node, dim)
                .map_err(|reason| EngineError::Checkpoint { node, reason })?;
        }
        match self.start_node(&launch) {
            Ok(child) => {
                if let (Some(pid), Some(tx)) = (child.local_pid(), self.tx.as_mut()) {
                    tx.authenticate_sender(node, pid);
                    if let Err(e) = tx.publish_senders() {
                        eprintln!("warning: node {node} restart: {e}");
                    }
                }
                self.nodes.children[i] = Some(child);
                self.nodes.restarting[i] = true;
                Processes::log(
                    self,
                    format_args!(
                        "node {node} restarted ({})",
                        if checkpoint {
                            "from its checkpoint"
                        } else {
                            "fresh"
                        }
                    ),
                );
            }
            Err(e) => eprintln!("warning: node {node} could not be restarted: {e}"),
        }
        Ok(())
    }

    /// Node `node` reported READY: a restarted node is up again.
    pub(super) fn ready(&mut self, node: u32) {
        let i = node as usize;
        if !self.nodes.restarting.get(i).copied().unwrap_or(false) {
            return;
        }
        self.nodes.restarting[i] = false;
        self.nodes.dead[i] = false;
        if let Some((s, _, _)) = self.faults.as_mut() {
            s.restarted(node);
        }
        if let Some(w) = &mut self.water {
            w.set_alive(node);
        }
        self.inbox.events.push(Event::NodeUp { node });
    }

    /// Node `node` was found dead (its process reaped): a crash that
    /// killed it is detected now.
    pub(super) fn fault_died(&mut self, node: u32) {
        self.fault_noticed(node, FaultWorld::died);
    }

    /// The coordinator gave up on node `node`: a pause or crash that caused
    /// it is detected now.
    pub(super) fn fault_abandoned(&mut self, node: u32) {
        self.fault_noticed(node, FaultWorld::abandoned);
    }

    /// Node `node` is gone: what was held for it is dropped, and the fault
    /// world hears of it now (`tell`: how it went).
    fn fault_noticed(&mut self, node: u32, tell: fn(&mut FaultWorld, u32, f64)) {
        if let Some(h) = self.held.get_mut(node as usize) {
            h.clear();
        }
        if let Some(now) = self.fault_now()
            && let Some((sched, _, _)) = self.faults.as_mut()
        {
            tell(sched, node, now);
        }
    }

    /// The applied faults and the paused masks of the first `samples`
    /// samples.
    pub fn take_faults(&mut self, samples: usize) -> crate::world::faults::FaultLog {
        self.faults
            .take()
            .map(|(s, _, _)| s.into_log(samples))
            .unwrap_or_default()
    }
}
