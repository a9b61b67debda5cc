//! What a run may be: the one place that accepts or refuses a combination of
//! engine, clock, transport and scenario, and that chooses the defaults.
//!
//! [`RunConfig::resolve`] is asked by [`RunPlan::new`](super::RunPlan::new)
//! and, before any work starts, by the command line and the pipeline; a
//! refusal is one [`Refused`] naming the flag or scenario key to change.

use crate::estimators::gossip::Mode;
use crate::scenario::{ClockCfg, Scenario};

crate::named_enum! {
    /// Which engine runs the nodes ([`crate::engine::inprocess`],
    /// [`crate::engine::des`], [`crate::runtime::processes`],
    /// [`crate::engine::threads`]).
    pub enum EngineKind {
        /// All nodes in one thread of this process (in virtual time for
        /// realtime clocks and the acoustic channel).
        Inprocess = "inprocess",
        /// One `sonarnet-node` OS process per receiver, over iceoryx2.
        Processes = "processes",
        /// One thread per node in this process, over the in-memory transport.
        Threads = "threads",
    }
}

crate::named_enum! {
    /// How a run is clocked.
    pub enum Clock {
        /// The coordinator sequences rounds/iterations; results are exact.
        Logical = "logical",
        /// Free-running nodes on Poisson clocks (async only): in wall time on
        /// node processes, in virtual time in-process.
        Realtime = "realtime",
    }
}

crate::named_enum! {
    /// What carries the frames between node processes.
    pub enum TransportKind {
        /// Shared memory: every node on this host.
        Iceoryx2 = "iceoryx2",
        /// zenoh over TCP: nodes on this host or on others (`--place`, `[deploy]`).
        Zenoh = "zenoh",
    }
    default Iceoryx2
}

crate::named_enum! {
    /// What actually runs the nodes of a plan (`driver` in `run.json`):
    /// `--engine inprocess` is the lock-step engine on logical clocks on the
    /// ideal channel, and the discrete-event engine otherwise.
    pub enum Driver {
        /// In-process, lock-step: the coordinator sequences every exchange.
        LockStep = "lock_step",
        /// In-process, the discrete-event engine: virtual time.
        DiscreteEvent = "discrete_event",
        /// One thread per node over the in-memory transport.
        Threads = "threads",
        /// One OS process per node, in wall time.
        Processes = "processes",
    }
}

impl Driver {
    /// The driver of `engine` on `clock`, on the acoustic channel or not.
    pub fn of(engine: EngineKind, clock: Clock, acoustic: bool) -> Driver {
        match engine {
            EngineKind::Inprocess if clock == Clock::Logical && !acoustic => Driver::LockStep,
            EngineKind::Inprocess => Driver::DiscreteEvent,
            EngineKind::Threads => Driver::Threads,
            EngineKind::Processes => Driver::Processes,
        }
    }
}

/// Wall time past which a realtime run goes to the discrete-event engine by
/// default (and `--engine processes` is told how long it will take).
pub const LONG_WALL_S: f64 = 60.0;

/// What a run is asked to be; `None` lets [`RunConfig::resolve`] choose.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunConfig {
    /// The engine (`--engine`).
    pub engine: Option<EngineKind>,
    /// The clock (`--clock`; else the scenario's `algorithm.clock`).
    pub clock: Option<Clock>,
    /// The transport of node processes (`--transport`).
    pub transport: TransportKind,
    /// Node processes poll their inbox this long before blocking (`--poll-us`).
    pub poll_us: u64,
    /// Monte Carlo trials (more than one: every trial in-process).
    pub trials: usize,
}

impl From<Clock> for RunConfig {
    /// A single in-process run on `clock`.
    fn from(clock: Clock) -> RunConfig {
        RunConfig {
            engine: Some(EngineKind::Inprocess),
            clock: Some(clock),
            trials: 1,
            ..RunConfig::default()
        }
    }
}

/// Where a refusal points: a command-line flag or a key of the scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key {
    /// A flag (`--clock`).
    Flag(&'static str),
    /// A scenario key (`channel.model`).
    Scenario(&'static str),
}

impl std::fmt::Display for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Key::Flag(k) | Key::Scenario(k) => f.write_str(k),
        }
    }
}

/// A combination that cannot run, found before anything starts.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key}: {reason}")]
pub struct Refused {
    /// The flag or key to change.
    pub key: Key,
    /// Why, and what would run.
    pub reason: String,
}

fn refuse<T>(key: Key, reason: &str) -> Result<T, Refused> {
    Err(Refused {
        key,
        reason: reason.to_string(),
    })
}

