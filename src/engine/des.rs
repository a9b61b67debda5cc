//! The discrete-event engine: the protocol in virtual time.
//! It runs `--engine inprocess --clock realtime`, and every clock on the
//! acoustic channel.
//!
//! Every node's [`NodeCore`] and the [`Coordinator`] run in one thread over an
//! event queue ordered by (virtual time, order of scheduling): node clock ticks
//! (each node draws its Poisson waits from its own seeded stream, as a node
//! process does), message deliveries, the nodes' timers and the coordinator's
//! (sample boundaries, snapshot deadlines, liveness checks). Nothing reads a
//! wall clock, so a run is exact and deterministic from the seed, and as fast
//! as the node cores.
//!
//! Every frame between two nodes goes through the run's [`Channel`] (the
//! world's one channel model): the engine puts each copy on its queue at the
//! time the channel says its fate is due, and hands it back then. On the
//! ideal channel that is the virtual time it is sent (after every event
//! already scheduled for that time) unless a link fault delays it; on the
//! acoustic channel (`[channel] model = "acoustic"`) it is when its arrival
//! ends, and the channel judges it then (delay, half-duplex, collisions,
//! loss; a frame to a node the coordinator left out is lost as `node_down`)
//! and records it; a delivered frame the node discards because the wait it
//! answers is over is recorded `late`. How each
//! protocol waits on a lossy channel is [`crate::protocol::Command::ExchangeTimeout`]
//! (realtime) and [`crate::protocol::Command::RoundTimeout`] (logical clocks).
//! The coordinator's commands and the nodes' reports are the emulator's own
//! wiring, not acoustic: they arrive at once.
//!
//! Faults ([`crate::model::fault`]) are events too, applied
//! exactly at their virtual time: a paused node does nothing (what reaches it
//! waits, its clock fires once on resume, as a SIGSTOPped process's would); a
//! crashed node is dead and the coordinator is told at once; a restarted node
//! is a new [`NodeCore`] (fresh, or from its last [`Output::Checkpoint`]) that
//! the coordinator re-admits ([`Event::NodeUp`]); partitions, link loss and
//! delay act on every frame between two nodes, on either channel; a drifting
//! clock scales the node's Poisson waits and timers.

use crate::engine::Progress;
use crate::engine::actions::{Actuator, carry_out};
use crate::engine::outcome::RunOutcome;
use crate::model::coords::Coords;
use crate::model::synth::Feed;
use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::config::Driver;
use crate::protocol::coordinator::Action;
use crate::protocol::coordinator::Coordinator;
use crate::protocol::coordinator::Event;
use crate::protocol::coordinator::Timer;
use crate::protocol::plan::RunPlan;
use crate::protocol::{Command, Input, NodeCore, Output};
use crate::world::faults::{FaultStep, FaultWorld};
use crate::world::medium::{Channel, ChannelLog, InFlight};
use crate::world::time::wait;
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How many events are handled between two looks at the interrupt flag.
const INTERRUPT_CHECK_EVERY: u64 = 4096;

/// Something that happens at a virtual time.
#[derive(Debug)]
enum Ev {
    /// Node `0`'s Poisson clock fires (incarnation `1`: a restarted node's
    /// old clock is stale).
    Tick(u32, u32),
    /// An input reaches a node.
    ToNode(u32, Input),
    /// A node's own timer (incarnation `1`).
    Timer(u32, u32, Command),
    /// An event reaches the coordinator.
    ToCoordinator(Event),
    /// A frame between two nodes is due ([`Channel::arrive`]).
    Arrive(InFlight),
    /// The next event of the fault schedule is due.
    Fault,
}

/// The event queue: `(time, class, sequence) -> event`, so events at one
/// time keep the order in which they were scheduled, except that a fault
/// comes after everything else at its time (a fault at the start of sample
/// `k` comes after the snapshot that ends sample `k - 1` and the
/// measurements of sample `k`, however those were scheduled).
#[derive(Default)]
struct Queue {
    events: BTreeMap<(Duration, u8, u64), Ev>,
    next: u64,
}

impl Queue {
    fn push(&mut self, at: Duration, ev: Ev) {
        let class = u8::from(matches!(ev, Ev::Fault));
        self.events.insert((at, class, self.next), ev);
        self.next += 1;
    }

