//! Realtime membership: a node that dies is left out while the rest of the
//! graph is connected; a node that is up again (a restart) rejoins.

use crate::protocol::Command;
use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::coordinator::Action;
use crate::protocol::coordinator::Coordinator;
use crate::protocol::coordinator::send;

impl Coordinator<'_> {
    /// A node is up again during a realtime run: its neighbours may call it
    /// again ([`Command::NodeUp`]), and it gets the current sample's
    /// measurements and its clock.
    pub(super) fn node_up(&mut self, node: u32, out: &mut Vec<Action>) {
        let i = node as usize;
        if !self.dead.get(i).is_some_and(|d| *d) {
            return;
        }
        self.dead[i] = false;
        let k = self.sample() as usize;
        out.push(Action::Log(format!(
            "node {node} is up again at sample {k}"
        )));
        for j in (0..self.plan.n()).filter(|&j| j != i && !self.dead[j]) {
            out.push(send(j, Command::NodeUp { node }));
        }
        if let Some(meas) = self.real.measurements.get(k).and_then(|m| m.nodes.get(i)) {
            out.push(send(
                i,
                Command::Sample {
                    sample: k as u32,
                    meas: meas.clone(),
                    sigmas: self.real.sigmas[k],
                },
            ));
        }
        if let Some(rt) = self.plan.realtime {
            out.push(Action::Send {
                node,
                msg: Control::StartClock(rt.wake_rate_hz),
            });
        }
        out.push(Action::Flush);
    }

    /// A node died during a realtime run: leave it out while the rest of the
    /// graph is connected.
    pub(super) fn node_died(
        &mut self,
        node: u32,
        how: String,
        out: &mut Vec<Action>,
    ) -> Result<(), EngineError> {
        let i = node as usize;
        if self.dead.get(i).is_none_or(|d| *d) {
            return Ok(());
        }
        let sample = self.sample();
        self.dead[i] = true;
        out.push(Action::Log(format!(
            "node {node} died ({how}) at sample {sample}"
        )));
        self.rec.deaths.push((node, sample, how.clone()));
        let dead: Vec<usize> = (0..self.plan.n()).filter(|&j| self.dead[j]).collect();
        let comps = self.plan.graph.components_without(&dead);
        if comps.len() != 1 {
            return Err(EngineError::NodeDied {
                node,
                sample,
                how: format!(
                    "{how}; the remaining network is disconnected ({} parts)",
                    comps.len()
                ),
            });
        }
        for j in (0..self.plan.n()).filter(|&j| !self.dead[j]) {
            out.push(send(j, Command::NodeDown { node }));
        }
        out.push(Action::Flush);
        Ok(())
    }
}
