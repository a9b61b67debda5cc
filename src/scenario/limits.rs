//! Size limits: every count a scenario or a flag gives has a documented
//! range, and the memory a run's record implies is computed before the run
//! and refused above [`MAX_RECORD_BYTES`] (values such as
//! `iterations_per_sample = 9223372036854775807` or `samples = 1e9` aborted
//! in an allocation or inside iceoryx2).

use crate::estimators::gossip::Mode;
use crate::model::error::InputError;
use crate::scenario::Scenario;
use crate::scenario::cli_error;

/// Most receivers (nodes): `geometry.receivers`, `network.generator.count`.
pub const MAX_RECEIVERS: usize = 4096;
/// Most transmitters: `geometry.transmitters` (a node reassembles at most
/// one bistatic range per transmitter per sample,
/// [`crate::protocol::codec::MAX_SAMPLE_FRAMES`]).
pub const MAX_TRANSMITTERS: usize = 4096;
/// Most samples: `target.samples`, `--samples`.
pub const MAX_SAMPLES: usize = 1_000_000;
/// Most DR iterations per sample: `algorithm.iterations_per_sample`,
/// `--iterations-per-sample`.
pub const MAX_ITERATIONS_PER_SAMPLE: usize = 1_000_000;
/// Most Monte Carlo trials: `monte_carlo.trials`, `--trials`.
pub const MAX_TRIALS: usize = 1_000_000;
/// Most memory the record of one run may need (4 GiB; this is an estimate
/// of what the engine keeps: every node's `theta` per sample, the
/// measurements, the async schedule, the `--trace-iterations` trace).
pub const MAX_RECORD_BYTES: u64 = 4 << 30;

/// The longest scenario file read (16 MiB; the shipped ones are under
/// 20 kB).
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// The text of the scenario file `path`, refused when longer than
/// [`MAX_SCENARIO_BYTES`] before more is read.
pub fn read_scenario_text(path: &std::path::Path) -> Result<String, InputError> {
    crate::model::error::read_text_at_most(path, MAX_SCENARIO_BYTES, "scenario")
}

/// Which input a size check is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SizeKey {
    /// `target.samples` / `--samples`.
    Samples,
    /// `algorithm.iterations_per_sample` / `--iterations-per-sample`.
    IterationsPerSample,
    /// `--trace-iterations`.
    TraceIterations,
}

impl SizeKey {
    /// The scenario key.
    pub fn key(self) -> &'static str {
        match self {
            SizeKey::Samples => "target.samples",
            SizeKey::IterationsPerSample => "algorithm.iterations_per_sample",
            SizeKey::TraceIterations => "--trace-iterations",
        }
    }

    /// The command-line flag.
    pub fn flag(self) -> &'static str {
        match self {
            SizeKey::Samples => "--samples",
            SizeKey::IterationsPerSample => "--iterations-per-sample",
            SizeKey::TraceIterations => "--trace-iterations",
        }
    }
}

/// `v` in `[1, max]`, else the reason.
pub(super) fn check_count(v: usize, max: usize) -> Result<(), String> {
    if v == 0 {
        Err("must be at least 1".into())
    } else if v > max {
        Err(format!("must be at most {max}, got {v}"))
    } else {
        Ok(())
    }
}

fn gib(b: u64) -> String {
    format!("{:.1} GiB", b as f64 / (1u64 << 30) as f64)
}

impl<const D: usize> Scenario<D> {
    /// Bytes of the record of one run (an estimate, seed-independent):
    /// per sample every node's `theta` and measurements and every track's
    /// point; per async iteration its `(v, w)` pair; with
    /// `--trace-iterations`, per iteration every updated node's `theta`.
    pub fn record_bytes(&self) -> u64 {
        let n = self.graph.len() as u64;
        let rows = (0..self.graph.len())
            .map(|i| self.nominal_rows(i) as u64)
            .max()
            .unwrap_or(0);
        let samples = self.samples as u64;
        let iterations = samples.saturating_mul(self.algorithm.iterations_per_sample as u64);
        let per_sample = n * (48 + 8 * rows) + 256;
        let schedule = match self.algorithm.mode {
            Mode::Async => iterations.saturating_mul(16),
            Mode::Sync => 0,
        };
        let trace = if self.trace_iterations {
            let updated = match self.algorithm.mode {
                Mode::Async => 2,
                Mode::Sync => n,
            };
            iterations.saturating_mul(updated).saturating_mul(40)
        } else {
            0
        };
        samples
            .saturating_mul(per_sample)
            .saturating_add(schedule)
            .saturating_add(trace)
    }

    /// Ranges of the counts and the record's memory
    /// ([`Scenario::record_bytes`] at most [`MAX_RECORD_BYTES`]); on error,
    /// the input most to blame and the reason with the numbers.
    pub fn check_size(&self) -> Result<(), (SizeKey, String)> {
        check_count(self.samples, MAX_SAMPLES).map_err(|r| (SizeKey::Samples, r))?;
        check_count(
            self.algorithm.iterations_per_sample,
            MAX_ITERATIONS_PER_SAMPLE,
        )
        .map_err(|r| (SizeKey::IterationsPerSample, r))?;
        let bytes = self.record_bytes();
        if bytes <= MAX_RECORD_BYTES {
            return Ok(());
        }
        let key = if self.trace_iterations {
            SizeKey::TraceIterations
        } else if self.algorithm.mode == Mode::Async && self.algorithm.iterations_per_sample > 64 {
            SizeKey::IterationsPerSample
        } else {
            SizeKey::Samples
        };
        Err((
            key,
            format!(
                "{} samples x {} iterations on {} nodes{} need about {} of memory for the run's record, \
                 more than the limit of {}; lower target.samples or algorithm.iterations_per_sample",
                self.samples,
                self.algorithm.iterations_per_sample,
                self.graph.len(),
                if self.trace_iterations {
                    " with --trace-iterations"
                } else {
                    ""
                },
                gib(bytes),
                gib(MAX_RECORD_BYTES)
            ),
        ))
    }

    /// [`Scenario::check_size`] as a command-line error naming the flag.
    pub fn check_size_cli(&self) -> Result<(), InputError> {
        self.check_size()
            .map_err(|(k, reason)| cli_error(k.flag(), reason))
    }
}

impl<const D: usize> Scenario<D> {
    /// What is allowed but probably not meant, one line each with the file
    /// and key (`sonarnet run` and `sonarnet validate` print them): receivers
    /// at the same position (their measurements are independent draws, so
    /// nothing is singular, but the two nodes see the target identically).
    /// O(N log N) in the receivers.
    pub fn warnings(&self) -> Vec<String> {
        let rx = &self.geometry.receivers;
        let mut order: Vec<usize> = (0..rx.len()).collect();
        order.sort_by(|&a, &b| {
            (0..D)
                .map(|i| rx[a][i].total_cmp(&rx[b][i]))
                .fold(std::cmp::Ordering::Equal, std::cmp::Ordering::then)
                .then(a.cmp(&b))
        });
        let mut out = Vec::new();
        for w in order.windows(2) {
            let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
            if (rx[a] - rx[b]).norm() <= 1e-9 * (1.0 + rx[a].norm()) {
                out.push(format!(
                    "{}: geometry.receivers: receivers {a} and {b} are at the same position ({}); \
                     they measure independently but see the target identically",
                    self.path.display(),
                    rx[a]
                        .iter()
                        .map(|c| c.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        out
    }
}
