//! The typed results: `metrics.json` ([`RunMetrics`], with the per-node
//! counters, realtime statistics, deaths and `[expect]` checks), `run.json`
//! ([`RunJson`]) and a Monte Carlo run's `summary.json` ([`McSummary`]). The
//! writers ([`super::Outcome::write`], [`super::montecarlo`]) and the readers
//! (the plots and the report, [`crate::plot::data`]) use these same types.

use crate::pipeline::score;
use crate::pipeline::score::BoundMetrics;
use crate::pipeline::score::TrackMetrics;
use crate::protocol::Counters;
use serde::Deserialize;
use serde::Serialize;
use std::collections::BTreeMap;

crate::named_enum! {
    /// How a run, trial or sweep ended (`status` in `run.json`,
    /// `metrics.json`, `summary.json` and a sweep's `runs.csv`).
    pub enum RunStatus {
        /// Every sample was run.
        Ok = "ok",
        /// SIGINT or SIGTERM stopped it; what was completed is written.
        Interrupted = "interrupted",
        /// An error stopped it; what was completed is written, and the error
        /// says where.
        Failed = "failed",
    }
    default Ok
}

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
    /// Multi-process: frames from this node the coordinator could not
    /// decode and dropped. Left out when zero.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bad_frames_sent: u64,
}

fn is_zero(x: &u64) -> bool {
    *x == 0
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

/// The acoustic channel's statistics (`metrics.json` `channel`; present
/// only on the acoustic channel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelStats {
    /// Frames sent between nodes and judged (delivered or lost).
    pub frames: u64,
    /// Frames still in the water when the run ended (in `messages.csv` with
    /// fate `in_flight`; not in `frames`).
    #[serde(default)]
    pub in_flight: u64,
    /// Frames delivered.
    pub delivered: u64,
    /// `delivered / frames`.
    pub delivery_ratio: f64,
    /// Frames lost, by reason (`loss`, `collision`, `half_duplex`,
    /// `blocked`, `node_down`, `late`); only the reasons that occurred.
    pub lost: BTreeMap<String, u64>,
    /// Per directed link with traffic.
    pub links: Vec<LinkStats>,
    /// Mean delay of the delivered frames, send to end of arrival (seconds).
    pub delay_mean_s: Option<f64>,
    /// 99th percentile of that delay.
    pub delay_p99_s: Option<f64>,
    /// Realtime exchanges started (Requests sent).
    pub exchanges_attempted: u64,
    /// Exchanges answered with an Accept that arrived.
    pub exchanges_completed: u64,
    /// Realtime: exchanges the initiator gave up at its timeout.
    pub exchanges_timed_out: u64,
    /// Sync rounds a node other than the root finished without the root's
    /// Average (it kept its state), summed over the nodes.
    #[serde(default)]
    pub rounds_timed_out: u64,
    /// Reflected points missing from the sync rounds the root averaged at
    /// their timeout.
    #[serde(default)]
    pub points_missing: u64,
    /// Async logical: steps a node finished without its partner's point (it
    /// kept its state), summed over the nodes.
    #[serde(default)]
    pub steps_timed_out: u64,
    /// Processes engine: the median realised delivery error of the
    /// delivered frames, forwarded minus planned end of arrival (emulated
    /// ms); absent on the discrete-event engine, which is exact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delivery_error_p50_ms: Option<f64>,
    /// Processes engine: its 99th percentile (emulated ms).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delivery_error_p99_ms: Option<f64>,
    /// Bits sent, all frames.
    pub bits_sent: u64,
    /// The emulated time the run covered (seconds).
    pub emulated_seconds: f64,
    /// Emulated seconds per wall-clock second of the engine.
    pub realtime_factor: f64,
    /// Events the discrete-event engine handled.
    pub events: u64,
    /// Events per wall-clock second.
    pub events_per_second: f64,
}

/// One directed link's traffic on the acoustic channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkStats {
    /// Sender.
    pub from: u32,
    /// Addressee.
    pub to: u32,
    /// Frames sent.
    pub frames: u64,
    /// `delivered / frames`.
    pub delivery_ratio: f64,
}

