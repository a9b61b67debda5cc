//! The I/O-free coordinator of a run, the counterpart of the node's
//! [`NodeCore`](crate::protocol::NodeCore).
//!
//! A [`Coordinator`] takes events (the start of the run, node reports, node
//! deaths, an interrupt, its own timers) and returns [`Action`]s: messages to
//! nodes, flushes, timers to set, progress, and finally the run's result. It
//! never touches a transport, a process or a clock: the time of every event is
//! passed in, so the same coordinator runs under a wall clock (node
//! processes; [`drive`](crate::engine::drive) is its driver over any
//! [`Network`](crate::engine::Network)) and under a virtual one (the discrete-event
//! engine, [`des`](crate::engine::des)).
//!
//! It covers every clock:
//! * **logical, sync**: per sample, the node's measurements and its rounds
//!   ([`Command::SyncRounds`]);
//! * **logical, async**: per sample, each node's share of the schedule drawn by
//!   the plan's [`Scheduler`] ([`Command::AsyncPlan`]);
//!   with both, up to [`LOOKAHEAD`] samples are in flight, and a sample is
//!   complete when every node reported [`Report::SampleDone`];
//! * **realtime**: free-running nodes on Poisson clocks. Measurements arrive
//!   every sample period; at each sample boundary (a timer) the coordinator
//!   asks every live node for a [`Command::Snapshot`]. A dead node is left out
//!   from then on ([`Command::NodeDown`] to the others) while the remaining
//!   graph stays connected.
//!
//! Liveness ([`RunPlan::stall_timeout`]): on logical clocks a
//! [`Timer::Watchdog`] pings every live node ([`Control::Ping`]) when no
//! report has come for half the stall timeout, and a node that has not
//! answered ([`Event::Pong`]) by [`Timer::PingDeadline`] ends the run
//! ([`EngineError::NotResponding`]); on the realtime clock a node that has
//! not answered its snapshot within the stall timeout is left out as dead.
//! Either way the engine is told to make sure it is gone ([`Action::Abandon`]).

use super::plan::{RunPlan, Scheduler};
use crate::estimators::gossip::Mode;
use crate::model::coords::Coords;
use crate::model::synth::Feed;
use crate::protocol::EngineError;
use crate::protocol::RunRecord;
use crate::protocol::codec::Control;
use crate::protocol::{Command, Counters, Report};
use std::collections::VecDeque;
use std::time::Duration;

/// How many samples the coordinator keeps in flight: it sends the commands of
/// sample `k + LOOKAHEAD - 1` as soon as sample `k` is complete, so nodes that finish
/// a sample early go straight on with the next one instead of waiting for the
/// slowest node and a round trip to the coordinator. Nodes run queued samples in
/// order ([`NodeCore::handle`](crate::protocol::NodeCore::handle)), so the results
/// do not depend on it.
pub const LOOKAHEAD: usize = 3;

mod liveness;
mod membership;
use liveness::Check;

/// What happens to the coordinator.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The run starts (every node is up).
    Start,
    /// A node reported.
    Report(Report),
    /// A node is gone (its process exited or was killed, its thread ended).
    NodeDied {
        /// The node.
        node: u32,
        /// How it ended (exit status, signal, error).
        how: String,
    },
    /// A node that died is up again (restarted; realtime clock):
    /// it rejoins with the current sample's measurements.
    NodeUp {
        /// The node.
        node: u32,
    },
    /// The user asked the run to stop (SIGINT/SIGTERM).
    Interrupted,
    /// A node answered liveness check `seq` ([`Control::Ping`]).
    Pong {
        /// The node.
        node: u32,
        /// The check number.
        seq: u64,
    },
    /// A timer the coordinator set ([`Action::SetTimer`]) is due.
    Timer(Timer),
}

/// The coordinator's timers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timer {
    /// Logical clocks: time to see whether any report came in the last half
    /// of the stall timeout, and to ping every live node if none did.
    Watchdog,
    /// Logical clocks: the answers to liveness check `seq` are due.
    PingDeadline(u64),
    /// The end of sample `k`'s period: time to snapshot.
    SampleBoundary(u32),
    /// The snapshot answers of sample `k` are overdue.
    SnapshotDeadline(u32),
}

