//! Scenario files: TOML parsed into validated types.
//!
//! The raw file format ([`ScenarioFile`]) is documented key by key in
//! the scenario reference (`docs/src/scenarios.md`). [`Scenario::load`] parses it with
//! `deny_unknown_fields`, checks every value, loads the trace, truth and
//! schedule files it names (paths relative to the scenario file), and returns
//! one [`InputError`] that names the file, the key or line, and the reason.

pub mod deploy;
pub mod expect;

pub use crate::estimators::gossip::Mode;
pub use crate::model::synth::{MeasurementsCfg, Realization};
pub use crate::scenario::expect::ExpectCfg;

use crate::estimators::prox::LocalSolver;
use crate::model::error::{InputError, KeyError};
use crate::model::geometry::{Lifted, Point};
use crate::model::graph::Graph;
use crate::model::measure::{Geometry, NodeMeasurements, SampleMeasurements, Sigmas};
use crate::model::motion::Motion;
use crate::model::rng::{Stream, stream_rng};
use std::path::{Path, PathBuf};

mod build;
mod describe;
mod limits;
mod overrides;
mod readers;
mod resolve;
pub mod scaffold;
mod sections;
pub mod shipped;
pub use describe::in_words;
mod schema;

use build::check_tracks;
pub use build::merge_tables;
pub use limits::{
    MAX_ITERATIONS_PER_SAMPLE, MAX_RECEIVERS, MAX_RECORD_BYTES, MAX_SAMPLES, MAX_SCENARIO_BYTES,
    MAX_TRANSMITTERS, MAX_TRIALS, SizeKey, read_scenario_text,
};
pub use overrides::Override;
pub use readers::{
    MAX_SCHEDULE_STEPS, read_schedule, read_trace, read_truth, schedule_from, trace_from,
    truth_from,
};
pub use schema::{
    AlgorithmCfg, BoundKind, BoundsCfg, ClockCfg, GeneratorCfg, GeometryCfg, InitMode, InitU,
    MonteCarloCfg, NetworkCfg, RealtimeCfg, RowWeights, ScenarioFile, ScoringCfg, TargetCfg,
    VariantCfg,
};

/// Where the measurements come from, in `D` = 2 or 3 dimensions.
#[derive(Debug, Clone, PartialEq)]
pub enum DataSource<const D: usize = 2> {
    /// Synthesized from a motion model at run time (depends on the seed).
    Synthetic {
        /// The target motion.
        motion: Motion,
    },
    /// Read from a trace file.
    Trace {
        /// The trace file.
        path: PathBuf,
        /// Per-sample measurements.
        measurements: Vec<SampleMeasurements>,
        /// The true track, if a truth file was given.
        truth: Option<Vec<Point<D>>>,
    },
}

/// Validated algorithm parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Algorithm {
    /// Gossip mode.
    pub mode: Mode,
    /// Prox step.
    pub gamma: f64,
    /// Iterations between samples.
    pub iterations_per_sample: usize,
    /// Local prox.
    pub local_solver: LocalSolver,
    /// Outlier budget per node of `gtrs_l0`.
    pub kappa: usize,
    /// Each node's prox scaling (Mourya 2017 eq. 5 or eq. 11).
    pub prox_scaling: crate::estimators::gossip::ProxScaling,
    /// Where the nodes start.
    pub init: InitMode,
    /// How each node weighs the rows of its cost.
    pub row_weights: RowWeights,
    /// Initial `u` of each node (`init_u[i]` is node `i`'s): `D + 1`
    /// numbers `[x, y(, z), d]`, checked against the scenario's dimension
    /// ([`Algorithm::init_u_of`]).
    pub init_u: Vec<Vec<f64>>,
    /// A replayed async schedule, `(v, w)` per iteration, and its file.
    pub schedule: Option<(PathBuf, Vec<(usize, usize)>)>,
    /// Burn-in samples.
    pub burn_in: usize,
    /// The file's clock (`algorithm.clock`), if it names one.
    pub clock: Option<ClockCfg>,
}

/// A validated scenario of either dimension, as its file decides: 2-D if
/// its receivers are `[x, y]`, 3-D if they are `[x, y, z]`.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyScenario {
    /// A 2-D scenario.
    Plane(Scenario<2>),
    /// A 3-D scenario.
    Space(Scenario<3>),
}