    fn pop(&mut self) -> Option<(Duration, Ev)> {
        self.events.pop_first().map(|((t, _, _), ev)| (t, ev))
    }
}

/// One node of the run as the engine sees it.
struct Slot {
    core: NodeCore,
    /// Poisson rate once its clock is started.
    rate: Option<f64>,
    dead: bool,
    /// Incarnation (bumped by a restart).
    epoch: u32,
    /// While the node is paused: the inputs held until it resumes, and
    /// whether its clock fired.
    held: Vec<Input>,
    tick_due: bool,
    /// Waits and timers are multiplied by this (clock drift).
    clock_factor: f64,
    /// Its last checkpoint `(u, theta)`.
    checkpoint: Option<(Coords, Coords)>,
}

/// The whole run in virtual time.
struct Des<'a> {
    plan: &'a RunPlan,
    nodes: Vec<Slot>,
    coord: Coordinator<'a>,
    queue: Queue,
    actions: Vec<Action>,
    outputs: Vec<Output>,
    now: Duration,
    channel: Channel,
    /// Frames just sent, before they go on the queue.
    sends: Vec<(Duration, InFlight)>,
    faults: FaultWorld,
}

/// Run `plan` in virtual time (a realtime clock, or any clock on the
/// acoustic channel). Returns the record of every completed sample and, if
/// the run stopped early, why. SIGINT/SIGTERM ([`super::interrupt`]) end it as
/// [`EngineError::Interrupted`].
pub fn run_des(plan: &RunPlan, real: Feed<'_>, progress: Progress<'_>) -> RunOutcome {
    let start = std::time::Instant::now();
    let interrupt = super::interrupt::flag();
    let mut des = Des {
        plan,
        nodes: plan
            .nodes
            .iter()
            .cloned()
            .map(|c| Slot {
                core: NodeCore::new(c),
                rate: None,
                dead: false,
                epoch: 0,
                held: Vec::new(),
                tick_due: false,
                clock_factor: 1.0,
                checkpoint: None,
            })
            .collect(),
        coord: Coordinator::new(plan, real),
        queue: Queue::default(),
        actions: Vec::new(),
        outputs: Vec::new(),
        now: Duration::ZERO,
        channel: match &plan.channel {
            Some(c) => Channel::planned(c, plan.seed),
            None => Channel::ideal(plan.n(), plan.seed),
        },
        sends: Vec::new(),
        faults: FaultWorld::new(
            &plan.faults,
            plan.n(),
            plan.realtime.map(|rt| rt.sample_period.as_secs_f64()),
        )
        .with_crashes_seen_at_once(),
    };
    if let Some(t) = des.faults.next_at() {
        des.queue.push(t, Ev::Fault);
    }
    let mut handled = 0u64;
    des.coord.handle(des.now, [Event::Start], &mut des.actions);
    let result = loop {
        // The actions go out of `des` while it carries them out (it adds none).
        let mut batch = std::mem::take(&mut des.actions);
        let over = carry_out(&mut batch, &mut des, progress);
        des.actions = batch;
        if let Some(r) = over {
            break r;
        }
        if des.coord.is_done() {
            break Ok(());
        }
        handled += 1;
        if handled.is_multiple_of(INTERRUPT_CHECK_EVERY) {
            des.channel.forget(des.now.as_secs_f64(), 1e-6);
            if interrupt.load(Ordering::SeqCst) {
                des.coord
                    .handle(des.now, [Event::Interrupted], &mut des.actions);
                continue;
            }
        }
        let Some((t, ev)) = des.queue.pop() else {
            break Err(EngineError::Stalled(
                "the discrete-event queue ran empty before the run ended".into(),
            ));
        };
        des.now = t;
        des.event(ev);
    };
    let emulated = des.now.as_secs_f64();
    let Des {
        coord,
        channel,
        faults,
        ..
    } = des;
    let mut rec = coord.into_record(result.is_err());
    rec.wall_seconds = start.elapsed().as_secs_f64();
    let samples = rec.thetas.len();
    let mut out = RunOutcome::new(Driver::DiscreteEvent, rec, result);
    if channel.is_acoustic() {
        out.channel = Some(ChannelLog {
            messages: channel.into_records(),
            emulated_seconds: emulated,
            events: Some(handled),
            delivery_errors_ms: Vec::new(),
        });
    }
    if !faults.is_empty() {
        out.faults = Some(faults.into_log(samples));
    }
    out
}