/// What one fault did to the track (`metrics.json` `faults`, `faults.csv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultOutcome {
    /// `pause`, `crash`, `restart`, `partition`, `link_loss`, `delay` or
    /// `clock_drift`.
    pub kind: String,
    /// The nodes it concerns.
    pub nodes: Vec<u32>,
    /// Its parameters in words.
    pub detail: String,
    /// When it was applied (emulated s).
    pub t_s: f64,
    /// When it ended (lasting faults), emulated s.
    pub until_s: Option<f64>,
    /// The sample in progress when it ended (its start sample if
    /// instantaneous): recovery counts from there.
    #[serde(default)]
    pub until_sample: u32,
    /// The sample in progress when it was applied.
    pub sample: u32,
    /// When the coordinator noticed it (a crash or restart at once; a pause
    /// when it outlasted the stall timeout), emulated s.
    pub detected_s: Option<f64>,
    /// The mean error of `theta_bar` over the five samples before it (m).
    pub error_before: Option<f64>,
    /// The largest error from its start to its end (m).
    pub peak_error: Option<f64>,
    /// Samples from its end (its start if instantaneous) until the error is
    /// back within 1.5x of `error_before`; `None`: not within the run.
    pub recovery_samples: Option<u32>,
    /// When that happened (the end of that sample's period), emulated s.
    pub recovered_s: Option<f64>,
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
///
/// Every track's metrics are a [`TrackMetrics`]: the distributed estimate's in
/// `theta_bar`, the centralised ML reference's in `ml`, each baseline's in
/// `baselines.NAME`. The top-level `rmse` ... `regret`, `ml_rmse` and `bounds`
/// repeat the most used of them under the names scripts have always read.
/// A key missing from the file (one written by an older version) reads as
/// its default.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
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
    /// Dynamic regret of `theta_bar` (Pun-So 2020), see [`crate::pipeline::score`].
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
    /// How the run ended.
    pub status: RunStatus,
    /// Why the run stopped early.
    pub error: Option<String>,
    /// Why some metrics are missing.
    pub note: Option<String>,
    /// Multi-process: seconds from spawning the nodes to all of them ready.
    pub startup_seconds: Option<f64>,
    /// Realtime clock statistics.
    pub realtime: Option<RealtimeStats>,
    /// Acoustic channel statistics (absent on the ideal channel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channel: Option<ChannelStats>,
    /// Nodes that died (the gap: they are left out of `theta_bar` from then on).
    pub deaths: Vec<Death>,
    /// Faults applied, with their detection, recovery and peak
    /// error; absent without faults.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<FaultOutcome>,
    /// Per-node counters.
    pub nodes: Vec<NodeCounters>,
    /// Certified bounds on `theta_bar` (`[bounds]`), by bound name.
    pub bounds: BTreeMap<String, BoundMetrics>,
    /// Every metric of the distributed estimate `theta_bar`.
    pub theta_bar: TrackMetrics,
    /// Every metric of the centralised ML reference track `ml`.
    pub ml: TrackMetrics,
    /// Every baseline's metrics, by track name.
    pub baselines: BTreeMap<String, TrackMetrics>,
    /// `x_hat_t` solves (regret) that stopped at 5000 iterations.
    pub x_hat_not_converged: usize,
    /// The scenario's `[expect]` checks on this run.
    pub expect: Vec<ExpectResult>,
}

impl RunMetrics {
    /// Read `metrics.json`. A file written before the tracks' metrics were
    /// embedded has `theta_bar`'s only at the top level and the ML
    /// reference's only as `ml_rmse`: those fill `theta_bar` and `ml`.
    pub fn from_json(v: serde_json::Value) -> Result<RunMetrics, serde_json::Error> {
        let mut m: RunMetrics = serde_json::from_value(v)?;
        if m.theta_bar == TrackMetrics::default() {
            m.theta_bar = TrackMetrics {
                rmse: m.rmse,
                rmse_after_burn_in: m.rmse_after_burn_in,
                median_error: m.median_error,
                final_error: m.final_error,
                ctte: m.ctte,
                regret: m.regret,
                bounds: m.bounds.clone(),
                ..TrackMetrics::default()
            };
        }
        if m.ml == TrackMetrics::default() {
            m.ml.rmse = m.ml_rmse;
        }
        Ok(m)
    }