/// What the coordinator wants done.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Queue a message for one node.
    Send {
        /// The node.
        node: u32,
        /// The message.
        msg: Control,
    },
    /// Deliver everything queued.
    Flush,
    /// Deliver [`Event::Timer`] at `at` (measured from [`Event::Start`]).
    SetTimer {
        /// When, from the start of the run.
        at: Duration,
        /// Which timer.
        timer: Timer,
    },
    /// `samples` samples and `iterations` DR iterations are complete.
    Progress {
        /// Samples complete.
        samples: usize,
        /// Iterations complete.
        iterations: u64,
    },
    /// A line for the verbose log.
    Log(String),
    /// The coordinator has given up on `node` (it does not answer): the
    /// engine makes sure it is gone (a node process is killed and reaped).
    Abandon {
        /// The node.
        node: u32,
    },
    /// The run is over: complete, or stopped early and why.
    Done(Result<(), EngineError>),
}

/// Logical clocks: one sample sent to the nodes and not yet complete.
struct InFlight {
    /// Each node's `theta` after the sample, once reported.
    thetas: Vec<Option<Coords>>,
    /// Each node's counters at the end of the sample: the record's counters
    /// are those of the last complete sample, so work a node did on the
    /// samples sent ahead ([`LOOKAHEAD`](super::LOOKAHEAD)) is not counted
    /// when the run stops early.
    counters: Vec<Counters>,
    /// Reports received.
    reports: usize,
}

impl InFlight {
    fn new(n: usize) -> InFlight {
        InFlight {
            thetas: vec![None; n],
            counters: vec![Counters::default(); n],
            reports: 0,
        }
    }
}

enum Phase {
    Logical {
        /// The samples in flight, oldest first.
        in_flight: VecDeque<InFlight>,
        sent: usize,
        completed: usize,
    },
    Realtime {
        /// The sample being run.
        sample: usize,
        /// `Some(asked)` while the snapshot of `sample` is awaited.
        snapshot: Option<Vec<bool>>,
        got: Vec<bool>,
        last_theta: Vec<Coords>,
        updates_before: u64,
    },
}

/// The coordinator of one run of a [`RunPlan`] on the measurements of a
/// [`Feed`].
pub struct Coordinator<'a> {
    plan: &'a RunPlan,
    real: Feed<'a>,
    sched: Scheduler<'a>,
    rec: RunRecord,
    dead: Vec<bool>,
    done: bool,
    phase: Phase,
    /// When the last report arrived (logical clocks).
    last_report: Duration,
    check: Option<Check>,
    checks: u64,
}

impl<'a> Coordinator<'a> {
    /// A coordinator for `plan`, sending the measurements of `real`.
    pub fn new(plan: &'a RunPlan, real: Feed<'a>) -> Self {
        let n = plan.n();
        let phase = match plan.realtime {
            None => Phase::Logical {
                in_flight: VecDeque::new(),
                sent: 0,
                completed: 0,
            },
            Some(_) => Phase::Realtime {
                sample: 0,
                snapshot: None,
                got: vec![false; n],
                last_theta: plan.nodes.iter().map(|c| c.init_u).collect(),
                updates_before: 0,
            },
        };
        Coordinator {
            plan,
            real,
            sched: plan.scheduler(),
            rec: RunRecord::empty(n),
            dead: vec![false; n],
            done: false,
            phase,
            last_report: Duration::ZERO,
            check: None,
            checks: 0,
        }
    }

    /// The run is over ([`Action::Done`] was returned).
    pub fn is_done(&self) -> bool {
        self.done
    }

    /// The oldest sample not yet complete.
    pub fn sample(&self) -> u32 {
        match &self.phase {
            Phase::Logical { completed, .. } => *completed as u32,
            Phase::Realtime { sample, .. } => *sample as u32,
        }
    }

    /// Handle a batch of events that happened by `now` (from the start of the
    /// run), appending the actions to `out`. After [`Action::Done`] every event
    /// is ignored.
    pub fn handle(
        &mut self,
        now: Duration,
        events: impl IntoIterator<Item = Event>,
        out: &mut Vec<Action>,
    ) {
        if self.done {
            return;
        }
        let result = match self.plan.realtime {
            None => self.handle_logical(now, events, out),
            Some(_) => self.handle_realtime(now, events, out),
        };
        match result {
            Ok(true) => self.finish_with(Ok(()), out),
            Ok(false) => {}
            Err(e) => self.finish_with(Err(e), out),
        }
    }

    fn finish_with(&mut self, r: Result<(), EngineError>, out: &mut Vec<Action>) {
        self.done = true;
        out.push(Action::Done(r));
    }