/// The emulated duration of a realtime run of `sc` in seconds (0 on logical
/// clocks): what node processes take in wall time.
pub fn realtime_wall_s<const D: usize>(sc: &Scenario<D>, clock: Clock) -> f64 {
    match (clock, &sc.realtime) {
        (Clock::Realtime, Some(rt)) => sc.samples as f64 * rt.sample_period_ms / 1000.0,
        _ => 0.0,
    }
}

/// The clock of `sc` when none is asked for: its `algorithm.clock`, else
/// realtime for the acoustic channel and faults (they happen in time), else
/// logical.
pub fn default_clock<const D: usize>(sc: &Scenario<D>) -> Clock {
    match sc.algorithm.clock {
        Some(ClockCfg::Realtime) => Clock::Realtime,
        Some(ClockCfg::Logical) => Clock::Logical,
        None if sc.channel.acoustic().is_some() || sc.has_faults() => Clock::Realtime,
        None => Clock::Logical,
    }
}

impl RunConfig {
    /// The engine and clock of a run of `sc`, or why it cannot run.
    ///
    /// Defaults: the clock of [`default_clock`]; Monte Carlo trials, the
    /// acoustic channel, faults and realtime runs longer than
    /// [`LONG_WALL_S`] run in-process (in virtual time on the discrete-event
    /// engine), unless zenoh is asked for; everything else on node processes.
    pub fn resolve<const D: usize>(
        &self,
        sc: &Scenario<D>,
    ) -> Result<(EngineKind, Clock), Refused> {
        let clock = self.clock.unwrap_or_else(|| default_clock(sc));
        // Which key chose the clock: the flag, or the scenario.
        let clock_key = match self.clock {
            Some(_) => Key::Flag("--clock"),
            None => Key::Scenario("algorithm.clock"),
        };
        let acoustic = sc.channel.acoustic().is_some();
        if self.trials > 1 {
            if self.poll_us > 0 {
                return refuse(Key::Flag("--poll-us"), MC_IN_PROCESS);
            }
            if self.engine.is_some_and(|e| e != EngineKind::Inprocess) {
                return refuse(Key::Flag("--engine"), MC_IN_PROCESS);
            }
        }
        let engine = self.engine.unwrap_or(
            if self.trials > 1
                || ((acoustic || sc.has_faults() || realtime_wall_s(sc, clock) > LONG_WALL_S)
                    && self.transport != TransportKind::Zenoh)
            {
                EngineKind::Inprocess
            } else {
                EngineKind::Processes
            },
        );
        if self.poll_us > 0 && engine != EngineKind::Processes {
            return refuse(
                Key::Flag("--poll-us"),
                "polling applies to node processes: it needs --engine processes",
            );
        }
        if sc.has_faults() && engine == EngineKind::Threads {
            return refuse(
                Key::Scenario("faults"),
                "faults run on --engine inprocess or processes, not threads",
            );
        }
        if sc.has_faults() && clock != Clock::Realtime {
            return refuse(
                Key::Scenario("faults"),
                "faults run on the realtime clock (--clock realtime, or algorithm.clock = \"realtime\")",
            );
        }
        if acoustic && engine == EngineKind::Threads {
            return refuse(
                Key::Scenario("channel.model"),
                "the acoustic channel runs on --engine inprocess (the discrete-event engine) or --engine processes, not threads",
            );
        }
        if clock == Clock::Realtime {
            if sc.algorithm.mode != Mode::Async {
                return refuse(
                    clock_key,
                    "realtime clocks need async mode (algorithm.mode = \"async\")",
                );
            }
            if engine == EngineKind::Threads {
                return refuse(
                    Key::Flag("--engine"),
                    "realtime clocks need --engine processes (wall time) or inprocess (virtual time), not threads",
                );
            }
            if sc.algorithm.schedule.is_some() {
                return refuse(
                    Key::Scenario("algorithm.schedule"),
                    "a replayed schedule sequences the logical clock; with --clock realtime every node draws its own exchanges",
                );
            }
            if sc.realtime.is_none() {
                return refuse(
                    Key::Scenario("realtime"),
                    "the realtime clock needs a [realtime] table (sample_period_ms, wake_rate_hz)",
                );
            }
        }
        Ok((engine, clock))
    }
}

const MC_IN_PROCESS: &str = "Monte Carlo trials run in-process (logical clocks, or realtime clocks and the acoustic \
     channel in virtual time); drop --engine processes|threads or use --trials 1";

