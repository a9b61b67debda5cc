//! The discrete-event engine (issue 16 item 3): the protocol in virtual time.
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
//! On the ideal channel a message is delivered at the virtual time it is
//! sent, after every event already scheduled for that time. On the acoustic
//! channel ([`crate::model::channel`], `[channel] model = "acoustic"`) every
//! frame between two nodes goes through the run's [`Medium`] (the sync root's
//! Average is one transmission heard by every node): it is judged when its
//! arrival ends (delay, half-duplex, collisions, loss; a frame to a node the
//! coordinator left out is lost as `node_down`) and delivered then or lost,
//! and it is recorded ([`MessageRecord`]); a delivered frame the node
//! discards because the wait it answers is over is recorded `late`. How each
//! protocol waits on a lossy channel is [`crate::protocol::Command::ExchangeTimeout`]
//! (realtime) and [`crate::protocol::Command::RoundTimeout`] (logical clocks).
//! The coordinator's commands and the nodes' reports are the emulator's own
//! wiring, not acoustic: they arrive at once.

use super::{Action, Coordinator, EngineError, Event, MessageRecord, Progress, RunPlan, RunRecord};
use crate::model::channel::{Fate, Frame, Medium, Reason};
use crate::model::synth::Realization;
use crate::protocol::codec::Control;
use crate::protocol::{Command, Input, NodeCore, Output, PeerMsg};
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How many events are handled between two looks at the interrupt flag.
const INTERRUPT_CHECK_EVERY: u64 = 4096;

/// Something that happens at a virtual time.
#[derive(Debug)]
enum Ev {
    /// Node `0`'s Poisson clock fires.
    Tick(u32),
    /// An input reaches a node.
    ToNode(u32, Input),
    /// An event reaches the coordinator.
    ToCoordinator(Event),
    /// The arrival of a frame on the acoustic channel ends: judge it.
    Arrive(Frame, PeerMsg),
}

/// The event queue: `(time, sequence) -> event`, so events at one time keep
/// the order in which they were scheduled.
#[derive(Default)]
struct Queue {
    events: BTreeMap<(Duration, u64), Ev>,
    next: u64,
}

impl Queue {
    fn push(&mut self, at: Duration, ev: Ev) {
        self.events.insert((at, self.next), ev);
        self.next += 1;
    }

    fn pop(&mut self) -> Option<(Duration, Ev)> {
        self.events.pop_first().map(|((t, _), ev)| (t, ev))
    }
}

/// A drawn wait in seconds as a virtual duration, clamped to `[0, 1 day]`.
fn wait(secs: f64) -> Duration {
    const DAY: Duration = Duration::from_secs(86_400);
    Duration::try_from_secs_f64(secs).map_or(DAY, |d| d.min(DAY))
}

/// An absolute emulated time in seconds as a virtual time.
fn at(secs: f64) -> Duration {
    Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX)
}