    /// The record of everything completed. `failed`: the run stopped early
    /// (the schedule then keeps the completed samples and the one in progress,
    /// not the samples sent ahead).
    pub fn into_record(self, failed: bool) -> RunRecord {
        let mut rec = self.rec;
        let ips = self.plan.iterations_per_sample;
        if failed {
            let keep = ((rec.thetas.len() + 1) * ips).min(rec.schedule.len());
            rec.schedule.truncate(keep);
        }
        if self.plan.trace_iterations {
            // Arrival order differs between engines; the file is ordered.
            rec.iteration_trace.sort_by_key(|e| (e.0, e.2));
            // Iterations of samples that did not complete are not part of the record.
            let done = rec.thetas.len() as u32;
            rec.iteration_trace.retain(|e| e.1 < done);
        }
        if self.plan.realtime.is_some() && rec.deaths.is_empty() {
            rec.alive.clear();
        }
        rec
    }

    /// Queue sample `k`'s measurements and, on logical clocks, its work.
    fn send_sample(&mut self, k: usize, out: &mut Vec<Action>) {
        let sample = k as u32;
        let n = self.plan.n();
        let ips = self.plan.iterations_per_sample;
        let start_clock = self.plan.realtime.filter(|_| k == 0);
        for (i, meas) in self.real.measurements[k].nodes.iter().enumerate() {
            if self.dead[i] {
                continue;
            }
            let meas = meas.clone();
            let sigmas = self.real.sigmas[k];
            out.push(send(
                i,
                Command::Sample {
                    sample,
                    meas,
                    sigmas,
                },
            ));
            if let Some(rt) = start_clock {
                out.push(Action::Send {
                    node: i as u32,
                    msg: Control::StartClock(rt.wake_rate_hz),
                });
            }
        }
        if self.plan.realtime.is_some() {
            return;
        }
        match self.plan.mode {
            Mode::Sync => {
                for i in 0..n {
                    let first_round = (k * ips) as u64;
                    let rounds = ips as u32;
                    out.push(send(
                        i,
                        Command::SyncRounds {
                            sample,
                            first_round,
                            rounds,
                        },
                    ));
                }
            }
            Mode::Async => {
                let mut steps: Vec<Vec<(u64, u32)>> = vec![Vec::new(); n];
                for j in 0..ips {
                    let it = (k * ips + j) as u64;
                    let (v, w) = self.sched.next_pair();
                    self.rec.schedule.push((v, w));
                    steps[v].push((it, w as u32));
                    steps[w].push((it, v as u32));
                }
                for (i, steps) in steps.into_iter().enumerate() {
                    out.push(send(i, Command::AsyncPlan { sample, steps }));
                }
            }
        }
    }

    /// Logical clocks; `Ok(true)` when every sample is complete.
    fn handle_logical(
        &mut self,
        now: Duration,
        events: impl IntoIterator<Item = Event>,
        out: &mut Vec<Action>,
    ) -> Result<bool, EngineError> {
        let n = self.plan.n();
        let samples = self.plan.samples;
        let ips = self.plan.iterations_per_sample;
        for e in events {
            if self.liveness(now, &e, out)? {
                continue;
            }
            let Phase::Logical {
                in_flight,
                sent,
                completed,
            } = &mut self.phase
            else {
                return Err(EngineError::Stalled(
                    "logical event on a realtime run".into(),
                ));
            };
            match e {
                Event::Start => {
                    let first = samples.min(LOOKAHEAD);
                    *sent = first;
                    in_flight.extend((0..first).map(|_| InFlight::new(n)));
                    for k in 0..first {
                        self.send_sample(k, out);
                    }
                    out.push(Action::Flush);
                    if samples == 0 {
                        return Ok(true);
                    }
                    out.push(Action::SetTimer {
                        at: now + self.plan.stall_timeout / 2,
                        timer: Timer::Watchdog,
                    });
                }
                Event::Report(Report::SampleDone {
                    node,
                    sample,
                    theta,
                    counters,
                }) => {
                    let i = node as usize;
                    let Some(slot) = (sample as usize)
                        .checked_sub(*completed)
                        .and_then(|d| in_flight.get_mut(d))
                    else {
                        continue;
                    };
                    if i < n && slot.thetas[i].is_none() {
                        slot.thetas[i] = Some(theta);
                        slot.reports += 1;
                        slot.counters[i] = counters;
                    }
                }
                Event::Report(Report::IterationDone {
                    node,
                    iteration,
                    theta,
                }) if self.plan.trace_iterations => {
                    let sample = (iteration / ips.max(1) as u64) as u32;
                    self.rec
                        .iteration_trace
                        .push((iteration, sample, node, theta));
                }
                Event::Report(Report::Failed {
                    node,
                    sample,
                    reason,
                    ..
                }) => {
                    return Err(EngineError::NodeFailed {
                        node,
                        sample,
                        reason,
                    });
                }
                Event::NodeDied { node, how } => {
                    let sample = *completed as u32;
                    return Err(EngineError::NodeDied { node, sample, how });
                }
                Event::Interrupted => {
                    return Err(EngineError::Interrupted {
                        sample: *completed as u32,
                    });
                }
                // Restarts run on the realtime clock.
                Event::Report(_) | Event::Timer(_) | Event::Pong { .. } | Event::NodeUp { .. } => {}
            }
        }
        if self.advance_logical(out) {
            out.push(Action::Flush);
        }
        Ok(self.sample() as usize >= samples)
    }

