//! OS process supervision: the node processes of a run (spawned here or by
//! agents on other hosts), their start-up, faults and checkpoints, the
//! resource check before a run, and the one entry point of every engine,
//! [`run`].
//!
//! The drivers of the protocol ([`crate::engine`]) run in this process;
//! [`processes`] runs the same coordinator over node processes that it
//! launches, watches, pauses, kills and reaps ([`processes::Processes`]),
//! and [`agent`] launches them on a host of its own for a coordinator
//! elsewhere. [`preflight`] checks, before anything starts, that this
//! machine can hold the run.

pub mod agent;
pub mod preflight;
pub mod processes;

use crate::engine::{Progress, RunOutcome, des, run_inprocess, threads};
use crate::model::synth::Feed;
use crate::protocol::{Clock, Driver, EngineError, RunPlan};

/// The one entry point of the engines: run `plan` on `real` on the engine
/// its [`RunConfig`](crate::protocol::RunConfig) chose (`popts` applies to
/// node processes only): logical clocks on the ideal channel on the
/// in-process, threads or processes engine; realtime clocks and the acoustic
/// channel in-process in virtual time ([`des`]) or on node processes in
/// wall time.
pub fn run(
    plan: &RunPlan,
    real: Feed<'_>,
    popts: &processes::ProcessOptions,
    progress: Progress<'_>,
) -> RunOutcome {
    match plan.driver() {
        Driver::LockStep => run_inprocess(plan, real, progress),
        Driver::DiscreteEvent => des::run_des(plan, real, progress),
        // `RunConfig::resolve` refuses these before a plan exists.
        Driver::Threads if plan.clock != Clock::Logical || plan.channel.is_some() => {
            RunOutcome::failed(
                Driver::Threads,
                plan.n(),
                EngineError::Unsupported(
                    "the threads engine runs logical clocks on the ideal channel".into(),
                ),
            )
        }
        Driver::Threads => threads::run_threads(plan, real, progress),
        Driver::Processes => processes::run_processes(plan, real, popts, progress),
    }
}