#[cfg(test)]
mod tests {
    use super::{Key, LONG_WALL_S, RunConfig, TransportKind, realtime_wall_s};
    use crate::estimators::gossip::Mode;
    use crate::protocol::{Clock, EngineKind};
    use crate::scenario::Scenario;

    /// A variant of a shipped scenario (the first when `variant` is empty).
    fn variant(name: &str, variant: &str) -> Scenario {
        let p = format!("{}/scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
        let all = Scenario::load_all(std::path::Path::new(&p)).expect("a shipped scenario loads");
        all.iter()
            .position(|s| variant.is_empty() || s.variant.as_deref() == Some(variant))
            .map(|i| all[i].clone())
            .expect("the variant exists")
    }

    fn scenario(name: &str) -> Scenario {
        variant(name, "")
    }

    fn asked(engine: Option<EngineKind>, clock: Option<Clock>) -> RunConfig {
        RunConfig {
            engine,
            clock,
            trials: 1,
            ..RunConfig::default()
        }
    }

    #[test]
    fn the_defaults_are_node_processes_on_the_logical_clock_and_virtual_time_for_long_realtime_runs()
     {
        let spiral = scenario("mourya2017-spiral.toml");
        assert_eq!(
            asked(None, None).resolve(&spiral),
            Ok((EngineKind::Processes, Clock::Logical))
        );
        // 5000 samples 20 ms apart: 100 s of wall time on node processes.
        let long = spiral.clone().with_samples(5000).expect("samples");
        assert!(realtime_wall_s(&long, Clock::Realtime) > LONG_WALL_S);
        assert_eq!(
            asked(None, Some(Clock::Realtime)).resolve(&long),
            Ok((EngineKind::Inprocess, Clock::Realtime))
        );
        // ... unless zenoh is asked for, which only node processes use.
        let zenoh = RunConfig {
            transport: TransportKind::Zenoh,
            ..asked(None, Some(Clock::Realtime))
        };
        assert_eq!(
            zenoh.resolve(&long),
            Ok((EngineKind::Processes, Clock::Realtime))
        );
        // The acoustic channel runs on the realtime clock in virtual time.
        let acoustic = variant("mourya2017-spiral-acoustic.toml", "modem");
        assert_eq!(
            asked(None, None).resolve(&acoustic),
            Ok((EngineKind::Inprocess, Clock::Realtime))
        );
        // Monte Carlo trials run in-process.
        let mc = RunConfig {
            trials: 8,
            ..asked(None, None)
        };
        assert_eq!(
            mc.resolve(&spiral),
            Ok((EngineKind::Inprocess, Clock::Logical))
        );
    }

    #[test]
    fn every_refusal_names_the_flag_or_key_to_change() {
        let spiral = scenario("mourya2017-spiral.toml");
        let faults = scenario("mourya2017-spiral-faults.toml");
        let acoustic = variant("mourya2017-spiral-acoustic.toml", "modem");
        let sync = spiral.clone().with_mode(Mode::Sync).expect("sync");
        let key = |cfg: RunConfig, sc: &Scenario| cfg.resolve(sc).expect_err("refused").key;
        let mc = |engine, poll_us| RunConfig {
            trials: 4,
            poll_us,
            ..asked(engine, None)
        };
        assert_eq!(
            key(mc(Some(EngineKind::Processes), 0), &spiral),
            Key::Flag("--engine")
        );
        assert_eq!(key(mc(None, 100), &spiral), Key::Flag("--poll-us"));
        let poll = RunConfig {
            poll_us: 100,
            ..asked(Some(EngineKind::Inprocess), None)
        };
        assert_eq!(key(poll, &spiral), Key::Flag("--poll-us"));
        assert_eq!(
            key(asked(Some(EngineKind::Threads), None), &faults),
            Key::Scenario("faults")
        );
        assert_eq!(
            key(asked(None, Some(Clock::Logical)), &faults),
            Key::Scenario("faults")
        );
        assert_eq!(
            key(asked(Some(EngineKind::Threads), None), &acoustic),
            Key::Scenario("channel.model")
        );
        assert_eq!(
            key(asked(None, Some(Clock::Realtime)), &sync),
            Key::Flag("--clock")
        );
        assert_eq!(
            key(
                asked(Some(EngineKind::Threads), Some(Clock::Realtime)),
                &spiral
            ),
            Key::Flag("--engine")
        );
        // What is allowed is allowed.
        assert!(
            asked(Some(EngineKind::Threads), Some(Clock::Logical))
                .resolve(&spiral)
                .is_ok()
        );
        assert!(
            asked(Some(EngineKind::Processes), None)
                .resolve(&faults)
                .is_ok()
        );
    }
}