impl AnyScenario {
    /// Read, parse and validate a scenario file of either dimension: one
    /// scenario, or one per `[[variants]]` entry (a variant keeps the
    /// file's dimension).
    pub fn load_all(path: &Path) -> Result<Vec<AnyScenario>, InputError> {
        let text = limits::read_scenario_text(path)?;
        Self::all_from_toml_str(&text, path)
    }

    /// [`AnyScenario::load_all`] from text; `path` names it in errors.
    pub fn all_from_toml_str(text: &str, path: &Path) -> Result<Vec<AnyScenario>, InputError> {
        let file: ScenarioFile =
            toml::from_str(text).map_err(|e| build::toml_error(path, text, &e))?;
        Ok(match sections::dimension(path, &file)? {
            3 => build::every_from_toml_str::<3>(text, path)?
                .into_iter()
                .map(AnyScenario::Space)
                .collect(),
            _ => build::every_from_toml_str::<2>(text, path)?
                .into_iter()
                .map(AnyScenario::Plane)
                .collect(),
        })
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        match self {
            AnyScenario::Plane(sc) => &sc.name,
            AnyScenario::Space(sc) => &sc.name,
        }
    }

    /// The run seed.
    pub fn seed(&self) -> u64 {
        match self {
            AnyScenario::Plane(sc) => sc.seed,
            AnyScenario::Space(sc) => sc.seed,
        }
    }

    /// The scenario file as parsed.
    pub fn file(&self) -> &ScenarioFile {
        match self {
            AnyScenario::Plane(sc) => &sc.file,
            AnyScenario::Space(sc) => &sc.file,
        }
    }

    /// What this scenario runs, in words ([`Scenario::describe`]).
    pub fn describe(&self) -> Vec<(String, String)> {
        match self {
            AnyScenario::Plane(sc) => sc.describe(),
            AnyScenario::Space(sc) => sc.describe(),
        }
    }

    /// The variant's name, for a file with `[[variants]]`.
    pub fn variant(&self) -> Option<&str> {
        match self {
            AnyScenario::Plane(sc) => sc.variant.as_deref(),
            AnyScenario::Space(sc) => sc.variant.as_deref(),
        }
    }

    /// The scenario's warnings ([`Scenario::warnings`]).
    pub fn warnings(&self) -> Vec<String> {
        match self {
            AnyScenario::Plane(sc) => sc.warnings(),
            AnyScenario::Space(sc) => sc.warnings(),
        }
    }

    /// 2 or 3.
    pub fn dim(&self) -> usize {
        match self {
            AnyScenario::Plane(_) => 2,
            AnyScenario::Space(_) => 3,
        }
    }
}

impl Algorithm {
    /// Node `id`'s initial `u` as a lifted variable of `L = D + 1`
    /// dimensions (the lengths were checked against the scenario's
    /// dimension when it was read).
    pub fn init_u_of<const L: usize>(&self, id: usize) -> Lifted<L> {
        let u = &self.init_u[id];
        Lifted::<L>::from_fn(|i, _| u.get(i).copied().unwrap_or(0.0))
    }

    /// Node `id`'s initial `u` in a `D`-dimensional scenario: `D + 1`
    /// numbers, as [`Algorithm::init_u_of`] reads them.
    pub fn init_u_coords(&self, id: usize, dim: usize) -> crate::model::coords::Coords {
        let u = &self.init_u[id];
        crate::model::coords::Coords::from_fn(dim + 1, |i| u.get(i).copied().unwrap_or(0.0))
    }
}

