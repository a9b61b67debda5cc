//! `sonarnet bench`: the multi-process engine's performance figures, measured
//! in one run (README's performance table quotes them).
//!
//! * **Engine overhead**: wall time of `mourya2017-spiral` (100 samples × 50
//!   iterations) on node processes over the in-process engine, async-logical
//!   and sync; the best of `repeats` runs of each, start-up excluded (it is
//!   reported separately). Measured with blocking nodes (the default) and with
//!   `--poll-us` [`POLL_US`].
//! * **Scale** (`--scale 64,256,1024,2048`): a ring of N node processes
//!   (async logical): start-up time (spawn to every READY), iterations per
//!   second, peak RSS per node, and the coordinator's own peak RSS.
//! * **Realtime throughput**: network-wide exchanges per second of the
//!   free-running emulator on the spiral.
//!
//! Results go to stdout as a table and to `bench.json` in the output directory.

use crate::pipeline::{self, Clock, EngineKind, RunOptions};
use crate::scenario::{Mode, Scenario};
use serde::Serialize;
use std::path::Path;

/// One engine-overhead measurement.
#[derive(Debug, Clone, Serialize)]
pub struct Overhead {
    /// `async` or `sync`.
    pub mode: String,
    /// Node polling before blocking (µs; 0 = block at once, the default engine).
    pub poll_us: u64,
    /// Best in-process wall time (s).
    pub inprocess_seconds: f64,
    /// Best multi-process wall time, start-up excluded (s).
    pub processes_seconds: f64,
    /// Multi-process start-up (s) of the best run.
    pub startup_seconds: f64,
    /// `processes_seconds / inprocess_seconds`.
    pub ratio: f64,
}

/// One scale measurement.
#[derive(Debug, Clone, Serialize)]
pub struct Scale {
    /// Node processes.
    pub nodes: usize,
    /// Spawn to all nodes ready (s).
    pub startup_seconds: f64,
    /// DR iterations per second (async logical).
    pub iterations_per_second: f64,
    /// Largest peak RSS of a node process (MiB).
    pub max_rss_mib: f64,
    /// Mean peak RSS of the node processes (MiB).
    pub mean_rss_mib: f64,
    /// The coordinator's peak RSS during the run (MiB; `VmHWM`, reset
    /// before the run where the kernel allows it).
    pub coordinator_rss_mib: Option<f64>,
    /// Whether the run completed.
    pub completed: bool,
}

/// This process's `VmHWM` (peak RSS) in MiB.
fn own_peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib: f64 = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kib / 1024.0)
}

/// Reset this process's `VmHWM` to its current RSS (`clear_refs` 5).
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Everything `sonarnet bench` measures.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Engine overhead, async and sync.
    pub overhead: Vec<Overhead>,
    /// Scale runs.
    pub scale: Vec<Scale>,
    /// Realtime exchanges per second on the spiral.
    pub realtime_iterations_per_second: Option<f64>,
    /// Realtime median exchanges per sample period.
    pub realtime_iterations_per_sample_median: Option<f64>,
}

/// The `--poll-us` of the second pair of overhead figures.
pub const POLL_US: u64 = 100;

fn spiral(dir: &Path) -> Result<Scenario, crate::model::error::InputError> {
    Scenario::load(&dir.join("mourya2017-spiral.toml"))
}

/// A scenario with `n` receivers on a 3 km circle joined in a ring, two
/// transmitters, a target at constant velocity, async gossip (TOML text).
pub fn ring_toml(n: usize, samples: usize, iterations_per_sample: usize) -> String {
    let receivers: Vec<String> = (0..n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            format!("[{:.3}, {:.3}]", 3000.0 * a.cos(), 3000.0 * a.sin())
        })
        .collect();
    format!(
        r#"name = "ring{n}"
seed = 1
[geometry]
transmitters = [[0.0, 0.0], [1000.0, 500.0]]
receivers = [{}]
[network]
generator = {{ kind = "ring" }}
[target]
samples = {samples}
motion = {{ model = "constant_velocity", start = [100.0, 200.0], velocity = [3.0, 1.0] }}
[measurements]
doa = true
range_noise = {{ model = "gaussian", sigma = 5.0 }}
doa_noise = {{ model = "gaussian", sigma = 0.5 }}
[algorithm]
mode = "async"
gamma = 2e-8
iterations_per_sample = {iterations_per_sample}
"#,
        receivers.join(", ")
    )
}

