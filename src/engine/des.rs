//! The discrete-event engine (issue 16 item 3): the realtime protocol in
//! virtual time, `--engine inprocess --clock realtime`.
//!
//! Every node's [`NodeCore`] and the [`Coordinator`] run in one thread over an
//! event queue ordered by (virtual time, order of scheduling): node clock ticks
//! (each node draws its Poisson waits from its own seeded stream, as a node
//! process does), message deliveries and the coordinator's timers (sample
//! boundaries, snapshot deadlines). Nothing reads a wall clock, so a run is
//! exact and deterministic from the seed, and as fast as the node cores.
//!
//! On the ideal channel a message is delivered at the virtual time it is
//! sent, after every event already scheduled for that time. On the acoustic
//! channel ([`crate::model::channel`], `[channel] model = "acoustic"`) every
//! frame between two nodes goes through the run's [`Medium`]: it is judged
//! when its arrival ends (delay, half-duplex, collisions, loss) and delivered
//! then or lost, and it is recorded ([`MessageRecord`]). An initiator whose
//! Request or answer is lost gives the exchange up at its timeout
//! ([`crate::protocol::Command::ExchangeTimeout`]) and keeps its state; a
//! responder that updated and whose Accept is lost stays updated, so the
//! consensus mean is no longer conserved. The coordinator's commands and the
//! nodes' reports are the emulator's own wiring, not acoustic: they arrive at
//! once.

use super::{Action, Coordinator, EngineError, Event, MessageRecord, Progress, RunPlan, RunRecord};
use crate::model::channel::{Fate, Frame, Medium};
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

/// Run `plan` (realtime clock) in virtual time. Returns the record of every
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
        2.0 * c.cfg.transmission_s(c.cfg.frame_bits(3)) + 1e-6
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
                let fate = m.judge(&f);
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
        nodes[node as usize].handle(input, &mut outputs);
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
                Output::Broadcast(msg) => {
                    for j in 0..nodes.len() as u32 {
                        queue.push(now, Ev::ToNode(j, Input::Peer(msg)));
                    }
                }
                Output::Report(r) => reports.push(Event::Report(r)),
                Output::Timer { seq, after_s } => queue.push(
                    now + wait(after_s),
                    Ev::ToNode(node, Input::Command(Command::ExchangeTimeout { seq })),
                ),
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
