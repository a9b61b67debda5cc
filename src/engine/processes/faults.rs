//! Faults on node processes ([`super::super::process_faults`]): the
//! coordinator side carries out the schedule with real signals.

use super::*;

impl Processes {
    /// Apply `plan`'s faults from now on (the run's emulated time 0).
    pub fn arm_faults(&mut self, plan: &RunPlan) {
        if plan.faults.is_empty() {
            return;
        }
        let period = plan
            .realtime
            .map_or(0.0, |rt| rt.sample_period.as_secs_f64());
        let scale = plan.channel.as_ref().map_or(1.0, |c| c.cfg.time_scale);
        let sched = FaultSchedule::new(&plan.faults, self.children.len(), period);
        self.faults = Some((sched, Instant::now(), scale));
    }

    /// The emulated seconds of the fault clock now.
    pub(super) fn fault_now(&self) -> Option<f64> {
        self.faults
            .as_ref()
            .map(|(_, t0, scale)| t0.elapsed().as_secs_f64() * scale)
    }

    /// Carry out every fault event that is due, with real signals.
    pub(super) fn apply_faults(&mut self) {
        let Some(now) = self.fault_now() else { return };
        let Some((sched, _, _)) = self.faults.as_mut() else {
            return;
        };
        for step in sched.due(now) {
            let signal = |c: &Option<Child>, sig: i32| {
                if let Some(child) = c {
                    // SAFETY: kill(2) on the pid of a child we own and have
                    // not reaped (it is `Some` until reaped).
                    unsafe {
                        libc::kill(child.id() as i32, sig);
                    }
                }
            };
            match step {
                FaultStep::Stop(n) => {
                    if let Some(c) = self.children.get(n as usize) {
                        signal(c, libc::SIGSTOP);
                    }
                }
                FaultStep::Cont(n) => {
                    if let Some(c) = self.children.get(n as usize) {
                        signal(c, libc::SIGCONT);
                    }
                }
                FaultStep::Kill(n) => {
                    if let Some(Some(child)) = self.children.get_mut(n as usize) {
                        let _ = child.kill();
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
                FaultStep::Drift(n, factor) => {
                    let _ = self.control(n, &Control::ClockFactor(factor));
                    let _ = self.flush_all();
                }
            }
        }
    }

    /// Node `node` was noticed dead or abandoned: a fault that did it is
    /// detected now.
    pub(super) fn fault_noticed(&mut self, node: u32) {
        if let Some(now) = self.fault_now()
            && let Some((sched, _, _)) = self.faults.as_mut()
        {
            sched.noticed(node, now);
        }
    }

    /// The applied faults.
    pub fn take_faults(&mut self) -> Vec<crate::engine::FaultRecord> {
        self.faults
            .take()
            .map(|(s, _, _)| s.records)
            .unwrap_or_default()
    }

    /// A sample completed: the nodes paused during it (empty without faults).
    pub fn sample_paused(&mut self) -> Vec<bool> {
        self.faults
            .as_mut()
            .map(|(s, _, _)| s.sample_mask())
            .unwrap_or_default()
    }
}