/// The coordinator's actions in virtual time: its messages and the nodes'
/// answers to pings arrive at once, its timers are events.
impl Actuator for Des<'_> {
    fn send(&mut self, node: u32, msg: Control) -> Result<(), EngineError> {
        let now = self.now;
        match msg {
            Control::Command(c) => self.queue.push(now, Ev::ToNode(node, Input::Command(c))),
            Control::StartClock(rate) => {
                if let Some(slot) = self.nodes.get_mut(node as usize) {
                    slot.rate = Some(rate);
                    let w = slot.core.draw_wait(rate) * slot.clock_factor;
                    self.queue.push(now + wait(w), Ev::Tick(node, slot.epoch));
                }
            }
            // Hop probes measure node processes only
            // (`processes::measure_hop`); the coordinator never sends one.
            Control::ClockFactor(_) | Control::ProbePeer { .. } => {}
            Control::Ping(seq) => self
                .queue
                .push(now, Ev::ToCoordinator(Event::Pong { node, seq })),
            Control::Stop => {}
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        Ok(())
    }

    fn set_timer(&mut self, at: Duration, timer: Timer) {
        self.queue.push(at, Ev::ToCoordinator(Event::Timer(timer)));
    }

    fn sample_done(&mut self, samples: usize) {
        self.faults.sample_done(samples);
        self.channel.at_sample(samples);
    }

    fn log(&mut self, _line: &str) {}

    /// The coordinator gave up on `node`: it is dead; a pause that caused it
    /// is detected now.
    fn abandon(&mut self, node: u32) {
        let Some(slot) = self.nodes.get_mut(node as usize) else {
            return;
        };
        slot.dead = true;
        self.faults.abandoned(node, self.now.as_secs_f64());
    }
}

