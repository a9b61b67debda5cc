//! The typed results of one run: `metrics.json` ([`RunMetrics`], with the
//! per-node counters, realtime statistics, deaths and `[expect]` checks).

use super::*;

/// Per-node counters as written to `metrics.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeCounters {
    /// Node id.
    pub node: usize,
    /// Counters.
    #[serde(flatten)]
    pub counters: Counters,
    /// Multi-process: seconds spent computing.
    pub busy_seconds: Option<f64>,
    /// Multi-process: seconds spent blocked waiting for messages.
    pub wait_seconds: Option<f64>,
    /// Multi-process: peak resident set size of the node process (KiB).
    pub peak_rss_kib: Option<u64>,
}

/// Free-running (realtime) statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RealtimeStats {
    /// Fewest exchanges completed in one sample period.
    pub iterations_per_sample_min: u64,
    /// Median exchanges per sample period.
    pub iterations_per_sample_median: f64,
    /// Most exchanges in one sample period.
    pub iterations_per_sample_max: u64,
    /// Declined exchange requests, all nodes.
    pub declines: u64,
    /// Network exchange rate (exchanges per second of run time).
    pub iterations_per_second: f64,
}

/// A node that died during the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Death {
    /// Node id.
    pub node: u32,
    /// Sample at which the coordinator noticed.
    pub sample: u32,
    /// Exit status or signal.
    pub how: String,
}

/// The contents of `metrics.json`. Error metrics are `null` without truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// RMSE of `theta_bar` over all samples.
    pub rmse: Option<f64>,
    /// RMSE after `burn_in` samples.
    pub rmse_after_burn_in: Option<f64>,
    /// Median error.
    pub median_error: Option<f64>,
    /// Error at the last sample.
    pub final_error: Option<f64>,
    /// Cumulative target tracking error.
    pub ctte: Option<f64>,
    /// Dynamic regret of `theta_bar` (seed 001), see [`crate::pipeline::score`].
    pub regret: Option<f64>,
    /// Largest consensus disagreement over all samples.
    pub max_disagreement: f64,
    /// RMSE of the centralised ML estimate.
    pub ml_rmse: Option<f64>,
    /// RMS of the per-sample CRLB.
    pub crlb_rms: Option<f64>,
    /// DR iterations (sync: rounds) completed.
    pub iterations: u64,
    /// Prox solves over all nodes.
    pub prox_solves: u64,
    /// Engine wall time (seconds).
    pub wall_seconds: f64,
    /// `inprocess` or `processes`.
    pub engine: String,
    /// `sync` or `async`.
    pub mode: String,
    /// `logical` or `realtime`.
    pub clock: String,
    /// Run seed.
    pub seed: u64,
    /// The scenario variant, if the file has `[[variants]]`.
    pub variant: Option<String>,
    /// Samples completed.
    pub samples_completed: usize,
    /// Samples asked for.
    pub samples: usize,
    /// `ok`, `failed` or `interrupted`.
    pub status: String,
    /// Why the run stopped early.
    pub error: Option<String>,
    /// Why some metrics are missing.
    pub note: Option<String>,
    /// Multi-process: seconds from spawning the nodes to all of them ready.
    pub startup_seconds: Option<f64>,
    /// Realtime clock statistics.
    pub realtime: Option<RealtimeStats>,
    /// Nodes that died (the gap: they are left out of `theta_bar` from then on).
    pub deaths: Vec<Death>,
    /// Per-node counters.
    pub nodes: Vec<NodeCounters>,
    /// Certified bounds on `theta_bar` (`[bounds]`), by bound name.
    pub bounds: BTreeMap<String, BoundMetrics>,
    /// Every baseline's metrics, by track name.
    pub baselines: BTreeMap<String, TrackMetrics>,
    /// `x_hat_t` solves (regret) that stopped at 5000 iterations.
    pub x_hat_not_converged: usize,
    /// The scenario's `[expect]` checks on this run.
    pub expect: Vec<ExpectResult>,
}

/// One `[expect]` check as recorded in `metrics.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectResult {
    /// The relation (thresholds as `theta_bar.rmse <= 5.0`), or why it
    /// could not be evaluated.
    pub expect: String,
    /// Left value (`None` when it could not be evaluated).
    pub lhs: Option<f64>,
    /// Right value.
    pub rhs: Option<f64>,
    /// Whether it holds.
    pub holds: bool,
}
