//! What an engine returns ([`RunOutcome`]): the coordinator's
//! [`RunRecord`] and, around it, what the engine that ran it saw: the node
//! processes' statistics, the channel's log and the fault log, each present
//! only where it applies.

use crate::protocol::EngineError;
use crate::protocol::RunRecord;
use crate::protocol::codec::Timing;
use crate::protocol::config::Driver;
use crate::world::faults::FaultLog;
use crate::world::medium::ChannelLog;

/// The node processes of a run, as the processes engine saw them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProcessStats {
    /// The run's IPC namespace (also when the nodes failed to start).
    pub run_id: String,
    /// Seconds from spawning to all nodes ready (`None`: they never were).
    pub startup_seconds: Option<f64>,
    /// Per-node busy/wait time split.
    pub timing: Vec<Timing>,
    /// Peak RSS (KiB) of every node process at the end of the run.
    pub peak_rss_kib: Vec<Option<u64>>,
    /// Per node: frames from it the coordinator could not decode and
    /// dropped; one more slot for frames that named no node of the run.
    pub bad_frames: Vec<u64>,
}

/// What an engine returns: the coordinator's record, why the run stopped
/// early if it did, and what the engine saw around it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOutcome {
    /// Every completed sample.
    pub record: RunRecord,
    /// Why the run stopped early, if it did.
    pub error: Option<EngineError>,
    /// What ran the nodes (`None`: nothing did, the run was refused before
    /// it started).
    pub driver: Option<Driver>,
    /// Node processes (the processes engine only).
    pub processes: Option<ProcessStats>,
    /// The acoustic channel's log (acoustic runs only).
    pub channel: Option<ChannelLog>,
    /// The faults applied (runs with a fault schedule only).
    pub faults: Option<FaultLog>,
}

impl RunOutcome {
    /// The outcome of `record` on `driver`, with nothing seen around it.
    pub fn new(driver: Driver, record: RunRecord, result: Result<(), EngineError>) -> RunOutcome {
        RunOutcome {
            record,
            error: result.err(),
            driver: Some(driver),
            processes: None,
            channel: None,
            faults: None,
        }
    }

    /// A run of `n` nodes on `driver` that failed before it started.
    pub fn failed(driver: Driver, n: usize, error: EngineError) -> RunOutcome {
        RunOutcome::new(driver, RunRecord::empty(n), Err(error))
    }

    /// A run of `n` nodes refused before any engine ran it.
    pub fn refused(n: usize, error: EngineError) -> RunOutcome {
        RunOutcome {
            driver: None,
            ..RunOutcome::new(Driver::LockStep, RunRecord::empty(n), Err(error))
        }
    }

    /// Which nodes were paused at the end of sample `k` (`None` without
    /// faults).
    pub fn paused(&self, k: usize) -> Option<&Vec<bool>> {
        self.faults.as_ref().and_then(|f| f.paused.get(k))
    }
}