impl Des<'_> {
    fn event(&mut self, ev: Ev) {
        let now = self.now;
        let (node, input) = match ev {
            Ev::ToCoordinator(e) => {
                self.coord.handle(now, [e], &mut self.actions);
                return;
            }
            Ev::Fault => return self.fault(),
            Ev::Tick(node, epoch) => {
                let Some(slot) = self.nodes.get_mut(node as usize) else {
                    return;
                };
                if slot.dead || slot.epoch != epoch {
                    return;
                }
                if self.faults.is_paused(node) {
                    // A stopped process's clock fires once when it resumes.
                    slot.tick_due = true;
                    return;
                }
                if let Some(rate) = slot.rate {
                    let w = slot.core.draw_wait(rate) * slot.clock_factor;
                    self.queue.push(now + wait(w), Ev::Tick(node, epoch));
                }
                (node, Input::Command(Command::Tick))
            }
            Ev::Timer(node, epoch, c) => {
                if self
                    .nodes
                    .get(node as usize)
                    .is_none_or(|s| s.epoch != epoch)
                {
                    return;
                }
                (node, Input::Command(c))
            }
            Ev::ToNode(node, input) => (node, input),
            Ev::Arrive(f) => {
                let dead = self.nodes.get(f.to() as usize).is_none_or(|s| s.dead);
                let delivered = self.channel.due(f, dead, self.now, &mut self.sends);
                for (t, f) in self.sends.drain(..) {
                    self.queue.push(t, Ev::Arrive(f));
                }
                let Some((to, msg)) = delivered else {
                    return;
                };
                (to, Input::Peer(msg))
            }
        };
        self.deliver(node, input);
    }

    /// Hand `input` to `node` (held while it is paused), then route what it
    /// says.
    fn deliver(&mut self, node: u32, input: Input) {
        let Some(slot) = self.nodes.get_mut(node as usize) else {
            return;
        };
        if slot.dead {
            return;
        }
        if self.faults.is_paused(node) {
            slot.held.push(input);
            return;
        }
        let late = slot.core.counters().late;
        let peer = match &input {
            Input::Peer(m) => Some((m.from(), m.kind())),
            Input::Command(_) => None,
        };
        slot.core.handle(input, &mut self.outputs);
        if let Some((from, kind)) = peer
            && slot.core.counters().late > late
        {
            // Delivered after its wait was over: discarded by the node.
            self.channel.mark_late(node, from, kind);
        }
        self.route(node);
    }

    /// Route the outputs of `node`.
    fn route(&mut self, node: u32) {
        let now = self.now;
        let mut reports = Vec::new();
        let (factor, epoch) = {
            let s = &self.nodes[node as usize];
            (s.clock_factor, s.epoch)
        };
        for o in std::mem::take(&mut self.outputs) {
            match o {
                Output::Peer { to, msg } => self.channel.send(now, node, to, msg, &mut self.sends),
                Output::Broadcast(msg) => {
                    // The sender hears its own broadcast at once (a
                    // transport's loopback; it is not on the channel).
                    self.queue.push(now, Ev::ToNode(node, Input::Peer(msg)));
                    self.channel.broadcast(now, node, msg, &mut self.sends);
                }
                Output::Report(r) => reports.push(Event::Report(r)),
                Output::Timer { after_s, then } => self
                    .queue
                    .push(now + wait(after_s * factor), Ev::Timer(node, epoch, then)),
                Output::Checkpoint { u, theta, .. } => {
                    self.nodes[node as usize].checkpoint = Some((u, theta));
                }
            }
            for (t, f) in self.sends.drain(..) {
                self.queue.push(t, Ev::Arrive(f));
            }
        }
        if !reports.is_empty() {
            self.coord.handle(now, reports, &mut self.actions);
        }
    }

    /// The next fault event is due: carry out its steps, then wait for the
    /// one after it.
    fn fault(&mut self) {
        let sample = self.coord.sample();
        let steps = self.faults.next_due(self.now, sample).unwrap_or_default();
        for step in steps {
            self.fault_step(step);
        }
        if let Some(t) = self.faults.next_at() {
            self.queue.push(t.max(self.now), Ev::Fault);
        }
    }

    /// Node `node` dies; the coordinator is told at once.
    fn kill(&mut self, node: u32, how: &str) {
        let slot = &mut self.nodes[node as usize];
        if slot.dead {
            return;
        }
        slot.dead = true;
        slot.held.clear();
        self.channel.sender_died(node);
        self.faults.died(node, self.now.as_secs_f64());
        self.coord.handle(
            self.now,
            [Event::NodeDied {
                node,
                how: how.into(),
            }],
            &mut self.actions,
        );
    }

    fn fault_step(&mut self, step: FaultStep) {
        match step {
            // The world paused it: inputs wait in `held`.
            FaultStep::Stop(_) => {}
            FaultStep::Cont(node) => self.resume(node),
            FaultStep::Kill(node) => self.kill(node, "crashed (fault)"),
            FaultStep::Restart(node, checkpoint) => {
                self.kill(node, "restarted (fault)");
                let slot = &mut self.nodes[node as usize];
                let cfg = self.plan.nodes[node as usize].clone();
                slot.core = match (checkpoint, slot.checkpoint) {
                    (true, Some((u, theta))) => NodeCore::restore(cfg, u, theta),
                    _ => NodeCore::new(cfg),
                };
                slot.dead = false;
                slot.rate = None;
                slot.tick_due = false;
                slot.epoch += 1;
                self.faults.restarted(node);
                self.coord
                    .handle(self.now, [Event::NodeUp { node }], &mut self.actions);
            }
            FaultStep::LinkStart(id, kind) => self.channel.link_fault_start(id, &kind),
            FaultStep::LinkEnd(id) => self.channel.link_fault_end(id),
            FaultStep::Drift(node, factor) => self.nodes[node as usize].clock_factor = factor,
        }
    }

    /// A paused node goes on: what reached it is delivered, and its clock
    /// fires once if it fired while it was paused.
    fn resume(&mut self, node: u32) {
        let slot = &mut self.nodes[node as usize];
        let held = std::mem::take(&mut slot.held);
        let tick = std::mem::take(&mut slot.tick_due);
        for input in held {
            self.deliver(node, input);
        }
        let slot = &mut self.nodes[node as usize];
        if tick && !slot.dead {
            if let Some(rate) = slot.rate {
                let w = slot.core.draw_wait(rate) * slot.clock_factor;
                self.queue
                    .push(self.now + wait(w), Ev::Tick(node, slot.epoch));
            }
            self.deliver(node, Input::Command(Command::Tick));
        }
    }
}