fn ring(n: usize) -> Result<Scenario, crate::model::error::InputError> {
    Scenario::from_toml_str(&ring_toml(n, 10, 200), Path::new("<bench ring>"))
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A scenario of the bench is bad input (exit 2).
    #[error(transparent)]
    Input(#[from] crate::model::error::InputError),
    /// A benchmark run failed; what it produced is in `dir`.
    #[error("{error}\npartial results were written to {}", dir.display())]
    RunFailed {
        /// The reason.
        error: crate::engine::EngineError,
        /// Where the partial results are.
        dir: std::path::PathBuf,
    },
    /// `bench.json` could not be written.
    #[error(transparent)]
    Run(#[from] pipeline::RunError),
}

/// Run the benchmarks. `scenarios` is the directory holding
/// `mourya2017-spiral.toml`; `nodes` the scale sizes; `repeats` per overhead figure.
pub fn run_bench(
    scenarios: &Path,
    nodes: &[usize],
    repeats: usize,
    out: &Path,
) -> Result<BenchReport, BenchError> {
    let processes = RunOptions::inprocess().with_engine(EngineKind::Processes);
    let mut overhead = Vec::new();
    for (mode, poll_us) in [
        (Mode::Async, 0),
        (Mode::Sync, 0),
        (Mode::Async, POLL_US),
        (Mode::Sync, POLL_US),
    ] {
        let sc = spiral(scenarios)?.with_mode(mode)?;
        let procs = RunOptions {
            poll_us,
            ..RunOptions::inprocess().with_engine(EngineKind::Processes)
        };
        let mut best_in = f64::INFINITY;
        let mut best_proc = (f64::INFINITY, 0.0);
        for _ in 0..repeats.max(1) {
            let rec = timed(&sc, &RunOptions::inprocess(), out)?;
            best_in = best_in.min(rec.wall_seconds);
            let rec = timed(&sc, &procs, out)?;
            if rec.wall_seconds < best_proc.0 {
                best_proc = (rec.wall_seconds, rec.startup_seconds.unwrap_or(0.0));
            }
        }
        eprintln!(
            "overhead {} (poll {poll_us} us): in-process {best_in:.4} s, processes {:.4} s",
            mode.as_str(),
            best_proc.0
        );
        overhead.push(Overhead {
            mode: mode.as_str().into(),
            poll_us,
            inprocess_seconds: best_in,
            processes_seconds: best_proc.0,
            startup_seconds: best_proc.1,
            ratio: best_proc.0 / best_in,
        });
    }
    let mut scale = Vec::new();
    for &n in nodes {
        let sc = ring(n)?;
        let reset = reset_peak_rss();
        let run = pipeline::execute(&sc, &processes, &mut |_, _| {});
        let coordinator_rss_mib = own_peak_rss_mib().filter(|_| reset);
        let (rec, res) = (run.record, run.error);
        let rss: Vec<f64> = rec
            .peak_rss_kib
            .iter()
            .flatten()
            .map(|k| *k as f64 / 1024.0)
            .collect();
        if let Some(e) = &res {
            eprintln!("scale run of {n} nodes failed: {e}");
        }
        scale.push(Scale {
            nodes: n,
            startup_seconds: rec.startup_seconds.unwrap_or(f64::NAN),
            iterations_per_second: rec.iterations as f64 / rec.wall_seconds.max(1e-9),
            max_rss_mib: rss.iter().copied().fold(0.0, f64::max),
            mean_rss_mib: if rss.is_empty() {
                0.0
            } else {
                rss.iter().sum::<f64>() / rss.len() as f64
            },
            coordinator_rss_mib,
            completed: res.is_none(),
        });
    }
    let sc = spiral(scenarios)?;
    let realtime = processes.clone().with_clock(Clock::Realtime);
    let run = pipeline::execute(&sc, &realtime, &mut |_, _| {});
    let rec = run.record;
    let (rt_ips, rt_med) = match run.error {
        None => {
            let v: Vec<f64> = rec
                .iterations_per_sample
                .iter()
                .map(|&x| x as f64)
                .collect();
            (
                Some(rec.iterations as f64 / rec.wall_seconds.max(1e-9)),
                crate::model::metrics::median(&v),
            )
        }
        Some(e) => {
            eprintln!("realtime run failed: {e}");
            (None, None)
        }
    };
    let report = BenchReport {
        overhead,
        scale,
        realtime_iterations_per_second: rt_ips,
        realtime_iterations_per_sample_median: rt_med,
    };
    std::fs::create_dir_all(out).map_err(|e| {
        BenchError::Run(pipeline::RunError::Output {
            path: out.to_path_buf(),
            source: e,
        })
    })?;
    pipeline::write_json(&out.join("bench.json"), &report)?;
    print_report(&report, out);
    Ok(report)
}

/// One run of `sc` on the engine of `opts`, for its timings.
fn timed(
    sc: &Scenario,
    opts: &RunOptions,
    out: &Path,
) -> Result<crate::engine::RunRecord, BenchError> {
    let run = pipeline::execute(sc, opts, &mut |_, _| {});
    match run.error {
        None => Ok(run.record),
        Some(e) => Err(run_failed(e, out)),
    }
}

fn run_failed(e: crate::engine::EngineError, out: &Path) -> BenchError {
    BenchError::RunFailed {
        error: e,
        dir: out.to_path_buf(),
    }
}

fn print_report(r: &BenchReport, out: &Path) {
    println!(
        "sonarnet bench (figures also in {})",
        out.join("bench.json").display()
    );
    println!("engine overhead on mourya2017-spiral (best run, start-up excluded):");
    for o in &r.overhead {
        println!(
            "  {:5}  poll {:3} us  in-process {:8.4} s   processes {:8.4} s   ratio {:5.2}x   (start-up {:.3} s)",
            o.mode, o.poll_us, o.inprocess_seconds, o.processes_seconds, o.ratio, o.startup_seconds
        );
    }
    println!("scale (ring, async logical):");
    for s in &r.scale {
        println!(
            "  N={:4}  start-up {:7.3} s   {:9.0} iterations/s   RSS per node max {:6.2} MiB mean {:6.2} MiB   coordinator {}{}",
            s.nodes,
            s.startup_seconds,
            s.iterations_per_second,
            s.max_rss_mib,
            s.mean_rss_mib,
            s.coordinator_rss_mib
                .map_or("n/a".to_string(), |m| format!("{m:.1} MiB")),
            if s.completed { "" } else { "   (FAILED)" }
        );
    }
    if let (Some(ips), Some(med)) = (
        r.realtime_iterations_per_second,
        r.realtime_iterations_per_sample_median,
    ) {
        println!(
            "realtime on mourya2017-spiral: {ips:.0} exchanges/s network-wide, median {med} per sample"
        );
    }
}