    /// Every scalar metric by the names `[expect]` uses: `theta_bar.rmse`,
    /// `ml.rmse`, `NAME.ctte`, `NAME.bounds.BOUND.coverage` for every track,
    /// plus `theta_bar.max_disagreement`, `theta_bar.iterations`,
    /// `theta_bar.prox_solves` and `crlb_rms`: the columns of `trials.csv`,
    /// and what the report's comparison table lists.
    pub fn flat(&self) -> BTreeMap<String, f64> {
        let mut f = BTreeMap::new();
        score::flatten_into(&mut f, "theta_bar", &self.theta_bar);
        score::flatten_into(&mut f, "ml", &self.ml);
        for (name, m) in &self.baselines {
            score::flatten_into(&mut f, name, m);
        }
        f.insert("theta_bar.max_disagreement".into(), self.max_disagreement);
        f.insert("theta_bar.iterations".into(), self.iterations as f64);
        f.insert("theta_bar.prox_solves".into(), self.prox_solves as f64);
        if let Some(c) = self.crlb_rms {
            f.insert("crlb_rms".into(), c);
        }
        if let Some(c) = &self.channel {
            for (k, v) in [
                ("frames", c.frames as f64),
                ("in_flight", c.in_flight as f64),
                ("delivery_ratio", c.delivery_ratio),
                ("exchanges_attempted", c.exchanges_attempted as f64),
                ("exchanges_completed", c.exchanges_completed as f64),
                ("exchanges_timed_out", c.exchanges_timed_out as f64),
                ("rounds_timed_out", c.rounds_timed_out as f64),
                ("points_missing", c.points_missing as f64),
                ("steps_timed_out", c.steps_timed_out as f64),
                ("emulated_seconds", c.emulated_seconds),
            ] {
                f.insert(format!("channel.{k}"), v);
            }
            // Every reason, zero when it did not occur.
            for r in crate::model::channel::Reason::ALL {
                let n = c.lost.get(r.as_str()).copied().unwrap_or(0);
                f.insert(format!("channel.lost.{}", r.as_str()), n as f64);
            }
            if let Some(d) = c.delay_mean_s {
                f.insert("channel.delay_mean_s".into(), d);
            }
        }
        // Faults: `faults.I.KEY` for the I-th fault applied.
        for (i, o) in self.faults.iter().enumerate() {
            let mut put = |k: &str, v: Option<f64>| {
                if let Some(v) = v {
                    f.insert(format!("faults.{i}.{k}"), v);
                }
            };
            put("t_s", Some(o.t_s));
            put("detected_s", o.detected_s);
            put("peak_error", o.peak_error);
            put("error_before", o.error_before);
            put("recovery_samples", o.recovery_samples.map(f64::from));
            put("recovered_s", o.recovered_s);
        }
        if !self.faults.is_empty() {
            f.insert("faults.count".into(), self.faults.len() as f64);
            let recovered = self.faults.iter().filter(|o| o.recovery_samples.is_some());
            f.insert("faults.recovered".into(), recovered.count() as f64);
        }
        f
    }
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

/// The contents of `run.json`: what was run, how, and how it ended. Every
/// field but the scenario is optional when read, so runs written by older
/// versions still load (keys in alphabetical order, as written).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RunJson {
    /// `logical` or `realtime`.
    #[serde(default)]
    pub clock: Option<String>,
    /// The command line.
    #[serde(default)]
    pub command_line: Vec<String>,
    /// Crate version that wrote the run.
    #[serde(default)]
    pub crate_version: Option<String>,
    /// The gossip graph's edges.
    #[serde(default)]
    pub edges: Option<Vec<(usize, usize)>>,
    /// `inprocess`, `processes` or `threads`.
    #[serde(default)]
    pub engine: Option<String>,
    /// What ran the nodes: `lock_step` or `discrete_event` (both
    /// `inprocess`), `threads` or `processes`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driver: Option<crate::protocol::Driver>,
    /// Why the run stopped early.
    #[serde(default)]
    pub error: Option<String>,
    /// The git commit sonarnet was built from (when built from a git checkout).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub git_commit: Option<String>,
    /// The host name of the machine that ran it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
    /// Absolute paths of the input files: `scenario`, and `trace`, `truth`,
    /// `schedule` when the scenario names them.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub inputs: std::collections::BTreeMap<String, String>,
    /// `gtrs`, `relaxed` or `gtrs_l0`.
    #[serde(default)]
    pub local_solver: Option<String>,
    /// `sync` or `async`.
    #[serde(default)]
    pub mode: Option<String>,
    /// The `--set KEY=VALUE` overrides, as given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<String>,
    /// Node polling before blocking (µs).
    #[serde(default)]
    pub poll_us: Option<u64>,
    /// Multi-process: the run's IPC namespace.
    #[serde(default)]
    pub run_id: Option<String>,
    /// The liveness watchdog (`--stall-timeout`, seconds).
    #[serde(default)]
    pub stall_timeout_s: Option<f64>,
    /// The resolved scenario (after command-line overrides), as a JSON object
    /// of the scenario file's keys.
    #[serde(default)]
    pub scenario: serde_json::Value,
    /// The scenario file.
    #[serde(default)]
    pub scenario_file: Option<String>,
    /// Run seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// When the run started, UTC (`2026-12-03T01:02:03Z`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_utc: Option<String>,
    /// How the run ended.
    #[serde(default)]
    pub status: Option<RunStatus>,
    /// Multi-process: `iceoryx2` or `zenoh` (absent for in-process engines).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transport: Option<String>,
    /// Multi-process over zenoh: which host ran which node (`--place`,
    /// `[deploy]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub placement: Option<crate::scenario::deploy::Placement>,
}

