//! The engines: the drivers of the protocol's one coordinator.
//!
//! A run is a [`RunPlan`] (built once from a scenario,
//! [`crate::protocol::plan`]) on the measurements of a run ([`Feed`]). The I/O-free
//! [`Coordinator`] turns events into actions, which [`actions::carry_out`]
//! performs over an [`Actuator`]; [`drive`] is its driver over any
//! [`Network`] in wall time: the in-process engine ([`inprocess::InProcess`])
//! implements [`Network`] with the [`NodeCore`](crate::protocol::NodeCore)s
//! in one thread, the threads engine ([`threads`]) with node threads over the
//! in-memory transport, and the multi-process engine
//! ([`crate::runtime::processes`]) with node processes over iceoryx2 or
//! zenoh; the discrete-event engine ([`des`])
//! runs the same coordinator and node cores in virtual time over the world's
//! channel and faults ([`crate::world`]). Each returns a [`RunOutcome`];
//! [`crate::runtime::run`] is the one entry point.

pub mod actions;
pub mod checkpoint;
pub mod des;
pub mod inprocess;
pub mod interrupt;
pub mod layout;
pub mod node;
pub mod outcome;
pub mod threads;
pub mod water;

pub use actions::Actuator;
pub use outcome::{ProcessStats, RunOutcome};

use crate::model::synth::Feed;
use crate::protocol::codec::Control;
use crate::protocol::config::Driver;
use crate::protocol::coordinator::{Coordinator, Event, Timer};
use crate::protocol::{EngineError, RunPlan, RunRecord};
use std::time::{Duration, Instant};

/// Where the coordinator's messages go and the nodes' events come from.
pub trait Network {
    /// Queue a message for node `node`.
    fn send(&mut self, node: u32, msg: &Control) -> Result<(), EngineError>;
    /// Deliver everything queued.
    fn flush(&mut self) -> Result<(), EngineError>;
    /// Wait until at least one event is available, or `timeout` has passed
    /// (`None`: no limit); append the events to `out`.
    fn recv(&mut self, timeout: Option<Duration>, out: &mut Vec<Event>) -> Result<(), EngineError>;
    /// A line of the coordinator's verbose log.
    fn log(&mut self, _line: &str) {}
    /// The coordinator gave up on `node` ([`Action::Abandon`](crate::protocol::Action::Abandon)): make sure it
    /// is gone (a node process is killed and reaped). Nothing by default.
    fn abandon(&mut self, _node: u32) {}
    /// `samples` samples are complete ([`Action::Progress`](crate::protocol::Action::Progress)). Nothing by
    /// default.
    fn sample_done(&mut self, _samples: usize) {}
}

/// Progress callback: `(samples done, iterations done)`.
pub type Progress<'a> = &'a mut dyn FnMut(usize, u64);

/// Run `plan` on `real` over `net`: the driver of the [`Coordinator`] under
/// the wall clock. Returns the record of everything completed and, if the run
/// stopped early, why.
pub fn drive(
    plan: &RunPlan,
    real: Feed<'_>,
    net: &mut dyn Network,
    progress: Progress<'_>,
) -> (RunRecord, Result<(), EngineError>) {
    let start = Instant::now();
    // The coordinator's clock: emulated time on the acoustic channel
    // (`channel.time_scale` emulated seconds per wall second), else wall time.
    let scale = plan.channel.as_ref().map(|c| c.cfg.time_scale);
    let to_coord = |wall: Duration| scale.map_or(wall, |s| wall.mul_f64(s));
    let to_wall = |coord: Duration| scale.map_or(coord, |s| coord.div_f64(s));
    let mut coord = Coordinator::new(plan, real);
    let mut actions = Vec::new();
    let mut events = Vec::new();
    let mut wired = Wired {
        net,
        timers: Vec::new(),
    };
    coord.handle(Duration::ZERO, [Event::Start], &mut actions);
    let result = loop {
        if let Some(r) = actions::carry_out(&mut actions, &mut wired, progress) {
            break r;
        }
        if coord.is_done() {
            break Ok(());
        }
        let timers = &mut wired.timers;
        timers.sort_by_key(|t| t.0);
        let timeout = timers
            .first()
            .map(|(at, _)| to_wall(at.saturating_sub(to_coord(start.elapsed()))));
        if let Err(e) = wired.net.recv(timeout, &mut events) {
            break Err(e);
        }
        let now = to_coord(start.elapsed());
        let due = timers.partition_point(|(at, _)| *at <= now);
        events.extend(timers.drain(..due).map(|(_, t)| Event::Timer(t)));
        coord.handle(now, events.drain(..), &mut actions);
    };
    let mut rec = coord.into_record(result.is_err());
    rec.wall_seconds = start.elapsed().as_secs_f64();
    (rec, result)
}

/// The coordinator's actions on a [`Network`], with the coordinator's
/// timers kept here until they are due.
struct Wired<'n> {
    net: &'n mut dyn Network,
    timers: Vec<(Duration, Timer)>,
}

impl Actuator for Wired<'_> {
    fn send(&mut self, node: u32, msg: Control) -> Result<(), EngineError> {
        self.net.send(node, &msg)
    }

    fn flush(&mut self) -> Result<(), EngineError> {
        self.net.flush()
    }

    fn set_timer(&mut self, at: Duration, timer: Timer) {
        self.timers.push((at, timer));
    }

    fn sample_done(&mut self, samples: usize) {
        self.net.sample_done(samples);
    }

    fn log(&mut self, line: &str) {
        self.net.log(line);
    }

    fn abandon(&mut self, node: u32) {
        self.net.abandon(node);
    }
}

/// Run `plan` in-process; SIGINT/SIGTERM ([`interrupt`]) end it with
/// [`EngineError::Interrupted`] and the samples completed.
pub fn run_inprocess(plan: &RunPlan, real: Feed<'_>, progress: Progress<'_>) -> RunOutcome {
    let mut net = inprocess::InProcess::new(plan.nodes.clone()).with_interrupt(interrupt::flag());
    let (rec, res) = drive(plan, real, &mut net, progress);
    RunOutcome::new(Driver::LockStep, rec, res)
}
