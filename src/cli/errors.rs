//! What the command line reports: [`CliError`] and its exit codes, and the
//! error chain printed once ([`error_report`]).

use crate::pipeline::RunError;
use std::path::PathBuf;

/// How a command failed; decides the exit code.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input (exit 2).
    #[error(transparent)]
    Input(#[from] crate::model::error::InputError),
    /// The run failed (exit 1); partial results were written to `dir`.
    #[error("{}\npartial results were written to {}", error.in_full(), dir.display())]
    RunFailed {
        /// The reason.
        error: crate::protocol::EngineError,
        /// Where the partial results are.
        dir: PathBuf,
    },
    /// Ctrl-C/SIGTERM stopped a Monte Carlo run (exit 1); the completed
    /// trials were written and summarised in `dir`.
    #[error(
        "interrupted after {done} of {requested} trials\nthe completed trials were written to {}",
        dir.display()
    )]
    TrialsInterrupted {
        /// Trials completed.
        done: usize,
        /// Trials asked for.
        requested: usize,
        /// Where they are.
        dir: PathBuf,
    },
    /// Anything else that stops a run (exit 1).
    #[error(transparent)]
    Run(RunError),
    /// `--check`: an `[expect]` check failed (exit 1).
    #[error("{failed} [expect] check(s) failed:\n{list}")]
    ExpectFailed {
        /// How many.
        failed: usize,
        /// One line per failed check, with the results directory.
        list: String,
    },
    /// Plots or report could not be written (exit 1).
    #[error(transparent)]
    Plot(crate::plot::PlotError),
    /// Ctrl-C/SIGTERM stopped a sweep (exit 1); the completed runs were
    /// written and summarised in `dir`.
    #[error(
        "interrupted after {done} of {requested} runs\nthe completed runs were written to {}",
        dir.display()
    )]
    SweepInterrupted {
        /// Runs completed.
        done: usize,
        /// Runs asked for.
        requested: usize,
        /// Where they are.
        dir: PathBuf,
    },
    /// `sonarnet replay`: the replay's results differ (exit 1).
    #[error("the replay differs from {}: {diff}\nthe replay's results are in {}", original.display(), replay.display())]
    ReplayDiffers {
        /// The original results directory.
        original: PathBuf,
        /// Where the replay wrote its results.
        replay: PathBuf,
        /// The first difference.
        diff: Box<crate::pipeline::replay::Difference>,
    },
    /// `sonarnet agent` failed (exit 1).
    #[error(transparent)]
    Agent(crate::runtime::agent::AgentError),
    /// `sonarnet agent` was stopped by SIGINT or SIGTERM (exit 1); its nodes
    /// were stopped and reaped.
    #[error("interrupted; this host's nodes were stopped")]
    AgentInterrupted,
    /// Some variants of a scenario failed; each error was printed as it
    /// happened (exit 1).
    #[error("{failed} variant(s) failed (their errors are above):\n{list}")]
    VariantsFailed {
        /// How many.
        failed: usize,
        /// One line per failed variant.
        list: String,
    },
}

/// An error and its causes as the command line prints them, once:
/// `error: ...` and one `  caused by: ...` line per cause.
pub fn error_report(e: &dyn std::error::Error) -> String {
    let mut out = format!("error: {e}\n");
    let mut src = e.source();
    while let Some(s) = src {
        out.push_str(&format!("  caused by: {s}\n"));
        src = s.source();
    }
    out
}

/// An error and its causes on one line (`cannot create x: permission
/// denied`), for a reason shown beside a key or flag.
pub fn one_line(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        out.push_str(&format!(": {s}"));
        src = s.source();
    }
    out
}

impl From<crate::pipeline::bench::BenchError> for CliError {
    fn from(e: crate::pipeline::bench::BenchError) -> Self {
        match e {
            crate::pipeline::bench::BenchError::Input(i) => CliError::Input(i),
            crate::pipeline::bench::BenchError::RunFailed { error, dir } => {
                CliError::RunFailed { error, dir }
            }
            crate::pipeline::bench::BenchError::Run(r) => r.into(),
        }
    }
}

impl From<crate::plot::PlotError> for CliError {
    fn from(e: crate::plot::PlotError) -> Self {
        match e {
            crate::plot::PlotError::Input(i) => CliError::Input(i),
            other => CliError::Plot(other),
        }
    }
}

impl CliError {
    /// The process exit code: 2 for bad input, 1 for a failed run.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Input(_)
            | CliError::Run(RunError::Input(_))
            | CliError::RunFailed {
                error: crate::protocol::EngineError::Checkpoint { .. },
                ..
            } => 2,
            _ => 1,
        }
    }
}

impl From<RunError> for CliError {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Input(i) => CliError::Input(i),
            other => CliError::Run(other),
        }
    }
}