/// A validated scenario in `D` = 2 or 3 dimensions (decided by its
/// receivers' coordinates; [`AnyScenario`] holds either).
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario<const D: usize = 2> {
    /// The scenario file.
    pub path: PathBuf,
    /// The raw file as parsed (recorded in `run.json`).
    pub file: ScenarioFile,
    /// Scenario name.
    pub name: String,
    /// Run seed.
    pub seed: u64,
    /// Positions.
    pub geometry: Geometry<D>,
    /// Gossip graph over the receivers.
    pub graph: Graph,
    /// Number of samples.
    pub samples: usize,
    /// Measurement source.
    pub source: DataSource<D>,
    /// What to synthesize and the nominal noise.
    pub measurements: MeasurementsCfg,
    /// DR parameters.
    pub algorithm: Algorithm,
    /// Realtime clocks, if given.
    pub realtime: Option<RealtimeCfg>,
    /// The network between the nodes (validated).
    pub channel: crate::model::channel::ChannelCfg,
    /// Faults, checked and in emulated seconds (`[[faults]]`, then `--fault`).
    pub faults: Vec<crate::model::fault::Fault>,
    /// Random faults (`[nemesis]` or `--nemesis`), drawn by the plan from the
    /// run seed.
    pub nemesis: Option<crate::model::fault::NemesisCfg>,
    /// Test thresholds.
    pub expect: ExpectCfg,
    /// Record every node's `theta` after every iteration (`iterations.csv`);
    /// a run option (`--trace-iterations`), not part of the file.
    pub trace_iterations: bool,
    /// Baselines (validated, unique names).
    pub baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    /// Certified bounds.
    pub bounds: Option<BoundsCfg>,
    /// Scoring options.
    pub scoring: ScoringCfg,
    /// Monte Carlo trials (`None`: a single run).
    pub trials: Option<usize>,
    /// The variant's name, for a file with `[[variants]]`.
    pub variant: Option<String>,
    /// The `--set KEY=VALUE` overrides applied to the file, as given.
    pub overrides: Vec<String>,
    /// Which host runs which node (`[deploy]`); `None`: all on this host.
    pub deploy: Option<deploy::Placement>,
}

impl<const D: usize> Scenario<D> {
    /// The nominal number of rows of node `id`'s local cost (Mourya 2017 eq. 9): one per
    /// bistatic range, two per DOA, one per one-way range. Synthetic data: what the
    /// measurements config synthesizes; a trace: the most the node has at any sample.
    pub fn nominal_rows(&self, id: usize) -> usize {
        let rows = |m: &NodeMeasurements| {
            m.bistatic.len() + 2 * usize::from(m.doa.is_some()) + usize::from(m.range.is_some())
        };
        match &self.source {
            DataSource::Trace { measurements, .. } => measurements
                .iter()
                .filter_map(|s| s.nodes.get(id).map(rows))
                .max()
                .unwrap_or(0),
            DataSource::Synthetic { .. } => {
                let m = &self.measurements;
                let n_tx = if m.bistatic {
                    self.geometry.transmitters.len()
                } else {
                    0
                };
                n_tx + 2 * usize::from(m.doa) + usize::from(m.range)
            }
        }
    }