/// Run `plan` in virtual time (a realtime clock, or any clock on the
/// acoustic channel). Returns the record of every
/// completed sample and, if the run stopped early, why. SIGINT/SIGTERM
/// ([`super::interrupt`]) end it as [`EngineError::Interrupted`].
pub fn run_des(
    plan: &RunPlan,
    real: &Realization,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let start = std::time::Instant::now();
    let interrupt = super::interrupt::flag();
    let mut nodes: Vec<NodeCore> = plan.nodes.iter().cloned().map(NodeCore::new).collect();
    let mut rates: Vec<Option<f64>> = vec![None; nodes.len()];
    let mut dead = vec![false; nodes.len()];
    let mut coord = Coordinator::new(plan, real);
    let mut queue = Queue::default();
    let mut actions = Vec::new();
    let mut outputs = Vec::new();
    let mut now = Duration::ZERO;
    let mut handled = 0u64;
    let mut medium = plan
        .channel
        .as_ref()
        .map(|c| Medium::new(c.cfg.clone(), plan.seed, c.positions.clone(), &c.links));
    // Nothing judged from now on can overlap what ended this long ago.
    let horizon = plan.channel.as_ref().map_or(0.0, |c| {
        2.0 * c.cfg.transmission_s(c.cfg.frame_bits(PeerMsg::MAX_VALUES)) + 1e-6
    });
    let mut messages: Vec<MessageRecord> = Vec::new();
    coord.handle(now, [Event::Start], &mut actions);
    let result = loop {
        // The coordinator's actions, at `now`.
        let mut done = None;
        for a in actions.drain(..) {
            match a {
                Action::Send { node, msg } => {
                    let i = node as usize;
                    match msg {
                        Control::Command(c) => queue.push(now, Ev::ToNode(node, Input::Command(c))),
                        Control::StartClock(rate) => {
                            rates[i] = Some(rate);
                            let w = nodes[i].draw_wait(rate);
                            queue.push(now + wait(w), Ev::Tick(node));
                        }
                        Control::Ping(seq) => {
                            queue.push(now, Ev::ToCoordinator(Event::Pong { node, seq }))
                        }
                        Control::Stop => {}
                    }
                }
                Action::SetTimer { at, timer } => {
                    queue.push(at, Ev::ToCoordinator(Event::Timer(timer)))
                }
                Action::Progress {
                    samples,
                    iterations,
                } => progress(samples, iterations),
                Action::Abandon { node } => dead[node as usize] = true,
                Action::Flush | Action::Log(_) => {}
                Action::Done(r) => done = Some(r),
            }
        }
        if let Some(r) = done {
            break r;
        }
        if coord.is_done() {
            break Ok(());
        }
        handled += 1;
        if handled.is_multiple_of(INTERRUPT_CHECK_EVERY) {
            if let Some(m) = &mut medium {
                m.forget_before(now.as_secs_f64() - horizon);
            }
            if interrupt.load(Ordering::SeqCst) {
                coord.handle(now, [Event::Interrupted], &mut actions);
                continue;
            }
        }
        let Some((t, ev)) = queue.pop() else {
            break Err(EngineError::Stalled(
                "the discrete-event queue ran empty before the run ended".into(),
            ));
        };
        now = t;
        let node_input = match ev {
            Ev::ToCoordinator(e) => {
                coord.handle(now, [e], &mut actions);
                continue;
            }
            Ev::Tick(node) => {
                let i = node as usize;
                if dead[i] {
                    continue;
                }
                if let Some(rate) = rates[i] {
                    let w = nodes[i].draw_wait(rate);
                    queue.push(now + wait(w), Ev::Tick(node));
                }
                (node, Input::Command(Command::Tick))
            }
            Ev::ToNode(node, input) => (node, input),
            Ev::Arrive(f, msg) => {
                let Some(m) = &medium else { continue };
                let fate = match m.judge(&f) {
                    Fate::Delivered if dead[f.to as usize] => Fate::Lost(Reason::NodeDown),
                    fate => fate,
                };
                messages.push(MessageRecord {
                    t_send: f.t_start,
                    t_recv: (fate == Fate::Delivered).then_some(f.arrive_end),
                    from: f.from,
                    to: f.to,
                    kind: msg.kind(),
                    bits: f.bits,
                    lost: match fate {
                        Fate::Delivered => None,
                        Fate::Lost(r) => Some(r),
                    },
                });
                if fate != Fate::Delivered {
                    continue;
                }
                (f.to, Input::Peer(msg))
            }
        };
        let (node, input) = node_input;
        if dead[node as usize] {
            continue;
        }
        let late = nodes[node as usize].counters().late;
        let from_channel = matches!(input, Input::Peer(_)) && medium.is_some();
        nodes[node as usize].handle(input, &mut outputs);
        if from_channel
            && nodes[node as usize].counters().late > late
            && let Some(last) = messages.last_mut()
        {
            // Delivered after its wait was over: discarded by the node.
            last.t_recv = None;
            last.lost = Some(Reason::Late);
        }
        let mut reports = Vec::new();
        for o in outputs.drain(..) {
            match o {
                Output::Peer { to, msg } => match (&mut medium, &plan.channel) {
                    (Some(m), Some(c)) => {
                        let bits = c.cfg.frame_bits(msg.values());
                        let f = m.send(now.as_secs_f64(), node, to, bits);
                        queue.push(at(f.arrive_end), Ev::Arrive(f, msg));
                    }
                    _ => queue.push(now, Ev::ToNode(to, Input::Peer(msg))),
                },
                Output::Broadcast(msg) => match (&mut medium, &plan.channel) {
                    (Some(m), Some(c)) => {
                        // One transmission, heard by every other node; the
                        // sender's loopback copy is not on the channel.
                        let others: Vec<u32> =
                            (0..nodes.len() as u32).filter(|&j| j != node).collect();
                        let bits = c.cfg.frame_bits(msg.values());
                        for f in m.broadcast(now.as_secs_f64(), node, &others, bits) {
                            queue.push(at(f.arrive_end), Ev::Arrive(f, msg));
                        }
                        queue.push(now, Ev::ToNode(node, Input::Peer(msg)));
                    }
                    _ => {
                        for j in 0..nodes.len() as u32 {
                            queue.push(now, Ev::ToNode(j, Input::Peer(msg)));
                        }
                    }
                },
                Output::Report(r) => reports.push(Event::Report(r)),
                Output::Timer { after_s, then } => {
                    queue.push(now + wait(after_s), Ev::ToNode(node, Input::Command(then)))
                }
            }
        }
        if !reports.is_empty() {
            coord.handle(now, reports, &mut actions);
        }
    };
    let mut rec = coord.into_record(result.is_err());
    rec.wall_seconds = start.elapsed().as_secs_f64();
    if medium.is_some() {
        rec.messages = messages;
        rec.emulated_seconds = Some(now.as_secs_f64());
        rec.events = Some(handled);
    }
    (rec, result)
}