/// A mean curve with its 5th and 95th percentiles across Monte Carlo trials,
/// one entry per kept sample (`null` where undefined).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Band {
    /// Mean across trials.
    pub mean: Vec<Option<f64>>,
    /// 5th percentile.
    pub p5: Vec<Option<f64>>,
    /// 95th percentile.
    pub p95: Vec<Option<f64>>,
}

/// The curves of one track in `summary.json`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TrackBands {
    /// Running CTTE.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ctte: Option<Band>,
    /// Error `||x_k - x_k*||`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<Band>,
    /// Running dynamic regret.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regret: Option<Band>,
}

/// The contents of `summary.json` of a Monte Carlo run (keys in
/// alphabetical order, as written; when read, every key but the curves'
/// shapes is optional).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct McSummary {
    /// The command line.
    #[serde(default)]
    pub command_line: Vec<String>,
    /// The per-sample CRLB across trials.
    #[serde(default)]
    pub crlb: Option<Band>,
    /// Curves per track (`theta_bar`, `ml`, baselines by name).
    #[serde(default)]
    pub curves: BTreeMap<String, TrackBands>,
    /// Always `inprocess`.
    #[serde(default)]
    pub engine: Option<String>,
    /// The `[expect]` checks on the trial statistics.
    #[serde(default)]
    pub expect: Vec<ExpectResult>,
    /// Trials that stopped early.
    #[serde(default)]
    pub failed_trials: Option<usize>,
    /// Why the first of them stopped.
    #[serde(default)]
    pub first_failure: Option<String>,
    /// Statistics of every scalar metric over the trials (`mean`, `std`, ...;
    /// `null` where undefined).
    #[serde(default)]
    pub metrics: BTreeMap<String, BTreeMap<String, Option<f64>>>,
    /// `sync` or `async`.
    #[serde(default)]
    pub mode: Option<String>,
    /// The sample indices of the curves.
    #[serde(default)]
    pub sample: Vec<usize>,
    /// Samples per trial.
    #[serde(default)]
    pub samples: Option<usize>,
    /// Scenario name.
    #[serde(default)]
    pub scenario: Option<String>,
    /// The first trial's seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// The first and last trial's seeds.
    #[serde(default)]
    pub seeds: Option<[u64; 2]>,
    /// Number of trials completed (and summarised).
    #[serde(default)]
    pub trials: Option<u64>,
    /// Number of trials asked for.
    #[serde(default)]
    pub trials_requested: Option<u64>,
    /// `ok`, or `interrupted` (Ctrl-C/SIGTERM: fewer trials than requested).
    #[serde(default)]
    pub status: Option<RunStatus>,
    /// The scenario variant.
    #[serde(default)]
    pub variant: Option<String>,
    /// Wall time of all trials (seconds).
    #[serde(default)]
    pub wall_seconds: Option<f64>,
}