    /// With `gtrs_l0`, `algorithm.kappa` must be below the nominal row count
    /// ([`Scenario::nominal_rows`]) of every node that has any row (a node without
    /// measurements runs the plain prox anyway). Samples with fewer rows are clamped at
    /// run time ([`crate::estimators::prox::l0::effective_kappa`]).
    pub fn check_kappa(&self) -> Result<(), InputError> {
        if self.algorithm.local_solver != LocalSolver::GtrsL0 {
            return Ok(());
        }
        let kappa = self.algorithm.kappa;
        for id in 0..self.geometry.receivers.len() {
            let rows = self.nominal_rows(id);
            if rows > 0 && kappa >= rows {
                return Err(InputError::at(
                    &self.path,
                    "algorithm.kappa",
                    format!(
                        "must be below the number of rows of every node's local cost with \
                         local_solver = \"gtrs_l0\" (node {id} has {rows}), got {kappa}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Total DR iterations of a run.
    pub fn total_iterations(&self) -> usize {
        self.samples * self.algorithm.iterations_per_sample
    }

    fn check_schedule(&self) -> Result<(), InputError> {
        if let (Mode::Sync, Some(_)) = (self.algorithm.mode, &self.algorithm.schedule) {
            return Err(InputError::at(
                &self.path,
                "algorithm.schedule",
                "a replayed schedule gives the (v, w) pair of each async iteration; this run is sync (algorithm.mode or --mode), where every node computes every round",
            ));
        }
        if let (Mode::Async, Some((p, s))) = (self.algorithm.mode, &self.algorithm.schedule) {
            let need = self.total_iterations();
            if s.len() < need {
                return Err(InputError::file(
                    p,
                    format!(
                        "has {} iterations but the run needs {need} ({} samples x {} iterations)",
                        s.len(),
                        self.samples,
                        self.algorithm.iterations_per_sample
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Replace the baselines (`--baselines`); names must be unique.
    pub fn with_baselines(
        mut self,
        baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    ) -> Result<Self, InputError> {
        check_tracks(
            &baselines,
            self.bounds.as_ref(),
            &self.geometry,
            build::has_one_way_ranges(&self.source, &self.measurements),
        )
        .map_err(|e| cli_error("--baselines", e.to_string()))?;
        self.baselines = baselines;
        Ok(self)
    }

    /// Run `n` Monte Carlo trials (`--trials`; `None` or 1 is a single run).
    pub fn with_trials(mut self, n: Option<usize>) -> Result<Self, InputError> {
        if let Some(n) = n {
            limits::check_count(n, MAX_TRIALS).map_err(|r| cli_error("--trials", r))?;
        }
        if n.is_some() {
            self.trials = n;
        }
        Ok(self)
    }

    /// Add the fault of a `--fault KIND:KEY=VALUE,...` flag
    /// ([`crate::model::fault::FaultSpec::parse_flag`]); it is checked as a
    /// `[[faults]]` entry is, and an error names `--fault`.
    pub fn with_fault_flag(mut self, flag: &str) -> Result<Self, InputError> {
        let spec = crate::model::fault::FaultSpec::parse_flag(flag)
            .map_err(|r| cli_error("--fault", format!("`{flag}`: {r}")))?;
        let Some(rt) = &self.realtime else {
            return Err(cli_error(
                "--fault",
                "faults run on the realtime clock: the scenario needs a [realtime] table",
            ));
        };
        let f = spec
            .resolve(self.graph.len(), rt.sample_period_ms / 1000.0)
            .map_err(|e| cli_error("--fault", format!("`{flag}`: {e}")))?;
        self.faults.push(f);
        self.file.faults.push(spec);
        Ok(self)
    }

    /// True if the run has faults (`[[faults]]`, `--fault`, a nemesis).
    pub fn has_faults(&self) -> bool {
        !self.faults.is_empty() || self.nemesis.is_some()
    }

    /// Draw random faults (`--nemesis KINDS --nemesis-interval-s S`); an
    /// error names the flag.
    pub fn with_nemesis(mut self, kinds: &str, interval_s: f64) -> Result<Self, InputError> {
        let kinds = kinds
            .split(',')
            .map(|k| k.trim().parse())
            .collect::<Result<_, _>>()
            .map_err(|e| cli_error("--nemesis", format!("{e} (fault kinds)")))?;
        let cfg = crate::model::fault::NemesisCfg { kinds, interval_s };
        cfg.validate().map_err(|KeyError { key, reason: r }| {
            let flag = if key.ends_with("interval_s") {
                "--nemesis-interval-s"
            } else {
                "--nemesis"
            };
            cli_error(flag, r)
        })?;
        if self.realtime.is_none() {
            return Err(cli_error(
                "--nemesis",
                "faults run on the realtime clock: the scenario needs a [realtime] table",
            ));
        }
        self.nemesis = Some(cfg);
        Ok(self)
    }

    /// Override the run seed.
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Record every node's `theta` after every iteration into `iterations.csv`.
    pub fn with_trace_iterations(mut self, on: bool) -> Self {
        self.trace_iterations = on;
        self
    }

    /// Override the gossip mode.
    pub fn with_mode(mut self, mode: Mode) -> Result<Self, InputError> {
        self.algorithm.mode = mode;
        self.check_schedule()?;
        if let Some(ch) = self.channel.acoustic() {
            build::check_tdma(ch, &self.geometry, &self.graph, mode)
                .map_err(|e| cli_error("--mode", e.to_string()))?;
        }
        Ok(self)
    }

    /// Override the prox scaling (`algorithm.prox_scaling`, Mourya 2017 eq. 5 or 11).
    pub fn with_prox_scaling(mut self, p: crate::estimators::gossip::ProxScaling) -> Self {
        self.algorithm.prox_scaling = p;
        self
    }

    /// Override the local solver (see [`Scenario::check_kappa`] for `gtrs_l0`).
    pub fn with_local_solver(mut self, s: LocalSolver) -> Self {
        self.algorithm.local_solver = s;
        self
    }

    /// Override the `gtrs_l0` outlier budget `algorithm.kappa` (checked by
    /// [`Scenario::check_kappa`]).
    pub fn with_kappa(mut self, kappa: usize) -> Self {
        self.algorithm.kappa = kappa;
        self
    }

    /// Override the iterations per sample (must be >= 1).
    pub fn with_iterations_per_sample(mut self, n: usize) -> Result<Self, InputError> {
        limits::check_count(n, MAX_ITERATIONS_PER_SAMPLE)
            .map_err(|r| cli_error("--iterations-per-sample", r))?;
        self.algorithm.iterations_per_sample = n;
        self.check_size_cli()?;
        self.check_schedule()?;
        Ok(self)
    }

    /// Override the number of samples (at most the trace length for traces).
    pub fn with_samples(mut self, n: usize) -> Result<Self, InputError> {
        limits::check_count(n, MAX_SAMPLES).map_err(|r| cli_error("--samples", r))?;
        if let DataSource::Trace { measurements, .. } = &self.source
            && n > measurements.len()
        {
            return Err(cli_error(
                "--samples",
                format!(
                    "the trace has only {} samples, asked for {n}",
                    measurements.len()
                ),
            ));
        }
        if self.algorithm.burn_in >= n {
            return Err(cli_error(
                "--samples",
                format!("must exceed algorithm.burn_in = {}", self.algorithm.burn_in),
            ));
        }
        self.samples = n;
        self.check_size_cli()?;
        self.check_schedule()?;
        Ok(self)
    }

    /// Nominal noise sigmas at sample `k`.
    pub fn sigmas_at(&self, k: usize) -> Sigmas {
        let m = &self.measurements;
        let doa = m.doa_noise.as_ref().map_or(0.1, |n| n.sigma_at(k));
        Sigmas {
            range: m.range_noise.as_ref().map_or(1.0, |n| n.sigma_at(k)),
            doa,
            // 2-D measures no elevation; 3-D draws it with its own noise
            // model, the DOA's when not given.
            elevation: if D == 3 {
                m.elevation_noise.as_ref().map_or(doa, |n| n.sigma_at(k))
            } else {
                0.0
            },
        }
    }

    /// The truth and measurements of a run with this scenario's seed
    /// (`self.seed`, the one run seed): synthesized for synthetic scenarios,
    /// read from the trace otherwise.
    pub fn realize(&self) -> Realization<D> {
        let seed = self.seed;
        let sigmas = (0..self.samples).map(|k| self.sigmas_at(k)).collect();
        match &self.source {
            DataSource::Trace {
                measurements,
                truth,
                ..
            } => Realization {
                truth: truth.as_ref().map(|t| t[..self.samples].to_vec()),
                measurements: measurements[..self.samples].to_vec(),
                sigmas,
                nlos: crate::model::noise::NlosMask::all_los(
                    self.geometry.transmitters.len(),
                    self.geometry.receivers.len(),
                ),
            },
            DataSource::Synthetic { motion } => {
                let truth =
                    motion.track::<D>(self.samples, &mut stream_rng(seed, Stream::Motion, 0));
                let (n_tx, n_rx) = (
                    self.geometry.transmitters.len(),
                    self.geometry.receivers.len(),
                );
                // Validated at load time, so a draw error cannot happen here;
                // fall back to all-LOS rather than panic.
                let nlos = self
                    .measurements
                    .nlos_links
                    .draw(n_tx, n_rx, &mut stream_rng(seed, Stream::Links, 0))
                    .unwrap_or_else(|_| crate::model::noise::NlosMask::all_los(n_tx, n_rx));
                let measurements = crate::model::synth::synthesize(
                    &self.geometry,
                    &truth,
                    &self.measurements,
                    &nlos,
                    seed,
                );
                Realization {
                    truth: Some(truth),
                    measurements,
                    sigmas,
                    nlos,
                }
            }
        }
    }
}

pub(super) fn cli_error(flag: &str, reason: impl Into<String>) -> InputError {
    InputError::at(Path::new("<command line>"), flag, reason)
}