    /// Logical clocks: the liveness side of event `e` (a report is
    /// progress, which makes a check in progress moot; the watchdog, ping
    /// deadlines and pongs). `Ok(true)`: the event is fully handled.
    fn liveness(
        &mut self,
        now: Duration,
        e: &Event,
        out: &mut Vec<Action>,
    ) -> Result<bool, EngineError> {
        match *e {
            Event::Report(_) => {
                self.last_report = now;
                self.check = None;
                Ok(false)
            }
            Event::Timer(Timer::Watchdog) => {
                self.watchdog(now, out);
                Ok(true)
            }
            Event::Timer(Timer::PingDeadline(seq)) => {
                self.ping_deadline(now, seq, out)?;
                Ok(true)
            }
            Event::Pong { node, seq } => {
                if let Some(c) = &mut self.check
                    && c.seq == seq
                    && let Some(a) = c.answered.get_mut(node as usize)
                {
                    *a = true;
                }
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// Logical clocks: record every sample now complete, oldest first, and
    /// send the commands of the next sample for each; whether any was.
    fn advance_logical(&mut self, out: &mut Vec<Action>) -> bool {
        let n = self.plan.n();
        let samples = self.plan.samples;
        let ips = self.plan.iterations_per_sample;
        let mut advanced = false;
        // A node that never reported the sample (only ever a dead one, left
        // out of `theta_bar`).
        let unreported = Coords::zeros(self.plan.dim() + 1);
        while let Some(thetas) = self.pop_complete() {
            self.rec.thetas.push(
                thetas
                    .into_iter()
                    .map(|t| t.unwrap_or(unreported))
                    .collect(),
            );
            self.rec.iterations += ips as u64;
            out.push(Action::Progress {
                samples: self.rec.thetas.len(),
                iterations: self.rec.iterations,
            });
            if let Phase::Logical {
                in_flight, sent, ..
            } = &mut self.phase
                && *sent < samples
            {
                let k = *sent;
                *sent += 1;
                in_flight.push_back(InFlight::new(n));
                self.send_sample(k, out);
            }
            advanced = true;
        }
        advanced
    }

    /// Logical clocks: the oldest sample in flight, taken out if every node
    /// reported it.
    fn pop_complete(&mut self) -> Option<Vec<Option<Coords>>> {
        let n = self.plan.n();
        let Phase::Logical {
            in_flight,
            completed,
            ..
        } = &mut self.phase
        else {
            return None;
        };
        if in_flight.front().is_none_or(|s| s.reports != n) {
            return None;
        }
        *completed += 1;
        let slot = in_flight.pop_front()?;
        self.rec.counters = slot.counters;
        Some(slot.thetas)
    }

    /// Realtime clocks; `Ok(true)` when every sample is complete.
    fn handle_realtime(
        &mut self,
        now: Duration,
        events: impl IntoIterator<Item = Event>,
        out: &mut Vec<Action>,
    ) -> Result<bool, EngineError> {
        let period = self
            .plan
            .realtime
            .map_or(Duration::ZERO, |rt| rt.sample_period);
        let n = self.plan.n();
        for e in events {
            let k = self.sample();
            match e {
                Event::Start => {
                    self.send_sample(0, out);
                    out.push(Action::Flush);
                    out.push(boundary(0, period));
                }
                Event::Timer(Timer::SampleBoundary(s)) if s == k => {
                    self.ask_snapshots(now, k, out);
                }
                Event::Timer(Timer::SnapshotDeadline(s)) if s == k => {
                    self.snapshot_deadline(out)?;
                }
                Event::Report(Report::Snapshot {
                    node,
                    sample,
                    theta,
                    counters,
                }) => {
                    let i = node as usize;
                    if let Phase::Realtime {
                        snapshot: Some(_),
                        got,
                        last_theta,
                        ..
                    } = &mut self.phase
                        && sample == k
                        && i < n
                    {
                        got[i] = true;
                        last_theta[i] = theta;
                        self.rec.counters[i] = counters;
                    }
                }
                Event::Report(Report::Failed {
                    node,
                    sample,
                    reason,
                    ..
                }) => {
                    return Err(EngineError::NodeFailed {
                        node,
                        sample,
                        reason,
                    });
                }
                Event::NodeDied { node, how } => self.node_died(node, how, out)?,
                Event::NodeUp { node } => self.node_up(node, out),
                Event::Interrupted => return Err(EngineError::Interrupted { sample: k }),
                Event::Report(_) | Event::Timer(_) | Event::Pong { .. } => {}
            }
        }
        Ok(self.complete_snapshot(period, out))
    }

    /// Realtime: sample `k`'s boundary: every live node is asked for its
    /// snapshot, with a deadline of one stall timeout.
    fn ask_snapshots(&mut self, now: Duration, k: u32, out: &mut Vec<Action>) {
        let n = self.plan.n();
        let asked: Vec<bool> = self.dead.iter().map(|d| !d).collect();
        for i in (0..n).filter(|&i| asked[i]) {
            out.push(send(i, Command::Snapshot { sample: k }));
        }
        out.push(Action::Flush);
        out.push(Action::SetTimer {
            at: now + self.plan.stall_timeout,
            timer: Timer::SnapshotDeadline(k),
        });
        if let Phase::Realtime { snapshot, got, .. } = &mut self.phase {
            *snapshot = Some(asked);
            got.fill(false);
        }
    }

    /// Realtime: the snapshot deadline of the sample in progress. A node
    /// that has not answered its snapshot within the stall timeout is not
    /// responding (stopped?): it is abandoned and left out like a dead node.
    fn snapshot_deadline(&mut self, out: &mut Vec<Action>) -> Result<(), EngineError> {
        let n = self.plan.n();
        let silent: Vec<u32> = match &self.phase {
            Phase::Realtime {
                snapshot: Some(asked),
                got,
                ..
            } => (0..n)
                .filter(|&i| asked[i] && !got[i] && !self.dead[i])
                .map(|i| i as u32)
                .collect(),
            _ => Vec::new(),
        };
        let how = format!(
            "not responding (stopped?) for {} s",
            self.plan.stall_timeout.as_secs_f64()
        );
        for node in silent {
            out.push(Action::Abandon { node });
            self.node_died(node, how.clone(), out)?;
        }
        Ok(())
    }

    /// Realtime: once every live node's snapshot of the sample in progress
    /// is in, record the sample and start the next (samples `period`
    /// long); `true` when every sample is complete.
    fn complete_snapshot(&mut self, period: Duration, out: &mut Vec<Action>) -> bool {
        let n = self.plan.n();
        let Phase::Realtime {
            sample,
            snapshot,
            got,
            last_theta,
            updates_before,
        } = &mut self.phase
        else {
            return false;
        };
        let complete = snapshot
            .as_ref()
            .is_some_and(|asked| (0..n).all(|i| !asked[i] || got[i] || self.dead[i]));
        if !complete {
            return false;
        }
        let k = *sample;
        *snapshot = None;
        self.rec.thetas.push(last_theta.clone());
        if self.rec.deaths.is_empty() {
            self.rec.alive.push(vec![true; n]);
        } else {
            // Backfill the all-alive masks of earlier samples.
            while self.rec.alive.len() < k {
                self.rec.alive.push(vec![true; n]);
            }
            self.rec.alive.push(self.dead.iter().map(|d| !d).collect());
        }
        let updates: u64 = self.rec.counters.iter().map(|c| c.updates).sum();
        // Every completed exchange updates both ends.
        let exchanges = (updates - (*updates_before).min(updates)) / 2;
        *updates_before = updates;
        self.rec.iterations_per_sample.push(exchanges);
        self.rec.iterations += exchanges;
        *sample += 1;
        out.push(Action::Progress {
            samples: k + 1,
            iterations: self.rec.iterations,
        });
        if k + 1 >= self.plan.samples {
            return true;
        }
        self.send_sample(k + 1, out);
        out.push(Action::Flush);
        out.push(boundary(k + 1, period));
        false
    }
}

fn send(node: usize, cmd: Command) -> Action {
    Action::Send {
        node: node as u32,
        msg: Control::Command(cmd),
    }
}

/// The timer at the end of sample `k`'s period.
fn boundary(k: usize, period: Duration) -> Action {
    Action::SetTimer {
        at: period * (k as u32 + 1),
        timer: Timer::SampleBoundary(k as u32),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Clock;
    use crate::scenario::Scenario;

    fn spiral(samples: usize) -> Scenario {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/mourya2017-spiral.toml"
        );
        let mut sc = Scenario::load(std::path::Path::new(path)).unwrap();
        sc.algorithm.burn_in = 0;
        sc.with_samples(samples).unwrap()
    }

    fn sends(out: &[Action]) -> Vec<(u32, &Control)> {
        out.iter()
            .filter_map(|a| match a {
                Action::Send { node, msg } => Some((*node, msg)),
                _ => None,
            })
            .collect()
    }

    fn snapshot(node: u32, sample: u32, x: f64, updates: u64) -> Event {
        Event::Report(Report::Snapshot {
            node,
            sample,
            theta: Coords::from([x, 0.0, 0.0]),
            counters: Counters {
                updates,
                ..Default::default()
            },
        })
    }

    #[test]
    fn realtime_starts_the_clocks_snapshots_at_each_boundary_and_counts_exchanges() {
        let sc = spiral(2);
        let plan = RunPlan::new(&sc, Clock::Realtime).unwrap();
        let real = sc.realize();
        let period = Duration::from_millis(20);
        let mut c = Coordinator::new(&plan, real.feed());
        let mut out = vec![];
        c.handle(Duration::ZERO, [Event::Start], &mut out);
        let s = sends(&out);
        // Every node: its measurements, then its clock.
        assert_eq!(s.len(), 12);
        assert!(matches!(s[1].1, Control::StartClock(r) if (r - 2000.0).abs() < 1e-12));
        let timer = Timer::SampleBoundary(0);
        assert_eq!(out.last(), Some(&Action::SetTimer { at: period, timer }));
        out.clear();
        c.handle(period, [Event::Timer(timer)], &mut out);
        let s = sends(&out);
        assert_eq!(s.len(), 6);
        assert!(
            s.iter()
                .all(|(_, m)| **m == Control::Command(Command::Snapshot { sample: 0 }))
        );
        out.clear();
        // Five answers: not complete; the sixth completes the sample.
        c.handle(
            period,
            (0..5).map(|i| snapshot(i, 0, i as f64, 10)),
            &mut out,
        );
        assert!(!out.iter().any(|a| matches!(a, Action::Progress { .. })));
        c.handle(period, [snapshot(5, 0, 5.0, 10)], &mut out);
        // 6 nodes x 10 updates, two per exchange.
        assert!(out.contains(&Action::Progress {
            samples: 1,
            iterations: 30
        }));
        assert!(out.contains(&Action::SetTimer {
            at: 2 * period,
            timer: Timer::SampleBoundary(1)
        }));
        out.clear();
        c.handle(
            2 * period,
            [Event::Timer(Timer::SampleBoundary(1))],
            &mut out,
        );
        c.handle(
            2 * period,
            (0..6).map(|i| snapshot(i, 1, 1.0, 12)),
            &mut out,
        );
        assert_eq!(out.last(), Some(&Action::Done(Ok(()))));
        assert!(c.is_done());
        let rec = c.into_record(false);
        assert_eq!(rec.iterations_per_sample, vec![30, 6]);
        assert_eq!(rec.thetas[0][3], Coords::from([3.0, 0.0, 0.0]));
        // No death: no alive masks.
        assert!(rec.alive.is_empty());
    }

    #[test]
    fn realtime_leaves_a_dead_leaf_out_and_fails_when_a_cut_node_dies() {
        let sc = spiral(3);
        let plan = RunPlan::new(&sc, Clock::Realtime).unwrap();
        let real = sc.realize();
        let mut c = Coordinator::new(&plan, real.feed());
        let mut out = vec![];
        let t = Duration::from_millis(20);
        c.handle(Duration::ZERO, [Event::Start], &mut out);
        c.handle(t, [Event::Timer(Timer::SampleBoundary(0))], &mut out);
        out.clear();
        // Node 4 hangs off node 3 only: the rest stays connected.
        let died = Event::NodeDied {
            node: 4,
            how: "killed by signal 9".into(),
        };
        c.handle(t, [died], &mut out);
        let s = sends(&out);
        assert_eq!(s.len(), 5);
        assert!(
            s.iter()
                .all(|(i, m)| *i != 4 && **m == Control::Command(Command::NodeDown { node: 4 }))
        );
        // The sample completes without node 4's answer.
        out.clear();
        c.handle(t, [0, 1, 2, 3, 5].map(|i| snapshot(i, 0, 0.0, 0)), &mut out);
        assert!(out.contains(&Action::Progress {
            samples: 1,
            iterations: 0
        }));
        // Measurements of the next sample go to the live nodes only.
        assert!(sends(&out).iter().all(|(i, _)| *i != 4));
        // Node 3 is a cut vertex: its death disconnects 5 from the rest.
        out.clear();
        c.handle(
            t,
            [Event::NodeDied {
                node: 3,
                how: "exit code 1".into(),
            }],
            &mut out,
        );
        let Some(Action::Done(Err(EngineError::NodeDied { node, sample, how }))) = out.last()
        else {
            panic!("{out:?}");
        };
        assert_eq!((*node, *sample), (3, 1));
        assert!(how.contains("disconnected (2 parts)"), "{how}");
        let rec = c.into_record(true);
        assert_eq!(rec.deaths.len(), 2);
        assert_eq!(rec.alive, vec![vec![true, true, true, true, false, true]]);
    }

    #[test]
    fn realtime_abandons_a_node_that_does_not_answer_its_snapshot_and_goes_on_without_it() {
        let sc = spiral(2);
        let plan = RunPlan::new(&sc, Clock::Realtime).unwrap();
        let real = sc.realize();
        let mut c = Coordinator::new(&plan, real.feed());
        let mut out = vec![];
        let t = Duration::from_millis(20);
        c.handle(Duration::ZERO, [Event::Start], &mut out);
        c.handle(t, [Event::Timer(Timer::SampleBoundary(0))], &mut out);
        let deadline = t + plan.stall_timeout;
        assert!(out.contains(&Action::SetTimer {
            at: deadline,
            timer: Timer::SnapshotDeadline(0)
        }));
        out.clear();
        // Node 5 (a leaf) never answers.
        c.handle(t, (0..5).map(|i| snapshot(i, 0, 1.0, 0)), &mut out);
        assert!(!out.iter().any(|a| matches!(a, Action::Progress { .. })));
        c.handle(
            deadline,
            [Event::Timer(Timer::SnapshotDeadline(0))],
            &mut out,
        );
        assert!(out.contains(&Action::Abandon { node: 5 }), "{out:?}");
        assert!(out.contains(&Action::Progress {
            samples: 1,
            iterations: 0
        }));
        let downs = sends(&out)
            .into_iter()
            .filter(|(_, m)| **m == Control::Command(Command::NodeDown { node: 5 }))
            .count();
        assert_eq!(downs, 5);
        let rec = c.into_record(false);
        assert_eq!(rec.deaths.len(), 1);
        assert_eq!((rec.deaths[0].0, rec.deaths[0].1), (5, 0));
        assert!(
            rec.deaths[0].2.contains("not responding (stopped?)"),
            "{:?}",
            rec.deaths
        );
        assert_eq!(rec.alive[0], vec![true, true, true, true, true, false]);
    }

    /// The logical coordinator's watchdog after `Start` at 0: the pings of
    /// the first check, at half the stall timeout.
    fn first_check(c: &mut Coordinator<'_>, plan: &RunPlan) -> (Duration, Vec<Action>) {
        let mut out = vec![];
        c.handle(Duration::ZERO, [Event::Start], &mut out);
        let half = plan.stall_timeout / 2;
        assert!(out.contains(&Action::SetTimer {
            at: half,
            timer: Timer::Watchdog
        }));
        out.clear();
        c.handle(half, [Event::Timer(Timer::Watchdog)], &mut out);
        (half, out)
    }

    #[test]
    fn a_logical_run_without_reports_pings_every_node_and_names_the_one_that_does_not_answer() {
        let sc = spiral(5);
        let plan = RunPlan::new(&sc, Clock::Logical).unwrap();
        let real = sc.realize();
        let mut c = Coordinator::new(&plan, real.feed());
        let (half, out) = first_check(&mut c, &plan);
        let pings: Vec<u32> = sends(&out)
            .into_iter()
            .filter(|(_, m)| matches!(m, Control::Ping(1)))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(pings, (0..6).collect::<Vec<u32>>());
        assert!(out.contains(&Action::SetTimer {
            at: 2 * half,
            timer: Timer::PingDeadline(1)
        }));
        let mut out = vec![];
        let pongs = [0, 1, 2, 4, 5].map(|node| Event::Pong { node, seq: 1 });
        c.handle(half, pongs, &mut out);
        c.handle(2 * half, [Event::Timer(Timer::PingDeadline(1))], &mut out);
        assert_eq!(out[0], Action::Abandon { node: 3 });
        let Some(Action::Done(Err(e))) = out.last() else {
            panic!("{out:?}");
        };
        assert_eq!(
            e,
            &EngineError::NotResponding {
                nodes: vec![3],
                sample: 0,
                silent_for: plan.stall_timeout,
            }
        );
        assert!(
            e.to_string()
                .starts_with("node 3 is not responding (stopped?) at sample 0"),
            "{e}"
        );
    }

    #[test]
    fn a_slow_logical_run_whose_nodes_all_answer_is_not_a_stall_and_a_moot_check_keeps_the_watchdog_going()
     {
        let sc = spiral(5);
        let plan = RunPlan::new(&sc, Clock::Logical).unwrap();
        let real = sc.realize();
        let mut c = Coordinator::new(&plan, real.feed());
        let (half, _) = first_check(&mut c, &plan);
        let mut out = vec![];
        c.handle(
            half,
            (0..6).map(|node| Event::Pong { node, seq: 1 }),
            &mut out,
        );
        c.handle(2 * half, [Event::Timer(Timer::PingDeadline(1))], &mut out);
        assert!(!c.is_done(), "{out:?}");
        assert!(out.contains(&Action::SetTimer {
            at: 3 * half,
            timer: Timer::Watchdog
        }));
        // A report before the next deadline makes the next check moot.
        out.clear();
        c.handle(3 * half, [Event::Timer(Timer::Watchdog)], &mut out);
        assert!(
            sends(&out)
                .iter()
                .any(|(_, m)| matches!(m, Control::Ping(2)))
        );
        let report = Event::Report(Report::SampleDone {
            node: 0,
            sample: 0,
            theta: Coords::zeros(3),
            counters: Counters::default(),
        });
        let reported = 3 * half + Duration::from_millis(1);
        c.handle(reported, [report], &mut out);
        out.clear();
        // The moot check's deadline keeps the watchdog going from the report
        // (it used to end the chain of timers, so a node stopped after that
        // report hung the run forever).
        c.handle(4 * half, [Event::Timer(Timer::PingDeadline(2))], &mut out);
        assert!(!c.is_done());
        assert_eq!(
            out,
            vec![Action::SetTimer {
                at: reported + half,
                timer: Timer::Watchdog
            }]
        );
        // And a node that then stops is still named.
        out.clear();
        c.handle(reported + half, [Event::Timer(Timer::Watchdog)], &mut out);
        assert!(
            sends(&out)
                .iter()
                .any(|(_, m)| matches!(m, Control::Ping(3)))
        );
        let pongs = [0, 1, 2, 4, 5].map(|node| Event::Pong { node, seq: 3 });
        c.handle(reported + half, pongs, &mut out);
        out.clear();
        c.handle(
            reported + 2 * half,
            [Event::Timer(Timer::PingDeadline(3))],
            &mut out,
        );
        assert!(
            matches!(
                out.last(),
                Some(Action::Done(Err(EngineError::NotResponding { nodes, .. }))) if nodes == &vec![3]
            ),
            "{out:?}"
        );
    }

    #[test]
    fn a_logical_run_stops_at_a_death_or_an_interrupt_naming_the_sample_in_progress() {
        let sc = spiral(5);
        let plan = RunPlan::new(&sc, Clock::Logical).unwrap();
        let real = sc.realize();
        for (event, want) in [
            (
                Event::NodeDied {
                    node: 2,
                    how: "exit code 3".into(),
                },
                EngineError::NodeDied {
                    node: 2,
                    sample: 0,
                    how: "exit code 3".into(),
                },
            ),
            (Event::Interrupted, EngineError::Interrupted { sample: 0 }),
        ] {
            let mut c = Coordinator::new(&plan, real.feed());
            let mut out = vec![];
            c.handle(Duration::ZERO, [Event::Start], &mut out);
            // LOOKAHEAD samples of measurements and plans, then one flush.
            assert_eq!(sends(&out).len(), LOOKAHEAD * 2 * plan.n());
            assert_eq!(out[out.len() - 2], Action::Flush);
            out.clear();
            c.handle(Duration::ZERO, [event], &mut out);
            assert_eq!(out, vec![Action::Done(Err(want))]);
            // The schedule keeps the sample in progress only.
            let rec = c.into_record(true);
            assert_eq!(rec.schedule.len(), plan.iterations_per_sample);
        }
    }
}
